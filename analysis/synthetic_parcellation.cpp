// A Desikan-style parcellation of the synthetic hemisphere (see analysis/synthetic_parcellation.h).
#include "analysis/synthetic_parcellation.h"

#include <cmath>
#include <limits>

namespace authalic::analysis {

namespace {

enum Face { Lateral, Medial, Both };

struct Seed {
  const char* name;
  double a, s;  // anterior and superior fractions of the bounding box
  Face face;
};

// Where the regions sit on a lateral or medial view of a real hemisphere (a = 0 occipital pole,
// 1 frontal pole; s = 0 bottom of the temporal lobe, 1 vertex).
const Seed kSeeds[] = {
    {"superiorfrontal", 0.74, 0.88, Both},        {"rostralmiddlefrontal", 0.86, 0.62, Lateral},
    {"caudalmiddlefrontal", 0.66, 0.74, Lateral},  {"parsopercularis", 0.66, 0.46, Lateral},
    {"parstriangularis", 0.76, 0.46, Lateral},     {"lateralorbitofrontal", 0.86, 0.30, Lateral},
    {"precentral", 0.56, 0.66, Lateral},           {"postcentral", 0.46, 0.68, Lateral},
    {"supramarginal", 0.38, 0.54, Lateral},        {"superiorparietal", 0.28, 0.86, Lateral},
    {"inferiorparietal", 0.20, 0.60, Lateral},     {"lateraloccipital", 0.06, 0.38, Lateral},
    {"superiortemporal", 0.54, 0.34, Lateral},     {"middletemporal", 0.46, 0.20, Lateral},
    {"inferiortemporal", 0.40, 0.05, Both},        {"medialorbitofrontal", 0.88, 0.28, Medial},
    {"rostralanteriorcingulate", 0.78, 0.50, Medial}, {"caudalanteriorcingulate", 0.64, 0.58, Medial},
    {"posteriorcingulate", 0.48, 0.58, Medial},    {"isthmuscingulate", 0.34, 0.46, Medial},
    {"paracentral", 0.52, 0.86, Medial},           {"precuneus", 0.27, 0.72, Medial},
    {"cuneus", 0.12, 0.66, Medial},                {"pericalcarine", 0.05, 0.50, Medial},
    {"lingual", 0.16, 0.30, Medial},               {"parahippocampal", 0.40, 0.22, Medial},
    {"fusiform", 0.28, 0.10, Medial},              {"entorhinal", 0.54, 0.16, Medial},
};

// Distinct colours (golden-angle hues); "unknown" is FreeSurfer's (25, 5, 25).
std::array<int, 4> colour(int i) {
  const double h = std::fmod(i * 137.508, 360.0) / 60.0;
  const double x = 1.0 - std::abs(std::fmod(h, 2.0) - 1.0);
  double r = 0, g = 0, b = 0;
  if (h < 1) { r = 1; g = x; } else if (h < 2) { r = x; g = 1; } else if (h < 3) { g = 1; b = x; }
  else if (h < 4) { g = x; b = 1; } else if (h < 5) { r = x; b = 1; } else { r = 1; b = x; }
  auto level = [](double c) { return static_cast<int>(std::lround(60 + 170 * c)); };
  return {level(r), level(g), level(b), 0};
}

}  // namespace

io::Annotation synthetic_parcellation(const Hemisphere& h) {
  io::Annotation a;
  a.names.push_back("unknown");
  a.colours.push_back({25, 5, 25, 0});
  const int n_seeds = static_cast<int>(sizeof(kSeeds) / sizeof(kSeeds[0]));
  for (int i = 0; i < n_seeds; ++i) {
    a.names.push_back(kSeeds[i].name);
    a.colours.push_back(colour(i + 1));
  }
  const MatrixXd& V = h.white.V;
  Eigen::Vector3d lo = V.colwise().minCoeff().transpose(), hi = V.colwise().maxCoeff().transpose();
  const Eigen::Vector3d ext = (hi - lo).cwiseMax(1e-9);
  // The medial face looks toward the midline: +x for a left hemisphere; a vertex is on it when
  // it lies in the medial 40 % of the hemisphere's width.
  a.label = VectorXi::Zero(V.rows());
  for (Eigen::Index v = 0; v < V.rows(); ++v) {
    if (!h.cortex[static_cast<std::size_t>(v)]) continue;
    const double across = (V(v, 0) - lo.x()) / ext.x();
    const bool medial = h.left ? across > 0.6 : across < 0.4;
    const double pa = (V(v, 1) - lo.y()) / ext.y(), ps = (V(v, 2) - lo.z()) / ext.z();
    double best = std::numeric_limits<double>::infinity();
    for (int i = 0; i < n_seeds; ++i) {
      const Seed& s = kSeeds[i];
      if (s.face != Both && (s.face == Medial) != medial) continue;
      const double d = (pa - s.a) * (pa - s.a) + (ps - s.s) * (ps - s.s);
      if (d < best) {
        best = d;
        a.label(v) = i + 1;
      }
    }
  }
  return a;
}

}  // namespace authalic::analysis
