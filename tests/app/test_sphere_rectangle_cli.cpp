// `authalic sphere` and `authalic rectangle` on fsaverage5 (issue 4 requirements), their outputs,
// determinism and errors; cross-checked with ../shared/tools/evalmap.py when python3 is there.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <vector>
#include <nlohmann/json.hpp>

#include "common/test_data.h"
#include "core/mesh.h"
#include "io/image_io.h"
#include "io/surface_io.h"

namespace {

namespace fs = std::filesystem;
using authalic::MatrixXd;
using authalic::MatrixXi;
using authalic::test::authalic_binary;
using authalic::test::run_command;

nlohmann::json read_json(const std::string& path) {
  std::ifstream in(path);
  return nlohmann::json::parse(in);
}

// Total |signed area| of a planar map (x, y of a surface).
double covered_area(const MatrixXd& V, const MatrixXi& F) {
  return authalic::signed_face_areas_2d(V, F).cwiseAbs().sum();
}

// `authalic sphere SURFACE OUT --metrics METRICS -q`: its exit code, what it printed in *output.
int run_sphere(const std::string& surface, const std::string& out, const std::string& metrics, std::string* output) {
  return run_command(authalic_binary() + " sphere " + surface + " " + out + " --metrics " + metrics + " -q", output);
}

bool have_evalmap() {
  return fs::exists("/usr/bin/python3") && !authalic::test::shared_data("../tools/evalmap.py").empty() &&
         run_command("/usr/bin/python3 -c 'import nibabel, numpy'") == 0;
}

// evalmap.py's metrics of a sphere map (surface and sphere: GIFTI paths), written to dir/e.json.
nlohmann::json evalmap_sphere(const std::string& surface, const std::string& sphere, const std::string& dir) {
  const std::string json = dir + "/e.json";
  const std::string cmd = "/usr/bin/python3 " + authalic::test::shared_data("../tools/evalmap.py") + " " + surface + " " +
                          sphere + " --domain sphere --json > " + json;
  EXPECT_EQ(run_command(cmd), 0) << cmd;
  return read_json(json);
}

}  // namespace

// In a test body: fails under CI=true, else skips, when `available` is false (what: the tools).
#define AUTHALIC_REQUIRE_TOOLS(available, what)                                    \
  if (!(available)) {                                                              \
    if (authalic::test::running_in_ci()) FAIL() << what << " missing under CI=true"; \
    GTEST_SKIP() << what << " not available";                                      \
  }
#define AUTHALIC_REQUIRE_EVALMAP() AUTHALIC_REQUIRE_TOOLS(have_evalmap(), "evalmap.py or python3-nibabel")

TEST(SphereCli, NativeResolutionWhiteSurfaceIsAuthalic) {
  // Issue 12: a real subject's native-resolution white surface (164,000 vertices), where the flow
  // route folds 221 faces (element CV 0.052); the default route goes through the square map.
  AUTHALIC_REQUIRE_SHARED(white, "fs741/lh.white.surf.gii");
  const std::string dir = authalic::test::temp_dir("sphere_fs741");
  const std::string out = dir + "/lh.sphere.surf.gii", metrics = dir + "/m.json";
  std::string output;
  ASSERT_EQ(run_sphere(white, out, metrics, &output), 0) << output;
  const auto j = read_json(metrics);
  EXPECT_EQ(j.at("route"), "square");
  EXPECT_EQ(j.at("acceptance").at("passed"), true);
  EXPECT_EQ(j.at("metrics").at("flips"), 0);
  // 0.005 required; 0.0012 measured (0.0020 before the coarse pass on the joined sphere).
  EXPECT_LE(j.at("metrics").at("element_cv").get<double>(), 0.0017);
  EXPECT_LE(j.at("metrics").at("face_ln_area_abs").at("mean").get<double>(), 0.05);
  EXPECT_NEAR(j.at("square_route").at("cap_area_fraction").get<double>(), 0.1, 0.01);
  EXPECT_EQ(j.at("square_route").at("coarse_sphere_pass").at("passes"), 1);
  AUTHALIC_REQUIRE_EVALMAP();
  const auto e = evalmap_sphere(white, out, dir);
  EXPECT_EQ(e.at("flips"), 0);
  EXPECT_LE(e.at("element_area_cv").get<double>(), 0.0017);
}

TEST(SphereCli, NativeResolutionPialSurfaceMeetsTheElementBar) {
  // Issue 12: the pial surface, whose medial-wall pocket the parts' harmonic starts crush (an
  // element at 1.27 x its share, CV 0.0067, before the crushed-patch step and the polish's log
  // residual). The issue requires element CV (64x32) <= 0.005: measured 0.0039, by authalic's
  // great-circle cells and by evalmap.py alike (0.0034 with the grid flow's per-vertex RK4 steps), since the square map's far-face steps take the log
  // residual (0.00485 before; 0.0052 and 0.0050 before the polish's regional free set). The map is chaotic in solver bits (docs/maps.md): a change that moves it above
  // the bar fails here. With the square's corner at the seam's most anterior vertex (it was the
  // seam's first vertex in index order) the medial-wall pocket does not form: 0.0031, no crushed
  // patch to open (core/crushed_patches.h has its own tests).
  AUTHALIC_REQUIRE_SHARED(pial, "fs741/lh.pial.surf.gii");
  const std::string dir = authalic::test::temp_dir("sphere_fs741_pial");
  const std::string out = dir + "/lh.sphere.surf.gii", metrics = dir + "/m.json";
  std::string output;
  ASSERT_EQ(run_sphere(pial, out, metrics, &output), 0) << output;
  const auto j = read_json(metrics);
  EXPECT_EQ(j.at("route"), "square");
  EXPECT_EQ(j.at("metrics").at("flips"), 0);
  EXPECT_LE(j.at("metrics").at("element_cv").get<double>(), 0.005);
  EXPECT_LE(j.at("metrics").at("face_ln_area_abs").at("mean").get<double>(), 0.05);
  EXPECT_LE(j.at("metrics").at("element_max_over_mean").get<double>(), 1.1);
  AUTHALIC_REQUIRE_EVALMAP();
  const auto e = evalmap_sphere(pial, out, dir);
  EXPECT_EQ(e.at("flips"), 0);
  EXPECT_LE(e.at("element_area_cv").get<double>(), 0.005);
  // The two evaluators agree on the cells (issue 15: both exact).
  EXPECT_NEAR(e.at("element_area_cv").get<double>(), j.at("metrics").at("element_cv").get<double>(), 2e-5);
}

