#pragma once
// Equal-area cortical elements (Zou et al. 2011a section 5.2, Fig. 5):
// the cells of a regular grid on the parametric domain of an authalic map, mapped back to the
// cortex. On an authalic map every element holds the same cortical area, so per-element PET
// values are comparable across elements and subjects.
//
// An element's value is the area-weighted mean of the per-vertex value over the part of the
// cortex that maps into its cell: every triangle is clipped against the cells (core/grid_overlap.h)
// and each piece contributes (its cortical area) x (the value at its centroid). With values linear
// on each triangle this is the exact integral, whatever the map's distortion.
//
// Element tables (one row per element, one block per hemisphere) are what the normative reference
// (analysis/normative.h) is built from. On disk: a TSV (tab-separated; a .csv path gives commas)
//     id hemisphere row col area_mm2 centroid_x_mm centroid_y_mm centroid_z_mm value n_vertices
// (RAS = scanner RAS of the surface; value in the table's units; NaN written as "nan") and a JSON
// sidecar next to it (same name, .json instead of .tsv) with the grid, the provenance and each
// column's Description and Units (as BIDS describes tabular files):
//     {"format": "authalic-element-table", "version": 1, "domain": "square", "k": 32, "rows": 32,
//      "cols": 32, "hemispheres": ["left"], "normalisation": "global", "units": "...",
//      "subject_id": "...", "age": 67 | null, "metadata": {...}}
#include <Eigen/Core>

#include <limits>
#include <map>
#include <string>
#include <vector>

#include "core/domain.h"
#include "core/mesh.h"

namespace authalic::analysis {

// The element grid of a domain at resolution K (core/domain.h: the grid, its cells, the seam of
// a two-part rectangle and the cluster neighbour rule Domain::same_part).
struct ElementGrid {
  Domain domain;
  int k = 32;
  int rows = 32, cols = 32;
  int num_elements() const { return rows * cols; }
};
// The map-file metadata key that carries Domain::seam_x ("none" for one surface), and its text.
// kSeamKey is in rectangle units (x in [0, 2]: the map files); a file scaled to mm (`rectangle
// --flat`, run's space-authalicrect_flat) records the seam in its own units under kSeamMmKey.
inline constexpr const char* kSeamKey = "authalic_seam_x";
inline constexpr const char* kSeamMmKey = "authalic_seam_x_mm";
std::string seam_text(double seam_x);
// seam_x from that metadata text (what: the file, for the error): "none" -> NaN; a number in (0, 2).
double parse_seam(const std::string& text, const std::string& what);
// The same for kSeamMmKey (a file scaled to mm): "none" -> NaN; a positive number of mm.
double parse_seam_mm(const std::string& text, const std::string& what);
ElementGrid element_grid(const Domain& domain, int k);

struct Element {
  int id = 0, row = 0, col = 0;
  double area_mm2 = 0.0;  // cortical area mapped into the cell
  Eigen::Vector3d centroid = Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN());  // RAS mm
  double value = std::numeric_limits<double>::quiet_NaN();  // area-weighted mean; NaN when no valid value
  int n_vertices = 0;      // surface vertices whose map position falls in the cell
};

struct ElementBlock {
  std::string hemisphere;  // "left", "right", "both" (rectangle) or "unknown"
  std::vector<Element> elements;  // rows * cols, by id
};

struct ElementTable {
  ElementGrid grid;
  std::vector<ElementBlock> blocks;
  std::string normalisation = "none";  // kind: "none", "global", "reference-region" (analysis/sampling.h)
  std::string units;                   // of the values
  std::string subject_id;
  double age = std::numeric_limits<double>::quiet_NaN();  // years; NaN = unknown
  std::map<std::string, std::string> metadata;            // provenance (sampling, map file, software, ...)
  int num_values() const { return static_cast<int>(blocks.size()) * grid.num_elements(); }
};

// A map ready for element integration: the map's triangles with, for each of its vertices, the
// 3D position, the domain position and the value.
struct ElementMap {
  MatrixXd V3;      // #V' x 3 surface positions (the surface's units, mm)
  MatrixXd D;       // #V' x 2 (planar, in the domain's coordinates) or #V' x 3 (unit sphere)
  MatrixXi F;       // the map's triangles
  VectorXd values;  // #V'
  int num_surface_vertices = 0;  // the first ones are the surface's
  int inserted_vertices = 0;     // vertices the flattening appended (traced to the edge they split)
  std::vector<std::string> notes;
};

