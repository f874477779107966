// Equal-area cortical elements (analysis/elements.h): exact integrals of linear values, areas,
// centroids, traced flattening vertices, sphere/rectangle grids, the table files, and the
// element-area CV of an authalic versus a conformal map of real cortex.
#include <gtest/gtest.h>
#include <omp.h>

#include <cmath>
#include <fstream>

#include "analysis/elements.h"
#include "analysis_test_util.h"
#include "common/test_data.h"
#include "core/authalic_flow.h"
#include "core/conformal_map.h"
#include "core/error.h"
#include "io/surface_io.h"

namespace authalic::analysis {
namespace {

// n x n vertices on [0,1]^2, two counter-clockwise triangles per square.
TriMesh grid_square(int n) {
  TriMesh m;
  m.V.resize(n * n, 3);
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) m.V.row(j * n + i) << double(i) / (n - 1), double(j) / (n - 1), 0.0;
  m.F.resize(2 * (n - 1) * (n - 1), 3);
  int f = 0;
  for (int j = 0; j + 1 < n; ++j)
    for (int i = 0; i + 1 < n; ++i) {
      const int a = j * n + i, b = a + 1, c = a + n, d = c + 1;
      m.F.row(f++) << a, b, d;
      m.F.row(f++) << a, d, c;
    }
  return m;
}

// A smooth non-isometric embedding of the unit square in 3D (mm).
MatrixXd warp(const MatrixXd& UV) {
  MatrixXd V(UV.rows(), 3);
  for (int v = 0; v < UV.rows(); ++v) {
    const double x = UV(v, 0), y = UV(v, 1);
    V.row(v) << 40 * x + 6 * std::sin(3 * y), 25 * y + 10 * y * y, 8 * std::sin(4 * x) * std::cos(2 * y);
  }
  return V;
}

double f3(const Eigen::Vector3d& p) { return 5.0 + 0.3 * p.x() - 0.2 * p.y() + 0.7 * p.z(); }

// The hemisphere of a table: the GIFTI structure, else the file's name as FreeSurfer, BIDS or
// nilearn write it (rh_white.surf.gii was "unknown" while `sphere` said right).
TEST(Elements, HemisphereFromTheSurfacesMetadataOrName) {
  EXPECT_EQ(hemisphere_of({{"AnatomicalStructurePrimary", "CortexRight"}}, "/d/lh.white"), "right");
  EXPECT_EQ(hemisphere_of({}, "/d/lh.white"), "left");
  EXPECT_EQ(hemisphere_of({}, "/d/rh_white.surf.gii"), "right");
  EXPECT_EQ(hemisphere_of({}, "/d/lh_pial.gii"), "left");
  EXPECT_EQ(hemisphere_of({}, "/d/sub-01_hemi-R_white.surf.gii"), "right");
  EXPECT_EQ(hemisphere_of({}, "/d/white_left.gii.gz"), "left");
  EXPECT_EQ(hemisphere_of({}, "/d/cortex.surf.gii"), "unknown");
}

TEST(Elements, ValueOfLinearFieldIsItsValueAtTheElementCentroid) {
  const TriMesh square = grid_square(41);
  const MatrixXd V = warp(square.V);
  VectorXd values(V.rows());
  for (int v = 0; v < V.rows(); ++v) values(v) = f3(V.row(v).transpose());
  const ElementMap m = prepare_element_map(V, square.F, square.V, square.F, values, Domain::square());
  const ElementGrid g = element_grid(Domain::square(), 7);  // cells not aligned with the triangles
  Eigen::Matrix4d shift = Eigen::Matrix4d::Identity();
  shift.block<3, 1>(0, 3) = Eigen::Vector3d(1, 2, 3);
  const ElementResult r = compute_elements(m, g, shift);
  ASSERT_EQ(r.block.elements.size(), 49u);
  double total = 0;
  int vertices = 0;
  for (const Element& e : r.block.elements) {
    EXPECT_EQ(e.id, e.row * 7 + e.col);
    EXPECT_GT(e.area_mm2, 0);
    // The mean of a linear function over a region is its value at the region's centroid.
    EXPECT_NEAR(e.value, f3(e.centroid - Eigen::Vector3d(1, 2, 3)), 1e-9) << e.id;
    total += e.area_mm2;
    vertices += e.n_vertices;
  }
  EXPECT_NEAR(total, face_areas(V, square.F).sum(), 1e-9 * total);
  EXPECT_NEAR(r.total_area_mm2, total, 1e-9 * total);
  EXPECT_EQ(vertices, 41 * 41);
  EXPECT_GT(r.area_cv, 0.05);  // the warp is far from area-preserving
  // Vertex (0.5, 0.5) is the grid's centre vertex: element (3, 3).
  EXPECT_EQ(r.vertex_element(20 * 41 + 20), 3 * 7 + 3);
}

TEST(Elements, IsometricMapGivesEqualAreasAndDeterministicResults) {
  const TriMesh square = grid_square(30);
  const MatrixXd V = 10.0 * square.V;  // 10 x 10 mm flat cortex: the map is authalic
  const VectorXd values = VectorXd::LinSpaced(V.rows(), 0.0, 1.0);
  const ElementMap m = prepare_element_map(V, square.F, square.V, square.F, values, Domain::square());
  const ElementGrid g = element_grid(Domain::square(), 8);
  omp_set_num_threads(1);
  const ElementResult a = compute_elements(m, g);
  omp_set_num_threads(2);
  const ElementResult b = compute_elements(m, g);
  EXPECT_LT(a.area_cv, 1e-12);
  for (std::size_t i = 0; i < a.block.elements.size(); ++i) {
    EXPECT_NEAR(a.block.elements[i].area_mm2, 100.0 / 64, 1e-12);
    EXPECT_EQ(a.block.elements[i].value, b.block.elements[i].value);
    EXPECT_EQ(a.block.elements[i].area_mm2, b.block.elements[i].area_mm2);
  }
}

TEST(Elements, MapInMillimetresIsRescaledAndWrongDomainRefused) {
  const TriMesh square = grid_square(12);
  const MatrixXd V = 10.0 * square.V;
  const VectorXd values = VectorXd::Ones(V.rows());
  // The flat surface scaled to the cortical area (a 10 mm square starting at -5).
  MatrixXd mm = (10.0 * square.V).array() - 5.0;
  mm.col(2).setZero();
  const ElementMap m = prepare_element_map(V, square.F, mm, square.F, values, Domain::square(), "flat.surf.gii");
  EXPECT_NEAR(m.D.maxCoeff(), 1.0, 1e-12);
  EXPECT_NEAR(m.D.minCoeff(), 0.0, 1e-12);
  ASSERT_EQ(m.notes.size(), 1u);
  // A 2:1 map is not a square map.
  MatrixXd wide = square.V;
  wide.col(0) *= 3.0;
  try {
    prepare_element_map(V, square.F, wide, square.F, values, Domain::square(), "wide.surf.gii");
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("wide.surf.gii: the map spans"), std::string::npos) << e.what();
  }
  // ... but it fits the rectangle once rescaled (aspect 3 does not).
  MatrixXd rect = square.V;
  rect.col(0) *= 2.0;
  EXPECT_NO_THROW(prepare_element_map(V, square.F, rect, square.F, values, Domain::rectangle()));
  EXPECT_THROW(prepare_element_map(V, square.F, wide, square.F, values, Domain::rectangle()), InputError);
  // Wrong sizes.
  EXPECT_THROW(prepare_element_map(V, square.F, square.V.topRows(10), square.F.topRows(2), values, Domain::square()), InputError);
  EXPECT_THROW(prepare_element_map(V, square.F, square.V, square.F, VectorXd::Ones(3), Domain::square()), InputError);
}