// Runs scripts/mesh_families.py (a mesh family FreeSurfer does not write, made from the real data).
static bool have_mesh_families() {
  return fs::exists("/usr/bin/python3") && run_command("/usr/bin/python3 -c 'import nibabel, numpy, scipy, vtk'") == 0;
}
static std::string mesh_families() { return "/usr/bin/python3 " + std::string(AUTHALIC_SOURCE_DIR) + "/scripts/mesh_families.py "; }

#define AUTHALIC_REQUIRE_MESH_FAMILIES() \
  AUTHALIC_REQUIRE_TOOLS(have_mesh_families(), "python3 with nibabel, numpy, scipy, vtk")

TEST(SphereCli, NativeResolutionNoisyWhiteSurfaceIsAuthalic) {
  // The native white surface with Gaussian noise of 0.1 mm on every coordinate (a tenth of its
  // edge length; scripts/mesh_families.py noise, seed 1), as a rougher pipeline's surface is. The
  // parts' maps leave medial-wall faces crushed below e^-2. Element CV (64x32) 0.0088 when the
  // crushed-patch window was kept although its fold repair crushed more than it opened and the
  // sphere polish's local steps stopped at their first slow step; 0.0048 after, 0.0011 with the grid
  // flow's per-vertex RK4 steps (docs/robustness.md).
  AUTHALIC_REQUIRE_SHARED(white, "fs741/lh.white.surf.gii");
  AUTHALIC_REQUIRE_MESH_FAMILIES();
  const std::string dir = authalic::test::temp_dir("sphere_fs741_noise");
  const std::string noisy = dir + "/noise.surf.gii", out = dir + "/sphere.surf.gii", metrics = dir + "/m.json";
  ASSERT_EQ(run_command(mesh_families() + "noise " + white + " " + noisy + " --sigma 0.1 --seed 1"), 0);
  std::string output;
  ASSERT_EQ(run_sphere(noisy, out, metrics, &output), 0) << output;
  const auto j = read_json(metrics);
  EXPECT_EQ(j.at("metrics").at("flips"), 0);
  EXPECT_LE(j.at("metrics").at("element_cv").get<double>(), 0.006);
  EXPECT_LE(j.at("metrics").at("face_ln_area_abs").at("mean").get<double>(), 0.01);
}

TEST(SphereCli, NativeResolutionVoxelisedWhiteSurfaceFailsOnItsBulbPocketAndSaysSo) {
  // The native white surface voxelised at 0.5 mm and remeshed by marching cubes (627,000 vertices;
  // scripts/mesh_families.py voxelise), as surfaces made from a segmentation are. Its medial wall
  // has a 50 mm² bulb on a 3 mm neck that the parts' maps crush to e^-12. The map's element CV is
  // within its limit (0.0085 against 0.0121; 0.0048 with an earlier seam placement), but the bulb
  // sits in one element that holds 1.35-1.48 x its share in every corner placement: a pocket the
  // element CV alone let pass (exit 0 before the acceptance checked every element). It is a
  // failure now (exit 3), and the three placements the route tries are recorded.
  AUTHALIC_REQUIRE_SHARED(white, "fs741/lh.white.surf.gii");
  AUTHALIC_REQUIRE_SHARED(label, "fs741/lh.cortex.label");
  AUTHALIC_REQUIRE_MESH_FAMILIES();
  const std::string dir = authalic::test::temp_dir("sphere_fs741_voxel");
  const std::string mesh = dir + "/voxel.surf.gii", out = dir + "/sphere.surf.gii", metrics = dir + "/m.json";
  ASSERT_EQ(run_command(mesh_families() + "voxelise " + white + " " + label + " " + mesh + " --voxel 0.5"), 0);
  std::string output;
  ASSERT_EQ(run_command(authalic_binary() + " sphere " + mesh + " " + out + " --metrics " + metrics + " --keep-failed -q", &output), 3)
      << output;
  EXPECT_NE(output.find("voxel.surf.gii: the sphere map is not authalic"), std::string::npos) << output;
  EXPECT_NE(output.find("an element holding 1."), std::string::npos) << output;
  EXPECT_NE(output.find("x the mean area (limit 1 +- 0.25)"), std::string::npos) << output;
  const auto j = read_json(metrics);
  EXPECT_EQ(j.at("acceptance").at("passed"), false);
  EXPECT_EQ(j.at("metrics").at("flips"), 0);
  EXPECT_LE(j.at("metrics").at("element_cv").get<double>(), j.at("acceptance").at("limits").at("element_cv_64x32").get<double>());
  EXPECT_GT(j.at("metrics").at("element_max_over_mean").get<double>(), 1.25);
  EXPECT_EQ(j.at("square_route").at("corner_placements_tried").size(), 3u);
  // The independent evaluator agrees on the elements.
  AUTHALIC_REQUIRE_EVALMAP();
  const auto e = evalmap_sphere(mesh, out, dir);
  EXPECT_EQ(e.at("flips"), 0);
  EXPECT_NEAR(e.at("element_area_cv").get<double>(), j.at("metrics").at("element_cv").get<double>(), 2e-5);
}

