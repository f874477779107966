// A cortex label as FreeSurfer writes it (holes, islands, bow-tie vertices) is accepted by
// `authalic flatten --label` and `authalic run` after the region cleanup (core/region.h), which
// both report; a hole too large to fill is refused with its size. And the FreeSurfer-style label
// `authalic phantom` writes on fsaverage5 is one disk after the cleanup.
#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "common/region_labels.h"
#include "common/test_data.h"
#include "core/mesh.h"
#include "core/region.h"
#include "core/square_map.h"
#include "io/surface_io.h"

namespace {

namespace fs = std::filesystem;
using namespace authalic;
using authalic::test::authalic_binary;
using authalic::test::run_command;

// Writes the label's surface (GIFTI) and label (FreeSurfer ASCII) into dir.
void write_inputs(const test::DefectLabel& d, const std::string& dir) {
  io::write_surface(dir + "/lh.white.surf.gii", d.mesh);
  TriMesh pial = d.mesh;
  pial.V *= 1.05;  // 2.5 mm outside
  io::write_surface(dir + "/lh.pial.surf.gii", pial);
  io::Label l;
  for (int v = 0; v < d.mesh.num_vertices(); ++v)
    if (d.in[v]) l.vertices.push_back(v);
  l.positions.resize(static_cast<Eigen::Index>(l.vertices.size()), 3);
  for (std::size_t i = 0; i < l.vertices.size(); ++i) l.positions.row(static_cast<Eigen::Index>(i)) = d.mesh.V.row(l.vertices[i]);
  l.values = VectorXd::Zero(static_cast<Eigen::Index>(l.vertices.size()));
  io::write_freesurfer_label(dir + "/lh.cortex.label", l);
}

// "812.3 mm^2 (1.61 % of the region" for the label's largest unfilled hole, on the surface as
// written in dir (GIFTI stores float32 coordinates).
std::string hole_size_text(const test::DefectLabel& d, const std::string& dir) {
  const TriMesh m = io::read_surface(dir + "/lh.white.surf.gii").mesh;
  const RegionCleanup r = region_faces_from_vertices(m.V, m.F, d.in);
  char buf[80];
  std::snprintf(buf, sizeof(buf), "%.1f mm^2 (%.2f %% of the region", r.largest_unfilled_hole_mm2,
                100 * r.largest_unfilled_hole_fraction);
  return buf;
}

}  // namespace

TEST(RegionCli, FlattenCleansALabelAndReportsWhatChanged) {
  // A hemisphere cap with a 1-vertex hole, an island and a bow-tie flap.
  const test::DefectLabel d = test::cap_label_with_hole_island_bowtie(0.0);
  const std::string dir = test::temp_dir("region_cli_flatten");
  write_inputs(d, dir);
  // Expected on the surface as written (GIFTI stores float32 coordinates).
  const TriMesh written = io::read_surface(dir + "/lh.white.surf.gii").mesh;
  const RegionCleanup expected = region_faces_from_vertices(written.V, written.F, d.in);
  ASSERT_TRUE(expected.is_disk()) << expected.problem();
  ASSERT_EQ(expected.holes_filled, 1);
  ASSERT_EQ(expected.islands_dropped, 2);
  std::string out;
  ASSERT_EQ(run_command(authalic_binary() + " flatten " + dir + "/lh.white.surf.gii " + dir + "/flat.surf.gii --label " + dir +
                            "/lh.cortex.label --metrics " + dir + "/m.json",
                        &out),
            0)
      << out;
  // One line on stderr saying what was changed.
  EXPECT_NE(out.find("flatten: " + dir + "/lh.cortex.label: " + expected.summary() + "\n"), std::string::npos) << out;
  std::ifstream in(dir + "/m.json");
  const nlohmann::json j = nlohmann::json::parse(in).at("region_cleanup");
  EXPECT_EQ(j.at("summary"), expected.summary());
  EXPECT_EQ(j.at("holes_filled").at("count"), 1);
  EXPECT_EQ(j.at("holes_filled").at("vertices"), 1);
  EXPECT_EQ(j.at("islands_dropped").at("count"), 2);
  EXPECT_EQ(j.at("islands_dropped").at("vertices"), expected.island_vertices);
  EXPECT_NEAR(j.at("islands_dropped").at("area_mm2").get<double>(), expected.island_area_mm2, 1e-9);
  EXPECT_EQ(j.at("pinch_vertices").at("fixed"), 1);
  EXPECT_EQ(j.at("faces"), expected.F.rows());
  // The map's faces are the cleaned region's (the map inserts no vertex on this cap, or splits
  // faces: either way no face of a dropped island is in it).
  const io::Surface flat = io::read_surface(dir + "/flat.surf.gii");
  EXPECT_GE(flat.mesh.num_faces(), expected.F.rows());
  for (int v : d.island) EXPECT_EQ((flat.mesh.F.array() == v).count(), 0) << "island vertex " << v << " was mapped";
  // --quiet: no line.
  ASSERT_EQ(run_command(authalic_binary() + " flatten " + dir + "/lh.white.surf.gii " + dir + "/flat2.surf.gii --label " + dir +
                            "/lh.cortex.label -q",
                        &out),
            0)
      << out;
  EXPECT_EQ(out.find("filled"), std::string::npos) << out;
}