TEST(Elements, VerticesAppendedByTheFlatteningAreTracedToTheirEdge) {
  // Surface: the square (0,1,2,3) as two triangles sharing the diagonal 0-2.
  MatrixXd V(4, 3);
  V << 0, 0, 0, 10, 0, 0, 10, 10, 4, 0, 10, 0;
  MatrixXi F(2, 3);
  F << 0, 1, 2, 0, 2, 3;
  VectorXd values(4);
  values << 1, 2, 5, 3;
  // Map: the diagonal split at its midpoint (vertex 4, placed anywhere by the map), 4 triangles.
  MatrixXd UV(5, 2);
  UV << 0, 0, 1, 0, 1, 1, 0, 1, 0.6, 0.45;
  MatrixXi MF(4, 3);
  MF << 0, 1, 4, 1, 2, 4, 2, 3, 4, 3, 0, 4;
  const ElementMap m = prepare_element_map(V, F, UV, MF, values, Domain::square());
  EXPECT_EQ(m.inserted_vertices, 1);
  EXPECT_TRUE(m.V3.row(4).isApprox(Eigen::RowVector3d(5, 5, 2)));
  EXPECT_DOUBLE_EQ(m.values(4), 3.0);
  // The 3D area is the surface's (the split does not change it), in one 1x1 element.
  const ElementResult r = compute_elements(m, element_grid(Domain::square(), 1));
  EXPECT_NEAR(r.block.elements[0].area_mm2, face_areas(V, F).sum(), 1e-9);
  EXPECT_EQ(r.block.elements[0].n_vertices, 4);  // only the surface's own vertices are counted
  // A map vertex that splits no edge of the surface (a point inside triangle 0-1-2) is refused.
  MatrixXi inside(4, 3);
  inside << 0, 1, 4, 1, 2, 4, 2, 0, 4, 0, 2, 3;
  try {
    prepare_element_map(V, F, UV, inside, values, Domain::square(), "split.surf.gii");
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("split.surf.gii: map vertex 4"), std::string::npos) << e.what();
  }
}