TEST(SphereCli, WhiteLeftMeetsTheIssueRequirements) {
  AUTHALIC_REQUIRE_SHARED(white, "fsaverage5/white_left.gii.gz");
  const std::string dir = authalic::test::temp_dir("sphere_cli");
  const std::string out = dir + "/lh.sphere.surf.gii", metrics = dir + "/m.json", png = dir + "/s.png";
  std::string output;
  ASSERT_EQ(run_command(authalic_binary() + " sphere " + white + " " + out + " --metrics " + metrics + " --png " + png +
                            " --route flow --conformal " + dir + "/conformal.surf.gii --area-radius -q",
                        &output),
            0)
      << output;
  const auto j = read_json(metrics);
  // Issue 4: 0 flips, element CV <= 0.01 (64 x 32), per-face mean |ln area ratio| <= 0.06.
  EXPECT_EQ(j.at("flips"), 0);
  const auto& m = j.at("metrics");
  EXPECT_EQ(m.at("flips"), 0);
  EXPECT_EQ(m.at("element_grid"), nlohmann::json({64, 32}));
  EXPECT_LE(m.at("element_cv").get<double>(), 0.01);
  EXPECT_LE(m.at("face_ln_area_abs").at("mean").get<double>(), 0.06);
  // The acceptance records the limit it applied: fsaverage5's 20,480 faces give 10 per element,
  // whose triangle-level noise allows up to 3 x 0.1 / sqrt(10) = 0.095 (core/metrics.h).
  const auto& acceptance = j.at("acceptance");
  EXPECT_EQ(acceptance.at("passed"), true);
  const double per_element = m.at("faces").get<double>() / (64 * 32);
  EXPECT_NEAR(acceptance.at("limits").at("element_cv_64x32").get<double>(), 0.3 / std::sqrt(per_element), 1e-12);
  EXPECT_GT(acceptance.at("limits").at("element_cv_64x32").get<double>(), 0.09);
  // The flow did the work: the conformal start is far from equal-area (measured CV ~0.87).
  EXPECT_GT(j.at("conformal_metrics").at("element_cv").get<double>(), 0.5);
  EXPECT_EQ(j.at("conformal_flips"), 0);

  // Output: same vertices and triangles, on a sphere whose area is the cortex's.
  const auto surface = authalic::io::read_surface(white);
  const auto sphere = authalic::io::read_surface(out);
  ASSERT_EQ(sphere.mesh.num_vertices(), surface.mesh.num_vertices());
  EXPECT_TRUE(sphere.mesh.F == surface.mesh.F);
  const double area = authalic::face_areas(surface.mesh.V, surface.mesh.F).sum();
  const double radius = std::sqrt(area / (4 * M_PI));
  EXPECT_NEAR(j.at("radius_mm").get<double>(), radius, 1e-9 * radius);
  for (int v = 0; v < sphere.mesh.num_vertices(); ++v) ASSERT_NEAR(sphere.mesh.V.row(v).norm(), radius, 1e-5 * radius);

  // Orientation rule (+x right, +y anterior, +z superior): the most superior, anterior and
  // medial (max x on a left hemisphere) points of the cortex land on those sides of the sphere.
  Eigen::Index top, front, medial, bottom;
  surface.mesh.V.col(2).maxCoeff(&top);
  surface.mesh.V.col(2).minCoeff(&bottom);
  surface.mesh.V.col(1).maxCoeff(&front);
  surface.mesh.V.col(0).maxCoeff(&medial);
  EXPECT_GT(sphere.mesh.V(top, 2), 0.5 * radius);
  EXPECT_LT(sphere.mesh.V(bottom, 2), -0.5 * radius);
  EXPECT_GT(sphere.mesh.V(front, 1), 0.5 * radius);
  EXPECT_GT(sphere.mesh.V(medial, 0), 0.5 * radius);
  // ... and within ~15 degrees of FreeSurfer's own sphere on average (measured 13 degrees).
  const std::string fs_sphere_path = authalic::test::shared_data("fsaverage5/sphere_left.gii.gz");
  if (!fs_sphere_path.empty()) {
    const auto fs_sphere = authalic::io::read_surface(fs_sphere_path);
    double sum = 0;
    for (int v = 0; v < sphere.mesh.num_vertices(); ++v) {
      const Eigen::Vector3d a = sphere.mesh.V.row(v).normalized(), b = fs_sphere.mesh.V.row(v).normalized();
      sum += std::atan2(a.cross(b).norm(), a.dot(b));
    }
    EXPECT_LT(sum / sphere.mesh.num_vertices(), 20.0 * M_PI / 180.0);
  }

  const auto picture = authalic::io::read_png(png);
  EXPECT_GT(picture.width, 400);
  EXPECT_GT(picture.height, 200);

  if (have_evalmap()) {
    // Independent check: evalmap's exact element areas (its own edge integrals on the sphere).
    ASSERT_EQ(run_command("/usr/bin/python3 " + authalic::test::shared_data("../tools/evalmap.py") + " " + white + " " + out +
                              " --domain sphere --json 2>/dev/null",
                          &output),
              0)
        << output;
    const auto e = nlohmann::json::parse(output);
    EXPECT_EQ(e.at("flips"), 0);
    EXPECT_NEAR(e.at("element_area_cv").get<double>(), m.at("element_cv").get<double>(), 2e-5);
    EXPECT_NEAR(e.at("ln_area_ratio_abs_mean").get<double>(), m.at("face_ln_area_abs").at("mean").get<double>(), 1e-3);
  }
}