TEST(RegionCli, FlattenRefusesAHoleTooLargeToFillNamingItsSize) {
  const test::DefectLabel d = test::cap_label_with_big_hole();
  const std::string dir = test::temp_dir("region_cli_big_hole");
  write_inputs(d, dir);
  fs::create_directory(dir + "/out");
  std::string out;
  EXPECT_EQ(run_command(authalic_binary() + " flatten " + dir + "/lh.white.surf.gii " + dir + "/out/flat.surf.gii --label " + dir +
                            "/lh.cortex.label",
                        &out),
            2)
      << out;
  EXPECT_NE(out.find("lh.cortex.label"), std::string::npos) << out;
  EXPECT_NE(out.find("not one disk"), std::string::npos) << out;
  EXPECT_NE(out.find("2 boundary loops"), std::string::npos) << out;
  EXPECT_NE(out.find("too large to fill, the largest " + hole_size_text(d, dir)), std::string::npos) << out << hole_size_text(d, dir);
  EXPECT_TRUE(fs::is_empty(dir + "/out")) << "nothing written";
}

TEST(RegionCli, RunRefusesAHoleTooLargeToFillNamingItsSize) {
  const test::DefectLabel d = test::cap_label_with_big_hole();
  const std::string dir = test::temp_dir("region_cli_run");
  write_inputs(d, dir);
  const std::string pet = std::string(AUTHALIC_SOURCE_DIR) + "/sample_data/sub-control01/sub-control01_pet.nii.gz";
  std::string out;
  const std::string h = dir + "/lh.";
  EXPECT_EQ(run_command(authalic_binary() + " run --id x --lh-white " + h + "white.surf.gii --lh-pial " + h + "pial.surf.gii --rh-white " +
                            h + "white.surf.gii --rh-pial " + h + "pial.surf.gii --lh-cortex " + h + "cortex.label --rh-cortex " + h +
                            "cortex.label --pet " + pet + " --out " + dir + "/out",
                        &out),
            2)
      << out;
  EXPECT_NE(out.find("not one disk"), std::string::npos) << out;
  EXPECT_NE(out.find("too large to fill, the largest " + hole_size_text(d, dir)), std::string::npos) << out;
  EXPECT_FALSE(fs::exists(dir + "/out/sub-x"));
}

