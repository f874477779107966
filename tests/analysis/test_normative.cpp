// Normative reference and patient comparison (analysis/normative.h): hand-computed z-scores,
// exact merging, the age model against a direct least-squares fit, refusals, clusters.
#include <gtest/gtest.h>
#include <omp.h>

#include <cmath>
#include <fstream>
#include <random>
#include <nlohmann/json.hpp>

#include "analysis/normative.h"
#include "common/test_data.h"
#include "core/error.h"

namespace authalic::analysis {
namespace {

ElementTable make_table(const Domain& domain, int k, const std::vector<std::string>& hemis, const std::string& id,
                        const std::vector<double>& values, double age = std::nan("")) {
  ElementTable t;
  t.grid = element_grid(domain, k);
  t.normalisation = "global";
  t.units = "ratio to the global cortical mean";
  t.subject_id = id;
  t.age = age;
  const int ne = t.grid.num_elements();
  for (std::size_t b = 0; b < hemis.size(); ++b) {
    ElementBlock block{hemis[b], {}};
    for (int e = 0; e < ne; ++e) {
      Element el;
      el.id = e;
      el.row = e / t.grid.cols;
      el.col = e % t.grid.cols;
      el.area_mm2 = 10.0 + e;
      el.centroid = Eigen::Vector3d(e, -e, 2.0 * e);
      el.value = values[b * ne + static_cast<std::size_t>(e)];
      el.n_vertices = 3;
      block.elements.push_back(el);
    }
    t.blocks.push_back(block);
  }
  return t;
}

// Deterministic pseudo-random numbers for the tests.
double noise(int i, int j) { return std::sin(12.9898 * i + 78.233 * j) * 0.5; }

TEST(Normative, ZScoresEqualHandComputationOnATinyTable) {
  // K = 2 square, 4 elements; three controls.
  const std::vector<std::vector<double>> controls = {{1.0, 2.0, 3.0, 4.0}, {2.0, 2.0, 5.0, 4.5}, {3.0, 2.0, 4.0, 5.0}};
  NormativeReference ref;
  for (std::size_t s = 0; s < controls.size(); ++s) {
    const ElementTable t = make_table(Domain::square(), 2, {"left"}, "c" + std::to_string(s), controls[s]);
    if (s == 0) ref = empty_reference_like(t);
    add_subject(ref, t, "c" + std::to_string(s) + ".csv");
  }
  EXPECT_FALSE(ref.age_model);  // no ages
  // Element 0: mean 2, SD 1. Element 1: SD 0 (no z). Element 2: mean 4, SD 1. Element 3: mean 4.5, SD 0.5.
  EXPECT_DOUBLE_EQ(ref.mean[0], 2.0);
  EXPECT_DOUBLE_EQ(ref.sd(0), 1.0);
  EXPECT_DOUBLE_EQ(ref.sd(1), 0.0);
  EXPECT_DOUBLE_EQ(ref.sd(3), 0.5);
  const ElementTable patient = make_table(Domain::square(), 2, {"left"}, "p", {0.0, 2.0, 5.5, 3.0});
  // Default: the predictive SD of a new control, SD x sqrt(1 + 1/n) = SD x sqrt(4/3) for n = 3.
  const Comparison p = compare_to_reference(ref, patient);
  EXPECT_TRUE(p.predictive);
  EXPECT_NEAR(p.sd[0], std::sqrt(4.0 / 3.0), 1e-15);
  EXPECT_NEAR(p.z[0], -2.0 / std::sqrt(4.0 / 3.0), 1e-15);   // -1.732: not flagged
  EXPECT_TRUE(std::isnan(p.z[1]));
  EXPECT_NEAR(p.z[2], 1.5 / std::sqrt(4.0 / 3.0), 1e-15);
  EXPECT_NEAR(p.z[3], -1.5 / (0.5 * std::sqrt(4.0 / 3.0)), 1e-14);  // -2.598
  EXPECT_EQ(p.flag, (std::vector<int>{0, 0, 0, -1}));
  // The plain reference SD (NEUROSTAT/3D-SSP).
  CompareOptions plain;
  plain.predictive = false;
  const Comparison c = compare_to_reference(ref, patient, plain);
  EXPECT_FALSE(c.predictive);
  EXPECT_DOUBLE_EQ(c.z[0], -2.0);   // (0 - 2) / 1: hypometabolic at exactly the threshold
  EXPECT_TRUE(std::isnan(c.z[1]));  // SD 0
  EXPECT_DOUBLE_EQ(c.z[2], 1.5);    // (5.5 - 4) / 1
  EXPECT_DOUBLE_EQ(c.z[3], -3.0);   // (3 - 4.5) / 0.5
  EXPECT_EQ(c.flag, (std::vector<int>{-1, 0, 0, -1}));
  EXPECT_EQ(c.num_hypo, 2);
  EXPECT_EQ(c.num_hyper, 0);
  EXPECT_EQ(c.num_compared, 3);
  // Elements 0 (row 0, col 0) and 3 (row 1, col 1) touch diagonally: one cluster.
  ASSERT_EQ(c.clusters.size(), 1u);
  EXPECT_EQ(c.clusters[0].elements, (std::vector<int>{0, 3}));
  EXPECT_DOUBLE_EQ(c.clusters[0].peak_z, -3.0);
  EXPECT_EQ(c.clusters[0].peak_element, 3);
  EXPECT_DOUBLE_EQ(c.clusters[0].area_mm2, 10.0 + 13.0);
  EXPECT_DOUBLE_EQ(c.clusters[0].mean_z, -2.5);
  EXPECT_EQ(c.cluster, (std::vector<int>{1, 0, 0, 1}));
  // A higher threshold flags only element 3.
  CompareOptions o = plain;
  o.threshold = 2.5;
  EXPECT_EQ(compare_to_reference(ref, patient, o).flag, (std::vector<int>{0, 0, 0, -1}));
}

NormativeReference build_from(const std::vector<ElementTable>& tables, std::size_t first, std::size_t last) {
  NormativeReference r = empty_reference_like(tables[first]);
  for (std::size_t s = first; s < last; ++s) add_subject(r, tables[s], tables[s].subject_id + ".csv");
  return r;
}

std::vector<ElementTable> cohort(int subjects, bool with_ages) {
  std::vector<ElementTable> tables;
  for (int s = 0; s < subjects; ++s) {
    std::vector<double> v(2 * 16);
    const double age = 50.0 + 2.5 * s + 3 * noise(s, 99);
    for (int i = 0; i < 32; ++i) v[static_cast<std::size_t>(i)] = 1.0 + 0.01 * i - 0.004 * age + 0.05 * noise(s, i);
    if (s == 3) v[5] = std::nan("");  // a missing element value
    tables.push_back(make_table(Domain::square(), 4, {"left", "right"}, "s" + std::to_string(s), v,
                                with_ages ? age : std::nan("")));
  }
  return tables;
}

// A focal loss lowers the patient's global mean, so after global normalisation every healthy
// element reads ~5 % high. The rescaling fits the one factor on the elements found normal: here the
// healthy ones are exactly 1.05 x the reference mean, so the factor is exactly 1 / 1.05, the lesion
// stays flagged and nothing healthy is flagged; without it, every healthy element is "hyper".
TEST(Normative, RescalingToTheReferenceRemovesTheGlobalNormalisationShift) {
  constexpr int kK = 8, kN = kK * kK;
  NormativeReference ref;
  for (int s = 0; s < 12; ++s) {
    std::vector<double> v(kN);
    for (int i = 0; i < kN; ++i) v[static_cast<std::size_t>(i)] = 1.0 + 0.01 * (i % 7) + 0.04 * noise(s, i);
    const ElementTable t = make_table(Domain::square(), kK, {"left"}, "c" + std::to_string(s), v);
    if (s == 0) ref = empty_reference_like(t);
    add_subject(ref, t, t.subject_id + ".csv");
  }
  std::vector<double> p(kN);
  std::vector<int> lesion;
  for (int i = 0; i < kN; ++i) {
    const int r = i / kK, c = i % kK;
    const bool in = r >= 2 && r < 5 && c >= 3 && c < 6;  // 3 x 3 elements
    if (in) lesion.push_back(i);
    p[static_cast<std::size_t>(i)] = 1.05 * ref.mean[static_cast<std::size_t>(i)] * (in ? 0.7 : 1.0);
  }
  const ElementTable patient = make_table(Domain::square(), kK, {"left"}, "p", p);
  const Comparison r = compare_to_reference(ref, patient);
  ASSERT_TRUE(r.rescaled);
  EXPECT_NEAR(r.scale, 1 / 1.05, 1e-12);
  EXPECT_EQ(r.scale_elements, kN - 9);
  EXPECT_EQ(r.num_hyper, 0);
  EXPECT_EQ(r.num_hypo, 9);
  for (int i : lesion) EXPECT_EQ(r.flag[static_cast<std::size_t>(i)], -1) << i;
  ASSERT_EQ(r.clusters.size(), 1u);
  EXPECT_EQ(r.clusters[0].elements, lesion);
  // z is measured on the rescaled value.
  EXPECT_NEAR(r.z[0], (r.scale * p[0] - r.expected[0]) / r.sd[0], 1e-12);
  EXPECT_NEAR(r.z[0], 0.0, 1e-9);
  CompareOptions off;
  off.rescale = false;
  const Comparison g = compare_to_reference(ref, patient, off);
  EXPECT_FALSE(g.rescaled);
  EXPECT_EQ(g.scale, 1.0);
  EXPECT_GT(g.num_hyper, kN / 2) << "the global-normalisation shift alone should flag most healthy elements";
  // A healthy control (exactly the reference mean) keeps factor 1 and no flags.
  std::vector<double> h(ref.mean.begin(), ref.mean.end());
  const Comparison c = compare_to_reference(ref, make_table(Domain::square(), kK, {"left"}, "h", h));
  EXPECT_NEAR(c.scale, 1.0, 1e-12);
  EXPECT_EQ(c.num_hypo + c.num_hyper, 0);
}

TEST(Normative, MergingTwoHalvesEqualsTheWhole) {
  const auto tables = cohort(21, true);
  const NormativeReference whole = build_from(tables, 0, 21);
  const NormativeReference half_a = build_from(tables, 0, 10), half_b = build_from(tables, 10, 21);
  const NormativeReference merged = merge_references(half_a, half_b);
  ASSERT_TRUE(merged.age_model);
  EXPECT_EQ(merged.subjects.size(), 21u);
  EXPECT_EQ(merged.subjects[12].id, "s12");
  for (int i = 0; i < whole.num_values(); ++i) {
    EXPECT_EQ(merged.n[i], whole.n[i]);
    EXPECT_NEAR(merged.mean[i], whole.mean[i], 1e-14 * std::abs(whole.mean[i]));
    EXPECT_NEAR(merged.m2[i], whole.m2[i], 1e-10 * whole.m2[i]);
    EXPECT_NEAR(merged.age_mean[i], whole.age_mean[i], 1e-13 * whole.age_mean[i]);
    EXPECT_NEAR(merged.age_m2[i], whole.age_m2[i], 1e-10 * whole.age_m2[i]);
    EXPECT_NEAR(merged.comoment[i], whole.comoment[i], 1e-9 * std::abs(whole.comoment[i]));
  }
  EXPECT_EQ(whole.n[5], 20);  // subject 3's NaN at element 5 is not counted
  // Merging is also exact in the other order and with an empty side.
  const NormativeReference reversed = merge_references(half_b, half_a);
  EXPECT_NEAR(reversed.m2[7], whole.m2[7], 1e-10 * whole.m2[7]);
  // Through the file format (shortest round-trip numbers): bit for bit.
  const std::string dir = test::temp_dir("normative_merge");
  write_reference(dir + "/ref.json", merged);
  const NormativeReference back = read_reference(dir + "/ref.json");
  EXPECT_EQ(back.mean, merged.mean);
  EXPECT_EQ(back.m2, merged.m2);
  EXPECT_EQ(back.comoment, merged.comoment);
  EXPECT_EQ(back.subjects.size(), 21u);
  EXPECT_EQ(back.subjects[4].age, merged.subjects[4].age);
}

TEST(Normative, AgeModelEqualsDirectLeastSquaresFit) {
  const auto tables = cohort(15, true);
  const NormativeReference ref = build_from(tables, 0, 15);
  const int e = 9;
  // Direct least squares on element 9 (all subjects have it).
  double sa = 0, sy = 0;
  for (const auto& t : tables) {
    sa += t.age;
    sy += t.blocks[0].elements[e].value;
  }
  const double ma = sa / 15, my = sy / 15;
  double saa = 0, say = 0, syy = 0;
  for (const auto& t : tables) {
    const double da = t.age - ma, dy = t.blocks[0].elements[e].value - my;
    saa += da * da;
    say += da * dy;
    syy += dy * dy;
  }
  const double beta = say / saa;
  const double sd_res = std::sqrt((syy - beta * say) / 13);
  ElementTable patient = tables[0];
  patient.subject_id = "patient";
  patient.age = 71.0;
  patient.blocks[0].elements[e].value = 0.8;
  // Hand computations of z: without the rescaling to the reference (tested on its own below).
  CompareOptions plain_sd;
  plain_sd.predictive = false;
  plain_sd.rescale = false;
  const Comparison c = compare_to_reference(ref, patient, plain_sd);
  ASSERT_TRUE(c.age_adjusted);
  const double expected = my + beta * (71.0 - ma);
  EXPECT_NEAR(c.expected[e], expected, 1e-12);
  EXPECT_NEAR(c.sd[e], sd_res, 1e-12);
  EXPECT_NEAR(c.z[e], (0.8 - expected) / sd_res, 1e-9);
  // Predictive SD of the regression (default): sd_res sqrt(1 + 1/n + (age - mean age)^2 / Saa).
  CompareOptions predictive;
  predictive.rescale = false;
  const Comparison pred = compare_to_reference(ref, patient, predictive);
  const double sd_pred = sd_res * std::sqrt(1 + 1.0 / 15 + (71.0 - ma) * (71.0 - ma) / saa);
  EXPECT_NEAR(pred.sd[e], sd_pred, 1e-12);
  EXPECT_NEAR(pred.z[e], (0.8 - expected) / sd_pred, 1e-9);
  // Without the age model: the plain mean and SD.
  CompareOptions o = plain_sd;
  o.use_age = false;
  const Comparison plain = compare_to_reference(ref, patient, o);
  EXPECT_FALSE(plain.age_adjusted);
  EXPECT_NEAR(plain.z[e], (0.8 - my) / std::sqrt(syy / 14), 1e-9);
  o.predictive = true;
  EXPECT_NEAR(compare_to_reference(ref, patient, o).z[e], (0.8 - my) / std::sqrt(syy / 14 * (1 + 1.0 / 15)), 1e-9);
  // A control without an age drops the age model.
  NormativeReference mixed = ref;
  ElementTable ageless = tables[1];
  ageless.subject_id = "ageless";
  ageless.age = std::nan("");
  add_subject(mixed, ageless, "ageless.csv");
  EXPECT_FALSE(mixed.age_model);
  EXPECT_TRUE(mixed.comoment.empty());
  // ... and a comparison says so, naming the control (qa4_cli D7: the model vanished silently).
  EXPECT_EQ(age_model_absent_reason(mixed),
            "1 of the reference's 16 controls ('ageless') have no age; the age model needs every control's age");
  const Comparison dropped = compare_to_reference(mixed, patient, plain_sd);
  EXPECT_FALSE(dropped.age_adjusted);
  ASSERT_FALSE(dropped.notes.empty());
  EXPECT_EQ(dropped.notes.back(), age_model_absent_reason(mixed) + ": no age model, z-scores are NOT age adjusted");
  // A reference without any ages has nothing to explain.
  NormativeReference none = mixed;
  for (auto& s : none.subjects) s.age = std::nan("");
  EXPECT_EQ(age_model_absent_reason(none), "");
  // Controls all of one age: no slope to fit, so z is the plain one and says so (it claimed to
  // be age adjusted).
  std::vector<ElementTable> same_age = tables;
  for (auto& t : same_age) t.age = 70.0;
  const NormativeReference flat = build_from(same_age, 0, 15);
  EXPECT_TRUE(flat.age_model);
  EXPECT_FALSE(has_age_model(flat));
  EXPECT_TRUE(has_age_model(ref));
  const Comparison no_slope = compare_to_reference(flat, patient, plain_sd);
  EXPECT_FALSE(no_slope.age_adjusted);
  EXPECT_NEAR(no_slope.z[e], (0.8 - my) / std::sqrt(syy / 14), 1e-9);
  bool noted = false;
  for (const auto& n : no_slope.notes) noted = noted || n.find("all of one age") != std::string::npos;
  EXPECT_TRUE(noted);
  // Fewer controls than kMinAgeModelControls: a line through them leaves too few degrees of
  // freedom for its residual SD (3 controls gave z in the tens of thousands): the plain mean and
  // SD, with a note saying why.
  const NormativeReference few = build_from(tables, 0, kMinAgeModelControls - 1);
  EXPECT_TRUE(few.age_model);
  EXPECT_FALSE(has_age_model(few));
  EXPECT_TRUE(has_age_model(few, kMinAgeModelControls - 1));  // as its parent's leave-one-out reference
  const Comparison small = compare_to_reference(few, patient, plain_sd);
  EXPECT_FALSE(small.age_adjusted);
  EXPECT_NEAR(small.z[e], (0.8 - few.mean[e]) / few.sd(e), 1e-9);
  noted = false;
  for (const auto& n : small.notes) noted = noted || n.find("the age model needs at least 8") != std::string::npos;
  EXPECT_TRUE(noted);
  // The comparison's summary says the model was not used (it said "age_model": true for the ages stored).
  const auto summary = nlohmann::json::parse(comparison_summary_json(few, "ref.json", patient, "p.tsv", small, {}));
  EXPECT_EQ(summary["reference"]["age_model"], false);
  EXPECT_EQ(summary["reference"]["age_statistics_stored"], true);
  EXPECT_TRUE(has_age_model(build_from(tables, 0, kMinAgeModelControls)));
}

// A patient older or younger than every control: the line extrapolates, and the comparison says
// so. A patient value no reference could hold (|value| > 1e15) is refused as build refuses it.
TEST(Normative, ExtrapolatedAgeIsNotedAndImplausibleValuesRefused) {
  const auto tables = cohort(15, true);
  const NormativeReference ref = build_from(tables, 0, 15);
  ElementTable patient = tables[0];
  patient.subject_id = "p";
  double oldest = 0;
  for (const auto& t : tables) oldest = std::max(oldest, t.age);
  CompareOptions o;
  o.age = oldest + 10;
  const Comparison c = compare_to_reference(ref, patient, o);
  ASSERT_TRUE(c.age_adjusted);
  bool noted = false;
  for (const auto& n : c.notes) noted = noted || n.find("is outside the controls' ages") != std::string::npos;
  EXPECT_TRUE(noted);
  o.age = oldest;
  for (const auto& n : compare_to_reference(ref, patient, o).notes) EXPECT_EQ(n.find("outside the controls' ages"), std::string::npos) << n;
  patient.blocks[0].elements[3].value = 1e300;
  o.patient_name = "p.tsv";
  try {
    compare_to_reference(ref, patient, o);
    FAIL() << "accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("p.tsv: element 3"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("beyond +-1e15"), std::string::npos) << e.what();
  }
}

// SUVRs of another reference region are other numbers: a patient normalised with another mask
// than the controls is refused (56.9 % of elements were flagged hyper with --no-rescale); tables
// that do not record their mask pass, as before.
TEST(Normative, APatientNormalisedWithAnotherReferenceRegionIsRefused) {
  auto tables = cohort(6, false);
  for (auto& t : tables) {
    t.normalisation = "reference-region";
    t.units = "SUVR";
    t.metadata[kReferenceMaskKey] = std::string(64, 'a');
  }
  const NormativeReference ref = build_from(tables, 0, 5);
  EXPECT_EQ(ref.reference_mask, std::string(64, 'a'));
  EXPECT_EQ(reference_from_json(reference_to_json(ref), "ref.json").reference_mask, ref.reference_mask);
  ElementTable patient = tables[5];
  EXPECT_NO_THROW(compare_to_reference(ref, patient, {}));
  patient.metadata[kReferenceMaskKey] = std::string(64, 'b');
  try {
    compare_to_reference(ref, patient, {});
    FAIL() << "accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("normalised with another reference-region mask (SHA-256 bbbbbbbbbbbb...)"), std::string::npos)
        << e.what();
  }
  patient.metadata.erase(kReferenceMaskKey);
  bool noted = false;
  for (const auto& n : compare_to_reference(ref, patient, {}).notes)
    noted = noted || n.find("the patient's table does not record its reference-region mask") != std::string::npos;
  EXPECT_TRUE(noted) << "a table without its mask passes, with a note";
}

// The share of a healthy subject's elements beyond |z| >= 2 is Student's t tail (known values:
// 2 P(T_5 >= 2) = 0.101939, 2 P(T_19 >= 2) = 0.060002, 2 P(T_4 >= 2) = 0.116117 (scipy)).
TEST(Normative, ExpectedAbnormalShareIsTheTDistributionsTail) {
  EXPECT_NEAR(expected_abnormal_share(6, false, true, 2.0), 0.101939, 1e-6);
  EXPECT_NEAR(expected_abnormal_share(20, false, true, 2.0), 0.060002, 1e-6);
  EXPECT_NEAR(expected_abnormal_share(6, true, true, 2.0), 0.116117, 1e-6);  // the age model: n - 2 df
  // The plain SD: z / sqrt(1 + 1/n) is the t; its tail at 2 / sqrt(1 + 1/20).
  EXPECT_NEAR(expected_abnormal_share(20, false, false, 2.0), expected_abnormal_share(20, false, true, 2.0 / std::sqrt(1.05)), 1e-12);
  EXPECT_TRUE(std::isnan(expected_abnormal_share(1, false, true, 2.0)));
}

// Leaving a control out by undoing its Welford update (for the chance clusters) gives the
// reference built without it, age model included, and the values travel with the subjects through
// the file, merges and leave-one-out.
TEST(Normative, LeavingAControlOutEqualsTheReferenceBuiltWithoutIt) {
  const auto tables = cohort(12, true);
  const NormativeReference ref = build_from(tables, 0, 12);
  ASSERT_EQ(ref.subject_values.size(), 12u);
  EXPECT_TRUE(std::isnan(ref.subject_values[3][5]));  // subject 3's missing value
  EXPECT_EQ(ref.subject_values[4][7], tables[4].blocks[0].elements[7].value);
  EXPECT_EQ(ref.subject_values[4][16 + 2], tables[4].blocks[1].elements[2].value);
  for (std::size_t s : {std::size_t{0}, std::size_t{3}, std::size_t{11}}) {
    std::vector<ElementTable> others;
    for (std::size_t t = 0; t < tables.size(); ++t)
      if (t != s) others.push_back(tables[t]);
    const NormativeReference direct = build_from(others, 0, others.size()), loo = leave_one_out(ref, s);
    ASSERT_EQ(loo.subjects.size(), 11u);
    EXPECT_TRUE(loo.subject_values.empty());
    for (int i = 0; i < ref.num_values(); ++i) {
      EXPECT_EQ(loo.n[i], direct.n[i]) << s << " " << i;
      EXPECT_NEAR(loo.mean[i], direct.mean[i], 1e-13) << s << " " << i;
      EXPECT_NEAR(loo.m2[i], direct.m2[i], 1e-12) << s << " " << i;
      EXPECT_NEAR(loo.age_mean[i], direct.age_mean[i], 1e-11) << s << " " << i;
      EXPECT_NEAR(loo.age_m2[i], direct.age_m2[i], 1e-8 * direct.age_m2[i]) << s << " " << i;
      EXPECT_NEAR(loo.comoment[i], direct.comoment[i], 1e-11) << s << " " << i;
    }
  }
  EXPECT_THROW(leave_one_out(ref, 12), std::out_of_range);
  // File round trip (null for the missing value) and merge (concatenated in subject order).
  const NormativeReference back = reference_from_json(reference_to_json(ref), "ref.json");
  ASSERT_EQ(back.subject_values.size(), 12u);
  EXPECT_TRUE(std::isnan(back.subject_values[3][5]));
  EXPECT_EQ(back.subject_values[7], ref.subject_values[7]);
  const NormativeReference merged = merge_references(build_from(tables, 0, 5), build_from(tables, 5, 12));
  ASSERT_EQ(merged.subject_values.size(), 12u);
  for (std::size_t s = 0; s < 12; ++s) EXPECT_EQ(merged.subject_values[s][9], ref.subject_values[s][9]);
  // A reference written before the values were kept reads, merges and compares without them.
  nlohmann::json old = nlohmann::json::parse(reference_to_json(ref));
  old.erase("subject_values");
  const NormativeReference old_ref = reference_from_json(old.dump(), "old.json");
  EXPECT_TRUE(old_ref.subject_values.empty());
  NormativeReference fresh = empty_reference_like(tables[0]);
  ElementTable newcomer = tables[1];
  newcomer.subject_id = "newcomer";
  add_subject(fresh, newcomer, "newcomer.csv");
  ASSERT_EQ(fresh.subject_values.size(), 1u);
  EXPECT_TRUE(merge_references(old_ref, fresh).subject_values.empty());
  NormativeReference grown = old_ref;
  ElementTable extra = tables[0];
  extra.subject_id = "extra";
  add_subject(grown, extra, "extra.csv");
  EXPECT_TRUE(grown.subject_values.empty()) << "values of some subjects only would misalign them";
  ElementTable patient = tables[2];
  patient.subject_id = "patient";
  const Comparison c = compare_to_reference(old_ref, patient);
  EXPECT_TRUE(c.control_mass_hypo.empty());
  EXPECT_NE(c.chance_note.find("does not keep its controls' values"), std::string::npos) << c.chance_note;
  for (const ElementCluster& cl : c.clusters) EXPECT_EQ(cl.controls_as_large, -1);
  // Values that do not add up to n are a corrupt file.
  nlohmann::json bad = nlohmann::json::parse(reference_to_json(ref));
  bad["subject_values"][3] = bad["subject_values"][4];  // subject 4 has element 5, subject 3 has not
  try {
    reference_from_json(bad.dump(), "bad.json");
    ADD_FAILURE() << "inconsistent subject_values were read";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("bad.json: element 5 has 11 controls but 12 values in subject_values"), std::string::npos)
        << e.what();
  }
  bad["subject_values"][3] = "AAAA";
  try {
    reference_from_json(bad.dump(), "bad.json");
    ADD_FAILURE() << "a short subject_values row was read";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("bad.json: subject_values[3] is not base64 of 32 float64 values"), std::string::npos) << e.what();
  }
  bad["subject_values"].erase(0);
  EXPECT_THROW(reference_from_json(bad.dump(), "bad.json"), InputError);
  // A file cut inside a value string: one short line, not the unfinished base64 quoted back.
  const std::string text = reference_to_json(ref);
  try {
    reference_from_json(text.substr(0, text.find("subject_values\": [") + 40), "cut.json");
    ADD_FAILURE() << "a truncated reference was read";
  } catch (const InputError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("cut.json: invalid normative reference ("), std::string::npos) << what;
    EXPECT_NE(what.find("the file is truncated or not a reference written by authalic"), std::string::npos) << what;
    EXPECT_LT(what.size(), 400u) << what;
  }
}