// Puts a surface (V, F: its own triangles), its map (map_V: #V' x 2 or 3, map_F) and per-vertex
// values together. The map keeps the surface's vertices first, in order; vertices it appended
// (corner and ear splits of the flattening, core/conformal_map.h) are traced to the surface edge
// they split and get the interpolated position and value (ear splits: the 3D midpoint, as the
// flattening places them; corner splits on the boundary: the fraction along the edge read from
// the map). A planar map in other units (e.g. the mm-scaled flat surface) is rescaled by its
// bounding box onto the domain when the box has the domain's aspect ratio; a sphere map is
// projected onto the unit sphere. Throws InputError (naming `map_name`) for a map that does not
// fit the domain or the surface.
ElementMap prepare_element_map(const MatrixXd& V, const MatrixXi& F, const MatrixXd& map_V, const MatrixXi& map_F,
                               const VectorXd& values, const Domain& domain, const std::string& map_name = "map");

struct ElementResult {
  ElementBlock block;
  VectorXi vertex_element;   // per surface vertex: element id, -1 when the vertex is in no map triangle
  double area_cv = 0.0;      // SD / mean of element areas (population SD, all cells)
  double total_area_mm2 = 0.0;
};

// Element values, areas, centroids and vertex counts; `to_scanner` moves the surface's
// coordinates to scanner RAS for the centroids. Deterministic for any thread count.
ElementResult compute_elements(const ElementMap& map, const ElementGrid& grid,
                               const Eigen::Matrix4d& to_scanner = Eigen::Matrix4d::Identity());

// The element correspondence mode of a table: its metadata "correspondence" ("per-subject" or
// "atlas <identity>", analysis/atlas.h); tables written before issue 14 are per-subject.
inline constexpr const char* kPerSubjectCorrespondence = "per-subject";
std::string table_correspondence(const ElementTable& table);

// "left", "right" or "unknown" for a surface: GIFTI AnatomicalStructurePrimary (CortexLeft/Right),
// else the file name (lh.* / rh.*, *left* / *right*, hemi-L / hemi-R).
std::string hemisphere_of(const std::map<std::string, std::string>& metadata, const std::string& path);


// ---- element tables on disk -------------------------------------------------------------

// "<path without .tsv or .csv>.json".
std::string element_sidecar_path(const std::string& csv_path);
// Writes the table and its JSON sidecar (atomically, each): tab-separated for a .tsv path (as `run`
// and `elements` write them), comma-separated otherwise; the sidecar describes each column (units).
void write_element_table(const std::string& csv_path, const ElementTable& table);
// Reads the table (.tsv or .csv, by extension) and its sidecar; checks ids, rows, columns and grid size against the sidecar.
// Throws InputError("<path>: <problem>; <hint>") on anything inconsistent. values_only: areas,
// centroids and vertex counts are checked to be present but not parsed (the normative build needs
// only the values; four times faster on large cohorts).
ElementTable read_element_table(const std::string& csv_path, bool values_only = false);

// ---- exported element images ------------------------------------------------------------

struct ElementOutputPaths {
  std::string table, sidecar, nifti, area_nifti, png, png_3d, label;
  std::vector<std::string> all() const;
};
// The paths write_element_outputs writes for PREFIX (listed below).
ElementOutputPaths element_output_paths(const std::string& prefix);
// Writes, for a one-block table and its result on a surface (V_scanner: RAS mm, F: its faces):
//   PREFIX.tsv + PREFIX.json   the element table (write_element_table)
//   PREFIX.nii.gz              cols x rows x 1 float image of element values (voxel (col, row));
//                              the grid is the domain's own space, not a scanner's (write_element_nifti)
//   PREFIX_area.nii.gz         the same with element areas (mm^2)
//   PREFIX.png                 the element image with a colour bar and units
//   PREFIX_3d.png              lateral and medial views coloured by element value, grid drawn
//   PREFIX.label.gii           per-vertex element as a GIFTI label: key = element id + 1, 0 = none,
//                              structure CortexLeft/CortexRight from the table's hemisphere
// All atomic. `left` picks the lateral side for the 3D views.
ElementOutputPaths write_element_outputs(const std::string& prefix, const ElementTable& table, const ElementResult& result,
                                         const MatrixXd& V_scanner, const MatrixXi& F, bool left);

