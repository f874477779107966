// Atlas correspondence at the command line (issue 14): `flatten --sphere-reg ... --atlas-*`, the
// mode recorded in the map and carried into element tables and references, and `normative
// compare` refusing a patient mapped in another mode.
#include <gtest/gtest.h>

#include <algorithm>
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

}  // namespace
}  // namespace authalic