TEST(RegionCli, RunCleansALabelAndLogsWhatChanged) {
  // sample_data's left cortex label with a 1-vertex hole, and an island (a vertex and its ring) in
  // the medial wall.
  const std::string s = std::string(AUTHALIC_SOURCE_DIR) + "/sample_data/";
  const TriMesh white = io::read_surface(s + "surf/lh.white").mesh;
  const int n = white.num_vertices();
  io::Label label = io::read_freesurfer_label(s + "label/lh.cortex.label");
  std::vector<bool> in(static_cast<std::size_t>(n), false);
  for (int v : label.vertices) in[v] = true;
  const auto ring = vertex_neighbours(white.F, n);
  // Every vertex within two rings of v has the label flag `flag`.
  auto two_rings = [&](int v, bool flag) {
    for (int w : ring[v])
      for (int u : ring[w])
        if (in[w] != flag || in[u] != flag) return false;
    return true;
  };
  int hole = -1, island = -1;
  for (int v = 0; v < n && (hole < 0 || island < 0); ++v) {
    if (hole < 0 && in[v] && two_rings(v, true)) hole = v;
    if (island < 0 && !in[v] && two_rings(v, false)) island = v;
  }
  ASSERT_GE(hole, 0);
  ASSERT_GE(island, 0);
  in[hole] = false;
  in[island] = true;
  for (int w : ring[island]) in[w] = true;
  io::Label changed;
  for (int v = 0; v < n; ++v)
    if (in[v]) changed.vertices.push_back(v);
  changed.positions.resize(static_cast<Eigen::Index>(changed.vertices.size()), 3);
  for (std::size_t i = 0; i < changed.vertices.size(); ++i)
    changed.positions.row(static_cast<Eigen::Index>(i)) = white.V.row(changed.vertices[i]);
  changed.values = VectorXd::Zero(static_cast<Eigen::Index>(changed.vertices.size()));
  const std::string dir = test::temp_dir("region_cli_run_log");
  io::write_freesurfer_label(dir + "/lh.cortex.label", changed);
  const RegionCleanup expected = region_faces_from_vertices(white.V, white.F, in);
  ASSERT_TRUE(expected.is_disk()) << expected.problem();
  ASSERT_EQ(expected.holes_filled, 1);
  ASSERT_EQ(expected.islands_dropped, 1);

  std::string out;
  ASSERT_EQ(run_command(authalic_binary() + " run --id c01 --lh-white " + s + "surf/lh.white --lh-pial " + s + "surf/lh.pial --rh-white " +
                            s + "surf/rh.white --rh-pial " + s + "surf/rh.pial --lh-cortex " + dir + "/lh.cortex.label --rh-cortex " + s +
                            "label/rh.cortex.label --pet " + s + "sub-control01/sub-control01_pet.nii.gz --no-report --no-rectangle -q --out " +
                            dir + "/out",
                        &out),
            0)
      << out;
  std::ifstream f(dir + "/out/sub-c01/sub-c01_log.txt");
  const std::string log{std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>()};
  EXPECT_NE(log.find("  left cortex lh.cortex.label: " + std::to_string(changed.vertices.size()) + " label vertices, " +
                     std::to_string(expected.F.rows()) + " faces, "),
            std::string::npos)
      << log;
  EXPECT_NE(log.find("; " + expected.summary() + "\n"), std::string::npos) << log << "lacks " << expected.summary();
  EXPECT_NE(log.find("  right cortex rh.cortex.label: "), std::string::npos) << log;
  EXPECT_NE(log.find("; no cleanup needed\n"), std::string::npos) << log;
}

TEST(RegionCli, PhantomFsaverage5CortexLabelIsOneDiskAfterCleanup) {
  // `authalic phantom` on the shared data writes label/lh.cortex.label: the vertices of flat_left's
  // faces, as FreeSurfer writes a cortex label. Its whole faces close the relaxation cuts and are
  // not one disk; the cleanup makes them one.
  AUTHALIC_REQUIRE_SHARED(white, "fsaverage5/white_left.gii.gz");
  AUTHALIC_REQUIRE_SHARED(pet, "spm/PET.nii");
  const std::string shared = fs::path(white).parent_path().parent_path().string();
  const std::string dir = test::temp_dir("region_cli_phantom");
  std::string out;
  ASSERT_EQ(run_command(authalic_binary() + " phantom " + dir + "/c --controls 1 --patients 0 --shared " + shared + " -q", &out), 0)
      << out;
  const io::Surface w = io::read_surface(dir + "/c/surf/lh.white");
  ASSERT_EQ(w.mesh.num_vertices(), 10242);
  const std::vector<int> label = io::read_region_vertices(dir + "/c/label/lh.cortex.label", 10242);
  EXPECT_EQ(label.size(), 9465u);
  std::vector<bool> in(10242, false);
  for (int v : label) in[v] = true;
  const RegionCleanup r = region_faces_from_vertices(w.mesh.V, w.mesh.F, in);
  // Before: what flatten and run refused ("4 boundary loops, Euler characteristic -2").
  MatrixXi raw(r.raw_faces, 3);
  for (int f = 0, k = 0; f < w.mesh.num_faces(); ++f)
    if (in[w.mesh.F(f, 0)] && in[w.mesh.F(f, 1)] && in[w.mesh.F(f, 2)]) raw.row(k++) = w.mesh.F.row(f);
  const TopologyReport before = analyze_topology(w.mesh.V, raw);
  EXPECT_EQ(before.num_boundary_loops, 4) << before.summary();
  EXPECT_EQ(before.euler_characteristic, -2) << before.summary();
  // After: one disk; measured: three small holes filled, nothing dropped.
  EXPECT_TRUE(r.is_disk()) << r.problem();
  EXPECT_EQ(r.topology.num_boundary_loops, 1);
  EXPECT_EQ(r.holes_filled, 3) << r.summary();
  EXPECT_EQ(r.hole_vertices_added, 14) << r.summary();
  EXPECT_NEAR(r.hole_area_mm2, 187.7, 0.05) << r.summary();
  EXPECT_EQ(r.islands_dropped, 0) << r.summary();
  EXPECT_EQ(r.pinch_faces_removed, 0) << r.summary();
  EXPECT_EQ(r.label_vertices_outside, 0);
  EXPECT_LT(r.hole_area_mm2, 0.005 * r.area_mm2);
}