// An element image (cols x rows x blocks float, voxel (col, row, block) holds element
// row * cols + col of that block) as NIfTI. The grid lives on the map, not in a scanner: sform and
// qform code 5 (NIFTI_XFORM_TEMPLATE_OTHER, the element grid's own space, io::NiftiWriteOptions::
// map_grid) with the affine diag(s, s, 1), s = sqrt(element area) mm (mm of cortex per element
// side): voxel (i, j, k) at (i s, j s, k) mm in every tool, and read_volume refuses it as a PET.
// kZScore images carry NIFTI_INTENT_ZSCORE. The description (header descrip) ends with "map grid,
// element <area> mm^2". Atomic.
enum class ElementImageKind { kValues, kAreas, kZScore };
void write_element_nifti(const std::string& path, const std::vector<float>& data, const ElementGrid& grid, int blocks,
                         double element_area_mm2, ElementImageKind kind, const std::string& description);
// Mean element area (mm^2) of a block, or over a table's blocks: the cortical area per element
// (over the elements that hold cortex).
double mean_element_area(const ElementBlock& block);
// Area statistics of a block's elements in columns [col_begin, col_end) (all by default): their
// count, mean area (mm^2), coefficient of variation (population SD / mean; 0 when the mean is 0)
// and smallest and largest area over the mean; NaN when no element is there.
struct ElementAreaStats {
  int count = 0;
  double mean_mm2 = std::numeric_limits<double>::quiet_NaN();
  double cv = std::numeric_limits<double>::quiet_NaN();
  double min_over_mean = std::numeric_limits<double>::quiet_NaN(), max_over_mean = std::numeric_limits<double>::quiet_NaN();
};
ElementAreaStats element_area_stats(const ElementBlock& block, int col_begin = 0, int col_end = std::numeric_limits<int>::max());
// Its coefficient of variation.
double element_area_cv(const ElementBlock& block, int col_begin = 0, int col_end = std::numeric_limits<int>::max());

// One hemisphere's part of a two-hemisphere rectangle (`rectangle --lh/--rh` writes one file per
// part): it fills the cells on its side of the seam (grid.domain.seam_x; x = 1 when unknown) and
// leaves the others empty, so its element statistics are those of the cells wholly on its side
// (over all cells its area CV would be near 1). D: the map's vertices in rectangle units (x in
// column 0), F: its triangles; a map whose triangles span more than 1.9 in x fills the whole
// rectangle. `elements` and `metrics` both measure a part this way.
struct RectanglePartCells {
  bool is_part = false;
  bool right = false;
  int col_begin = 0, col_end = 0;  // the cells wholly inside the part: columns [begin, end)
};
RectanglePartCells rectangle_part_cells(const MatrixXd& D, const MatrixXi& F, const ElementGrid& grid);
// The note both commands print for a part: which hemisphere's part, over which columns.
std::string rectangle_part_note(const RectanglePartCells& part);
double mean_element_area(const ElementTable& table);
// One block's element values (value, or area_mm2 with areas = true) as the data of a cols x rows
// element image (voxel (col, row) = element row * cols + col), for write_element_nifti.
std::vector<float> element_image(const ElementBlock& block, const ElementGrid& grid, bool areas = false);

// Per-vertex values from element values: vertex v gets element_values[vertex_element(v)] (NaN for
// a vertex in no element or an element id beyond the values).
VectorXd element_values_at_vertices(const VectorXi& vertex_element, const double* element_values, int num_elements);

// Per-vertex element of a result as a GIFTI label file: key = element id + 1 (id = row * cols +
// col), 0 = in no element; the label table names each element's row and column. `hemisphere`
// ("left", "right"; the table's block) gives the GIFTI structure (CortexLeft, CortexRight; none for
// "both" or "unknown"), so Workbench shows the file on that hemisphere. Atomic.
void write_element_labels(const std::string& path, const ElementResult& result, const ElementGrid& grid,
                          const std::string& hemisphere);

// Element values of one block as a rows x cols image (row 0 at the bottom), e.g. for render.h.
std::vector<double> block_values(const ElementBlock& block);
std::vector<double> block_areas(const ElementBlock& block);

}  // namespace authalic::analysis
