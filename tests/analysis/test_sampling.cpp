// PET sampling on surfaces (analysis/sampling.h): known answers on volumes linear in world
// position, Connectome Workbench agreement on real data, NaN/field-of-view/normalisation rules.
#include <gtest/gtest.h>
#include <omp.h>

#include <cmath>
#include <fstream>

#include "analysis/sampling.h"
#include "analysis_test_util.h"
#include "common/test_data.h"
#include "core/error.h"
#include "io/surface_io.h"
#include "io/volume_io.h"

namespace authalic::analysis {
namespace {

using test::function_volume;
using test::sphere_mesh;

double linear_f(const Eigen::Vector3d& p) { return 1000.0 + 2.0 * p.x() + 3.0 * p.y() - 1.5 * p.z(); }

Eigen::Vector3d volume_centre(const io::Volume& v) {
  return (v.vox2ras * Eigen::Vector4d((v.dims[0] - 1) / 2.0, (v.dims[1] - 1) / 2.0, (v.dims[2] - 1) / 2.0, 1)).head<3>();
}

TEST(Sampling, TrilinearReproducesLinearFunctionOnObliqueRadiologicalGrid) {
  const io::Volume vol = function_volume({60, 70, 50}, test::oblique_radiological_affine(), linear_f);
  const TrilinearSampler s(vol);
  const Eigen::Vector3d c = volume_centre(vol);
  for (int i = 0; i < 50; ++i) {
    const Eigen::Vector3d p = c + Eigen::Vector3d(std::sin(i * 1.3), std::cos(i * 0.7), std::sin(i * 2.1)) * 30.0;
    EXPECT_NEAR(s(p), linear_f(p), 1e-3) << i;
  }
  // Beyond half a voxel outside the grid: NaN; the voxel centre itself: exact.
  EXPECT_TRUE(std::isnan(s(c + Eigen::Vector3d(1000, 0, 0))));
  const Eigen::Vector3d corner = vol.vox2ras.block<3, 1>(0, 3);
  EXPECT_NEAR(s(corner), linear_f(corner), 1e-3);
  EXPECT_TRUE(s.inside(corner));
}

TEST(Sampling, NormalProjectionMeanIsValueAtSegmentMidpoint) {
  const io::Volume vol = function_volume({60, 70, 50}, test::oblique_radiological_affine(), linear_f);
  const TriMesh m = sphere_mesh(4, 35.0, volume_centre(vol));
  const SamplingResult r = sample_normal_projection(vol, m.V, m.F);
  // Step: half the smallest voxel size (1.5 mm / 2) dividing 10 mm: 14 intervals, 15 samples.
  EXPECT_EQ(r.samples_per_vertex, 15);
  EXPECT_NEAR(r.step_mm, 10.0 / 14, 1e-12);
  EXPECT_FALSE(r.normals_flipped);
  const MatrixXd N = vertex_normals(m.V, m.F);
  for (int v = 0; v < m.V.rows(); ++v) {
    const Eigen::Vector3d mid = m.V.row(v).transpose() - 5.0 * N.row(v).transpose();
    EXPECT_NEAR(r.values(v) / linear_f(mid), 1.0, 1e-6) << v;
  }
  // Outward: the midpoint is 5 mm outside. Max: the larger end of the segment.
  SamplingOptions o;
  o.outward = true;
  const SamplingResult out = sample_normal_projection(vol, m.V, m.F, o);
  o.outward = false;
  o.statistic = SamplingStatistic::Max;
  const SamplingResult mx = sample_normal_projection(vol, m.V, m.F, o);
  for (int v = 0; v < m.V.rows(); v += 7) {
    const Eigen::Vector3d x = m.V.row(v).transpose(), n = N.row(v).transpose();
    EXPECT_NEAR(out.values(v) / linear_f(x + 5.0 * n), 1.0, 1e-6);
    EXPECT_NEAR(mx.values(v) / std::max(linear_f(x), linear_f(x - 10.0 * n)), 1.0, 1e-6);
  }
}

TEST(Sampling, ClockwiseSurfaceStillSamplesInward) {
  const io::Volume vol = function_volume({60, 70, 50}, test::oblique_radiological_affine(), linear_f);
  TriMesh m = sphere_mesh(3, 35.0, volume_centre(vol));
  const MatrixXd N = vertex_normals(m.V, m.F);
  m.F.col(1).swap(m.F.col(2));  // clockwise: vertex normals now point inward
  const SamplingResult r = sample_normal_projection(vol, m.V, m.F);
  EXPECT_TRUE(r.normals_flipped);
  ASSERT_EQ(r.notes.size(), 1u);
  for (int v = 0; v < m.V.rows(); v += 5)
    EXPECT_NEAR(r.values(v) / linear_f(m.V.row(v).transpose() - 5.0 * N.row(v).transpose()), 1.0, 1e-6);
}

TEST(Sampling, RibbonMeanIsValueAtMidpointOfWhitePialSegment) {
  const io::Volume vol = function_volume({60, 70, 50}, test::oblique_radiological_affine(), linear_f);
  const Eigen::Vector3d c = volume_centre(vol);
  const TriMesh white = sphere_mesh(3, 30.0, c);
  TriMesh pial = white;
  for (int v = 0; v < pial.V.rows(); ++v)  // thickness varies from 1.5 to 4.5 mm
    pial.V.row(v) = c.transpose() + (pial.V.row(v) - c.transpose()) * (1.0 + (3.0 + 1.5 * std::sin(v * 0.37)) / 30.0);
  const SamplingResult r = sample_ribbon(vol, white.V, pial.V, white.F);
  for (int v = 0; v < white.V.rows(); ++v) {
    const Eigen::Vector3d mid = 0.5 * (white.V.row(v) + pial.V.row(v)).transpose();
    EXPECT_NEAR(r.values(v) / linear_f(mid), 1.0, 1e-6) << v;
  }
  TriMesh other = white;
  other.V.conservativeResize(white.V.rows() - 1, 3);
  EXPECT_THROW(sample_ribbon(vol, white.V, other.V, white.F), InputError);
}

TEST(Sampling, NanVoxelsAreLeftOutAndAllNanGivesNan) {
  io::Volume vol = function_volume({4, 4, 4}, Eigen::Matrix4d::Identity(), [](const Eigen::Vector3d&) { return 2.0; });
  vol.data[1 + 4 * (1 + 4 * 1)] = std::nanf("");  // voxel (1,1,1)
  const TrilinearSampler s(vol);
  EXPECT_DOUBLE_EQ(s(Eigen::Vector3d(1.5, 1.5, 1.5)), 2.0);   // re-weighted over the 7 finite corners
  EXPECT_TRUE(std::isnan(s(Eigen::Vector3d(1.0, 1.0, 1.0))));  // only the NaN voxel has weight
  for (float& x : vol.data) x = std::nanf("");
  const TrilinearSampler all(vol);
  EXPECT_TRUE(std::isnan(all(Eigen::Vector3d(1.5, 1.5, 1.5))));
}

TEST(Sampling, RefusesSurfaceMostlyOutsideTheFieldOfViewAndSaysHowMuch) {
  io::Volume vol = function_volume({20, 20, 20}, Eigen::Matrix4d::Identity(), linear_f);
  vol.source_path = "pet.nii";
  TriMesh m = sphere_mesh(2, 5.0, Eigen::Vector3d(10, 10, 10));
  EXPECT_NO_THROW(sample_at_vertices(vol, m.V, m.F));
  m.V.col(0).array() += 500.0;
  try {
    sample_normal_projection(vol, m.V, m.F);
    FAIL() << "no error";
  } catch (const InputError& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find("pet.nii: 100% of the surface's vertices"), std::string::npos) << msg;
    EXPECT_NE(msg.find("outside the volume's field of view"), std::string::npos) << msg;
  }
  // Partly outside (less than half): accepted with a note, outside vertices NaN.
  m.V.col(0).array() -= 500.0 + 9.5;  // sphere centre x = 0.5: the part with x < -0.5 (~40%) is outside
  const SamplingResult r = sample_at_vertices(vol, m.V, m.F);
  EXPECT_GT(r.vertices_outside, 0);
  EXPECT_LT(r.outside_fraction, 0.5);
  EXPECT_EQ(r.nan_vertices, r.vertices_outside);
  EXPECT_EQ(r.notes.size(), 1u);
}

// A vertex whose inward segment leaves the field of view (or crosses NaN or infinite voxels) has
// no value: the mean of the rest describes the segment's deep end only (a PET whose axial field
// of view cuts the cortex gave biased values there, read as hypometabolism).
TEST(Sampling, APartlySampledSegmentGivesNoValueAndIsCounted) {
  io::Volume vol = function_volume({20, 20, 20}, Eigen::Matrix4d::Identity(), linear_f);
  TriMesh m = sphere_mesh(3, 5.0, Eigen::Vector3d(10, 10, 10));
  const SamplingResult whole = sample_normal_projection(vol, m.V, m.F);
  EXPECT_EQ(whole.partial_vertices, 0);
  EXPECT_EQ(whole.nan_vertices, 0);
  // The sphere's centre on the volume's x = 0 face: the inward segments (10 mm, through the centre)
  // of the vertices inside the field of view (x >= -0.5) leave it on the other side.
  m.V.col(0).array() -= 10.0;
  const SamplingResult cut = sample_normal_projection(vol, m.V, m.F);
  EXPECT_GT(cut.partial_vertices, 0);
  int inside_with_value = 0, inside_nan = 0;
  for (int v = 0; v < m.num_vertices(); ++v) {
    if (m.V(v, 0) < -0.5) continue;
    (std::isnan(cut.values(v)) ? inside_nan : inside_with_value)++;
  }
  EXPECT_EQ(inside_nan, cut.partial_vertices);  // every inside vertex without a value is a partial one
  EXPECT_GT(inside_with_value, 0);
  EXPECT_EQ(cut.nan_vertices, cut.vertices_outside + cut.partial_vertices);
  bool noted = false;
  for (const auto& n : cut.notes) noted |= n.find("have part of their sampling segment outside the field of view") != std::string::npos;
  EXPECT_TRUE(noted);
  // An infinite voxel is left out of the interpolation as a NaN one is (it gave Inf values).
  io::Volume inf = function_volume({4, 4, 4}, Eigen::Matrix4d::Identity(), [](const Eigen::Vector3d&) { return 2.0; });
  inf.data[1 + 4 * (1 + 4 * 1)] = std::numeric_limits<float>::infinity();
  EXPECT_DOUBLE_EQ(TrilinearSampler(inf)(Eigen::Vector3d(1.5, 1.5, 1.5)), 2.0);
}

TEST(Sampling, DeterministicForOneAndTwoThreads) {
  const io::Volume vol = function_volume({60, 70, 50}, test::oblique_radiological_affine(),
                                         [](const Eigen::Vector3d& p) { return std::sin(p.x() / 7) * std::cos(p.y() / 5) + p.z() / 50; });
  const TriMesh m = sphere_mesh(4, 35.0, volume_centre(vol));
  omp_set_num_threads(1);
  const SamplingResult a = sample_normal_projection(vol, m.V, m.F);
  omp_set_num_threads(2);
  const SamplingResult b = sample_normal_projection(vol, m.V, m.F);
  EXPECT_EQ(a.values, b.values);
}

TEST(Sampling, GlobalAndReferenceRegionNormalisation) {
  const io::Volume vol = function_volume({30, 30, 30}, Eigen::Matrix4d::Identity(),
                                         [](const Eigen::Vector3d& p) { return p.x() < 15 ? 4.0 : 8.0; });
  // Reference region: the mask covers only voxels with x >= 20 (value 8) -> SUVR = value / 8.
  io::Volume mask = function_volume({30, 30, 30}, Eigen::Matrix4d::Identity(),
                                    [](const Eigen::Vector3d& p) { return p.x() >= 20 ? 1.0 : 0.0; });
  const Normalisation n = reference_region_mean(vol, mask);
  EXPECT_EQ(n.kind, NormalisationKind::ReferenceRegion);
  EXPECT_DOUBLE_EQ(n.reference_value, 8.0);
  EXPECT_EQ(n.count, 10 * 30 * 30);
  EXPECT_EQ(n.units, "SUVR");
  // A mask on a different (coarser, shifted) grid of the same world works too.
  Eigen::Matrix4d coarse = Eigen::Matrix4d::Identity();
  coarse.block<3, 3>(0, 0) *= 2.0;
  coarse(0, 3) = 20.0;
  const io::Volume mask2 = function_volume({5, 15, 15}, coarse, [](const Eigen::Vector3d&) { return 1.0; });
  EXPECT_DOUBLE_EQ(reference_region_mean(vol, mask2).reference_value, 8.0);
  // A mask outside the PET is refused.
  Eigen::Matrix4d far = Eigen::Matrix4d::Identity();
  far(0, 3) = 1000;
  io::Volume mask3 = function_volume({5, 5, 5}, far, [](const Eigen::Vector3d&) { return 1.0; });
  mask3.source_path = "cerebellum.nii";
  try {
    reference_region_mean(vol, mask3);
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("cerebellum.nii: none of the mask's 125 voxels"), std::string::npos) << e.what();
  }