// The square route puts the square's corner (0, 0) at a point of the seam chosen by geometry (its
// most anterior vertex), so the sphere does not depend on the vertex order (it was parametrised from
// the seam's first vertex in index order: a permuted fs741 white moved 12 mm on average); and a
// placement that leaves a pocket (an element more than 10 % off its share) is tried again half a
// side further. fsaverage5 white with the corner 0.625 of the seam along: one element at 1.28 x
// its share (element CV 0.0092); the second placement gives 0.0016.
TEST(SphereCli, SeamCornerPlacementIsGeometricAndAPocketIsTriedAgain) {
  AUTHALIC_REQUIRE_SHARED(white, "fsaverage5/white_left.gii.gz");
  const std::string dir = authalic::test::temp_dir("sphere_cli_corner");
  std::string output;
  ASSERT_EQ(run_command(authalic_binary() + " sphere " + white + " " + dir + "/pocket.surf.gii --seam-corner 0.625 --metrics " +
                            dir + "/pocket.json -q",
                        &output),
            0)
      << output;
  const auto pocket = read_json(dir + "/pocket.json");
  const auto& tried = pocket.at("square_route").at("corner_placements_tried");
  ASSERT_EQ(tried.size(), 2u) << tried.dump();
  EXPECT_DOUBLE_EQ(tried[0].at("corner_offset_of_seam_length").get<double>(), 0.625);
  EXPECT_DOUBLE_EQ(tried[1].at("corner_offset_of_seam_length").get<double>(), 0.75);
  EXPECT_GT(tried[0].at("element_max_over_mean").get<double>(), 1.1);
  EXPECT_NE(tried[0].at("corner_vertex"), tried[1].at("corner_vertex"));
  // The better one is kept, and it is the sphere written.
  EXPECT_EQ(pocket.at("square_route").at("corner_vertex"), tried[1].at("corner_vertex"));
  EXPECT_LT(tried[1].at("element_cv_64x32").get<double>(), 0.5 * tried[0].at("element_cv_64x32").get<double>());
  EXPECT_NEAR(pocket.at("metrics").at("element_cv").get<double>(), tried[1].at("element_cv_64x32").get<double>(), 1e-9);
  EXPECT_LT(pocket.at("metrics").at("element_max_over_mean").get<double>(), 1.1);

  // The default placement on this surface leaves no pocket: one attempt.
  ASSERT_EQ(run_sphere(white, dir + "/a.surf.gii", dir + "/a.json", &output), 0) << output;
  const auto a = read_json(dir + "/a.json");
  EXPECT_EQ(a.at("square_route").at("corner_placements_tried").size(), 1u);

  // The same surface with its vertices in another order (and the triangles renumbered): the same
  // seam corner, and the same sphere up to round-off carried through the iterations.
  const auto surface = authalic::io::read_surface(white);
  const Eigen::Index n = surface.mesh.num_vertices();
  std::vector<int> order(static_cast<std::size_t>(n));  // new index -> old index
  for (Eigen::Index i = 0; i < n; ++i) order[static_cast<std::size_t>(i)] = static_cast<int>((i * 7919) % n);
  std::vector<int> new_of(static_cast<std::size_t>(n));
  authalic::TriMesh permuted;
  permuted.V.resize(n, 3);
  for (Eigen::Index i = 0; i < n; ++i) {
    permuted.V.row(i) = surface.mesh.V.row(order[static_cast<std::size_t>(i)]);
    new_of[static_cast<std::size_t>(order[static_cast<std::size_t>(i)])] = static_cast<int>(i);
  }
  permuted.F = surface.mesh.F;
  for (Eigen::Index f = 0; f < permuted.F.rows(); ++f)
    for (int c = 0; c < 3; ++c) permuted.F(f, c) = new_of[static_cast<std::size_t>(surface.mesh.F(f, c))];
  authalic::io::write_surface(dir + "/permuted.surf.gii", permuted);
  ASSERT_EQ(run_sphere(dir + "/permuted.surf.gii", dir + "/b.surf.gii", dir + "/b.json", &output), 0) << output;
  const auto b = read_json(dir + "/b.json");
  EXPECT_EQ(new_of[a.at("square_route").at("corner_vertex").get<std::size_t>()], b.at("square_route").at("corner_vertex").get<int>());
  const auto sa = authalic::io::read_surface(dir + "/a.surf.gii"), sb = authalic::io::read_surface(dir + "/b.surf.gii");
  double sum = 0;
  for (Eigen::Index i = 0; i < n; ++i) sum += (sb.mesh.V.row(i) - sa.mesh.V.row(order[static_cast<std::size_t>(i)])).norm();
  EXPECT_LT(sum / static_cast<double>(n), 0.5) << "mm on the 100 mm sphere";
  EXPECT_NEAR(b.at("metrics").at("element_cv").get<double>(), a.at("metrics").at("element_cv").get<double>(), 5e-4);
}

