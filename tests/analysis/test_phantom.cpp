// Phantom cohort: the synthetic anatomy has the promised topology and geometry, the planted region
// has its stated depth in the PET along the surface, and everything is deterministic.
#include <gtest/gtest.h>
#include <omp.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "analysis/phantom.h"
#include "common/test_data.h"
#include "core/error.h"
#include "io/surface_io.h"
#include "io/volume_io.h"

namespace {

namespace an = authalic::analysis;
namespace fs = std::filesystem;
using authalic::MatrixXd;
using authalic::VectorXd;

// Trilinear interpolation at a world point (RAS mm); outside the grid -> NaN.
double trilinear(const authalic::io::Volume& vol, const Eigen::Vector3d& p) {
  const Eigen::Vector4d ijk = vol.vox2ras.inverse() * Eigen::Vector4d(p.x(), p.y(), p.z(), 1.0);
  const int i = static_cast<int>(std::floor(ijk(0))), j = static_cast<int>(std::floor(ijk(1))), k = static_cast<int>(std::floor(ijk(2)));
  if (i < 0 || j < 0 || k < 0 || i + 1 >= vol.dims[0] || j + 1 >= vol.dims[1] || k + 1 >= vol.dims[2]) return std::nan("");
  const double fx = ijk(0) - i, fy = ijk(1) - j, fz = ijk(2) - k;
  double v = 0.0;
  for (int c = 0; c < 8; ++c) {
    const int dx = c & 1, dy = (c >> 1) & 1, dz = (c >> 2) & 1;
    v += (dx ? fx : 1 - fx) * (dy ? fy : 1 - fy) * (dz ? fz : 1 - fz) * vol.at(i + dx, j + dy, k + dz);
  }
  return v;
}

// Mean of 21 samples along the inward normal from the pial surface over 10 mm (the paper's
// normal projection), at vertex v.
double normal_projection(const authalic::io::Volume& vol, const an::Hemisphere& h, const MatrixXd& pial_normals, int v) {
  double sum = 0.0;
  for (int s = 0; s <= 20; ++s) {
    sum += trilinear(vol, h.pial.V.row(v).transpose() - (10.0 * s / 20.0) * pial_normals.row(v).transpose());
  }
  return sum / 21.0;
}

double signed_volume(const authalic::TriMesh& m) {
  double vol = 0.0;
  for (int f = 0; f < m.num_faces(); ++f) {
    const Eigen::Vector3d a = m.V.row(m.F(f, 0)).transpose(), b = m.V.row(m.F(f, 1)).transpose(),
                          c = m.V.row(m.F(f, 2)).transpose();
    vol += a.dot(b.cross(c)) / 6.0;
  }
  return vol;
}

TEST(PhantomRng, UniformAndNormalMoments) {
  an::PhantomRng rng(42);
  double sum = 0, sum2 = 0, usum = 0;
  const int n = 200000;
  for (int i = 0; i < n; ++i) {
    const double x = rng.normal();
    sum += x;
    sum2 += x * x;
    const double u = rng.uniform();
    ASSERT_GE(u, 0.0);
    ASSERT_LT(u, 1.0);
    usum += u;
  }
  EXPECT_NEAR(sum / n, 0.0, 0.01);
  EXPECT_NEAR(sum2 / n, 1.0, 0.01);
  EXPECT_NEAR(usum / n, 0.5, 0.005);
  an::PhantomRng a(7), b(7), c(8);
  EXPECT_EQ(a.next(), b.next());
  EXPECT_NE(a.next(), c.next());
}

TEST(SyntheticHemisphere, ClosedWhiteAndDiskCortex) {
  const an::Hemisphere h = an::synthetic_left_hemisphere();
  EXPECT_EQ(h.white.num_vertices(), 10 * 20 * 20 + 2);  // geodesic icosphere, frequency 20
  EXPECT_TRUE(authalic::analyze_topology(h.white.V, h.white.F).is_sphere());
  EXPECT_GT(signed_volume(h.white), 0.0);  // faces counter-clockwise seen from outside
  std::vector<bool> face_mask(h.white.num_faces());
  for (int f = 0; f < h.white.num_faces(); ++f) {
    face_mask[f] = h.cortex[h.white.F(f, 0)] && h.cortex[h.white.F(f, 1)] && h.cortex[h.white.F(f, 2)];
  }
  const auto cortex = authalic::submesh_from_faces(h.white, face_mask);
  const auto topo = authalic::analyze_topology(cortex.mesh.V, cortex.mesh.F);
  EXPECT_TRUE(topo.is_disk()) << topo.summary();
  // The medial wall is a minority of the surface, as in a real hemisphere (~10-15 %).
  const double cortex_area = authalic::face_areas(cortex.mesh.V, cortex.mesh.F).sum();
  const double total_area = authalic::face_areas(h.white.V, h.white.F).sum();
  EXPECT_GT(cortex_area / total_area, 0.8);
  EXPECT_LT(cortex_area / total_area, 0.95);
  // Hemisphere-sized: 150-180 mm long, white area of the order of 40,000 mm^2.
  const Eigen::Vector3d ext = (h.white.V.colwise().maxCoeff() - h.white.V.colwise().minCoeff()).transpose();
  EXPECT_GT(ext.y(), 150.0);
  EXPECT_LT(ext.y(), 185.0);
  EXPECT_GT(total_area, 30000.0);
  EXPECT_LT(total_area, 60000.0);
  EXPECT_LT(h.white.V.col(0).maxCoeff(), 0.0);  // a left hemisphere stays at x < 0
}

TEST(SyntheticHemisphere, PialIsTwoAndAHalfMillimetresOutside) {
  const an::Hemisphere h = an::synthetic_left_hemisphere();
  ASSERT_EQ(h.pial.F, h.white.F);
  const VectorXd gap = (h.pial.V - h.white.V).rowwise().norm();
  EXPECT_NEAR(gap.minCoeff(), 2.5, 1e-9);
  EXPECT_NEAR(gap.maxCoeff(), 2.5, 1e-9);
  EXPECT_TRUE(authalic::analyze_topology(h.pial.V, h.pial.F).is_sphere());
  EXPECT_TRUE(authalic::degenerate_faces(h.pial.V, h.pial.F).empty());
  // The continuous white surface the PET model uses agrees with the mesh: 1 mm inside each
  // vertex is inside, 1 mm outside is outside.
  const an::SyntheticHemisphereOptions o;
  const MatrixXd N = authalic::vertex_normals(h.white.V, h.white.F);
  int agree = 0;
  for (int v = 0; v < h.white.num_vertices(); ++v) {
    const Eigen::Vector3d p = h.white.V.row(v).transpose(), n = N.row(v).transpose();
    agree += an::inside_synthetic_white(p - 1.0 * n, o) && !an::inside_synthetic_white(p + 1.0 * n, o);
  }
  EXPECT_GE(agree, h.white.num_vertices() * 99 / 100);
}

TEST(SyntheticHemisphere, MirrorIsARightHemisphere) {
  const an::Hemisphere l = an::synthetic_left_hemisphere();
  const an::Hemisphere r = an::mirror_hemisphere(l);
  EXPECT_FALSE(r.left);
  EXPECT_GT(r.white.V.col(0).minCoeff(), 0.0);
  EXPECT_TRUE(((r.white.V.col(0) + l.white.V.col(0)).array() == 0).all());
  EXPECT_NEAR(signed_volume(r.white), signed_volume(l.white), 1e-6 * signed_volume(l.white));
  EXPECT_EQ(r.cortex, l.cortex);
}

TEST(PlantedRegion, IsAGeodesicDiskInTheCortex) {
  const an::Hemisphere h = an::synthetic_left_hemisphere();
  const an::PlantedRegion r = an::plant_region(h, an::default_region_target(true), 22.0, 0.25);
  ASSERT_GE(r.centre_vertex, 0);
  EXPECT_TRUE(h.cortex[r.centre_vertex]);
  const VectorXd d = an::edge_path_distances(h.white, h.cortex, r.centre_vertex);
  const VectorXd areas = authalic::barycentric_vertex_areas(h.white.V, h.white.F);
  double area = 0;
  for (int v = 0; v < h.white.num_vertices(); ++v) {
    EXPECT_EQ(r.left_mask[v], d(v) <= 22.0);
    if (r.left_mask[v]) {
      EXPECT_TRUE(h.cortex[v]);
      area += areas(v);
    }
  }
  // Edge paths overestimate geodesics by a few per cent, folds add area: near pi r^2 = 1520 mm^2.
  EXPECT_GT(area, 0.6 * M_PI * 22 * 22);
  EXPECT_LT(area, 1.6 * M_PI * 22 * 22);
  // Posterior (y below the centre), superior and medial-ish, like the precuneus.
  EXPECT_LT(h.white.V(r.centre_vertex, 1), -40.0);
  EXPECT_GT(h.white.V(r.centre_vertex, 2), 30.0);
  EXPECT_THROW(an::plant_region(h, an::default_region_target(true), 22.0, 1.5), authalic::InputError);
}

TEST(PlantedRegion, HasTheStatedDepthInThePetAlongTheSurface) {
  const an::SyntheticHemisphereOptions o;
  const an::Hemisphere left = an::synthetic_left_hemisphere(o);
  const an::Hemisphere right = an::mirror_hemisphere(left);
  const double radius = 22.0, depth = 0.25;
  const an::PlantedRegion r = an::plant_region(left, an::default_region_target(true, o), radius, depth);
  const authalic::io::Volume healthy = an::synthetic_pet_template(left, o, 2.5);
  const std::vector<float> mult = an::region_multiplier(healthy, left, right, r);
  an::PhantomRng rng(3);
  an::SubjectEffects e = an::draw_subject_effects(rng);
  e.noise_fraction = 0.0;  // the depth is checked on the noise-free scan; noise is checked below
  const auto with = an::subject_pet(healthy, e, mult, 8000.0);
  const auto without = an::subject_pet(healthy, e, {}, 8000.0);

  const VectorXd dist = an::edge_path_distances(left.white, left.cortex, r.centre_vertex);
  for (const an::Hemisphere* h : {&left, &right}) {
    const MatrixXd N = authalic::vertex_normals(h->pial.V, h->pial.F);
    double core_sum = 0, far_sum = 0;
    int core = 0, far = 0;
    double core_min = 1e9, core_max = -1e9;
    for (int v = 0; v < h->white.num_vertices(); ++v) {
      if (!h->cortex[v]) continue;
      const double ratio = normal_projection(with, *h, N, v) / normal_projection(without, *h, N, v);
      if (dist(v) <= radius - 10.0) {  // the core: farther than the blur reaches from the edge
        core_sum += ratio;
        core_min = std::min(core_min, ratio);
        core_max = std::max(core_max, ratio);
        ++core;
      } else if (dist(v) >= radius + 20.0) {
        far_sum += ratio;
        ++far;
      }
    }
    ASSERT_GT(core, 10);
    EXPECT_NEAR(core_sum / core, 1.0 - depth, 0.01) << (h->left ? "left" : "right");
    EXPECT_GT(core_min, 1.0 - depth - 0.03);
    EXPECT_LT(core_max, 1.0 - depth + 0.03);
    EXPECT_NEAR(far_sum / far, 1.0, 0.002);
  }
}

TEST(SubjectPet, NoiseAndBlurAreDeterministicAndThreadIndependent) {
  const an::SyntheticHemisphereOptions o;
  const an::Hemisphere left = an::synthetic_left_hemisphere(o);
  omp_set_num_threads(1);
  const auto t1 = an::synthetic_pet_template(left, o, 3.0);
  an::PhantomRng rng1(11);
  const auto e1 = an::draw_subject_effects(rng1);
  const auto a = an::subject_pet(t1, e1, {}, 8000.0);
  omp_set_num_threads(2);
  const auto t2 = an::synthetic_pet_template(left, o, 3.0);
  an::PhantomRng rng2(11);
  const auto e2 = an::draw_subject_effects(rng2);
  const auto b = an::subject_pet(t2, e2, {}, 8000.0);
  EXPECT_EQ(t1.data, t2.data);
  EXPECT_EQ(a.data, b.data);
  an::PhantomRng rng3(12);
  const auto c = an::subject_pet(t1, an::draw_subject_effects(rng3), {}, 8000.0);
  EXPECT_NE(a.data, c.data);
  // The template has the model's tissue levels: white matter 0.3, grey matter up to 1.
  const float tmax = *std::max_element(t1.data.begin(), t1.data.end());
  EXPECT_FLOAT_EQ(tmax, 1.0f);
  int wm = 0;
  for (float v : t1.data) wm += v == 0.3f;
  EXPECT_GT(wm, 1000);
}

TEST(GaussianBlur, DeltaSpreadsToTheRequestedFwhm) {
  authalic::io::Volume vol;
  vol.dims = {61, 5, 5};
  vol.vox2ras = Eigen::Matrix4d::Identity();
  vol.vox2ras(0, 0) = vol.vox2ras(1, 1) = vol.vox2ras(2, 2) = 0.5;  // 0.5 mm voxels
  vol.data.assign(vol.num_voxels(), 0.0f);
  for (int k = 0; k < 5; ++k)
    for (int j = 0; j < 5; ++j) vol.data[30 + 61 * (j + 5 * k)] = 1.0f;  // a plane x = 30
  an::gaussian_blur(vol, 6.0);
  // Half maximum crossings of the x profile are 6 mm apart.
  std::vector<double> prof(61);
  for (int i = 0; i < 61; ++i) prof[i] = vol.at(i, 2, 2);
  const double half = prof[30] / 2;
  int i = 30;
  while (prof[i] > half) ++i;
  const double x_right = (i - 1) + (prof[i - 1] - half) / (prof[i - 1] - prof[i]);
  EXPECT_NEAR(2 * (x_right - 30) * 0.5, 6.0, 0.1);
  double sum = 0;
  for (double p : prof) sum += p;
  EXPECT_NEAR(sum, 1.0, 1e-5);
}

// ---- files (needs the io layer) ---------------------------------------------------------------

std::string slurp(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  std::ostringstream s;
  s << f.rdbuf();
  return s.str();
}

TEST(WritePhantom, SyntheticCohortIsCompleteReadableAndByteIdenticalForOneSeed) {
  const std::string a = authalic::test::temp_dir("phantom_a"), b = authalic::test::temp_dir("phantom_b");
  an::PhantomOptions o;
  o.controls = 2;
  o.patients = 1;
  o.seed = 5;
  o.synthetic = true;
  o.voxel_mm = 4.0;
  const an::PhantomResult ra = an::write_phantom(a, o);
  an::write_phantom(b, o);
  EXPECT_EQ(ra.source, "synthetic");
  ASSERT_EQ(ra.subjects.size(), 3u);
  EXPECT_EQ(ra.subjects[2].id, "patient01");
  std::vector<std::string> files;
  for (const auto& entry : fs::recursive_directory_iterator(a)) {
    if (entry.is_regular_file()) files.push_back(fs::relative(entry.path(), a).string());
  }
  std::sort(files.begin(), files.end());
  for (const char* expected : {"cohort.csv", "phantom.json", "surf/lh.white", "surf/lh.pial", "surf/rh.white", "surf/rh.pial",
                               "label/lh.cortex.label", "label/rh.cortex.label", "truth/lh.lesion.label.gii",
                               "truth/rh.lesion.label.gii", "truth/lesion.json", "sub-control01/sub-control01_pet.nii.gz",
                               "sub-patient01/sub-patient01_pet.nii.gz"}) {
    EXPECT_TRUE(std::find(files.begin(), files.end(), expected) != files.end()) << expected;
  }
  for (const auto& f : files) EXPECT_EQ(slurp(a + "/" + f), slurp(b + "/" + f)) << f << " differs between two runs";

  // Readable by the project's own readers, consistent with each other.
  const auto white = authalic::io::read_surface(a + "/surf/lh.white");
  EXPECT_EQ(white.mesh.num_vertices(), 4002);
  const auto rh = authalic::io::read_surface(a + "/surf/rh.pial");
  EXPECT_GT(rh.mesh.V.col(0).minCoeff(), 0.0);
  const auto cortex = authalic::io::read_region_vertices(a + "/label/lh.cortex.label", 4002);
  EXPECT_GT(cortex.size(), 3000u);
  const auto pet = authalic::io::read_volume(a + "/sub-patient01/sub-patient01_pet.nii.gz");
  EXPECT_GT(pet.num_voxels(), 10000u);
  // The surface lies inside the PET's field of view.
  const Eigen::Matrix4d ras2vox = pet.vox2ras.inverse();
  for (int v = 0; v < white.mesh.num_vertices(); v += 97) {
    const Eigen::Vector4d ijk = ras2vox * Eigen::Vector4d(white.mesh.V(v, 0), white.mesh.V(v, 1), white.mesh.V(v, 2), 1.0);
    for (int k = 0; k < 3; ++k) {
      EXPECT_GE(ijk(k), 0.0);
      EXPECT_LE(ijk(k), pet.dims[k] - 1.0);
    }
  }
  std::istringstream csv(slurp(ra.cohort_csv));
  std::string line;
  std::getline(csv, line);
  EXPECT_EQ(line, "subject_id,role,age,pet,lh_white,lh_pial,rh_white,rh_pial,lh_cortex,rh_cortex");
  int rows = 0;
  while (std::getline(csv, line)) ++rows;
  EXPECT_EQ(rows, 3);

  // Another seed gives other scans.
  o.seed = 6;
  const std::string c = authalic::test::temp_dir("phantom_c");
  an::write_phantom(c, o);
  EXPECT_NE(slurp(a + "/sub-control01/sub-control01_pet.nii.gz"), slurp(c + "/sub-control01/sub-control01_pet.nii.gz"));
  EXPECT_EQ(slurp(a + "/surf/lh.white"), slurp(c + "/surf/lh.white"));
}

TEST(WritePhantom, FromSharedDataUsesFsaverageAndTheSpmTemplate) {
  AUTHALIC_REQUIRE_SHARED(pet_path, "spm/PET.nii");
  AUTHALIC_REQUIRE_SHARED(white_path, "fsaverage5/white_left.gii.gz");
  const std::string out = authalic::test::temp_dir("phantom_shared");
  an::PhantomOptions o;
  o.controls = 1;
  o.patients = 1;
  o.shared_dir = fs::path(pet_path).parent_path().parent_path().string();
  const an::PhantomResult r = an::write_phantom(out, o);
  EXPECT_NE(r.source.find("shared"), std::string::npos);
  const auto white = authalic::io::read_surface(out + "/surf/lh.white");
  EXPECT_EQ(white.mesh.num_vertices(), 10242);
  // The planted centre is near the left precuneus target.
  const Eigen::Vector3d centre = white.mesh.V.row(r.region.centre_vertex).transpose();
  EXPECT_LT((centre - an::default_region_target(false)).norm(), 15.0);
  const auto pet = authalic::io::read_volume(out + "/sub-patient01/sub-patient01_pet.nii.gz");
  const auto spm = authalic::io::read_volume(pet_path);
  EXPECT_EQ(pet.dims, spm.dims);
  EXPECT_TRUE(pet.vox2ras.isApprox(spm.vox2ras));
}

}  // namespace