  // Global: area-weighted cortical mean; a sphere straddling the two halves equally -> 6.
  const TriMesh m = sphere_mesh(4, 8.0, Eigen::Vector3d(14.5, 15, 15));
  VectorXd values = sample_at_vertices(vol, m.V, m.F).values;
  const Normalisation g = global_cortical_mean(values, m.V, m.F);
  EXPECT_NEAR(g.reference_value, 6.0, 0.15);
  apply_normalisation(values, g);
  const VectorXd area = barycentric_vertex_areas(m.V, m.F);
  EXPECT_NEAR(area.dot(values) / area.sum(), 1.0, 1e-12);
  VectorXd zeros = VectorXd::Zero(m.V.rows());
  EXPECT_THROW(global_cortical_mean(zeros, m.V, m.F), InputError);  // bad input: exit 2
  // Noise around zero: the mean is small against the values' magnitude (issue 17).
  VectorXd noise(m.V.rows());
  for (Eigen::Index v = 0; v < noise.size(); ++v) noise[v] = 0.02 + std::sin(12.9898 * static_cast<double>(v));
  try {
    global_cortical_mean(noise, m.V, m.F);
    FAIL() << "noise around zero was normalised";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("mostly noise around zero"), std::string::npos) << e.what();
  }
}

TEST(Sampling, AffineTextParsing) {
  const Eigen::Matrix4d T = parse_affine_text("# tkr to scanner\n1 0 0 5\n0 1 0 -3\n0 0 1 2.5\n0 0 0 1\n", "m.txt");
  EXPECT_EQ(T(0, 3), 5);
  EXPECT_EQ(T(2, 3), 2.5);
  EXPECT_EQ(parse_affine_text("1 0 0 5 0 1 0 -3 0 0 1 2.5", "m.txt"), T);
  EXPECT_THROW(parse_affine_text("1 0 0", "m.txt"), InputError);
  EXPECT_THROW(parse_affine_text("1 0 0 5 0 1 0 -3 0 0 1 x 0 0 0 1", "m.txt"), InputError);
  EXPECT_THROW(parse_affine_text("0 0 0 5 0 0 0 -3 0 0 0 2 0 0 0 1", "m.txt"), InputError);
  const MatrixXd P = transform_points(T, MatrixXd::Zero(2, 3));
  EXPECT_EQ(P(1, 0), 5);
  EXPECT_EQ(P(1, 1), -3);
}

