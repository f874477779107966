// Atlas correspondence at the command line (issue 14): `flatten --sphere-reg ... --atlas-*`, the
// mode recorded in the map and carried into element tables and references, and `normative
// compare` refusing a patient mapped in another mode.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "common/test_data.h"
#include "io/surface_io.h"

namespace authalic {
namespace {

TEST(AtlasCli, FlattenInAtlasModeRecordsTheModeAndNormativeRefusesMixedModes) {
  AUTHALIC_REQUIRE_SHARED(white, "fsaverage5/white_left.gii.gz");
  AUTHALIC_REQUIRE_SHARED(sphere, "fsaverage5/sphere_left.gii.gz");
  AUTHALIC_REQUIRE_SHARED(flat, "fsaverage5/flat_left.gii.gz");
  AUTHALIC_REQUIRE_SHARED(sulc, "fsaverage5/sulc_left.gii.gz");
  AUTHALIC_REQUIRE_SHARED(curv, "fsaverage5/curv_left.gii.gz");
  AUTHALIC_REQUIRE_SHARED(thick, "fsaverage5/thick_left.gii.gz");
  const std::string dir = test::temp_dir("atlas_cli");
  const std::string exe = test::authalic_binary();
  const std::string atlas = " --atlas-surface " + white + " --atlas-sphere " + sphere + " --atlas-faces-from " + flat;
  std::string out;
  // The subject is the atlas itself: its sphere.reg is the atlas sphere.
  ASSERT_EQ(test::run_command(exe + " flatten " + white + " " + dir + "/atlas.surf.gii --faces-from " + flat + " --sphere-reg " +
                                  sphere + atlas + " --metrics " + dir + "/atlas.json --quiet",
                              &out),
            0)
      << out;
  const nlohmann::json m = nlohmann::json::parse(std::ifstream(dir + "/atlas.json"));
  const std::string mode = m["correspondence"]["mode"];
  EXPECT_EQ(mode.rfind("atlas ", 0), 0u) << mode;
  EXPECT_EQ(mode.size(), 6u + 16u) << mode;  // "atlas " + 16 hex digits of the atlas files' checksum
  EXPECT_EQ(m["correspondence"]["vertices_outside_atlas_cortex"], 0);
  EXPECT_LT(m["correspondence"]["flow_displacement_elements"]["median"].get<double>(), 0.02);
  EXPECT_LT(m["correspondence"]["flow_displacement_elements"]["max"].get<double>(), 0.5);
  EXPECT_EQ(m["flips"], 0);
  EXPECT_EQ(io::read_surface(dir + "/atlas.surf.gii").metadata.at("authalic_correspondence"), mode);

  ASSERT_EQ(test::run_command(exe + " flatten " + white + " " + dir + "/own.surf.gii --faces-from " + flat + " --quiet", &out), 0) << out;
  EXPECT_EQ(io::read_surface(dir + "/own.surf.gii").metadata.at("authalic_correspondence"), "per-subject");

  // Atlas options without a sphere.reg (and the reverse) are refused.
  EXPECT_EQ(test::run_command(exe + " flatten " + white + " " + dir + "/x.surf.gii --faces-from " + flat + atlas, &out), 2) << out;
  EXPECT_NE(out.find("need --sphere-reg"), std::string::npos) << out;
  EXPECT_NE(out.find("or --register"), std::string::npos) << out;
  EXPECT_EQ(test::run_command(exe + " flatten " + white + " " + dir + "/x.surf.gii --faces-from " + flat + " --sphere-reg " + sphere, &out),
            2) << out;
  EXPECT_NE(out.find("--sphere-reg needs the atlas"), std::string::npos) << out;

  // Element tables inherit the map's mode; a reference of atlas-mode controls refuses a per-subject patient.
  std::string tables;
  for (int s = 0; s < 3; ++s) {
    const std::string p = dir + "/c" + std::to_string(s);
    const std::string values = s == 0 ? sulc : s == 1 ? curv : thick;  // three "controls" that differ
    ASSERT_EQ(test::run_command(exe + " elements " + white + " " + dir + "/atlas.surf.gii " + values + " " + p + " --k 8 --subject c" +
                                    std::to_string(s) + " --quiet",
                                &out),
              0) << out;
    tables += " " + p + ".tsv";
  }
  ASSERT_EQ(test::run_command(exe + " normative build " + dir + "/ref.json" + tables + " --quiet", &out), 0) << out;
  EXPECT_EQ(nlohmann::json::parse(std::ifstream(dir + "/ref.json"))["correspondence"], mode);
  ASSERT_EQ(test::run_command(exe + " elements " + white + " " + dir + "/own.surf.gii " + sulc + " " + dir + "/p --k 8 --subject p --quiet", &out), 0)
      << out;
  EXPECT_EQ(test::run_command(exe + " normative compare " + dir + "/ref.json " + dir + "/p.tsv " + dir + "/cmp --quiet", &out), 2)
      << out;
  EXPECT_NE(out.find("the element correspondence is 'per-subject' but"), std::string::npos) << out;
  EXPECT_EQ(std::count(out.begin(), out.end(), '\n'), 1) << out;  // one line
}

// Registration mode (`flatten --register`: no sphere.reg; the subject's own map aligned to the
// atlas's by sulcal depth): recorded as "registration <atlas identity>", its option errors, and a
// reference built in it refusing an atlas-mode patient of the same atlas.
TEST(AtlasCli, FlattenInRegistrationModeRecordsTheModeAndNormativeRefusesAtlasMode) {
  AUTHALIC_REQUIRE_SHARED(white, "fsaverage5/white_left.gii.gz");
  AUTHALIC_REQUIRE_SHARED(sphere, "fsaverage5/sphere_left.gii.gz");
  AUTHALIC_REQUIRE_SHARED(flat, "fsaverage5/flat_left.gii.gz");
  AUTHALIC_REQUIRE_SHARED(sulc, "fsaverage5/sulc_left.gii.gz");
  AUTHALIC_REQUIRE_SHARED(curv, "fsaverage5/curv_left.gii.gz");
  AUTHALIC_REQUIRE_SHARED(thick, "fsaverage5/thick_left.gii.gz");
  const std::string dir = test::temp_dir("registration_cli");
  const std::string exe = test::authalic_binary();
  const std::string atlas = " --atlas-surface " + white + " --atlas-sphere " + sphere + " --atlas-faces-from " + flat;
  const std::string subject = exe + " flatten " + white + " ";
  std::string out;
  // The subject is the atlas: registered, nothing moves.
  ASSERT_EQ(test::run_command(subject + dir + "/reg.surf.gii --faces-from " + flat + " --register" + atlas + " --metrics " + dir +
                                  "/reg.json --quiet",
                              &out),
            0)
      << out;
  const nlohmann::json m = nlohmann::json::parse(std::ifstream(dir + "/reg.json"));
  const std::string mode = m["correspondence"]["mode"];
  EXPECT_EQ(mode.rfind("registration ", 0), 0u) << mode;
  EXPECT_EQ(mode.size(), 13u + 16u) << mode;
  EXPECT_EQ(m["correspondence"]["registration_iterations"], 0);
  EXPECT_NEAR(m["correspondence"]["depth_correlation_after"].get<double>(), 1.0, 1e-9);
  EXPECT_EQ(m["flips"], 0);
  EXPECT_EQ(io::read_surface(dir + "/reg.surf.gii").metadata.at("authalic_correspondence"), mode);

  // Option errors: one line each, exit 2, no map written.
  EXPECT_EQ(test::run_command(subject + dir + "/x.surf.gii --faces-from " + flat + " --register --sphere-reg " + sphere + atlas, &out), 2)
      << out;
  EXPECT_NE(out.find("not both"), std::string::npos) << out;
  EXPECT_EQ(test::run_command(subject + dir + "/x.surf.gii --faces-from " + flat + " --register", &out), 2) << out;
  EXPECT_NE(out.find("--register needs the atlas"), std::string::npos) << out;
  EXPECT_FALSE(std::ifstream(dir + "/x.surf.gii").good());

  // A reference of registration-mode controls refuses a patient mapped through sphere.reg on the same atlas.
  std::string tables;
  for (int s = 0; s < 3; ++s) {
    const std::string p = dir + "/c" + std::to_string(s);
    ASSERT_EQ(test::run_command(exe + " elements " + white + " " + dir + "/reg.surf.gii " + (s == 0 ? sulc : s == 1 ? curv : thick) + " " +
                                    p + " --k 8 --subject c" + std::to_string(s) + " --quiet",
                                &out),
              0)
        << out;
    tables += " " + p + ".tsv";
  }
  ASSERT_EQ(test::run_command(exe + " normative build " + dir + "/ref.json" + tables + " --quiet", &out), 0) << out;
  EXPECT_EQ(nlohmann::json::parse(std::ifstream(dir + "/ref.json"))["correspondence"], mode);
  ASSERT_EQ(test::run_command(subject + dir + "/atl.surf.gii --faces-from " + flat + " --sphere-reg " + sphere + atlas + " --quiet", &out), 0)
      << out;
  ASSERT_EQ(test::run_command(exe + " elements " + white + " " + dir + "/atl.surf.gii " + sulc + " " + dir + "/p --k 8 --subject p --quiet", &out), 0)
      << out;
  EXPECT_EQ(test::run_command(exe + " normative compare " + dir + "/ref.json " + dir + "/p.tsv " + dir + "/cmp --quiet", &out), 2)
      << out;
  EXPECT_NE(out.find("the element correspondence is 'atlas " + mode.substr(13) + "' but"), std::string::npos) << out;
  EXPECT_EQ(std::count(out.begin(), out.end(), '\n'), 1) << out;
}

// `run --atlas` for a subject without a sphere.reg: the maps are registered to the atlas's (mode
// "registration", both atlas hemispheres' identities), the run says so before it starts and in its
// warnings, and the maps are authalic.
TEST(AtlasCli, RunWithTheAtlasButNoSphereRegRegistersTheMapsAndSaysSo) {
  AUTHALIC_REQUIRE_SHARED(fs5, "fsaverage5/white_left.gii.gz");
  const std::string dir = test::temp_dir("registration_run");
  const std::string exe = test::authalic_binary();
  const std::string shared = std::filesystem::path(fs5).parent_path().parent_path().string();
  std::string out;
  ASSERT_EQ(test::run_command(exe + " phantom " + dir + "/ph --anatomical-variability --controls 1 --patients 0 --seed 3 --shared " +
                                  shared + " --quiet",
                              &out),
            0)
      << out;
  const std::string subject = dir + "/ph/sub-control01";
  ASSERT_TRUE(std::filesystem::remove(subject + "/surf/lh.sphere.reg"));
  ASSERT_EQ(test::run_command(exe + " run --subjects-dir " + dir + "/ph --subject sub-control01 --atlas " + dir + "/ph/atlas --pet " +
                                  subject + "/sub-control01_pet.nii.gz --out " + dir + "/out --no-report",
                              &out),
            0)
      << out;
  EXPECT_NE(out.find("lh.sphere.reg is missing: element correspondence by registration to the atlas map"), std::string::npos) << out;
  EXPECT_NE(out.find("mode 'registration'"), std::string::npos) << out;
  const std::string base = dir + "/out/sub-control01/sub-control01";  // the BIDS name, not sub-subcontrol01
  const nlohmann::json elements = nlohmann::json::parse(std::ifstream(base + "_elements.json"));
  const std::string mode = elements["metadata"]["correspondence"];
  EXPECT_EQ(mode.rfind("registration ", 0), 0u) << mode;
  EXPECT_EQ(mode.size(), 13u + 16u + 1u + 16u) << mode;  // "registration " + left id + "+" + right id
  for (const char* h : {"L", "R"}) {
    const nlohmann::json flat = nlohmann::json::parse(std::ifstream(base + "_hemi-" + h + "_space-authalic_flat.json"));
    EXPECT_LE(flat["metrics"]["element_area_cv"].get<double>(), 0.005) << h;
    EXPECT_EQ(flat["metrics"]["flips"], 0) << h;
  }
}

}  // namespace
}  // namespace authalic