// A large reference keeps the values of its first kMaxChanceControls subjects only (its size stays
// bounded), the same whether built at once or merged from pieces, and leaves each of them out.
TEST(Normative, ALargeReferenceKeepsTheFirstHundredControlsValues) {
  const auto tables = cohort(130, false);
  const NormativeReference whole = build_from(tables, 0, 130);
  ASSERT_EQ(whole.subject_values.size(), kMaxChanceControls);
  EXPECT_TRUE(whole.keeps_values());
  EXPECT_EQ(whole.subject_values[99][4], tables[99].blocks[0].elements[4].value);
  for (std::size_t cut : {std::size_t{40}, std::size_t{100}, std::size_t{120}}) {
    const NormativeReference merged = merge_references(build_from(tables, 0, cut), build_from(tables, cut, 130));
    ASSERT_EQ(merged.subject_values.size(), kMaxChanceControls) << cut;
    for (std::size_t s = 0; s < kMaxChanceControls; ++s) EXPECT_EQ(merged.subject_values[s][7], whole.subject_values[s][7]) << cut;
  }
  const NormativeReference back = reference_from_json(reference_to_json(whole), "big.json");
  EXPECT_EQ(back.subject_values.size(), kMaxChanceControls);
  EXPECT_EQ(leave_one_out(whole, 99).n[0], 129);
  EXPECT_THROW(leave_one_out(whole, 100), std::out_of_range);
  ElementTable patient = tables[0];
  patient.subject_id = "patient";
  EXPECT_EQ(compare_to_reference(whole, patient).control_mass_hypo.size(), kMaxChanceControls);
}