// ---- real data: spm/PET.nii (radiological) and fsaverage5 ---------------------------------

TEST(SamplingRealData, LinearVolumeOnPetGridRecoveredAtEveryPialVertex) {
  AUTHALIC_REQUIRE_SHARED(pet_path, "spm/PET.nii");
  AUTHALIC_REQUIRE_SHARED(pial_path, "fsaverage5/pial_left.gii.gz");
  io::Volume pet = io::read_volume(pet_path);
  ASSERT_LT(pet.vox2ras(0, 0), 0) << "spm/PET.nii is radiological (negative x axis)";
  // Same grid and affine, values linear in world position.
  const io::Volume vol = function_volume(pet.dims, pet.vox2ras, linear_f);
  const io::Surface pial = io::read_surface(pial_path);
  const MatrixXd V = transform_points(pial.to_scanner, pial.mesh.V);
  const SamplingResult r = sample_normal_projection(vol, V, pial.mesh.F);
  EXPECT_EQ(r.samples_per_vertex, 11);  // 2 mm voxels: 1 mm step over 10 mm
  const MatrixXd N = vertex_normals(V, pial.mesh.F);
  int checked = 0;
  for (int v = 0; v < V.rows(); ++v) {
    const Eigen::Vector3d mid = V.row(v).transpose() - 5.0 * N.row(v).transpose();
    ASSERT_NEAR(r.values(v) / linear_f(mid), 1.0, 1e-3) << "vertex " << v;
    ++checked;
  }
  EXPECT_EQ(checked, 10242);
}

