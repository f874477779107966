// Anatomical names for the report: majority regions, the regional table, lobes from
// coordinates, the findings sentence, the minimum cluster size and the BIDS sidecar.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>

#include "analysis/regions.h"
#include "analysis/report_inputs.h"
#include "analysis/synthetic_parcellation.h"
#include "common/test_data.h"
#include "core/error.h"

namespace {

namespace an = authalic::analysis;
using authalic::MatrixXd;
using authalic::MatrixXi;
using authalic::VectorXi;

an::Parcellation three_regions() {
  an::Parcellation p;
  p.names = {"precuneus", "posteriorcingulate", "cuneus"};
  p.label.resize(8);
  p.label << 0, 0, 0, 1, 1, 2, -1, -1;
  return p;
}

TEST(Regions, MajorityRegionOfTheLabelledVertices) {
  const an::Parcellation p = three_regions();
  const an::RegionShare r = an::majority_region(p, {0, 1, 3, 6, 7});
  EXPECT_EQ(r.name, "precuneus");
  EXPECT_NEAR(r.fraction, 2.0 / 3.0, 1e-12);  // unlabelled vertices are not counted
  EXPECT_EQ(an::majority_region(p, {6, 7}).name, "");
  EXPECT_EQ(an::majority_region(p, {3, 5}).name, "posteriorcingulate");  // tie: the lower index
}

TEST(Regions, RegionalTableMeansByRegionAndLobe) {
  const an::Parcellation p = three_regions();
  VectorXi element_of_vertex(8);
  element_of_vertex << 0, 0, 1, 2, 2, 3, -1, -1;
  const auto vertices = an::vertices_of_elements(element_of_vertex, 4);
  ASSERT_EQ(vertices[2], (std::vector<int>{3, 4}));
  const std::vector<double> z = {-3.0, -1.0, 2.0, std::nan("")};
  const auto rows = an::regional_table("left", p, z, vertices);
  // cingulate: posteriorcingulate (element 2); occipital: cuneus has only the NaN element; parietal: precuneus (0, 1).
  std::map<std::string, an::RegionRow> by;
  for (const auto& r : rows) by[r.lobe + "/" + r.region] = r;
  ASSERT_TRUE(by.count("parietal/precuneus"));
  EXPECT_EQ(by["parietal/precuneus"].elements, 2);
  EXPECT_DOUBLE_EQ(by["parietal/precuneus"].mean_z, -2.0);
  EXPECT_DOUBLE_EQ(by["parietal/"].mean_z, -2.0);
  EXPECT_DOUBLE_EQ(by["cingulate/posteriorcingulate"].mean_z, 2.0);
  EXPECT_FALSE(by.count("occipital/"));
}

TEST(Regions, DesikanNamesLobesAndReadableNames) {
  EXPECT_EQ(an::lobe_of_region("precuneus"), "parietal");
  EXPECT_EQ(an::lobe_of_region("parsopercularis"), "frontal");
  EXPECT_EQ(an::lobe_of_region("isthmuscingulate"), "cingulate");
  EXPECT_EQ(an::lobe_of_region("temporal"), "temporal");
  EXPECT_EQ(an::lobe_of_region("nonsense"), "");
  EXPECT_EQ(an::readable_region("caudalanteriorcingulate"), "caudal anterior cingulate");
  EXPECT_EQ(an::readable_region("G_cuneus"), "G cuneus");
}

TEST(Regions, LobesFromCoordinatesFollowTheStatedRule) {
  // Four vertices at known positions in a 100 mm (y) x 100 mm (z) box.
  MatrixXd V(6, 3);
  V << 0, 0, 0,  //
      0, 100, 100, 0, 10, 50, 0, 80, 50, 0, 40, 20, 0, 40, 80;
  MatrixXi F(2, 3);
  F << 0, 1, 2, 3, 4, 5;
  const an::Parcellation p = an::lobes_from_coordinates(V, F);
  auto lobe = [&](int v) { return p.names[static_cast<std::size_t>(p.label(v))]; };
  EXPECT_EQ(lobe(2), "occipital");
  EXPECT_EQ(lobe(3), "frontal");
  EXPECT_EQ(lobe(4), "temporal");
  EXPECT_EQ(lobe(5), "parietal");
  EXPECT_NE(p.method.find("approximate"), std::string::npos);
}

TEST(Regions, FindingsSummaryInWords) {
  std::vector<an::Finding> f = {{"hypo", "left", "precuneus", -4.94, 820.0},
                                {"hypo", "left", "posteriorcingulate", -3.1, 630.0},
                                {"hyper", "right", "cuneus", 2.6, 95.0}};
  const std::string s = an::findings_summary(f, 2.0, 3);
  EXPECT_NE(s.find("Hypometabolism in left precuneus and left posterior cingulate (2 clusters, 1,450 mm\u00b2), peak z "
                   "\u22124.9 in left precuneus."),
            std::string::npos)
      << s;
  EXPECT_NE(s.find("Hypermetabolism in right cuneus (1 cluster, 95 mm\u00b2), peak z 2.6 in right cuneus."), std::string::npos) << s;
  const std::string none = an::findings_summary({}, 2.0, 3);
  EXPECT_NE(none.find("No hypometabolism (|z| \u2265 2.0 over at least 3 elements)."), std::string::npos) << none;
  // With the controls' chance clusters measured: how many clusters beat every control.
  for (auto& x : f) x.controls = 20;
  f[0].controls_as_large = 0;
  f[1].controls_as_large = 4;
  f[2].controls_as_large = 9;
  const std::string chance = an::findings_summary(f, 2.0, 3);
  EXPECT_NE(chance.find("peak z \u22124.9 in left precuneus; against chance clusters in the 20 controls: 1 of the 2 clusters "
                        "(left precuneus) is larger than in every control (p = 0.048)."),
            std::string::npos)
      << chance;
  EXPECT_NE(chance.find("peak z 2.6 in right cuneus; against chance clusters in the 20 controls: the cluster is not larger "
                        "than in every control."),
            std::string::npos)
      << chance;
  f[1].controls_as_large = 0;
  EXPECT_NE(an::findings_summary(f, 2.0, 3).find("2 of the 2 clusters (left precuneus and left posterior cingulate) are larger than in every control (p = 0.048)"), std::string::npos);
  f[0].controls_as_large = f[1].controls_as_large = 3;
  EXPECT_NE(an::findings_summary(f, 2.0, 3).find("none of the 2 clusters is larger than in every control."), std::string::npos);
}

TEST(ReportInputs, SmallClustersAreDroppedAndRenumbered) {
  an::Comparison c;
  for (int id = 1; id <= 3; ++id) {
    an::ElementCluster cl;
    cl.id = id;
    cl.elements.assign(static_cast<std::size_t>(id == 2 ? 1 : 4), 0);
    c.clusters.push_back(cl);
  }
  c.cluster = {1, 2, 3, 0, 3};
  EXPECT_EQ(an::drop_small_clusters(c, 3), 1);
  ASSERT_EQ(c.clusters.size(), 2u);
  EXPECT_EQ(c.clusters[1].id, 2);
  EXPECT_EQ(c.cluster, (std::vector<int>{1, 0, 2, 0, 2}));
}

TEST(ReportInputs, ScanDetailsFromTheBidsSidecar) {
  const std::string dir = authalic::test::temp_dir("bids_sidecar");
  std::ofstream(dir + "/sub-01_pet.nii.gz") << "x";
  std::ofstream(dir + "/sub-01_pet.json") << R"({"TracerName": "[18F]FDG", "InjectedRadioactivity": 205.4,
      "InjectedRadioactivityUnits": "MBq", "AcquisitionDateTime": "2024-03-18T09:12:00"})";
  const an::ScanDetails d = an::scan_details_from_sidecar(dir + "/sub-01_pet.nii.gz");
  EXPECT_EQ(d.tracer, "[18F]FDG");
  EXPECT_EQ(d.dose, "205.4 MBq");
  EXPECT_EQ(d.scan_date, "2024-03-18");
  EXPECT_TRUE(an::scan_details_from_sidecar(dir + "/other_pet.nii.gz").tracer.empty());  // no sidecar: nothing
  std::ofstream(dir + "/sub-02_pet.nii") << "x";
  std::ofstream(dir + "/sub-02_pet.json") << "not json";
  EXPECT_THROW(an::scan_details_from_sidecar(dir + "/sub-02_pet.nii"), authalic::InputError);
  EXPECT_EQ(an::human_number(61.8), "61.8");
  EXPECT_EQ(an::human_number(67.0), "67");
}