// Chance clusters: 15 controls with independent Gaussian noise per element (SD 0.05) and a patient with a
// 3 x 3 block 6 SD low. Each control, compared with the other 14, has only small, weak clusters;
// the block's mass (about 9 x 4) beats every one of them: p = 1 / 16. The patient's chance
// clusters get p well above 0.05, and every p is the share of the controls' masses at least as large.
TEST(Normative, APlantedClusterBeatsEveryControlsChanceClusters) {
  constexpr int kK = 12, kN = kK * kK, kControls = 15;
  std::mt19937 generator(7);
  std::normal_distribution<double> gaussian(1.0, 0.05);
  std::vector<ElementTable> controls;
  for (int s = 0; s < kControls; ++s) {
    std::vector<double> v(kN);
    for (double& x : v) x = gaussian(generator);
    controls.push_back(make_table(Domain::square(), kK, {"left"}, "c" + std::to_string(s), v));
  }
  const NormativeReference ref = build_from(controls, 0, kControls);
  std::vector<double> p(kN);
  for (double& x : p) x = gaussian(generator);
  const std::vector<int> block = {5 * kK + 5, 5 * kK + 6, 5 * kK + 7, 6 * kK + 5, 6 * kK + 6, 6 * kK + 7, 7 * kK + 5, 7 * kK + 6, 7 * kK + 7};
  for (int i : block) p[static_cast<std::size_t>(i)] = ref.mean[static_cast<std::size_t>(i)] - 6 * ref.sd(i);
  const Comparison c = compare_to_reference(ref, make_table(Domain::square(), kK, {"left"}, "patient", p));
  ASSERT_EQ(c.control_mass_hypo.size(), static_cast<std::size_t>(kControls)) << c.chance_note;
  ASSERT_EQ(c.control_mass_hyper.size(), static_cast<std::size_t>(kControls));
  const ElementCluster* planted = nullptr;
  for (const ElementCluster& cl : c.clusters)
    if (cl.sign < 0 && cl.elements.size() >= 9) planted = &cl;
  ASSERT_NE(planted, nullptr);
  EXPECT_GT(planted->mass, 30.0);
  EXPECT_EQ(planted->controls_as_large, 0);
  EXPECT_DOUBLE_EQ(planted->p_controls, 1.0 / 16);
  double largest = 0;
  for (double m : c.control_mass_hypo) largest = std::max(largest, m);
  EXPECT_LT(largest, planted->mass / 3) << "independent noise gives only small chance clusters";
  int chance = 0;
  for (const ElementCluster& cl : c.clusters) {
    if (&cl == planted) continue;
    ++chance;
    double mass = 0;
    for (int e : cl.elements) mass += std::abs(c.z[static_cast<std::size_t>(e)]) - 2.0;
    EXPECT_NEAR(cl.mass, mass, 1e-12);
    const auto& null = cl.sign < 0 ? c.control_mass_hypo : c.control_mass_hyper;
    const int as_large = static_cast<int>(std::count_if(null.begin(), null.end(), [&](double m) { return m >= cl.mass; }));
    EXPECT_EQ(cl.controls_as_large, as_large);
    EXPECT_DOUBLE_EQ(cl.p_controls, (1.0 + as_large) / 16);
    EXPECT_GT(cl.p_controls, 0.05) << "a chance cluster of " << cl.elements.size() << " elements, mass " << cl.mass;
  }
  EXPECT_GT(chance, 0) << "the patient's own noise should flag a few elements";
  // Off: nothing measured; too few controls: said so.
  CompareOptions off;
  off.chance_clusters = false;
  EXPECT_TRUE(compare_to_reference(ref, make_table(Domain::square(), kK, {"left"}, "patient", p), off).control_mass_hypo.empty());
  const Comparison few = compare_to_reference(build_from(controls, 0, 3), make_table(Domain::square(), kK, {"left"}, "patient", p));
  EXPECT_TRUE(few.control_mass_hypo.empty());
  EXPECT_NE(few.chance_note.find("the reference has 3 controls; leaving one out needs at least 4"), std::string::npos) << few.chance_note;
}