TEST(SamplingRealData, TrilinearEqualsWorkbenchAtSampledVertices) {
  AUTHALIC_REQUIRE_SHARED(pet_path, "spm/PET.nii");
  AUTHALIC_REQUIRE_SHARED(pial_path, "fsaverage5/pial_left.gii.gz");
  // Produced once with Connectome Workbench 1.5.0 (Debian connectome-workbench):
  //   wb_command -volume-to-surface-mapping spm/PET.nii pial_left.surf.gii tri.func.gii -trilinear
  // (pial_left.surf.gii = zcat fsaverage5/pial_left.gii.gz), values printed with %.9g for every
  // 731st vertex and the last one.
  const std::pair<int, double> workbench[] = {
      {0, 0.549689174},    {731, 0.814128697},  {1462, 0.736015856}, {2193, 0.693293512}, {2924, 0.678354979},
      {3655, 0.586617529}, {4386, 0.841562212}, {5117, 0.58742696},  {5848, 0.676133633}, {6579, 0.629687667},
      {7310, 0.795310497}, {8041, 0.626707494}, {8772, 0.718765199}, {9503, 0.652449548}, {10234, 0.693335295},
      {10241, 0.6929878}};
  const io::Volume pet = io::read_volume(pet_path);
  const io::Surface pial = io::read_surface(pial_path);
  const SamplingResult r = sample_at_vertices(pet, transform_points(pial.to_scanner, pial.mesh.V), pial.mesh.F);
  for (const auto& [v, expected] : workbench) EXPECT_NEAR(r.values(v), expected, 1e-5 * std::abs(expected)) << "vertex " << v;
}