TEST(SphereCli, PialMeetsTheIssueRequirementsAndIsThreadDeterministic) {
  AUTHALIC_REQUIRE_SHARED(pial, "fsaverage5/pial_left.gii.gz");
  const std::string dir = authalic::test::temp_dir("sphere_cli_pial");
  std::string output;
  for (int threads : {1, 2}) {
    const std::string t = std::to_string(threads);
    ASSERT_EQ(run_command(authalic_binary() + " sphere " + pial + " " + dir + "/s" + t + ".surf.gii --metrics " + dir + "/m" + t +
                              ".json --threads " + t + " -q",
                          &output),
              0)
        << output;
  }
  const auto j = read_json(dir + "/m1.json");
  EXPECT_EQ(j.at("metrics").at("flips"), 0);
  EXPECT_LE(j.at("metrics").at("element_cv").get<double>(), 0.01);
  EXPECT_LE(j.at("metrics").at("face_ln_area_abs").at("mean").get<double>(), 0.08);
  const auto a = authalic::io::read_surface(dir + "/s1.surf.gii"), b = authalic::io::read_surface(dir + "/s2.surf.gii");
  EXPECT_TRUE(a.mesh.V == b.mesh.V) << "1 and 2 threads differ by " << (a.mesh.V - b.mesh.V).cwiseAbs().maxCoeff();
}

TEST(SphereCli, RefusesSurfacesThatAreNotClosedGenusZero) {
  AUTHALIC_REQUIRE_SHARED(flat, "fsaverage5/flat_left.gii.gz");
  const std::string dir = authalic::test::temp_dir("sphere_cli_bad");
  std::string output;
  // flat_left's faces form a disk: one boundary loop.
  EXPECT_EQ(run_command(authalic_binary() + " sphere " + flat + " " + dir + "/x.surf.gii", &output), 2) << output;
  EXPECT_NE(output.find(flat), std::string::npos) << output;
  EXPECT_NE(output.find("1 boundary loop"), std::string::npos) << output;
  EXPECT_FALSE(fs::exists(dir + "/x.surf.gii"));
  EXPECT_EQ(run_command(authalic_binary() + " sphere /nonexistent.gii " + dir + "/x.surf.gii", &output), 2) << output;
  EXPECT_EQ(run_command(authalic_binary() + " sphere " + flat + " " + dir + "/x.surf.gii --radius -1", &output), 2) << output;
}

TEST(RectangleCli, TwoHemispheresFillTheRectangleMirrorSymmetric) {
  AUTHALIC_REQUIRE_SHARED(white, "fsaverage5/white_left.gii.gz");
  AUTHALIC_REQUIRE_SHARED(flat, "fsaverage5/flat_left.gii.gz");
  // B1 and its mirror image (x negated, triangles reversed) as the right hemisphere.
  const std::string dir = authalic::test::temp_dir("rectangle_cli_two");
  const auto lh = authalic::io::read_surface(white), faces = authalic::io::read_surface(flat);
  authalic::TriMesh rh = lh.mesh, rh_faces = faces.mesh;
  rh.V.col(0) = -rh.V.col(0);
  rh.F.col(1).swap(rh.F.col(2));
  rh_faces.V.col(0) = -rh_faces.V.col(0);
  rh_faces.F.col(1).swap(rh_faces.F.col(2));
  authalic::io::write_surface(dir + "/rh.white.surf.gii", rh);
  authalic::io::write_surface(dir + "/rh.faces.surf.gii", rh_faces);
  std::string output;
  ASSERT_EQ(run_command(authalic_binary() + " rectangle " + dir + "/brain --lh " + white + " --lh-faces-from " + flat + " --rh " +
                            dir + "/rh.white.surf.gii --rh-faces-from " + dir + "/rh.faces.surf.gii --metrics " + dir +
                            "/m.json --png " + dir + "/r.png -q",
                        &output),
            0)
      << output;
  const auto j = read_json(dir + "/m.json");
  EXPECT_EQ(j.at("metrics").at("flips"), 0);
  EXPECT_EQ(j.at("metrics").at("element_grid"), nlohmann::json({64, 32}));
  EXPECT_LE(j.at("metrics").at("element_cv").get<double>(), 0.01);
  EXPECT_NEAR(j.at("split_x").get<double>(), 1.0, 1e-9);  // equal areas
  EXPECT_EQ(j.at("extent"), nlohmann::json({0.0, 0.0, 2.0, 1.0}));
  const auto l = authalic::io::read_surface(dir + "/brain.lh.surf.gii"), r = authalic::io::read_surface(dir + "/brain.rh.surf.gii");
  // 2:1 and fully covered: each part is its unit square, covered once.
  EXPECT_NEAR(covered_area(l.mesh.V, l.mesh.F), 1.0, 1e-4);
  EXPECT_NEAR(covered_area(r.mesh.V, r.mesh.F), 1.0, 1e-4);
  EXPECT_NEAR(l.mesh.V.col(0).maxCoeff(), 1.0, 1e-6);
  EXPECT_NEAR(r.mesh.V.col(0).minCoeff(), 1.0, 1e-6);
  // Each part records where the parts meet, and `elements` carries it into the table, whose
  // clusters then do not cross it (issue 19: the seam is at w_L, not at column K).
  EXPECT_NEAR(std::stod(l.metadata.at("authalic_seam_x")), j.at("split_x").get<double>(), 1e-12);
  AUTHALIC_REQUIRE_SHARED(thick, "fsaverage5/thick_left.gii.gz");
  ASSERT_EQ(run_command(authalic_binary() + " elements " + white + " " + dir + "/brain.lh.surf.gii " + thick + " " + dir +
                            "/el --domain rectangle -q",
                        &output),
            0)
      << output;
  EXPECT_NEAR(read_json(dir + "/el.json").at("seam_x").get<double>(), j.at("split_x").get<double>(), 1e-12);
  // Mirror symmetry: the right part is the left one reflected about x = 1.
  ASSERT_EQ(l.mesh.num_vertices(), r.mesh.num_vertices());
  for (int v = 0; v < l.mesh.num_vertices(); ++v) {
    ASSERT_NEAR(r.mesh.V(v, 0), 2.0 - l.mesh.V(v, 0), 1e-5);
    ASSERT_NEAR(r.mesh.V(v, 1), l.mesh.V(v, 1), 1e-5);
  }
  EXPECT_GT(authalic::io::read_png(dir + "/r.png").width, 500);
  // Swapped hemispheres, or one given twice, would make a left/right swapped rectangle labelled
  // CortexLeft on the right hemisphere (it was accepted): refused, nothing written.
  EXPECT_EQ(run_command(authalic_binary() + " rectangle " + dir + "/swapped --lh " + dir + "/rh.white.surf.gii --lh-faces-from " + dir +
                            "/rh.faces.surf.gii --rh " + white + " --rh-faces-from " + flat + " -q",
                        &output),
            2)
      << output;
  EXPECT_NE(output.find(" is CortexLeft (its GIFTI structure) but was given as --rh"), std::string::npos) << output;
  // Without a GIFTI structure (the mirror image written here has none), by the side of the midline.
  const std::string rhw = dir + "/rh.white.surf.gii", rhf = dir + "/rh.faces.surf.gii";
  EXPECT_EQ(run_command(authalic_binary() + " rectangle " + dir + "/twice --lh " + rhw + " --lh-faces-from " + rhf + " --rh " + rhw +
                            " --rh-faces-from " + rhf + " -q",
                        &output),
            2)
      << output;
  EXPECT_NE(output.find("the same file was given twice"), std::string::npos) << output;
  EXPECT_FALSE(fs::exists(dir + "/swapped.lh.surf.gii"));
  EXPECT_FALSE(fs::exists(dir + "/twice.lh.surf.gii"));
}