TEST(Normative, IncompatibleInputsAreRefusedWithAClearError) {
  const auto tables = cohort(4, false);
  NormativeReference ref = build_from(tables, 0, 3);
  auto expect_refusal = [&](const ElementTable& t, const std::string& words) {
    try {
      NormativeReference r = ref;
      add_subject(r, t, "other.csv");
      FAIL() << "no error for " << words;
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(words), std::string::npos) << e.what();
    }
  };
  ElementTable t = tables[3];
  t.normalisation = "reference-region";
  t.units = "SUVR";
  expect_refusal(t, "other.csv: the intensity normalisation is reference-region but the reference has global");
  t = make_table(Domain::square(), 2, {"left", "right"}, "x", std::vector<double>(8, 1.0));
  expect_refusal(t, "other.csv: K is 2 but the reference has 4");
  t = make_table(Domain::square(), 4, {"left"}, "x", std::vector<double>(16, 1.0));
  t.normalisation = "global";
  t.units = ref.units;
  expect_refusal(t, "the hemisphere list is left but the reference has left,right");
  t = tables[1];
  expect_refusal(t, "subject 's1' is already in the reference");
  // Merging references of different K, or sharing a subject, is refused too.
  const NormativeReference other = build_from({make_table(Domain::square(), 2, {"left", "right"}, "y", std::vector<double>(8, 1.0))}, 0, 1);
  EXPECT_THROW(merge_references(ref, other), InputError);
  EXPECT_THROW(merge_references(ref, build_from(tables, 2, 4)), InputError);
  // Comparing a patient of another domain.
  const ElementTable rect = make_table(Domain::rectangle(), 4, {"left", "right"}, "p", std::vector<double>(64, 1.0));
  EXPECT_THROW(compare_to_reference(ref, rect), InputError);
  // A corrupt or future reference file.
  const std::string dir = test::temp_dir("normative_refusal");
  std::string json = reference_to_json(ref);
  const std::string v1 = "\"version\": 1";
  ASSERT_NE(json.find(v1), std::string::npos);
  std::string v2 = json;
  v2.replace(v2.find(v1), v1.size(), "\"version\": 2");
  try {
    reference_from_json(v2, "ref.json");
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("ref.json: reference format version 2 is not supported"), std::string::npos) << e.what();
  }
  EXPECT_THROW(reference_from_json("{\"format\": \"something\"}", "x.json"), InputError);
  EXPECT_THROW(reference_from_json("not json", "x.json"), InputError);
}