TEST(SyntheticParcellation, NamesThePhantomsPlantedRegionPrecuneus) {
  const an::Hemisphere h = an::synthetic_left_hemisphere(an::SyntheticHemisphereOptions{});
  const authalic::io::Annotation a = an::synthetic_parcellation(h);
  ASSERT_EQ(a.label.size(), h.white.num_vertices());
  std::map<std::string, int> count;
  for (int v = 0; v < a.label.size(); ++v) {
    if (!h.cortex[static_cast<std::size_t>(v)]) {
      EXPECT_EQ(a.names[static_cast<std::size_t>(a.label(v))], "unknown");
      continue;
    }
    ++count[a.names[static_cast<std::size_t>(a.label(v))]];
  }
  EXPECT_GE(count.size(), 25u);  // every seed owns some cortex
  // The phantom patients' planted region (medial, posterior, superior) lies mostly in precuneus.
  const an::PlantedRegion r = an::plant_region(h, an::default_region_target(true, an::SyntheticHemisphereOptions{}), 22.0, 0.25);
  std::vector<int> inside;
  for (int v = 0; v < a.label.size(); ++v)
    if (r.left_mask[static_cast<std::size_t>(v)]) inside.push_back(v);
  an::Parcellation p = an::parcellation_from_annotation(a, "synthetic");
  EXPECT_EQ(an::majority_region(p, inside).name, "precuneus");
}

}  // namespace
