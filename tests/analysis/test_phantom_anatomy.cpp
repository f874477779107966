// Phantom subjects with anatomical variability (analysis/phantom_anatomy.h, issue 14).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <iostream>

#include "analysis/phantom_anatomy.h"
#include "common/test_data.h"
#include "core/atlas_map.h"
#include "io/surface_io.h"

namespace authalic::analysis {
namespace {

TEST(PhantomAnatomy, WarpIsInvertibleAndChangesAreaByAboutFifteenPercent) {
  AUTHALIC_REQUIRE_SHARED(white_path, "fsaverage5/white_left.gii.gz");
  const TriMesh white = io::read_surface(white_path).mesh;
  PhantomRng rng(7);
  std::vector<double> p95;
  for (int s = 0; s < 5; ++s) {
    const AnatomyWarp w = draw_anatomy_warp(rng, 0.15);
    MatrixXd D(white.V.rows(), 3);
    double worst = 0;
    for (Eigen::Index v = 0; v < D.rows(); ++v) {
      const Eigen::Vector3d x = white.V.row(v).transpose();
      D.row(v) = deform(w, x).transpose();
      worst = std::max(worst, (undeform(w, D.row(v).transpose()) - x).norm());
    }
    EXPECT_LT(worst, 1e-4);  // D⁻¹ by fixed-point iteration (mm)
    const VectorXd a0 = face_areas(white.V, white.F), a1 = face_areas(D, white.F);
    std::vector<double> r(static_cast<std::size_t>(a0.size()));
    for (Eigen::Index f = 0; f < a0.size(); ++f) r[static_cast<std::size_t>(f)] = std::abs(std::log(a1[f] / a0[f]));
    std::sort(r.begin(), r.end());
    p95.push_back(r[r.size() * 95 / 100]);
  }
  std::cout << "[ |ln area ratio| 95th percentile per warp:";
  for (double x : p95) std::cout << ' ' << x;
  std::cout << " ]\n";
  for (double x : p95) {
    EXPECT_GT(x, 0.04);
    EXPECT_LT(x, 0.3);
  }
}

// The variant carries the template anatomy at φ(s_v): without any warp it is the template itself;
// with one, its sphere.reg is not the template sphere but locates each vertex's anatomy exactly.
TEST(PhantomAnatomy, VariantCarriesTheTemplateAnatomyAtItsSphereReg) {
  AUTHALIC_REQUIRE_SHARED(white_path, "fsaverage5/white_left.gii.gz");
  AUTHALIC_REQUIRE_SHARED(pial_path, "fsaverage5/pial_left.gii.gz");
  AUTHALIC_REQUIRE_SHARED(sphere_path, "fsaverage5/sphere_left.gii.gz");
  AUTHALIC_REQUIRE_SHARED(sulc_path, "fsaverage5/sulc_left.gii.gz");
  Hemisphere t;
  t.white = io::read_surface(white_path).mesh;
  t.pial = io::read_surface(pial_path).mesh;
  t.cortex.assign(static_cast<std::size_t>(t.white.num_vertices()), true);
  const MatrixXd sphere = io::read_surface(sphere_path).mesh.V;
  const VectorXd sulc = io::read_per_vertex(sulc_path, t.white.num_vertices());
  const std::vector<bool> lesion(static_cast<std::size_t>(t.white.num_vertices()), false);

  const AnatomyVariant same = anatomy_variant(t, sphere, sulc, lesion, AnatomyWarp{});
  EXPECT_LT((same.hemisphere.white.V - t.white.V).cwiseAbs().maxCoeff(), 1e-6);
  EXPECT_LT((same.hemisphere.pial.V - t.pial.V).cwiseAbs().maxCoeff(), 1e-6);

  PhantomRng rng(3);
  AnatomyWarp w = draw_anatomy_warp(rng);
  w.fold_amplitude = 0;
  for (auto& a : w.wave_amplitude) a = 0;  // φ alone: the variant lies on the template surface
  const AnatomyVariant v = anatomy_variant(t, sphere, sulc, lesion, w);
  const MatrixXd S = normalize_to_unit_sphere(sphere, "sphere");
  const MatrixXd reg = normalize_to_unit_sphere(v.sphere_reg, "sphere.reg");
  double moved = 0;
  for (Eigen::Index i = 0; i < S.rows(); ++i) moved = std::max(moved, std::acos(std::clamp(S.row(i).dot(reg.row(i)), -1.0, 1.0)));
  EXPECT_GT(moved * 180 / M_PI, 2.0);  // a non-trivial registration
  const MatrixXd back = interpolate_on_sphere(SpherePointLocator(S, t.white.F), t.white.V, reg);
  EXPECT_LT((back - v.hemisphere.white.V).cwiseAbs().maxCoeff(), 1e-9);
}

}  // namespace
}  // namespace authalic::analysis