TEST(Normative, ClustersFollowTheDomainsNeighbourhoods) {
  // 4 x 8 grids (rectangle and sphere at K = 4); flags in row 1.
  std::vector<int> flags(32, 0);
  flags[1 * 8 + 3] = -1;  // column 3: left of the rectangle's seam (K = 4)
  flags[1 * 8 + 4] = -1;  // column 4: right of it
  flags[1 * 8 + 0] = 1;   // column 0 (hyper)
  flags[1 * 8 + 7] = 1;   // column 7: touches column 0 only on the sphere
  flags[2 * 8 + 5] = -1;  // diagonal neighbour of (1, 4)
  int count = 0;
  const auto square_like = label_clusters(element_grid(Domain::rectangle(), 4), flags, &count);
  EXPECT_EQ(count, 4);  // {3}, {4, (2,5)}, {0}, {7}
  EXPECT_NE(square_like[11], square_like[12]);
  EXPECT_EQ(square_like[12], square_like[21]);
  EXPECT_NE(square_like[8], square_like[15]);
  const auto sphere = label_clusters(element_grid(Domain::sphere(), 4), flags, &count);
  EXPECT_EQ(count, 2);  // {3, 4, (2,5)} across longitude; {0, 7} wrapping around
  EXPECT_EQ(sphere[11], sphere[12]);
  EXPECT_EQ(sphere[8], sphere[15]);
  // Unequal hemispheres (w_L = 1.5): columns 0-5 (centres up to 1.375) are the left part, so 3, 4
  // and 5 join and the seam runs between columns 5 and 6; a one-surface rectangle has no seam.
  std::vector<int> run(32, 0);
  for (int c = 3; c <= 6; ++c) run[1 * 8 + c] = -1;
  ElementGrid wide = element_grid(Domain::rectangle(), 4);
  wide.domain.seam_x = 1.5;
  const auto unequal = label_clusters(wide, run, &count);
  EXPECT_EQ(count, 2);
  EXPECT_EQ(unequal[11], unequal[13]);
  EXPECT_NE(unequal[13], unequal[14]);
  wide.domain.seam_x = std::nan("");
  label_clusters(wide, run, &count);
  EXPECT_EQ(count, 1);
  // Opposite signs never join.
  std::vector<int> mixed(16, 0);
  mixed[0] = -1;
  mixed[1] = 1;
  label_clusters(element_grid(Domain::square(), 4), mixed, &count);
  EXPECT_EQ(count, 2);
}