// fsaverage5's cortex (the vertices of flat_left's faces, with their white-surface coordinates, as
// FreeSurfer writes a label) given for the native subject fs741: every index is in range (10242
// of 150k vertices), but the label belongs to another mesh. Refused, naming the file; nothing
// written. The subject's own label is read as before.
TEST(RegionCli, FlattenRefusesTheLabelOfAnotherMesh) {
  AUTHALIC_REQUIRE_SHARED(white5, "fsaverage5/white_left.gii.gz");
  AUTHALIC_REQUIRE_SHARED(flat5, "fsaverage5/flat_left.gii.gz");
  AUTHALIC_REQUIRE_SHARED(native, "fs741/lh.white.surf.gii");
  AUTHALIC_REQUIRE_SHARED(native_label, "fs741/lh.cortex.label");
  const TriMesh fs5 = io::read_surface(white5).mesh;
  const MatrixXi cortex = io::read_surface(flat5).mesh.F;
  std::vector<char> used(static_cast<std::size_t>(fs5.num_vertices()), 0);
  for (Eigen::Index f = 0; f < cortex.rows(); ++f)
    for (int c = 0; c < 3; ++c) used[static_cast<std::size_t>(cortex(f, c))] = 1;
  io::Label l;
  for (int v = 0; v < fs5.num_vertices(); ++v)
    if (used[static_cast<std::size_t>(v)]) l.vertices.push_back(v);
  l.positions.resize(static_cast<Eigen::Index>(l.vertices.size()), 3);
  for (std::size_t i = 0; i < l.vertices.size(); ++i) l.positions.row(static_cast<Eigen::Index>(i)) = fs5.V.row(l.vertices[i]);
  l.values = VectorXd::Zero(static_cast<Eigen::Index>(l.vertices.size()));
  const std::string dir = test::temp_dir("region_cli_other_mesh");
  io::write_freesurfer_label(dir + "/fsaverage5.cortex.label", l);
  fs::create_directory(dir + "/out");
  std::string out;
  EXPECT_EQ(run_command(authalic_binary() + " flatten " + native + " " + dir + "/out/flat.surf.gii --label " + dir + "/fsaverage5.cortex.label", &out), 2)
      << out;
  EXPECT_NE(out.find("fsaverage5.cortex.label: the label's coordinates do not follow this surface's triangles"), std::string::npos) << out;
  EXPECT_NE(out.find("belongs to another mesh"), std::string::npos) << out;
  EXPECT_TRUE(fs::is_empty(dir + "/out")) << "nothing written";
  // The native label passes the same check (the map itself is tested elsewhere).
  EXPECT_EQ(io::read_region_vertices(native_label, io::read_surface(native).mesh).size(),
            io::read_freesurfer_label(native_label).vertices.size());
}