bool have_workbench() { return test::run_command("command -v wb_command > /dev/null 2>&1") == 0; }

#define REQUIRE_WORKBENCH()                                                                                   \
  if (!have_workbench()) {                                                                                    \
    if (test::running_in_ci()) FAIL() << "CI=true but wb_command (Debian package connectome-workbench) is missing"; \
    GTEST_SKIP() << "wb_command (connectome-workbench) not installed; skipping the Workbench comparison";      \
  }

VectorXd run_workbench(const std::string& dir, const std::string& args, const std::string& out) {
  std::string log;
  const int rc = test::run_command("cd " + dir + " && wb_command -volume-to-surface-mapping " + args, &log);
  EXPECT_EQ(rc, 0) << log;
  return io::read_per_vertex(dir + "/" + out);
}

double pearson(const VectorXd& a, const VectorXd& b) {
  const double ma = a.mean(), mb = b.mean();
  const VectorXd da = a.array() - ma, db = b.array() - mb;
  return da.dot(db) / std::sqrt(da.squaredNorm() * db.squaredNorm());
}

TEST(SamplingRealData, TrilinearAndRibbonAgreeWithWorkbenchOnAllVertices) {
  AUTHALIC_REQUIRE_SHARED(pet_path, "spm/PET.nii");
  AUTHALIC_REQUIRE_SHARED(pial_path, "fsaverage5/pial_left.gii.gz");
  AUTHALIC_REQUIRE_SHARED(white_path, "fsaverage5/white_left.gii.gz");
  REQUIRE_WORKBENCH();
  const std::string dir = test::temp_dir("sampling_workbench");
  const io::Surface pial = io::read_surface(pial_path), white = io::read_surface(white_path);
  io::write_surface(dir + "/pial.surf.gii", pial.mesh);
  io::write_surface(dir + "/white.surf.gii", white.mesh);
  const io::Volume pet = io::read_volume(pet_path);
  const MatrixXd P = transform_points(pial.to_scanner, pial.mesh.V), W = transform_points(white.to_scanner, white.mesh.V);

  const VectorXd wb_tri = run_workbench(dir, pet_path + " pial.surf.gii tri.func.gii -trilinear", "tri.func.gii");
  const VectorXd ours_tri = sample_at_vertices(pet, P, pial.mesh.F).values;
  ASSERT_EQ(wb_tri.size(), ours_tri.size());
  for (Eigen::Index v = 0; v < wb_tri.size(); ++v)
    ASSERT_NEAR(ours_tri(v), wb_tri(v), 1e-5 * std::max(1e-3, std::abs(wb_tri(v)))) << "vertex " << v;

  const VectorXd wb_rib = run_workbench(
      dir, pet_path + " pial.surf.gii ribbon.func.gii -ribbon-constrained white.surf.gii pial.surf.gii", "ribbon.func.gii");
  const VectorXd ours_rib = sample_ribbon(pet, W, P, pial.mesh.F).values;
  // Cortex vertices: Workbench gives 0 where the ribbon holds no voxel (the medial wall, white = pial).
  std::vector<double> a, b;
  for (Eigen::Index v = 0; v < wb_rib.size(); ++v)
    if (wb_rib(v) != 0) {
      a.push_back(wb_rib(v));
      b.push_back(ours_rib(v));
    }
  ASSERT_GT(a.size(), 9000u);
  const double r = pearson(Eigen::Map<VectorXd>(a.data(), static_cast<Eigen::Index>(a.size())),
                           Eigen::Map<VectorXd>(b.data(), static_cast<Eigen::Index>(b.size())));
  EXPECT_GE(r, 0.98);
  std::cout << "[ ribbon vs wb_command -ribbon-constrained: Pearson " << r << " over " << a.size() << " vertices ]\n";
}

}  // namespace
}  // namespace authalic::analysis