// The closed native white hemisphere (fs741, 164,000 vertices) cut open onto the rectangle. Its
// medial wall under the cut starts crushed against the bottom side (408 faces at e^-2, one element
// at 1.87 x its share); the flow and the global polish leave it at 1.23 x, and the far-face steps
// open it by 5-10 % a step: with 16 of them (the old budget, shared with the global steps) the
// element stayed at 1.23 x (1.35 x under another machine's BLAS, exit 3); with their own budget
// they stopped after 29, at 1.10 x, but a slow step among fast ones ended them at 1.62 x once the
// CG's summation order changed: they now end after three slow steps in a row (35 steps, 1.11 x).
TEST(RectangleCli, NativeResolutionSurfaceCutOpenHasNoCrushedPocket) {
  AUTHALIC_REQUIRE_SHARED(white, "fs741/lh.white.surf.gii");
  const std::string dir = authalic::test::temp_dir("rectangle_cli_fs741");
  std::string output;
  ASSERT_EQ(run_command(authalic_binary() + " rectangle " + dir + "/w.surf.gii --surface " + white + " --metrics " + dir +
                            "/m.json -q",
                        &output),
            0)
      << output;
  const auto j = read_json(dir + "/m.json");
  const auto& m = j.at("metrics");
  EXPECT_EQ(m.at("flips"), 0);
  EXPECT_LE(m.at("element_cv").get<double>(), 0.007);
  EXPECT_LE(m.at("element_max_over_mean").get<double>(), 1.15);
  EXPECT_GE(m.at("element_min_over_mean").get<double>(), 0.95);
  EXPECT_GE(j.at("part").at("flow").at("polish_iterations").get<int>(), 30) << "the far-face steps ran out of budget again";
}

TEST(RectangleCli, OneClosedSurfaceCutOpenFillsTheRectangle) {
  AUTHALIC_REQUIRE_SHARED(white, "fsaverage5/white_left.gii.gz");
  const std::string dir = authalic::test::temp_dir("rectangle_cli_one");
  const std::string out = dir + "/whole.surf.gii";
  std::string output;
  ASSERT_EQ(run_command(authalic_binary() + " rectangle " + out + " --surface " + white + " --metrics " + dir +
                            "/m.json --cut-surface --flat -q",
                        &output),
            0)
      << output;
  const auto j = read_json(dir + "/m.json");
  EXPECT_EQ(j.at("metrics").at("flips"), 0);
  EXPECT_LE(j.at("metrics").at("element_cv").get<double>(), 0.01);
  EXPECT_EQ(j.at("extent"), nlohmann::json({0.0, 0.0, 2.0, 1.0}));
  const auto map = authalic::io::read_surface(out);
  EXPECT_NEAR(covered_area(map.mesh.V, map.mesh.F), 2.0, 1e-4);
  // The cut surface is on the map's vertices and keeps the cortex's area; the flat surface is
  // the map scaled so 1 mm^2 of flat map is 1 mm^2 of cortex.
  const auto cut = authalic::io::read_surface(dir + "/whole.cut.surf.gii");
  const auto flat = authalic::io::read_surface(dir + "/whole.flat.surf.gii");
  ASSERT_EQ(cut.mesh.num_vertices(), map.mesh.num_vertices());
  const double area = authalic::face_areas(cut.mesh.V, cut.mesh.F).sum();
  const double white_area = authalic::face_areas(authalic::io::read_surface(white).mesh.V, authalic::io::read_surface(white).mesh.F).sum();
  EXPECT_NEAR(area, white_area, 1e-3 * white_area);
  EXPECT_NEAR(covered_area(flat.mesh.V, flat.mesh.F), area, 1e-3 * area);
  // The cut path is the documented inferior-medial one between two landmark vertices, and the
  // user can choose them; neighbours cannot be cut between.
  EXPECT_GE(j.at("cut_path_vertices").get<int>(), 3);
  const auto s = authalic::io::read_surface(white);
  const int a = s.mesh.F(0, 0), b = s.mesh.F(0, 1);
  EXPECT_EQ(run_command(authalic_binary() + " rectangle " + dir + "/x.surf.gii --surface " + white + " --cut-from " + std::to_string(a) +
                            " --cut-to " + std::to_string(b),
                        &output),
            2)
      << output;
  EXPECT_NE(output.find("at least 3"), std::string::npos) << output;
}