TEST(Elements, SphereCellsOfARoundSphereHaveEqualAreas) {
  const TriMesh s = test::sphere_mesh(5, 50.0);
  const VectorXd values = s.V.col(2);  // z: linear
  const ElementMap m = prepare_element_map(s.V, s.F, s.V / 50.0, s.F, values, Domain::sphere());
  const ElementGrid g = element_grid(Domain::sphere(), 4);
  EXPECT_EQ(g.cols, 8);
  EXPECT_EQ(g.rows, 4);
  const ElementResult r = compute_elements(m, g);
  EXPECT_LT(r.area_cv, 0.01);
  EXPECT_NEAR(r.total_area_mm2, face_areas(s.V, s.F).sum(), 1e-6 * r.total_area_mm2);
  for (const Element& e : r.block.elements) {
    // Bands are equal in z, so band b holds z in [-1 + b/2, -1 + (b+1)/2] x 50 mm.
    const double z_lo = 50.0 * (-1 + 0.5 * e.row), z_hi = z_lo + 25.0;
    EXPECT_GT(e.value, z_lo - 1.0);
    EXPECT_LT(e.value, z_hi + 1.0);
    EXPECT_NEAR(e.value, e.centroid.z(), 1e-9);  // linear value: its value at the centroid
  }
  EXPECT_THROW(prepare_element_map(s.V, s.F, s.V.array() + 30.0, s.F, values, Domain::sphere()), InputError);
}

TEST(Elements, TableRoundTripAndCorruptFilesAreRefused) {
  const TriMesh square = grid_square(10);
  const MatrixXd V = warp(square.V);
  VectorXd values(V.rows());
  for (int v = 0; v < V.rows(); ++v) values(v) = f3(V.row(v).transpose()) / 3.0;
  values(0) = std::nan("");
  const ElementMap m = prepare_element_map(V, square.F, square.V, square.F, values, Domain::square());
  const ElementResult r = compute_elements(m, element_grid(Domain::square(), 4));
  ElementTable t;
  t.grid = element_grid(Domain::square(), 4);
  t.blocks = {{"left", r.block.elements}, {"right", r.block.elements}};
  t.normalisation = "global";
  t.units = "ratio to the global cortical mean";
  t.subject_id = "sub01";
  t.age = 63.5;
  t.metadata["sampling"] = "test";
  const std::string dir = test::temp_dir("elements_table");
  write_element_table(dir + "/t.csv", t);
  const ElementTable u = read_element_table(dir + "/t.csv");
  EXPECT_EQ(u.grid.k, 4);
  EXPECT_EQ(u.blocks.size(), 2u);
  EXPECT_EQ(u.blocks[1].hemisphere, "right");
  EXPECT_EQ(u.normalisation, "global");
  EXPECT_EQ(u.subject_id, "sub01");
  EXPECT_EQ(u.age, 63.5);
  EXPECT_EQ(u.metadata.at("sampling"), "test");
  for (std::size_t b = 0; b < 2; ++b)
    for (std::size_t i = 0; i < 16; ++i) {
      const Element &x = t.blocks[b].elements[i], &y = u.blocks[b].elements[i];
      EXPECT_EQ(x.area_mm2, y.area_mm2);  // shortest round-trip text: bit for bit
      EXPECT_EQ(x.centroid, y.centroid);
      EXPECT_EQ(x.n_vertices, y.n_vertices);
      if (std::isnan(x.value)) {
        EXPECT_TRUE(std::isnan(y.value));
      } else {
        EXPECT_EQ(x.value, y.value);
      }
    }
  // The same table as TSV (what `run` writes): tab-separated, the same values read back; a
  // rectangle table keeps its seam.
  write_element_table(dir + "/t.tsv", t);
  {
    std::ifstream in(dir + "/t.tsv");
    std::string header;
    std::getline(in, header);
    EXPECT_EQ(header, "id\themisphere\trow\tcol\tarea_mm2\tcentroid_x_mm\tcentroid_y_mm\tcentroid_z_mm\tvalue\tn_vertices");
  }
  const ElementTable w = read_element_table(dir + "/t.tsv");
  for (std::size_t b = 0; b < 2; ++b)
    for (std::size_t i = 0; i < 16; ++i) EXPECT_EQ(w.blocks[b].elements[i].area_mm2, u.blocks[b].elements[i].area_mm2);
  ElementTable rect;
  rect.grid = element_grid(Domain::rectangle(), 2);
  rect.grid.domain.seam_x = 1.25;
  rect.blocks = {{"both", std::vector<Element>(8)}};
  for (int e = 0; e < 8; ++e) rect.blocks[0].elements[static_cast<std::size_t>(e)] = Element{e, e / 4, e % 4};
  write_element_table(dir + "/r.tsv", rect);
  EXPECT_EQ(read_element_table(dir + "/r.tsv").grid.domain.seam_x, 1.25);
  // Corruptions: a bad number, a missing row, a missing sidecar.
  std::string csv;
  {
    std::ifstream in(dir + "/t.csv");
    csv.assign(std::istreambuf_iterator<char>(in), {});
  }
  auto write = [&](const std::string& name, const std::string& text) {
    std::ofstream(dir + "/" + name + ".csv") << text;
    std::ifstream src(dir + "/t.json");
    std::ofstream(dir + "/" + name + ".json") << src.rdbuf();
    return dir + "/" + name + ".csv";
  };
  std::string bad = csv;
  bad.replace(bad.find(",left,0,1,") + 10, 1, "x");
  try {
    read_element_table(write("bad_number", bad));
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("bad_number.csv:3: "), std::string::npos) << e.what();
  }
  std::string short_csv = csv.substr(0, csv.rfind('\n', csv.size() - 2) + 1);
  try {
    read_element_table(write("short", short_csv));
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("has 31 element rows, expected 32"), std::string::npos) << e.what();
  }
  std::ofstream(dir + "/lonely.csv") << csv;
  EXPECT_THROW(read_element_table(dir + "/lonely.csv"), InputError);
}

