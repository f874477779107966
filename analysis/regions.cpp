// Anatomical names, regional table and the findings sentence (see analysis/regions.h).
#include "analysis/regions.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <set>

#include "analysis/canvas.h"

namespace authalic::analysis {

namespace {

// Desikan-Killiany regions by lobe, as FreeSurfer's mri_annotation2label --lobesStrict groups
// them, with the cingulate and the insula kept apart.
const std::map<std::string, std::pair<std::string, std::string>>& desikan_regions() {
  static const std::map<std::string, std::pair<std::string, std::string>> table = {
      {"superiorfrontal", {"frontal", "superior frontal"}},
      {"rostralmiddlefrontal", {"frontal", "rostral middle frontal"}},
      {"caudalmiddlefrontal", {"frontal", "caudal middle frontal"}},
      {"parsopercularis", {"frontal", "pars opercularis"}},
      {"parstriangularis", {"frontal", "pars triangularis"}},
      {"parsorbitalis", {"frontal", "pars orbitalis"}},
      {"lateralorbitofrontal", {"frontal", "lateral orbitofrontal"}},
      {"medialorbitofrontal", {"frontal", "medial orbitofrontal"}},
      {"precentral", {"frontal", "precentral"}},
      {"paracentral", {"frontal", "paracentral"}},
      {"frontalpole", {"frontal", "frontal pole"}},
      {"superiorparietal", {"parietal", "superior parietal"}},
      {"inferiorparietal", {"parietal", "inferior parietal"}},
      {"supramarginal", {"parietal", "supramarginal"}},
      {"postcentral", {"parietal", "postcentral"}},
      {"precuneus", {"parietal", "precuneus"}},
      {"superiortemporal", {"temporal", "superior temporal"}},
      {"middletemporal", {"temporal", "middle temporal"}},
      {"inferiortemporal", {"temporal", "inferior temporal"}},
      {"bankssts", {"temporal", "banks of the superior temporal sulcus"}},
      {"fusiform", {"temporal", "fusiform"}},
      {"transversetemporal", {"temporal", "transverse temporal"}},
      {"entorhinal", {"temporal", "entorhinal"}},
      {"temporalpole", {"temporal", "temporal pole"}},
      {"parahippocampal", {"temporal", "parahippocampal"}},
      {"lateraloccipital", {"occipital", "lateral occipital"}},
      {"lingual", {"occipital", "lingual"}},
      {"cuneus", {"occipital", "cuneus"}},
      {"pericalcarine", {"occipital", "pericalcarine"}},
      {"rostralanteriorcingulate", {"cingulate", "rostral anterior cingulate"}},
      {"caudalanteriorcingulate", {"cingulate", "caudal anterior cingulate"}},
      {"posteriorcingulate", {"cingulate", "posterior cingulate"}},
      {"isthmuscingulate", {"cingulate", "isthmus cingulate"}},
      {"insula", {"insula", "insula"}},
  };
  return table;
}

const std::set<std::string> kLobes = {"frontal", "parietal", "temporal", "occipital", "cingulate", "insula"};

std::string with_thousands(double v) {
  const long n = std::lround(v);
  std::string s = std::to_string(std::abs(n));
  for (int i = static_cast<int>(s.size()) - 3; i > 0; i -= 3) s.insert(static_cast<std::size_t>(i), ",");
  return (n < 0 ? "-" : "") + s;
}

// "a", "a and b", "a, b and c".
std::string joined(const std::vector<std::string>& items) {
  std::string s;
  for (std::size_t i = 0; i < items.size(); ++i) {
    if (i > 0) s += i + 1 == items.size() ? " and " : ", ";
    s += items[i];
  }
  return s;
}

}  // namespace

Parcellation parcellation_from_annotation(const io::Annotation& a, const std::string& source) {
  Parcellation p;
  p.names = a.names;
  p.label = a.label;
  for (Eigen::Index v = 0; v < p.label.size(); ++v) {
    const int l = p.label(v);
    if (l < 0) continue;
    const std::string& n = a.names[static_cast<std::size_t>(l)];
    if (n == "unknown" || n == "corpuscallosum" || n == "medialwall" || n == "Medial_wall") p.label(v) = -1;
  }
  p.method = "the subject's FreeSurfer parcellation (" + source + ", Desikan-Killiany names): majority region of the vertices";
  return p;
}

Parcellation lobes_from_coordinates(const MatrixXd& V, const MatrixXi& cortex_faces) {
  Parcellation p;
  p.names = {"frontal", "parietal", "temporal", "occipital"};
  p.label = VectorXi::Constant(V.rows(), -1);
  std::vector<bool> used(static_cast<std::size_t>(V.rows()), false);
  for (Eigen::Index f = 0; f < cortex_faces.rows(); ++f)
    for (int k = 0; k < 3; ++k) used[static_cast<std::size_t>(cortex_faces(f, k))] = true;
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(1e300), hi = -lo;
  for (Eigen::Index v = 0; v < V.rows(); ++v) {
    if (!used[static_cast<std::size_t>(v)]) continue;
    lo = lo.cwiseMin(V.row(v).transpose().head<3>());
    hi = hi.cwiseMax(V.row(v).transpose().head<3>());
  }
  const Eigen::Vector3d ext = (hi - lo).cwiseMax(1e-9);
  for (Eigen::Index v = 0; v < V.rows(); ++v) {
    if (!used[static_cast<std::size_t>(v)]) continue;
    const double y = (V(v, 1) - lo.y()) / ext.y(), z = (V(v, 2) - lo.z()) / ext.z();
    p.label(v) = y < 0.18 ? 3 : y > 0.58 ? 0 : z < 0.38 ? 2 : 1;
  }
  p.method = "lobe from position (no parcellation given): within each hemisphere's bounding box, posterior 18 % occipital, "
             "anterior 42 % frontal, in between lower 38 % temporal, else parietal; approximate";
  return p;
}

std::string lobe_of_region(const std::string& region) {
  if (kLobes.count(region)) return region;
  const auto it = desikan_regions().find(region);
  return it == desikan_regions().end() ? "" : it->second.first;
}

std::string readable_region(const std::string& region) {
  const auto it = desikan_regions().find(region);
  if (it != desikan_regions().end()) return it->second.second;
  std::string s = region;
  std::replace(s.begin(), s.end(), '_', ' ');
  return s;
}

RegionShare majority_region(const Parcellation& p, const std::vector<int>& vertices) {
  std::vector<int> count(p.names.size(), 0);
  int labelled = 0;
  for (int v : vertices) {
    if (v < 0 || v >= p.label.size() || p.label(v) < 0) continue;
    ++count[static_cast<std::size_t>(p.label(v))];
    ++labelled;
  }
  RegionShare r;
  if (labelled == 0) return r;
  const auto best = std::max_element(count.begin(), count.end());  // first maximum: the lower index
  r.name = p.names[static_cast<std::size_t>(best - count.begin())];
  r.fraction = double(*best) / labelled;
  return r;
}

std::vector<std::vector<int>> vertices_of_elements(const VectorXi& element_of_vertex, int num_elements) {
  std::vector<std::vector<int>> out(static_cast<std::size_t>(std::max(num_elements, 0)));
  for (Eigen::Index v = 0; v < element_of_vertex.size(); ++v) {
    const int e = element_of_vertex(v);
    if (e >= 0 && e < num_elements) out[static_cast<std::size_t>(e)].push_back(static_cast<int>(v));
  }
  return out;
}

std::vector<RegionRow> regional_table(const std::string& hemisphere, const Parcellation& p, const std::vector<double>& element_z,
                                      const std::vector<std::vector<int>>& element_vertices) {
  std::map<std::string, std::pair<int, double>> by_region, by_lobe;  // count, sum
  for (std::size_t e = 0; e < element_z.size() && e < element_vertices.size(); ++e) {
    if (!std::isfinite(element_z[e])) continue;
    const RegionShare r = majority_region(p, element_vertices[e]);
    if (r.name.empty()) continue;
    auto& reg = by_region[r.name];
    ++reg.first;
    reg.second += element_z[e];
    const std::string lobe = lobe_of_region(r.name);
    auto& lb = by_lobe[lobe.empty() ? "other" : lobe];
    ++lb.first;
    lb.second += element_z[e];
  }
  std::vector<RegionRow> rows;
  for (const auto& [lobe, cs] : by_lobe) {
    rows.push_back({hemisphere, lobe, "", cs.first, cs.second / cs.first});
    for (const auto& [region, rs] : by_region) {
      const std::string l = lobe_of_region(region);
      if ((l.empty() ? "other" : l) != lobe || region == lobe) continue;
      rows.push_back({hemisphere, lobe, region, rs.first, rs.second / rs.first});
    }
  }
  return rows;
}

namespace {
// "; against chance clusters in the 20 controls: 2 of the 6 clusters (left precuneus, right
// cuneus) are larger than in every control (p = 0.048)" (or "none of the 6 clusters is"; "the
// cluster is"); "" when not measured.
std::string chance_clause(const std::vector<const Finding*>& of) {
  const int controls = of.front()->controls;
  if (controls <= 0 || of.front()->controls_as_large < 0) return "";
  int beyond = 0;
  std::vector<std::string> places;
  for (const Finding* f : of)
    if (f->controls_as_large == 0) {
      ++beyond;
      const std::string place = f->hemisphere + " " + readable_region(f->region);
      if (std::find(places.begin(), places.end(), place) == places.end()) places.push_back(place);
    }
  const std::string p = format_fixed(1.0 / (1.0 + controls), 3);
  std::string text = "; against chance clusters in the " + std::to_string(controls) + " controls: ";
  if (of.size() == 1)
    return text + "the cluster is " + (beyond ? "larger than in every control (p = " + p + ")" : "not larger than in every control");
  if (beyond == 0) return text + "none of the " + std::to_string(of.size()) + " clusters is larger than in every control";
  return text + std::to_string(beyond) + " of the " + std::to_string(of.size()) + " clusters (" + joined(places) + ") " +
         (beyond == 1 ? "is" : "are") + " larger than in every control (p = " + p + ")";
}
}  // namespace

std::string findings_summary(const std::vector<Finding>& findings, double threshold, int min_elements) {
  std::string text;
  const char* kWords[2][2] = {{"hypo", "Hypometabolism"}, {"hyper", "Hypermetabolism"}};
  for (const auto& [key, word] : kWords) {
    std::vector<const Finding*> of;
    for (const Finding& f : findings)
      if (f.direction == key) of.push_back(&f);
    if (!text.empty()) text += " ";
    if (of.empty()) {
      text += std::string("No ") + (key == std::string("hypo") ? "hypometabolism" : "hypermetabolism") + " (|z| \u2265 " +
              format_fixed(threshold, 1) + " over at least " + std::to_string(min_elements) + " element" +
              (min_elements == 1 ? "" : "s") + ").";
      continue;
    }
    std::vector<std::string> places;
    double area = 0.0;
    const Finding* peak = of.front();
    for (const Finding* f : of) {
      const std::string place = f->hemisphere + " " + readable_region(f->region);
      if (std::find(places.begin(), places.end(), place) == places.end()) places.push_back(place);
      area += f->area_mm2;
      if (std::abs(f->peak_z) > std::abs(peak->peak_z)) peak = f;
    }
    if (places.size() > 4) {
      places.resize(4);
      places.push_back("elsewhere");
    }
    text += std::string(word) + " in " + joined(places) + " (" + std::to_string(of.size()) + " cluster" +
            (of.size() == 1 ? "" : "s") + ", " + with_thousands(area) + " mm\u00b2), peak z " + format_fixed(peak->peak_z, 1, true) +
            " in " + peak->hemisphere + " " + readable_region(peak->region) + chance_clause(of) + ".";
  }
  return text;
}

}  // namespace authalic::analysis