TEST(Normative, BuildFromFilesStreamsAndIsThreadIndependent) {
  const auto tables = cohort(20, true);
  const std::string dir = test::temp_dir("normative_build");
  std::vector<std::string> paths;
  for (const auto& t : tables) {
    paths.push_back(dir + "/" + t.subject_id + "_elements.csv");
    write_element_table(paths.back(), t);
  }
  omp_set_num_threads(1);
  const NormativeReference a = build_reference(paths);
  omp_set_num_threads(2);
  const NormativeReference b = build_reference(paths);
  EXPECT_EQ(reference_to_json(a), reference_to_json(b));
  const NormativeReference direct = build_from(tables, 0, 20);
  EXPECT_EQ(a.mean, direct.mean);
  EXPECT_EQ(a.m2, direct.m2);
  EXPECT_EQ(a.subjects[19].table, paths[19]);
  // A bad table names itself.
  std::ofstream(dir + "/s7_elements.csv") << "garbage\n";
  try {
    build_reference(paths);
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("s7_elements.csv:1: unexpected header"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace authalic::analysis

namespace authalic::analysis {
namespace {

// Issue 14: element (i, j) covers other anatomy in another correspondence mode or atlas, so a
// reference records its mode (and keeps it through its file) and refuses tables of another.
TEST(NormativeCorrespondence, ReferenceRecordsTheModeAndRefusesAnother) {
  const int k = 4;
  std::vector<ElementTable> controls;
  for (int s = 0; s < 3; ++s) {
    std::vector<double> v(16);
    for (int e = 0; e < 16; ++e) v[static_cast<std::size_t>(e)] = 1.0 + 0.1 * noise(s, e);
    controls.push_back(make_table(Domain::square(), k, {"left"}, "c" + std::to_string(s), v));
    controls.back().metadata["correspondence"] = "atlas 0123456789abcdef";
  }
  NormativeReference ref = empty_reference_like(controls[0]);
  for (const auto& t : controls) add_subject(ref, t, t.subject_id);
  EXPECT_EQ(ref.correspondence, "atlas 0123456789abcdef");
  const NormativeReference back = reference_from_json(reference_to_json(ref), "ref.json");
  EXPECT_EQ(back.correspondence, "atlas 0123456789abcdef");

  ElementTable patient = controls[0];
  patient.subject_id = "p";
  EXPECT_NO_THROW(compare_to_reference(back, patient));
  for (const std::string& mode : {std::string(""), std::string("atlas fedcba9876543210")}) {
    if (mode.empty())
      patient.metadata.erase("correspondence");  // a table without the key: per-subject (before issue 14)
    else
      patient.metadata["correspondence"] = mode;
    try {
      compare_to_reference(back, patient);
      ADD_FAILURE() << "a patient in mode '" << mode << "' was compared";
    } catch (const InputError& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find("element correspondence is '" + (mode.empty() ? std::string("per-subject") : mode) + "'"),
                std::string::npos) << what;
      EXPECT_NE(what.find("atlas 0123456789abcdef"), std::string::npos) << what;
    }
    ElementTable other = patient;
    other.subject_id = "c9";
    EXPECT_THROW(add_subject(ref, other, "c9"), InputError);
  }
  // References written before issue 14 have no key: per-subject.
  nlohmann::json j = nlohmann::json::parse(reference_to_json(ref));
  j.erase("correspondence");
  EXPECT_EQ(reference_from_json(j.dump(), "old.json").correspondence, "per-subject");
}

}  // namespace
}  // namespace authalic::analysis