// Issue 5: element areas are equal on an authalic square map of B1 (fsaverage5 white, cortex of
// flat_left), and not on the conformal initial map.
TEST(ElementsRealData, AuthalicSquareMapHasEqualAreaElementsConformalDoesNot) {
  AUTHALIC_REQUIRE_SHARED(white_path, "fsaverage5/white_left.gii.gz");
  AUTHALIC_REQUIRE_SHARED(flat_path, "fsaverage5/flat_left.gii.gz");
  const io::Surface white = io::read_surface(white_path);
  const io::Surface flat = io::read_surface(flat_path);
  const MatrixXi& F = flat.mesh.F;  // the cortex: a disk
  const ConformalMapResult conformal = conformal_rectangle_map(white.mesh.V, F, RectangleBoundaryMap{});
  ASSERT_GE(conformal.V.rows(), white.mesh.V.rows());
  const FlowResult flow = authalic_flow(conformal.V, conformal.F, conformal.UV, conformal.side_mask, FlowOptions{});
  ASSERT_EQ(flow.report.flips, 0);
  const VectorXd values = white.mesh.V.col(1);  // y: any per-vertex field
  const ElementGrid g = element_grid(Domain::square(), 32);
  const ElementMap cm = prepare_element_map(white.mesh.V, F, conformal.UV, conformal.F, values, Domain::square());
  const ElementMap am = prepare_element_map(white.mesh.V, F, flow.UV, conformal.F, values, Domain::square());
  EXPECT_EQ(am.inserted_vertices, static_cast<int>(conformal.V.rows() - white.mesh.V.rows()));
  // Traced positions equal the flattening's own inserted vertices on the conformal map (its
  // boundary is isometric, so corner splits are read back exactly). On the authalic map boundary
  // vertices have slid along their side: ear splits stay exact, corner splits move along their edge.
  int moved = 0;
  for (Eigen::Index v = white.mesh.V.rows(); v < conformal.V.rows(); ++v) {
    EXPECT_LT((cm.V3.row(v) - conformal.V.row(v)).norm(), 1e-9) << "inserted vertex " << v;
    if ((am.V3.row(v) - conformal.V.row(v)).norm() > 1e-9) ++moved;
  }
  EXPECT_LE(moved, conformal.corner_vertices_inserted);
  const ElementResult ca = compute_elements(cm, g), aa = compute_elements(am, g);
  std::cout << "[ B1 element-area CV at K=32: authalic " << aa.area_cv << ", conformal " << ca.area_cv << " ]\n";
  EXPECT_LE(aa.area_cv, 0.02);
  EXPECT_GT(ca.area_cv, 0.2);
  const double cortex = face_areas(white.mesh.V, F).sum();
  EXPECT_NEAR(aa.total_area_mm2, cortex, 1e-3 * cortex);
}

}  // namespace
}  // namespace authalic::analysis
