#pragma once
// Anatomical names for the report: which region each vertex, element, cluster and peak lies
// in, from the subject's own parcellation (FreeSurfer `?h.aparc.annot`, Desikan et al. 2006) or,
// without one, from the lobe its position suggests. The regional table summarises z by region
// and by lobe, and the findings are put into one sentence per direction.
#include <string>
#include <vector>

#include "core/mesh.h"
#include "io/freesurfer_annot.h"

namespace authalic::analysis {

// Per vertex region of one hemisphere: label(v) indexes names (-1 = none, e.g. medial wall).
struct Parcellation {
  VectorXi label;
  std::vector<std::string> names;
  std::string method;  // how the names were obtained, shown in the report
};

// From an annotation: "unknown", "corpuscallosum" and "medialwall" count as no region.
Parcellation parcellation_from_annotation(const io::Annotation& annotation, const std::string& source);

// Without an atlas: the lobe suggested by each cortex vertex's position in its hemisphere's
// bounding box (RAS: y anterior, z superior), over the vertices of `cortex_faces`:
// the posterior 18 % of y is occipital, the anterior 42 % frontal, in between the lower 38 % of
// z temporal and the rest parietal. A coarse, stated approximation (cingulate and insula are
// folded into their neighbours).
Parcellation lobes_from_coordinates(const MatrixXd& V, const MatrixXi& cortex_faces);

// The lobe of a Desikan-Killiany region name (frontal, parietal, temporal, occipital,
// cingulate, insula), "" when unknown; a lobe name maps to itself.
std::string lobe_of_region(const std::string& region);
// "precuneus" -> "precuneus", "parsopercularis" -> "pars opercularis",
// "caudalanteriorcingulate" -> "caudal anterior cingulate": Desikan names written for people.
std::string readable_region(const std::string& region);

// The region holding most of the given vertices (ties: the lower index); fraction = its share of
// the labelled ones. Empty name when none is labelled.
struct RegionShare {
  std::string name;
  double fraction = 0.0;
};
RegionShare majority_region(const Parcellation& p, const std::vector<int>& vertices);

// The vertices of each element (element id -> vertex ids) from a per-vertex element id.
std::vector<std::vector<int>> vertices_of_elements(const VectorXi& element_of_vertex, int num_elements);

// Mean z of the elements whose majority region is each region, and of each lobe.
struct RegionRow {
  std::string hemisphere;  // "left"/"right"
  std::string lobe, region;  // region empty on a lobe row
  int elements = 0;
  double mean_z = 0.0;
};
// One hemisphere: element_z (NaN = no z) and each element's vertices.
std::vector<RegionRow> regional_table(const std::string& hemisphere, const Parcellation& p, const std::vector<double>& element_z,
                                      const std::vector<std::vector<int>>& element_vertices);

// A cluster for the sentence: direction, hemisphere, region, its peak z and area.
struct Finding {
  std::string direction;  // "hypo" / "hyper"
  std::string hemisphere, region;
  double peak_z = 0.0, area_mm2 = 0.0;
  int controls_as_large = -1, controls = 0;  // chance clusters (ReportCluster); -1: not measured
};
// "Hypometabolism in left precuneus and left superior parietal (2 clusters, 1,450 mm²), peak z
// −4.9 in left precuneus; against chance clusters in the 20 controls: 1 of the 2 clusters (left
// precuneus) is larger than in every control (p = 0.048). No hypermetabolism of at least 3 elements." One
// paragraph; the chance-cluster clause only when they were measured.
std::string findings_summary(const std::vector<Finding>& findings, double threshold, int min_elements);

}  // namespace authalic::analysis