// Issue 15 item 16: `rectangle --lh/--rh` takes the cortex as `run` does: a FreeSurfer label
// (cleaned up into one disk, with its line) or a face set by content; never with --?h-faces-from.
TEST(RectangleCli, TwoHemispheresTakeTheirCortexAsLabels) {
  const std::string dir = authalic::test::temp_dir("rectangle_cli_labels");
  const std::string s = std::string(AUTHALIC_SOURCE_DIR) + "/sample_data/";
  std::string output;
  ASSERT_EQ(run_command(authalic_binary() + " rectangle " + dir + "/brain --lh " + s + "surf/lh.white --rh " + s +
                            "surf/rh.white --lh-cortex " + s + "label/lh.cortex.label --rh-cortex " + s +
                            "label/rh.cortex.label --metrics " + dir + "/m.json",
                        &output),
            0)
      << output;
  EXPECT_NE(output.find("rectangle: left cortex lh.cortex.label: 3579 label vertices"), std::string::npos) << output;
  EXPECT_NE(output.find("rectangle: right cortex rh.cortex.label"), std::string::npos) << output;
  const auto j = read_json(dir + "/m.json");
  EXPECT_EQ(j.at("metrics").at("flips"), 0);
  EXPECT_LE(j.at("metrics").at("element_cv").get<double>(), 0.01);
  // Each file records where the parts meet in its own units (QA 4 item 6: the mm files said x = 1
  // in rectangle units, the seam being at 187.78 mm): the maps w_L as authalic_seam_x, the --flat
  // files w_L x (mm per unit) as authalic_seam_x_mm, which is where their parts end in mm. The
  // right hemisphere enlarged 1.1 times, so that the seam is not at x = 1.
  authalic::TriMesh big = authalic::io::read_surface(s + "surf/rh.white").mesh;
  big.V *= 1.1;
  const std::string rh_big = dir + "/rh.big.surf.gii";
  authalic::io::write_surface(rh_big, big);
  ASSERT_EQ(run_command(authalic_binary() + " rectangle " + dir + "/uneven --lh " + s + "surf/lh.white --rh " + rh_big + " --lh-cortex " +
                            s + "label/lh.cortex.label --rh-cortex " + s + "label/rh.cortex.label --metrics " + dir +
                            "/uneven.json --flat -q",
                        &output),
            0)
      << output;
  const double split = read_json(dir + "/uneven.json").at("split_x").get<double>();
  EXPECT_NEAR(split, 2.0 / (1.0 + 1.21), 0.02) << "w_L = 2 A_L / (A_L + A_R)";
  for (const char* part : {"lh", "rh"}) {
    const auto map = authalic::io::read_surface(dir + "/uneven." + part + ".surf.gii");
    const auto mm = authalic::io::read_surface(dir + "/uneven." + part + ".flat.surf.gii");
    EXPECT_NEAR(std::stod(map.metadata.at("authalic_seam_x")), split, 1e-12) << part;
    EXPECT_EQ(map.metadata.count("authalic_seam_x_mm"), 0u) << part;
    EXPECT_EQ(mm.metadata.count("authalic_seam_x"), 0u) << part << ": no rectangle-unit seam in a file in mm";
    const double scale = mm.mesh.V.col(1).maxCoeff() - mm.mesh.V.col(1).minCoeff();  // the part spans y in [0, 1] x scale
    EXPECT_GT(scale, 100.0) << part << ": in mm";
    const double seam_mm = std::stod(mm.metadata.at("authalic_seam_x_mm"));
    EXPECT_NEAR(seam_mm, split * scale, 1e-6 * scale) << part;
    EXPECT_NEAR(std::string(part) == "lh" ? mm.mesh.V.col(0).maxCoeff() : mm.mesh.V.col(0).minCoeff(), seam_mm, 1e-4 * scale) << part;
  }
  // `metrics --domain rectangle` of one part measures the part's cells, as `elements` does (QA 4
  // item 3: it printed CV 1, min/mean 0, with no note), for the map and for its copy in mm.
  for (const char* part : {"lh", "rh"}) {
    const std::string surface = std::string(part) == "lh" ? s + "surf/lh.white" : rh_big, map = dir + "/uneven." + part + ".surf.gii";
    authalic::io::write_per_vertex(dir + "/y.func.gii", authalic::io::read_surface(surface).mesh.V.col(1));
    ASSERT_EQ(run_command(authalic_binary() + " elements " + surface + " " + map + " " + dir + "/y.func.gii " + dir + "/el_" + part +
                              " --domain rectangle --json -q",
                          &output),
              0)
        << output;
    const double elements_cv = nlohmann::json::parse(output.substr(output.find('{'))).at("element_area_cv").get<double>();
    EXPECT_LT(elements_cv, 0.01) << part;
    const std::string side = std::string(part) == "lh" ? "left" : "right";
    const int columns = std::string(part) == "lh" ? static_cast<int>(std::floor(split * 32)) : 64 - static_cast<int>(std::ceil(split * 32));
    for (const std::string& measured : {map, dir + "/uneven." + part + ".flat.surf.gii"}) {
      ASSERT_EQ(run_command(authalic_binary() + " metrics " + surface + " " + measured + " --domain rectangle --json", &output), 0) << output;
      const auto m = nlohmann::json::parse(output.substr(output.find('{')));
      EXPECT_NEAR(m.at("element_cv").get<double>(), elements_cv, 1e-6) << measured;  // the mm copy: float32 mm, scaled back
      EXPECT_GT(m.at("element_min_over_mean").get<double>(), 0.9) << measured;
      EXPECT_LT(m.at("element_max_over_mean").get<double>(), 1.1) << measured;
      EXPECT_EQ(m.at("rectangle_part").at("hemisphere"), side) << measured;
      EXPECT_NEAR(m.at("rectangle_part").at("seam_x").get<double>(), split, 1e-6) << measured;
      const auto& cols = m.at("rectangle_part").at("element_columns");
      EXPECT_EQ(cols.at(1).get<int>() - cols.at(0).get<int>(), columns) << measured;
    }
    ASSERT_EQ(run_command(authalic_binary() + " metrics " + surface + " " + map + " --domain rectangle", &output), 0) << output;
    EXPECT_NE(output.find("note: the map is the " + side + " hemisphere's part of a two-hemisphere rectangle"), std::string::npos) << output;
  }
  // The same region as a face set under a name that says nothing of it: the same map.
  const auto white = authalic::io::read_surface(s + "surf/lh.white");
  const auto left = authalic::io::read_surface(dir + "/brain.lh.surf.gii");
  EXPECT_EQ(left.mesh.num_vertices(), white.mesh.num_vertices());
  authalic::TriMesh faces = white.mesh;
  faces.F = left.mesh.F;
  authalic::io::write_surface(dir + "/lh_cortex.gii", faces);
  ASSERT_EQ(run_command(authalic_binary() + " rectangle " + dir + "/again --lh " + s + "surf/lh.white --rh " + s +
                            "surf/rh.white --lh-cortex " + dir + "/lh_cortex.gii --rh-cortex " + s + "label/rh.cortex.label -q",
                        &output),
            0)
      << output;
  const auto again = authalic::io::read_surface(dir + "/again.lh.surf.gii");
  EXPECT_TRUE(again.mesh.V.isApprox(left.mesh.V, 1e-6));
  EXPECT_EQ(run_command(authalic_binary() + " rectangle " + dir + "/x --lh " + s + "surf/lh.white --rh " + s +
                            "surf/rh.white --lh-cortex " + s + "label/lh.cortex.label --lh-faces-from " + dir +
                            "/lh_cortex.gii --rh-cortex " + s + "label/rh.cortex.label",
                        &output),
            2)
      << output;
  EXPECT_NE(output.find("excludes"), std::string::npos) << output;
}

