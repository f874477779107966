// `authalic normative build|merge|compare` end to end on small element tables.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>
#include <tuple>

#include "analysis/normative.h"
#include "common/test_data.h"
#include "io/surface_io.h"
#include "io/volume_io.h"

namespace authalic {
namespace {

analysis::ElementTable table(const std::string& id, double age, const std::function<double(int)>& value) {
  analysis::ElementTable t;
  t.grid = analysis::element_grid(Domain::square(), 4);
  t.normalisation = "global";
  t.units = "ratio to the global cortical mean";
  t.subject_id = id;
  t.age = age;
  analysis::ElementBlock b{"left", {}};
  for (int e = 0; e < 16; ++e) {
    analysis::Element el;
    el.id = e;
    el.row = e / 4;
    el.col = e % 4;
    el.area_mm2 = 50;
    el.centroid = Eigen::Vector3d(-40, e, 10);
    el.value = value(e);
    el.n_vertices = 10;
    b.elements.push_back(el);
  }
  t.blocks.push_back(b);
  return t;
}

TEST(NormativeCli, BuildMergeCompare) {
  const std::string dir = test::temp_dir("normative_cli");
  std::vector<std::string> paths;
  for (int s = 0; s < 10; ++s) {
    paths.push_back(dir + "/c" + std::to_string(s) + "_elements.csv");
    analysis::write_element_table(paths.back(), table("c" + std::to_string(s), 60 + s, [&](int e) {
      return 1.0 + 0.1 * std::sin(1.7 * s + 0.3 * e);
    }));
  }
  const std::string exe = test::authalic_binary();
  std::string out, all, first, second;
  for (int s = 0; s < 10; ++s) (s < 5 ? first : second) += " " + paths[static_cast<std::size_t>(s)];
  ASSERT_EQ(test::run_command(exe + " normative build " + dir + "/all.json" + first + second + " --json", &out), 0) << out;
  EXPECT_EQ(nlohmann::json::parse(out.substr(out.find('{')))["num_subjects"], 10);
  ASSERT_EQ(test::run_command(exe + " normative build " + dir + "/a.json" + first + " --quiet", &out), 0) << out;
  ASSERT_EQ(test::run_command(exe + " normative build " + dir + "/b.json" + second + " --quiet", &out), 0) << out;
  ASSERT_EQ(test::run_command(exe + " normative merge " + dir + "/merged.json " + dir + "/a.json " + dir + "/b.json --quiet", &out), 0) << out;
  const auto whole = analysis::read_reference(dir + "/all.json"), merged = analysis::read_reference(dir + "/merged.json");
  for (int i = 0; i < 16; ++i) {
    EXPECT_NEAR(merged.mean[i], whole.mean[i], 1e-14);
    EXPECT_NEAR(merged.m2[i], whole.m2[i], 1e-12);
  }
  // Merging a reference with itself counts subjects twice: refused.
  EXPECT_EQ(test::run_command(exe + " normative merge " + dir + "/twice.json " + dir + "/a.json " + dir + "/a.json", &out), 2);
  EXPECT_NE(out.find("is already in the reference"), std::string::npos) << out;

  // A patient 30% low in elements 5, 6, 9 (a 2x2-ish patch) and normal elsewhere.
  const auto patient = table("p1", 65, [&](int e) { return (e == 5 || e == 6 || e == 9) ? 0.7 : whole.mean[e]; });
  analysis::write_element_table(dir + "/p1_elements.csv", patient);
  VectorXd labels(4);
  labels << 1, 6, 7, 0;  // four vertices in elements 0, 5, 6 and none
  io::write_per_vertex(dir + "/el.label.gii", labels);
  ASSERT_EQ(test::run_command(exe + " normative compare " + dir + "/merged.json " + dir + "/p1_elements.csv " + dir +
                                  "/cmp --labels " + dir + "/el.label.gii --json",
                              &out),
            0)
      << out;
  const auto j = nlohmann::json::parse(out.substr(out.find('{')));
  EXPECT_EQ(j["counts"]["hypo"], 3);
  EXPECT_EQ(j["counts"]["hyper"], 0);
  ASSERT_EQ(j["clusters"].size(), 1u);
  EXPECT_EQ(j["clusters"][0]["num_elements"], 3);
  EXPECT_DOUBLE_EQ(j["clusters"][0]["area_mm2"].get<double>(), 150.0);
  EXPECT_EQ(j["clusters"][0]["sign"], "hypo");
  // The merged reference kept its 10 controls' values: every control was compared with the others.
  EXPECT_EQ(j["chance_clusters"]["measured"], true) << j["chance_clusters"].dump();
  EXPECT_EQ(j["chance_clusters"]["controls"], 10);
  const double p = j["clusters"][0]["p_controls"].get<double>();
  EXPECT_DOUBLE_EQ(p, (1.0 + j["clusters"][0]["controls_as_large"].get<int>()) / 11);
  // --min-cluster, as in `run`: the 3-element cluster is kept at 3 and dropped, and said so, at 4
  // (its elements are still counted as abnormal).
  for (const int min_cluster : {3, 4}) {
    std::string said;
    ASSERT_EQ(test::run_command(exe + " normative compare " + dir + "/merged.json " + dir + "/p1_elements.csv " + dir + "/cmp_min" +
                                    std::to_string(min_cluster) + " --min-cluster " + std::to_string(min_cluster),
                                &said),
              0)
        << said;
    const auto jm = nlohmann::json::parse(std::ifstream(dir + "/cmp_min" + std::to_string(min_cluster) + ".json"));
    EXPECT_EQ(jm["counts"]["hypo"], 3);
    EXPECT_EQ(jm["clusters"].size(), min_cluster == 3 ? 1u : 0u) << said;
    EXPECT_EQ(said.find("1 cluster(s) of fewer than 4 elements not reported (--min-cluster)") != std::string::npos, min_cluster == 4)
        << said;
  }
  // A reference written before the values were kept: compared, without p, and said so.
  {
    nlohmann::json old = nlohmann::json::parse(std::ifstream(dir + "/merged.json"));
    old.erase("subject_values");
    std::ofstream(dir + "/old.json") << old.dump();
    std::string said;
    ASSERT_EQ(test::run_command(exe + " normative compare " + dir + "/old.json " + dir + "/p1_elements.csv " + dir + "/cmp_old", &said), 0)
        << said;
    EXPECT_NE(said.find("note: clusters have no p: the reference does not keep its controls' values"), std::string::npos) << said;
    const auto jo = nlohmann::json::parse(std::ifstream(dir + "/cmp_old.json"));
    EXPECT_TRUE(jo["clusters"][0]["p_controls"].is_null());
    EXPECT_EQ(jo["chance_clusters"]["measured"], false);
  }
  // Element labels written for another grid or the other hemisphere (their metadata says so) would
  // put every vertex's z on the wrong element: refused, nothing written.
  const VectorXi keys = (VectorXi(4) << 1, 6, 7, 0).finished();
  for (const auto& [name, meta, said] :
       {std::tuple<std::string, std::map<std::string, std::string>, std::string>{
            "k8", {{"k", "8"}, {"domain", "square"}}, "element labels of a square grid at K = 8, but the reference has a square grid at K = 4"},
        {"right", {{"k", "4"}, {"domain", "square"}}, "element labels of CortexRight given for the reference's left hemisphere block"}}) {
    io::FuncWriteOptions fo;
    fo.metadata = meta;
    if (name == "right") fo.anatomical_structure = "CortexRight";
    io::write_label_gifti(dir + "/" + name + ".label.gii", keys, {{0, "none"}, {1, "a"}, {6, "b"}, {7, "c"}}, fo);
    std::string refused;
    EXPECT_EQ(test::run_command(exe + " normative compare " + dir + "/merged.json " + dir + "/p1_elements.csv " + dir + "/cmp_" + name +
                                    " --labels " + dir + "/" + name + ".label.gii",
                                &refused),
              2)
        << refused;
    EXPECT_NE(refused.find(name + ".label.gii: " + said), std::string::npos) << refused;
    EXPECT_FALSE(std::filesystem::exists(dir + "/cmp_" + name + ".json"));
  }
  for (const char* suffix : {"_z.nii.gz", "_z.png", "_abnormal.csv", ".json", "_z.func.gii"})
    EXPECT_TRUE(std::filesystem::exists(dir + "/cmp" + suffix)) << suffix;
  const VectorXd zv = io::read_per_vertex(dir + "/cmp_z.func.gii");
  // The z image as nibabel reads it (issue 15 item 8): NIFTI_INTENT_ZSCORE, no scanner or aligned
  // space claimed but the element grid's own (sform/qform code 5, template other; QA 4 item 7: codes
  // 0 left tools to guess), the element area in its description and voxel size.
  if (test::run_command("/usr/bin/python3 -c 'import nibabel'") == 0) {
    std::string nib;
    ASSERT_EQ(test::run_command("/usr/bin/python3 -c \"import nibabel as nib, numpy as np; i = nib.load('" + dir +
                                    "/cmp_z.nii.gz'); h = i.header; print(h['intent_code'], h['sform_code'], h['qform_code'], "
                                    "repr(float(np.asanyarray(i.dataobj)[1, 1, 0])), h.get_zooms()[0] ** 2, h['descrip'].tobytes().decode())\"",
                                &nib),
              0)
        << nib;
    std::istringstream in(nib);
    int intent = -1, sform = -1, qform = -1;
    double z11 = 0, area = 0;
    in >> intent >> sform >> qform >> z11 >> area;
    EXPECT_EQ(intent, 5) << nib;
    EXPECT_EQ(sform, 5) << nib;
    EXPECT_EQ(qform, 5) << nib;
    EXPECT_NEAR(zv(1), z11, 1e-5) << nib;  // element 5 = (row 1, col 1)
    EXPECT_NEAR(area, 50.0, 1e-3) << nib;   // the table's element area (mm^2)
    EXPECT_NE(nib.find("map grid, element 50 mm^2"), std::string::npos) << nib;
    // The per-vertex z carries the same intent (QA 4 item 10: its data array said NONE).
    std::string func;
    ASSERT_EQ(test::run_command("/usr/bin/python3 -c \"import nibabel as nib; d = nib.load('" + dir +
                                    "/cmp_z.func.gii').darrays[0]; print(d.intent, nib.nifti1.intent_codes.niistring[d.intent])\"",
                                &func),
              0)
        << func;
    EXPECT_EQ(func, "5 NIFTI_INTENT_ZSCORE\n");
  } else if (test::running_in_ci()) {
    FAIL() << "CI=true but /usr/bin/python3 with nibabel is missing";
  }
  EXPECT_LT(zv(1), -2.0);
  EXPECT_TRUE(std::isnan(zv(3)));
  std::ifstream csv(dir + "/cmp_abnormal.csv");
  std::string line;
  int rows = 0;
  while (std::getline(csv, line)) ++rows;
  EXPECT_EQ(rows, 4);  // header + 3 elements

  // Incompatible patient (K = 2 table) -> exit 2 with the reason.
  analysis::ElementTable small = table("p2", 60, [](int) { return 1.0; });
  small.grid = analysis::element_grid(Domain::square(), 2);
  small.blocks[0].elements.resize(4);
  for (auto& e : small.blocks[0].elements) {
    e.row = e.id / 2;
    e.col = e.id % 2;
  }
  analysis::write_element_table(dir + "/p2_elements.csv", small);
  EXPECT_EQ(test::run_command(exe + " normative compare " + dir + "/merged.json " + dir + "/p2_elements.csv " + dir + "/cmp2", &out), 2);
  // Both files are named (it said "patient p2: ... but the reference has 4").
  EXPECT_NE(out.find("p2_elements.csv (patient p2): K is 2 but " + dir + "/merged.json has 4"), std::string::npos) << out;
}

}  // namespace
}  // namespace authalic