// A region facing the hemisphere's centre (30 rings about vertex 94315 of the native white
// surface, on the insula: 4,795 vertices) keeps its outward winding: the map is not the mirror
// image the centroid's cone rule made of it (it reversed the faces, and the lateral side faced
// away from the viewer). The closed hemisphere it is cut from tells which side is out.
TEST(RegionCli, ARegionFacingTheHemispheresCentreIsNotMirrored) {
  AUTHALIC_REQUIRE_SHARED(native, "fs741/lh.white.surf.gii");
  const TriMesh white = io::read_surface(native).mesh;
  std::vector<char> in(static_cast<std::size_t>(white.num_vertices()), 0);
  in[94315] = 1;
  grow_by_rings(in, vertex_neighbours(white.F, white.num_vertices()), 30);
  io::Label l;
  for (int v = 0; v < white.num_vertices(); ++v)
    if (in[static_cast<std::size_t>(v)]) l.vertices.push_back(v);
  l.positions.resize(static_cast<Eigen::Index>(l.vertices.size()), 3);
  for (std::size_t i = 0; i < l.vertices.size(); ++i) l.positions.row(static_cast<Eigen::Index>(i)) = white.V.row(l.vertices[i]);
  l.values = VectorXd::Zero(static_cast<Eigen::Index>(l.vertices.size()));
  const std::string dir = test::temp_dir("region_cli_insula");
  io::write_freesurfer_label(dir + "/insula.label", l);
  MatrixXi region(0, 3);  // the label's whole faces, in the surface's (outward) winding
  for (Eigen::Index f = 0; f < white.F.rows(); ++f)
    if (in[white.F(f, 0)] && in[white.F(f, 1)] && in[white.F(f, 2)]) {
      region.conservativeResize(region.rows() + 1, 3);
      region.row(region.rows() - 1) = white.F.row(f);
    }
  MatrixXi by_cone = region;
  ASSERT_TRUE(orient_outward(white.V, by_cone)) << "the region no longer faces the centroid: pick another";

  std::string out;
  ASSERT_EQ(run_command(authalic_binary() + " flatten " + native + " " + dir + "/flat.surf.gii --uv " + dir + "/uv.surf.gii --label " +
                            dir + "/insula.label --metrics " + dir + "/m.json -q",
                        &out),
            0)
      << out;
  std::ifstream metrics(dir + "/m.json");
  const nlohmann::json m = nlohmann::json::parse(metrics);
  EXPECT_FALSE(m.at("faces_reversed_to_point_outward").get<bool>());
  // The surface's own faces keep their counter-clockwise winding in the map (the few the map
  // re-triangulated, dividing edges flipped, are not among the map's faces).
  const TriMesh uv = io::read_surface(dir + "/uv.surf.gii").mesh;
  const VectorXd area = signed_face_areas_2d(uv.V.leftCols(2), region);
  EXPECT_GT((area.array() > 0).count(), 0.99 * static_cast<double>(region.rows()));
}

// A region too small to be spread evenly over the square (one vertex ring: 6 triangles) fails its
// acceptance (exit 3) with advice about the region, not "try more passes"; a label on a surface
// with inconsistently oriented faces is bad input (exit 2) naming the surface's damage (it was
// reported as the region's holes and boundary loops).
TEST(RegionCli, ATooSmallRegionOrADamagedSurfaceIsNamed) {
  const std::string dir = test::temp_dir("region_cli_bad_input");
  test::DefectLabel cap = test::cap_label();
  const std::vector<bool> whole = cap.in;
  const int centre = test::nearest_vertex(cap.mesh, {0.0, 0.0, 1.0});
  cap.in.assign(cap.in.size(), false);
  cap.in[centre] = true;
  const auto ring = vertex_neighbours(cap.mesh.F, cap.mesh.num_vertices());
  for (const int w : ring[static_cast<std::size_t>(centre)]) cap.in[static_cast<std::size_t>(w)] = true;
  write_inputs(cap, dir);
  std::string out;
  EXPECT_EQ(run_command(authalic_binary() + " flatten " + dir + "/lh.white.surf.gii " + dir + "/flat.surf.gii --label " + dir +
                            "/lh.cortex.label -q",
                        &out),
            3)
      << out;
  EXPECT_NE(out.find("The region has only "), std::string::npos) << out;
  EXPECT_NE(out.find(" triangles, fewer than the 32 x 32 elements of the acceptance grid: give a larger region"), std::string::npos) << out;
  EXPECT_EQ(out.find("Try more passes"), std::string::npos) << out;
  EXPECT_FALSE(fs::exists(dir + "/flat.surf.gii"));

  cap.in = whole;
  for (int f = 0; f < cap.mesh.num_faces(); f += 97) cap.mesh.F.row(f) = Eigen::RowVector3i(cap.mesh.F(f, 0), cap.mesh.F(f, 2), cap.mesh.F(f, 1));
  write_inputs(cap, dir);
  EXPECT_EQ(run_command(authalic_binary() + " flatten " + dir + "/lh.white.surf.gii " + dir + "/flat.surf.gii --label " + dir +
                            "/lh.cortex.label -q",
                        &out),
            2)
      << out;
  EXPECT_NE(out.find("lh.white.surf.gii: the surface is not a clean triangle mesh:"), std::string::npos) << out;
  EXPECT_NE(out.find("(inconsistent orientation)"), std::string::npos) << out;
  EXPECT_FALSE(fs::exists(dir + "/flat.surf.gii"));
}