TEST(RectangleCli, RefusesMixedOrMissingForms) {
  std::string output;
  EXPECT_EQ(run_command(authalic_binary() + " rectangle /tmp/x.surf.gii", &output), 2) << output;
  EXPECT_EQ(run_command(authalic_binary() + " rectangle /tmp/x --lh a.gii", &output), 2) << output;  // --rh missing
  EXPECT_EQ(run_command(authalic_binary() + " rectangle /tmp/x --surface a.gii --lh a.gii --rh b.gii", &output), 2) << output;
}

// `sphere --refine omt` (issue 18 part 1): the square route's square part is refined by optimal
// transport before it is carried to the sphere; the sphere stays authalic and says what was done.
// The flow route has no square part: refused, nothing written.
TEST(SphereCli, OptimalTransportRefinementOfTheSquareRoute) {
  AUTHALIC_REQUIRE_SHARED(white, "fsaverage5/white_left.gii.gz");
  const std::string dir = authalic::test::temp_dir("sphere_omt");
  std::string output;
  ASSERT_EQ(run_command(authalic_binary() + " sphere " + white + " " + dir + "/s.surf.gii --refine omt --metrics " + dir +
                            "/m.json -q",
                        &output),
            0)
      << output;
  const auto j = read_json(dir + "/m.json");
  EXPECT_EQ(j.at("refine"), "omt");
  EXPECT_EQ(j.at("route"), "square");
  const auto& t = j.at("square_route_transport");
  EXPECT_GT(t.at("iterations").get<int>(), 0);
  EXPECT_LT(t.at("cost_after_refinement").get<double>(), t.at("cost_before").get<double>());
  EXPECT_EQ(j.at("metrics").at("flips"), 0);
  EXPECT_LE(j.at("metrics").at("element_cv").get<double>(), 0.005);
  EXPECT_NE(run_command(authalic_binary() + " sphere " + white + " " + dir + "/f.surf.gii --refine omt --route flow -q",
                        &output),
            0);
  EXPECT_NE(output.find("--refine omt"), std::string::npos) << output;
  EXPECT_FALSE(std::filesystem::exists(dir + "/f.surf.gii"));
}

// Issue 13's sphere bar on S1 (fsaverage5 white, default square route): element CV <= 0.004 and
// per-face mean <= 0.03. Measured: CV 0.0027, per-face 0.0060 (0.0040 / 0.0079 with the native
// meshes' 50 CG iterations per polish step: sphere_polish_cg_iterations).
TEST(SphereCli, S1MeetsThePeersBar) {
  AUTHALIC_REQUIRE_SHARED(white, "fsaverage5/white_left.gii.gz");
  const std::string dir = authalic::test::temp_dir("sphere_s1");
  std::string output;
  ASSERT_EQ(run_command(authalic_binary() + " sphere " + white + " " + dir + "/s1.surf.gii --metrics " + dir + "/m.json -q", &output), 0)
      << output;
  const auto m = read_json(dir + "/m.json").at("metrics");
  EXPECT_EQ(m.at("flips"), 0);
  EXPECT_LE(m.at("element_cv").get<double>(), 0.004);
  EXPECT_LE(m.at("face_ln_area_abs").at("mean").get<double>(), 0.03);
  EXPECT_LE(m.at("vertex_ln_area_abs").at("mean").get<double>(), 0.01);
}
