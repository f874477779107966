// Phantom cohort generator (see analysis/phantom.h).
#include "analysis/phantom.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <queue>
#include <sstream>

#include "analysis/atlas.h"
#include "analysis/phantom_anatomy.h"
#include "analysis/synthetic_parcellation.h"
#include "core/atlas_map.h"
#include "core/error.h"
#include "core/version.h"
#include "io/atomic_file.h"
#include "io/freesurfer_annot.h"
#include "io/surface_io.h"

namespace fs = std::filesystem;

namespace authalic::analysis {

// ---- random numbers ------------------------------------------------------------------------

namespace {
std::uint64_t splitmix64(std::uint64_t& x) {
  std::uint64_t z = (x += 0x9E3779B97F4A7C15ULL);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
  return z ^ (z >> 31);
}
std::uint64_t rotl(std::uint64_t x, int k) { return (x << k) | (x >> (64 - k)); }
constexpr double kPi = 3.14159265358979323846;
}  // namespace

PhantomRng::PhantomRng(std::uint64_t seed) {
  std::uint64_t x = seed;
  for (auto& s : s_) s = splitmix64(x);
}

std::uint64_t PhantomRng::next() {  // xoshiro256** (Blackman & Vigna)
  const std::uint64_t result = rotl(s_[1] * 5, 7) * 9;
  const std::uint64_t t = s_[1] << 17;
  s_[2] ^= s_[0];
  s_[3] ^= s_[1];
  s_[1] ^= s_[2];
  s_[0] ^= s_[3];
  s_[2] ^= t;
  s_[3] = rotl(s_[3], 45);
  return result;
}

double PhantomRng::uniform() { return static_cast<double>(next() >> 11) * 0x1.0p-53; }

double PhantomRng::normal() {
  if (has_spare_) {
    has_spare_ = false;
    return spare_;
  }
  double u1 = uniform();
  while (u1 <= 0.0) u1 = uniform();
  const double u2 = uniform();
  const double r = std::sqrt(-2.0 * std::log(u1));
  spare_ = r * std::sin(2.0 * kPi * u2);
  has_spare_ = true;
  return r * std::cos(2.0 * kPi * u2);
}

// ---- synthetic anatomy -----------------------------------------------------------------------

namespace {

// Geodesic icosphere of frequency f (each icosahedron face cut into f^2 triangles), on the unit
// sphere, faces counter-clockwise seen from outside. Vertices shared by faces are merged exactly
// by their barycentric key over the icosahedron's corners.
TriMesh geodesic_icosphere(int f) {
  const double phi = (1.0 + std::sqrt(5.0)) / 2.0;
  const double P[12][3] = {{-1, phi, 0}, {1, phi, 0}, {-1, -phi, 0}, {1, -phi, 0}, {0, -1, phi}, {0, 1, phi},
                           {0, -1, -phi}, {0, 1, -phi}, {phi, 0, -1}, {phi, 0, 1}, {-phi, 0, -1}, {-phi, 0, 1}};
  int T[20][3] = {{0, 11, 5}, {0, 5, 1},  {0, 1, 7},   {0, 7, 10}, {0, 10, 11}, {1, 5, 9}, {5, 11, 4},
                  {11, 10, 2}, {10, 7, 6}, {7, 1, 8},  {3, 9, 4},  {3, 4, 2},   {3, 2, 6}, {3, 6, 8},
                  {3, 8, 9},  {4, 9, 5},  {2, 4, 11}, {6, 2, 10}, {8, 6, 7},   {9, 8, 1}};
  std::map<std::vector<std::pair<int, int>>, int> index;  // sorted (corner, weight) -> vertex
  std::vector<Eigen::Vector3d> verts;
  std::vector<Eigen::Vector3i> faces;
  auto vertex = [&](const int c[3], int wa, int wb, int wc) {
    std::vector<std::pair<int, int>> key;
    if (wa) key.emplace_back(c[0], wa);
    if (wb) key.emplace_back(c[1], wb);
    if (wc) key.emplace_back(c[2], wc);
    std::sort(key.begin(), key.end());
    auto it = index.find(key);
    if (it != index.end()) return it->second;
    Eigen::Vector3d p = Eigen::Vector3d::Zero();
    for (const auto& [corner, w] : key) p += w * Eigen::Vector3d(P[corner][0], P[corner][1], P[corner][2]);
    verts.push_back(p.normalized());
    const int id = static_cast<int>(verts.size()) - 1;
    index.emplace(key, id);
    return id;
  };
  for (auto& t : T) {
    // Make every face counter-clockwise seen from outside.
    const Eigen::Vector3d a(P[t[0]][0], P[t[0]][1], P[t[0]][2]), b(P[t[1]][0], P[t[1]][1], P[t[1]][2]),
        c(P[t[2]][0], P[t[2]][1], P[t[2]][2]);
    if ((b - a).cross(c - a).dot(a + b + c) < 0) std::swap(t[1], t[2]);
    // Point (i, j) = a + i/f (b - a) + j/f (c - a): weights (f - i - j, i, j).
    std::vector<std::vector<int>> id(f + 1);
    for (int i = 0; i <= f; ++i) {
      for (int j = 0; j <= f - i; ++j) id[i].push_back(vertex(t, f - i - j, i, j));
    }
    for (int i = 0; i < f; ++i) {
      for (int j = 0; j < f - i; ++j) {
        faces.emplace_back(id[i][j], id[i + 1][j], id[i][j + 1]);
        if (j + 1 < f - i) faces.emplace_back(id[i + 1][j], id[i + 1][j + 1], id[i][j + 1]);
      }
    }
  }
  TriMesh mesh;
  mesh.V.resize(static_cast<int>(verts.size()), 3);
  for (int v = 0; v < mesh.V.rows(); ++v) mesh.V.row(v) = verts[v].transpose();
  mesh.F.resize(static_cast<int>(faces.size()), 3);
  for (int k = 0; k < mesh.F.rows(); ++k) mesh.F.row(k) = faces[k].transpose();
  return mesh;
}

double smoothstep(double e0, double e1, double x) {
  const double t = std::clamp((x - e0) / (e1 - e0), 0.0, 1.0);
  return t * t * (3.0 - 2.0 * t);
}

// Semi-axes for a unit direction u of the left hemisphere (medial side = +x is flatter).
Eigen::Vector3d semi_axes(const Eigen::Vector3d& u, const SyntheticHemisphereOptions& o) {
  return {u.x() > 0 ? o.medial_semi_axis : o.lateral_semi_axis, o.ap_semi_axis, o.si_semi_axis};
}

// Angle (radians) between u and the medial axis +x.
double medial_angle(const Eigen::Vector3d& u) { return std::acos(std::clamp(u.x(), -1.0, 1.0)); }

// Fold pattern on the unit sphere: two families of curved plane waves (gyri and sulci about
// 25-30 mm apart on the scaled surface), faded out over the medial wall. Radial displacement, mm.
double folds(const Eigen::Vector3d& u, const SyntheticHemisphereOptions& o) {
  const double w = o.fold_frequency;
  const double g1 = std::sin(w * (0.20 * u.x() + 0.55 * u.y() + 0.81 * u.z()) + 1.1 * std::sin(4.0 * u.y() - 2.0 * u.x()));
  const double g2 = std::sin(w * (0.85 * u.x() - 0.30 * u.y() + 0.43 * u.z()) + 0.9 * std::cos(3.0 * u.z() + 1.5 * u.y()));
  const double cap = o.medial_wall_angle_deg * kPi / 180.0;
  const double fade = smoothstep(cap, cap + 0.35, medial_angle(u));
  return o.fold_amplitude_mm * fade * (0.6 * g1 + 0.4 * g2);
}

// Distance from the centre to the white surface along the direction of S u.
double white_radius(const Eigen::Vector3d& u, const SyntheticHemisphereOptions& o) {
  return semi_axes(u, o).cwiseProduct(u).norm() + folds(u, o);
}

Eigen::Vector3d white_point(const Eigen::Vector3d& u, const SyntheticHemisphereOptions& o) {
  const Eigen::Vector3d c(o.centre[0], o.centre[1], o.centre[2]);
  const Eigen::Vector3d su = semi_axes(u, o).cwiseProduct(u);
  return c + white_radius(u, o) * su.normalized();
}

// Closest point on triangle abc to p (Ericson, Real-Time Collision Detection, 5.1.5).
Eigen::Vector3d closest_point_on_triangle(const Eigen::Vector3d& p, const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                                          const Eigen::Vector3d& c) {
  const Eigen::Vector3d ab = b - a, ac = c - a, ap = p - a;
  const double d1 = ab.dot(ap), d2 = ac.dot(ap);
  if (d1 <= 0 && d2 <= 0) return a;
  const Eigen::Vector3d bp = p - b;
  const double d3 = ab.dot(bp), d4 = ac.dot(bp);
  if (d3 >= 0 && d4 <= d3) return b;
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) return a + (d1 / (d1 - d3)) * ab;
  const Eigen::Vector3d cp = p - c;
  const double d5 = ab.dot(cp), d6 = ac.dot(cp);
  if (d6 >= 0 && d5 <= d6) return c;
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) return a + (d2 / (d2 - d6)) * ac;
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0) return b + ((d4 - d3) / ((d4 - d3) + (d5 - d6))) * (c - b);
  const double denom = 1.0 / (va + vb + vc);
  return a + ab * (vb * denom) + ac * (vc * denom);
}

// Uniform grid of buckets over points or triangles for nearest queries.
class BucketGrid {
 public:
  BucketGrid(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi, double cell) : lo_(lo), cell_(cell) {
    for (int k = 0; k < 3; ++k) n_[k] = std::max(1, static_cast<int>(std::ceil((hi[k] - lo[k]) / cell)) + 1);
    buckets_.resize(static_cast<std::size_t>(n_[0]) * n_[1] * n_[2]);
  }
  void insert_box(const Eigen::Vector3d& a, const Eigen::Vector3d& b, int item) {
    int i0[3], i1[3];
    for (int k = 0; k < 3; ++k) {
      i0[k] = clamp_index(a[k], k);
      i1[k] = clamp_index(b[k], k);
    }
    for (int z = i0[2]; z <= i1[2]; ++z)
      for (int y = i0[1]; y <= i1[1]; ++y)
        for (int x = i0[0]; x <= i1[0]; ++x) buckets_[flat(x, y, z)].push_back(item);
  }
  // Calls fn(item) for items in the cells overlapping the box p +- r (an item may repeat).
  template <class Fn>
  void visit(const Eigen::Vector3d& p, double r, Fn&& fn) const {
    int i0[3], i1[3];
    for (int k = 0; k < 3; ++k) {
      if (p[k] + r < lo_[k] || p[k] - r > lo_[k] + n_[k] * cell_) return;
      i0[k] = clamp_index(p[k] - r, k);
      i1[k] = clamp_index(p[k] + r, k);
    }
    for (int z = i0[2]; z <= i1[2]; ++z)
      for (int y = i0[1]; y <= i1[1]; ++y)
        for (int x = i0[0]; x <= i1[0]; ++x)
          for (int item : buckets_[flat(x, y, z)]) fn(item);
  }

 private:
  int clamp_index(double v, int k) const {
    return std::clamp(static_cast<int>(std::floor((v - lo_[k]) / cell_)), 0, n_[k] - 1);
  }
  std::size_t flat(int x, int y, int z) const { return static_cast<std::size_t>(x) + n_[0] * (y + static_cast<std::size_t>(n_[1]) * z); }
  Eigen::Vector3d lo_;
  double cell_;
  int n_[3];
  std::vector<std::vector<int>> buckets_;
};

Eigen::Vector3d voxel_centre(const io::Volume& vol, int i, int j, int k) {
  return (vol.vox2ras * Eigen::Vector4d(i, j, k, 1.0)).head<3>();
}

}  // namespace

bool inside_synthetic_white(const Eigen::Vector3d& p, const SyntheticHemisphereOptions& o) {
  const Eigen::Vector3d c(o.centre[0], o.centre[1], o.centre[2]);
  const Eigen::Vector3d w = p - c;
  const double r = w.norm();
  if (r == 0.0) return true;
  // The direction u on the unit sphere whose scaled point lies along w.
  Eigen::Vector3d axes = semi_axes(w, o);  // the sign of x is the same for w and u
  const Eigen::Vector3d u = w.cwiseQuotient(axes).normalized();
  return r < white_radius(u, o);
}

Hemisphere synthetic_left_hemisphere(const SyntheticHemisphereOptions& o) {
  if (o.frequency < 2 || o.frequency > 200) throw InputError("phantom: icosphere frequency must be in 2..200");
  const TriMesh sphere = geodesic_icosphere(o.frequency);
  Hemisphere h;
  h.left = true;
  h.white.F = sphere.F;
  h.white.V.resize(sphere.V.rows(), 3);
  h.cortex.assign(static_cast<std::size_t>(sphere.V.rows()), false);
  const double cap = o.medial_wall_angle_deg * kPi / 180.0;
  for (int v = 0; v < sphere.V.rows(); ++v) {
    const Eigen::Vector3d u = sphere.V.row(v).transpose();
    h.white.V.row(v) = white_point(u, o).transpose();
    h.cortex[v] = medial_angle(u) > cap;
  }
  h.pial.F = h.white.F;
  h.pial.V = h.white.V + o.thickness_mm * vertex_normals(h.white.V, h.white.F);
  return h;
}

Hemisphere mirror_hemisphere(const Hemisphere& in) {
  Hemisphere out = in;
  out.left = !in.left;
  for (TriMesh* m : {&out.white, &out.pial}) {
    m->V.col(0) *= -1.0;
    m->F.col(1).swap(m->F.col(2));  // mirroring flips orientation: swap back to counter-clockwise
  }
  return out;
}


// ---- PET ----------------------------------------------------------------------------------

io::Volume synthetic_pet_template(const Hemisphere& left, const SyntheticHemisphereOptions& o, double voxel_mm) {
  if (!(voxel_mm > 0.5 && voxel_mm <= 10.0)) throw InputError("phantom: voxel size must be in (0.5, 10] mm");
  const double margin = 12.0;
  Eigen::Vector3d lo = left.pial.V.colwise().minCoeff().transpose(), hi = left.pial.V.colwise().maxCoeff().transpose();
  // Both hemispheres: x in [min_x, -min_x].
  hi.x() = -lo.x();
  lo.array() -= margin;
  hi.array() += margin;
  io::Volume vol;
  for (int k = 0; k < 3; ++k) vol.dims[k] = static_cast<int>(std::ceil((hi[k] - lo[k]) / voxel_mm)) + 1;
  vol.vox2ras = Eigen::Matrix4d::Identity();
  vol.vox2ras.block<3, 3>(0, 0) *= voxel_mm;
  vol.vox2ras.block<3, 1>(0, 3) = lo;
  vol.orientation_source = "sform";
  vol.units = "relative";
  vol.data.assign(vol.num_voxels(), 0.0f);

  // Triangles of the white surface bucketed for the ribbon test.
  const double cell = 4.0;
  const Eigen::Vector3d wlo = left.white.V.colwise().minCoeff().transpose(), whi = left.white.V.colwise().maxCoeff().transpose();
  BucketGrid grid(wlo.array() - cell, whi.array() + cell, cell);
  for (int f = 0; f < left.white.num_faces(); ++f) {
    Eigen::Vector3d a = left.white.V.row(left.white.F(f, 0)).transpose(), b = a;
    for (int k = 1; k < 3; ++k) {
      a = a.cwiseMin(left.white.V.row(left.white.F(f, k)).transpose());
      b = b.cwiseMax(left.white.V.row(left.white.F(f, k)).transpose());
    }
    grid.insert_box(a, b, f);
  }
  const double t = o.thickness_mm;
  const Eigen::Vector3d c(o.centre[0], o.centre[1], o.centre[2]);
  auto tissue = [&](Eigen::Vector3d q) {
    if (q.x() > 0) q.x() = -q.x();  // right hemisphere = mirror of the left
    if (inside_synthetic_white(q, o)) return 0.3;
    // Radial excess over the white surface bounds the distance to it from above.
    const Eigen::Vector3d w = q - c;
    const Eigen::Vector3d axes = semi_axes(w, o);
    const Eigen::Vector3d u = w.cwiseQuotient(axes).normalized();
    const double excess = w.norm() - white_radius(u, o);
    if (excess <= t) return 1.0;
    if (excess > t + 20.0) return 0.0;
    double best = std::numeric_limits<double>::infinity();
    grid.visit(q, t, [&](int f) {
      const Eigen::Vector3d p = closest_point_on_triangle(q, left.white.V.row(left.white.F(f, 0)).transpose(),
                                                          left.white.V.row(left.white.F(f, 1)).transpose(),
                                                          left.white.V.row(left.white.F(f, 2)).transpose());
      best = std::min(best, (p - q).squaredNorm());
    });
    if (best <= t * t) return 1.0;
    return excess <= t + 8.0 ? 0.05 : 0.0;
  };
  const int nx = vol.dims[0], ny = vol.dims[1], nz = vol.dims[2];
#pragma omp parallel for schedule(dynamic, 1)
  for (int k = 0; k < nz; ++k) {
    for (int j = 0; j < ny; ++j) {
      for (int i = 0; i < nx; ++i) {
        // 2x2x2 supersampling for partial-volume values at the ribbon's edges.
        double sum = 0.0;
        for (int s = 0; s < 8; ++s) {
          const Eigen::Vector3d q =
              voxel_centre(vol, i, j, k) + 0.25 * voxel_mm * Eigen::Vector3d((s & 1) ? 1 : -1, (s & 2) ? 1 : -1, (s & 4) ? 1 : -1);
          sum += tissue(q);
        }
        vol.data[static_cast<std::size_t>(i) + static_cast<std::size_t>(nx) * (j + static_cast<std::size_t>(ny) * k)] =
            static_cast<float>(sum / 8.0);
      }
    }
  }
  return vol;
}

PlantedRegion plant_region(const Hemisphere& left, const Eigen::Vector3d& target, double radius_mm, double depth) {
  if (!(depth > 0.0 && depth < 1.0)) throw InputError("phantom: region depth must be in (0, 1), e.g. 0.25 for -25%");
  if (!(radius_mm > 0.0)) throw InputError("phantom: region radius must be positive (mm)");
  PlantedRegion r;
  r.radius_mm = radius_mm;
  r.depth = depth;
  double best = std::numeric_limits<double>::infinity();
  for (int v = 0; v < left.white.num_vertices(); ++v) {
    if (!left.cortex[v]) continue;
    const double d = (left.white.V.row(v).transpose() - target).squaredNorm();
    if (d < best) {
      best = d;
      r.centre_vertex = v;
    }
  }
  if (r.centre_vertex < 0) throw ProcessingError("phantom: the hemisphere has no cortex vertex");
  const VectorXd dist = edge_path_distances(left.white, left.cortex, r.centre_vertex);
  r.left_mask.assign(static_cast<std::size_t>(left.white.num_vertices()), false);
  for (int v = 0; v < dist.size(); ++v) r.left_mask[v] = dist(v) <= radius_mm;
  r.right_mask = r.left_mask;  // the right hemisphere is the mirror, vertex for vertex
  return r;
}

Eigen::Vector3d default_region_target(bool synthetic, const SyntheticHemisphereOptions& o) {
  if (!synthetic) return {-10.0, -62.0, 40.0};  // left precuneus / posterior parietal, MNI mm
  // Medial-posterior-superior direction, well outside the medial-wall cap.
  const Eigen::Vector3d u = Eigen::Vector3d(0.30, -0.70, 0.65).normalized();
  return white_point(u, o);
}

std::vector<float> region_multiplier(const io::Volume& grid, const Hemisphere& left, const Hemisphere& right,
                                     const PlantedRegion& region, double column_depth_mm) {
  std::vector<float> mult(grid.num_voxels(), 1.0f);
  struct Side {
    const Hemisphere* h;
    const std::vector<bool>* mask;
    MatrixXd P;  // white and pial vertices stacked
    Eigen::Vector3d lo, hi;
  };
  std::vector<Side> sides;
  for (auto [h, mask] : {std::make_pair(&left, &region.left_mask), std::make_pair(&right, &region.right_mask)}) {
    Side s{h, mask, MatrixXd(), Eigen::Vector3d(), Eigen::Vector3d()};
    s.P.resize(2 * h->white.num_vertices(), 3);
    s.P << h->white.V, h->pial.V;
    s.lo = s.P.colwise().minCoeff().transpose().array() - column_depth_mm;
    s.hi = s.P.colwise().maxCoeff().transpose().array() + column_depth_mm;
    sides.push_back(std::move(s));
  }
  const double cell = 5.0;
  std::vector<BucketGrid> grids;
  for (const Side& s : sides) {
    grids.emplace_back(s.lo, s.hi, cell);
    for (int p = 0; p < s.P.rows(); ++p) grids.back().insert_box(s.P.row(p).transpose(), s.P.row(p).transpose(), p);
  }
  // Tubes along the inward normal under every region vertex (pial + 2 mm down to pial - 20 mm):
  // deep white matter can be nearer to some other part of the surface (the medial wall, the
  // other bank of a sulcus) than to the region above it, yet samplers reach it from the region.
  struct Segment {
    Eigen::Vector3d a, b;
  };
  std::vector<Segment> segments;
  const double tube_radius = 3.0;
  for (const Side& s : sides) {
    const MatrixXd N = vertex_normals(s.h->pial.V, s.h->pial.F);
    for (int v = 0; v < s.h->pial.num_vertices(); ++v) {
      if (!(*s.mask)[v]) continue;
      const Eigen::Vector3d p = s.h->pial.V.row(v).transpose(), n = N.row(v).transpose();
      segments.push_back({p + 2.0 * n, p - 20.0 * n});
    }
  }
  Eigen::Vector3d seg_lo = sides[0].lo.cwiseMin(sides[1].lo), seg_hi = sides[0].hi.cwiseMax(sides[1].hi);
  BucketGrid segment_grid(seg_lo, seg_hi, cell);
  for (std::size_t i = 0; i < segments.size(); ++i) {
    const Eigen::Vector3d a = segments[i].a.cwiseMin(segments[i].b).array() - tube_radius;
    const Eigen::Vector3d b = segments[i].a.cwiseMax(segments[i].b).array() + tube_radius;
    segment_grid.insert_box(a, b, static_cast<int>(i));
  }
  auto in_tube = [&](const Eigen::Vector3d& q) {
    bool hit = false;
    segment_grid.visit(q, 0.0, [&](int i) {
      if (hit) return;
      const Eigen::Vector3d ab = segments[i].b - segments[i].a;
      const double t = std::clamp((q - segments[i].a).dot(ab) / ab.squaredNorm(), 0.0, 1.0);
      hit = (segments[i].a + t * ab - q).squaredNorm() <= tube_radius * tube_radius;
    });
    return hit;
  };

  const int nx = grid.dims[0], ny = grid.dims[1], nz = grid.dims[2];
  const auto one_minus_depth = static_cast<float>(1.0 - region.depth);
#pragma omp parallel for schedule(dynamic, 1)
  for (int k = 0; k < nz; ++k) {
    for (int j = 0; j < ny; ++j) {
      for (int i = 0; i < nx; ++i) {
        const Eigen::Vector3d q = voxel_centre(grid, i, j, k);
        if (in_tube(q)) {
          mult[static_cast<std::size_t>(i) + static_cast<std::size_t>(nx) * (j + static_cast<std::size_t>(ny) * k)] = one_minus_depth;
          continue;
        }
        // The nearest surface vertex of either hemisphere decides (ties: the first found).
        double best = column_depth_mm * column_depth_mm;
        int best_side = -1, best_vertex = -1;
        for (int s = 0; s < 2; ++s) {
          if ((q.array() < sides[s].lo.array()).any() || (q.array() > sides[s].hi.array()).any()) continue;
          grids[s].visit(q, column_depth_mm, [&](int p) {
            const double d = (sides[s].P.row(p).transpose() - q).squaredNorm();
            if (d < best || (d == best && (s < best_side || (s == best_side && p < best_vertex)))) {
              best = d;
              best_side = s;
              best_vertex = p;
            }
          });
        }
        if (best_side < 0) continue;
        const int nv = sides[best_side].h->white.num_vertices();
        if ((*sides[best_side].mask)[best_vertex % nv]) {
          mult[static_cast<std::size_t>(i) + static_cast<std::size_t>(nx) * (j + static_cast<std::size_t>(ny) * k)] = one_minus_depth;
        }
      }
    }
  }
  return mult;
}

SubjectEffects draw_subject_effects(PhantomRng& rng) {
  SubjectEffects e;
  e.global_scale = std::exp(0.10 * rng.normal());
  e.field_amplitude = 0.02;
  // Random direction (normalised Gaussian vector), wavelength 150-300 mm, random phase.
  Eigen::Vector3d d(rng.normal(), rng.normal(), rng.normal());
  if (d.norm() < 1e-9) d = Eigen::Vector3d(1, 0, 0);
  d.normalize();
  const double wavelength = 150.0 + 150.0 * rng.uniform();
  for (int k = 0; k < 3; ++k) e.field_wave[k] = 2.0 * kPi / wavelength * d[k];
  e.field_phase = 2.0 * kPi * rng.uniform();
  e.noise_fraction = 0.04;
  e.fwhm_mm = 6.0 + 2.0 * rng.uniform();
  e.parcel_amplitude = 0.10;
  e.parcel_mm = 25.0;
  e.parcel_seed = rng.next();
  e.noise_seed = rng.next();
  return e;
}

void gaussian_blur(io::Volume& vol, double fwhm_mm) {
  if (!(fwhm_mm > 0)) return;
  const double sigma_mm = fwhm_mm / (2.0 * std::sqrt(2.0 * std::log(2.0)));
  const Eigen::Vector3d vs = vol.voxel_size();
  const int n[3] = {vol.dims[0], vol.dims[1], vol.dims[2]};
  const std::size_t stride[3] = {1, static_cast<std::size_t>(n[0]), static_cast<std::size_t>(n[0]) * n[1]};
  for (int axis = 0; axis < 3; ++axis) {
    const double sigma = sigma_mm / vs[axis];
    const int radius = std::max(1, static_cast<int>(std::ceil(3.0 * sigma)));
    std::vector<double> kernel(2 * radius + 1);
    double sum = 0.0;
    for (int r = -radius; r <= radius; ++r) sum += kernel[r + radius] = std::exp(-0.5 * r * r / (sigma * sigma));
    for (double& w : kernel) w /= sum;
    const int a1 = (axis + 1) % 3, a2 = (axis + 2) % 3;
    const std::vector<float> src = vol.data;
    const int lines = n[a1] * n[a2];
#pragma omp parallel for schedule(static)
    for (int line = 0; line < lines; ++line) {
      const int p1 = line % n[a1], p2 = line / n[a1];
      const std::size_t base = p1 * stride[a1] + p2 * stride[a2];
      for (int x = 0; x < n[axis]; ++x) {
        double acc = 0.0;
        for (int r = -radius; r <= radius; ++r) {
          const int xx = std::clamp(x + r, 0, n[axis] - 1);
          acc += kernel[r + radius] * src[base + xx * stride[axis]];
        }
        vol.data[base + x * stride[axis]] = static_cast<float>(acc);
      }
    }
  }
}

namespace {
// U(0,1) of the cube of side `size` (world-fixed lattice) that holds x, for one subject's seed.
double parcel_uniform(const Eigen::Vector3d& x, double size, std::uint64_t seed) {
  std::uint64_t h = seed;
  for (int k = 0; k < 3; ++k) {
    h ^= static_cast<std::uint64_t>(static_cast<std::int64_t>(std::floor(x[k] / size))) + 0x9E3779B97F4A7C15ULL + (h << 6) + (h >> 2);
    h = splitmix64(h);
  }
  return static_cast<double>(h >> 11) * 0x1.0p-53;
}
}  // namespace

io::Volume subject_pet(const io::Volume& healthy, const SubjectEffects& e, const std::vector<float>& multiplier,
                       double reference) {
  if (!multiplier.empty() && multiplier.size() != healthy.num_voxels()) {
    throw std::invalid_argument("subject_pet: multiplier size does not match the volume");
  }
  io::Volume out = healthy;
  out.units = "Bq/mL";
  const int nx = healthy.dims[0], ny = healthy.dims[1], nz = healthy.dims[2];
  const Eigen::Vector3d k(e.field_wave[0], e.field_wave[1], e.field_wave[2]);
#pragma omp parallel for schedule(static)
  for (int kk = 0; kk < nz; ++kk) {
    for (int j = 0; j < ny; ++j) {
      for (int i = 0; i < nx; ++i) {
        const std::size_t idx = static_cast<std::size_t>(i) + static_cast<std::size_t>(nx) * (j + static_cast<std::size_t>(ny) * kk);
        const Eigen::Vector3d x = voxel_centre(healthy, i, j, kk);
        double field = 1.0 + e.field_amplitude * std::cos(k.dot(x) + e.field_phase);
        if (e.parcel_amplitude > 0) field *= 1.0 + e.parcel_amplitude * (2.0 * parcel_uniform(x, e.parcel_mm, e.parcel_seed) - 1.0);
        double v = healthy.data[idx];
        if (!std::isfinite(v)) v = 0.0;
        v *= reference * e.global_scale * field * (multiplier.empty() ? 1.0 : multiplier[idx]);
        out.data[idx] = static_cast<float>(v);
      }
    }
  }
  // Noise: one sequential stream, so the result does not depend on the thread count.
  if (e.noise_fraction > 0) {
    PhantomRng rng(e.noise_seed);
    for (float& v : out.data) {
      const double sd = e.noise_fraction * std::sqrt(std::max(0.0, static_cast<double>(v)) * reference);
      v = static_cast<float>(std::max(0.0, v + sd * rng.normal()));
    }
  }
  gaussian_blur(out, e.fwhm_mm);
  for (std::size_t i = 0; i < out.data.size(); ++i) {
    // Outside the head (template 0) stays exactly 0, and whole Bq/mL are plenty: both make the
    // gzipped NIfTI several times smaller.
    const float h = healthy.data[i];
    out.data[i] = !(std::isfinite(h) && h != 0.0f) ? 0.0f : static_cast<float>(std::round(out.data[i]));
  }
  return out;
}

// ---- the cohort on disk ---------------------------------------------------------------------

namespace {

std::string two_digits(int i) {
  char buf[16];
  std::snprintf(buf, sizeof(buf), "%02d", i);
  return buf;
}

std::string csv_number(double v) {
  char buf[32];
  std::snprintf(buf, sizeof(buf), "%.1f", v);
  return buf;
}

// Cortex vertices of the shared fsaverage5 patch: those used by flat_left's face set.
std::vector<bool> used_vertices(const MatrixXi& F, int n) {
  std::vector<bool> used(static_cast<std::size_t>(n), false);
  for (int f = 0; f < F.rows(); ++f) {
    for (int k = 0; k < 3; ++k) used[F(f, k)] = true;
  }
  return used;
}

void write_hemisphere_files(const std::string& out, const Hemisphere& h, const PlantedRegion& region,
                            const std::string& hemi) {
  const std::string software = std::string("authalic phantom ") + kVersion;
  io::SurfaceWriteOptions so;
  so.anatomical_structure = h.left ? "CortexLeft" : "CortexRight";
  so.geometric_type = "Anatomical";
  so.metadata["generator"] = software;
  // A FreeSurfer volume-geometry footer with c_ras = 0: tkregister RAS = scanner RAS, so the
  // surfaces sit in the PET's world coordinates as they are.
  so.volume_geometry.valid = true;
  so.volume_geometry.filename = "authalic-phantom";
  so.volume_geometry.volume = {256, 256, 256};
  so.volume_geometry.cras = Eigen::Vector3d::Zero();
  io::write_surface(out + "/surf/" + hemi + ".white", h.white, so);
  io::write_surface(out + "/surf/" + hemi + ".pial", h.pial, so);

  io::Label cortex;
  for (int v = 0; v < h.white.num_vertices(); ++v) {
    if (h.cortex[v]) cortex.vertices.push_back(v);
  }
  cortex.positions.resize(static_cast<int>(cortex.vertices.size()), 3);
  for (std::size_t i = 0; i < cortex.vertices.size(); ++i) cortex.positions.row(static_cast<int>(i)) = h.white.V.row(cortex.vertices[i]);
  cortex.values = VectorXd::Zero(static_cast<int>(cortex.vertices.size()));
  io::write_freesurfer_label(out + "/label/" + hemi + ".cortex.label", cortex);
  // Region names for the report, as recon-all's label/?h.aparc.annot gives them.
  io::write_freesurfer_annotation(out + "/label/" + hemi + ".aparc.annot", synthetic_parcellation(h));

  const std::vector<bool>& mask = h.left ? region.left_mask : region.right_mask;
  VectorXi lesion(h.white.num_vertices());
  for (int v = 0; v < lesion.size(); ++v) lesion(v) = mask[v] ? 1 : 0;
  io::FuncWriteOptions fo;
  fo.anatomical_structure = so.anatomical_structure;
  fo.metadata["generator"] = software;
  fo.metadata["description"] = "planted hypometabolic region (1) of the phantom patients";
  io::write_label_gifti(out + "/truth/" + hemi + ".lesion.label.gii", lesion, {{0, "healthy"}, {1, "planted_region"}}, fo);
}

// The template as an atlas folder in FreeSurfer layout (OUT/atlas: surf/?h.white, ?h.pial,
// ?h.sphere, label/?h.cortex.label); returns the atlas maps of both hemispheres, read back from
// those files as `run --atlas` reads them.
struct VariabilityTemplate {
  MatrixXd sphere;  // left template sphere (radius 100)
  VectorXd sulc;
  std::unique_ptr<Atlas> atlas[2];
};

MatrixXd mirror_x(MatrixXd P) {
  P.col(0) = -P.col(0);
  return P;
}

VariabilityTemplate write_atlas_folder(const std::string& out, const std::string& shared, const Hemisphere& left,
                                       const Hemisphere& right, const PlantedRegion& region) {
  VariabilityTemplate t;
  t.sphere = io::read_surface(shared + "/fsaverage5/sphere_left.gii.gz").mesh.V;
  t.sulc = io::read_per_vertex(shared + "/fsaverage5/sulc_left.gii.gz", left.white.num_vertices());
  for (const char* sub : {"/atlas/surf", "/atlas/label", "/atlas/truth"}) fs::create_directories(out + sub);
  write_hemisphere_files(out + "/atlas", left, region, "lh");
  write_hemisphere_files(out + "/atlas", right, region, "rh");
  io::write_surface(out + "/atlas/surf/lh.sphere", TriMesh{t.sphere, left.white.F});
  io::write_surface(out + "/atlas/surf/rh.sphere", TriMesh{mirror_x(t.sphere), right.white.F});
  for (int h = 0; h < 2; ++h) t.atlas[h] = std::make_unique<Atlas>(load_atlas(atlas_files_from_dir(out + "/atlas", h ? "rh" : "lh")));
  return t;
}

// One subject's own anatomy (both hemispheres: the right is the mirror of the left variant), its
// sphere.reg, lesion mask and the atlas map at its vertices' corresponding points.
void write_variant_subject(const std::string& dir, const Hemisphere& left, const VariabilityTemplate& t,
                           const PlantedRegion& region, const AnatomyWarp& warp) {
  for (const char* sub : {"/surf", "/label", "/truth"}) fs::create_directories(dir + sub);
  const AnatomyVariant v = anatomy_variant(left, t.sphere, t.sulc, region.left_mask, warp);
  PlantedRegion own = region;
  own.left_mask = own.right_mask = v.lesion;
  const Hemisphere hemis[2] = {v.hemisphere, mirror_hemisphere(v.hemisphere)};
  const MatrixXd reg[2] = {v.sphere_reg, mirror_x(v.sphere_reg)};
  for (int h = 0; h < 2; ++h) {
    const std::string name = h ? "rh" : "lh";
    write_hemisphere_files(dir, hemis[h], own, name);
    io::write_surface(dir + "/surf/" + name + ".sphere.reg", TriMesh{reg[h], hemis[h].white.F});
    const AtlasSquare& a = t.atlas[h]->square;
    const MatrixXd uv = interpolate_on_sphere(SpherePointLocator(a.S, a.map.F), a.map.UV, normalize_to_unit_sphere(reg[h], "sphere.reg"));
    io::FuncWriteOptions fo;
    fo.column_names = {"atlas_u", "atlas_v"};
    fo.anatomical_structure = h ? "CortexRight" : "CortexLeft";
    fo.metadata["description"] = "the atlas's authalic map (unit square) at each vertex's corresponding atlas point";
    io::write_per_vertex(dir + "/truth/" + name + ".atlas_uv.func.gii", uv, fo);
  }
}

// A subject's PET with its own anatomy: the variant's files written (write_variant_subject), the
// healthy template and the lesion (empty: none) carried by its warp, then its effects.
io::Volume variant_subject_pet(const std::string& dir, const Hemisphere& left, const VariabilityTemplate& t,
                               const PlantedRegion& region, const PhantomOptions& options, PhantomRng& rng,
                               const io::Volume& healthy, const SubjectEffects& effects, const std::vector<float>& lesion,
                               double reference) {
  const AnatomyWarp warp = draw_anatomy_warp(rng, options.area_change, options.deformation_wavelength_mm, options.fold_change);
  write_variant_subject(dir, left, t, region, warp);
  io::Volume column = healthy;
  column.data = lesion;
  return subject_pet(deform_volume(healthy, warp), effects, lesion.empty() ? lesion : deform_volume(column, warp).data,
                     reference);
}

// cohort.csv: the shared anatomy in surf/ and label/, or (variability) each subject's own with its sphere.reg.
std::string cohort_csv_text(const std::vector<PhantomSubject>& subjects, bool variability) {
  std::ostringstream csv;
  csv << "subject_id,role,age,pet,lh_white,lh_pial,rh_white,rh_pial,lh_cortex,rh_cortex"
      << (variability ? ",lh_sphere_reg,rh_sphere_reg\n" : "\n");
  for (const auto& s : subjects) {
    const std::string d = variability ? "sub-" + s.id + "/" : "";
    csv << s.id << ',' << s.role << ',' << csv_number(s.age) << ',' << s.pet << ',' << d << "surf/lh.white," << d
        << "surf/lh.pial," << d << "surf/rh.white," << d << "surf/rh.pial," << d << "label/lh.cortex.label," << d
        << "label/rh.cortex.label";
    if (variability) csv << ',' << d << "surf/lh.sphere.reg," << d << "surf/rh.sphere.reg";
    csv << '\n';
  }
  return csv.str();
}

// The phantom's template: the left hemisphere and the healthy PET, from the shared data
// (fsaverage5 + SPM's PET) when present, else synthetic. Sets result.source.
struct PhantomTemplate {
  Hemisphere left;
  io::Volume healthy;
  bool use_shared = false;
};

PhantomTemplate phantom_template(const PhantomOptions& options, const ProgressFn& progress, PhantomResult& result) {
  PhantomTemplate t;
  t.use_shared = !options.synthetic && !options.shared_dir.empty() &&
                 fs::exists(options.shared_dir + "/fsaverage5/white_left.gii.gz") && fs::exists(options.shared_dir + "/spm/PET.nii");
  report(progress, "phantom", 0.0, "anatomy");
  if (t.use_shared) {
    const std::string d = options.shared_dir;
    const io::Surface white = io::read_surface(d + "/fsaverage5/white_left.gii.gz");
    const io::Surface pial = io::read_surface(d + "/fsaverage5/pial_left.gii.gz");
    const io::Surface flat = io::read_surface(d + "/fsaverage5/flat_left.gii.gz");
    t.left.white = white.mesh;
    t.left.pial = pial.mesh;
    t.left.cortex = used_vertices(flat.mesh.F, white.mesh.num_vertices());
    t.healthy = io::read_volume(d + "/spm/PET.nii");
    // Scale the template so that its cortical level (the 90th percentile) is the reference.
    std::vector<float> finite;
    for (float v : t.healthy.data) {
      if (std::isfinite(v) && v > 0) finite.push_back(v);
    }
    if (finite.empty()) throw InputError(d + "/spm/PET.nii: no positive values; is it a PET image?");
    std::nth_element(finite.begin(), finite.begin() + finite.size() * 9 / 10, finite.end());
    const double p90 = finite[finite.size() * 9 / 10];
    for (float& v : t.healthy.data) v = std::isfinite(v) ? static_cast<float>(v / p90) : 0.0f;
    result.source = "shared: fsaverage5 white/pial_left (cortex = flat_left faces) + spm/PET.nii";
  } else {
    t.left = synthetic_left_hemisphere(options.synthetic_options);
    report(progress, "phantom", 0.02, "healthy PET model");
    t.healthy = synthetic_pet_template(t.left, options.synthetic_options, options.voxel_mm);
    result.source = "synthetic";
  }
  return t;
}

// The cohort's subjects: each one's age, effects and PET (the patients' with the planted region),
// drawn in order from the seed's stream and written to sub-<id>/.
void write_subjects(const std::string& out, const PhantomOptions& options, const PhantomTemplate& t,
                    const VariabilityTemplate& variability, const std::vector<float>& multiplier, double reference,
                    const ProgressFn& progress, PhantomResult& result) {
  std::error_code ec;
  PhantomRng anatomy_rng(options.seed ^ 0x9e3779b97f4a7c15ULL);  // its own stream: the PET draws stay as without
  PhantomRng rng(options.seed);
  const int total = options.controls + options.patients;
  for (int s = 0; s < total; ++s) {
    PhantomSubject subj;
    const bool patient = s >= options.controls;
    subj.role = patient ? "patient" : "control";
    subj.id = subj.role + two_digits(patient ? s - options.controls + 1 : s + 1);
    subj.age = std::round(10.0 * (patient ? 60.0 + 18.0 * rng.uniform() : 50.0 + 30.0 * rng.uniform())) / 10.0;
    subj.effects = draw_subject_effects(rng);
    subj.pet = "sub-" + subj.id + "/sub-" + subj.id + "_pet.nii.gz";
    report(progress, "phantom", 0.05 + 0.95 * s / total, subj.id);
    fs::create_directories(out + "/sub-" + subj.id, ec);
    const std::vector<float> lesion = patient ? multiplier : std::vector<float>{};
    const io::Volume pet = options.anatomical_variability
                               ? variant_subject_pet(out + "/sub-" + subj.id, t.left, variability, result.region, options,
                                                     anatomy_rng, t.healthy, subj.effects, lesion, reference)
                               : subject_pet(t.healthy, subj.effects, lesion, reference);
    if (ec) throw InputError(out + "/sub-" + subj.id + ": cannot create the folder (" + ec.message() + ")");
    io::write_nifti(out + "/" + subj.pet, pet,
                    "authalic phantom " + subj.role + (patient ? " (planted -" + csv_number(100 * options.region_depth) + "%)" : ""));
    result.subjects.push_back(subj);
  }
}

// truth/lesion.json: where the planted region is and how it was planted.
nlohmann::json lesion_json(const PhantomResult& result, const Hemisphere& left) {
  const auto& region = result.region;
  int region_vertices = 0;
  for (bool b : region.left_mask) region_vertices += b;
  return {
      {"description", "planted hypometabolic region of the patients: PET multiplied by (1 - depth) in every voxel within "
                      "column_depth_mm of the cortical surface whose nearest white/pial vertex is in the region, and in "
                      "every voxel within 3 mm of a region vertex's inward normal segment (pial + 2 mm to pial - 20 mm); "
                      "both hemispheres (the right is the mirror of the left, same vertex indices)"},
      {"depth_fraction", region.depth},
      {"column_depth_mm", kRegionColumnDepthMm},
      {"radius_mm", region.radius_mm},
      {"radius_definition", "shortest path along the white surface's edges through cortex vertices"},
      {"centre_vertex", region.centre_vertex},
      {"centre_ras_mm",
       {left.white.V(region.centre_vertex, 0), left.white.V(region.centre_vertex, 1), left.white.V(region.centre_vertex, 2)}},
      {"num_vertices_per_hemisphere", region_vertices},
      {"area_mm2_white_per_hemisphere", result.region_area_mm2},
      {"masks", {{"lh", "truth/lh.lesion.label.gii"}, {"rh", "truth/rh.lesion.label.gii"}}},
  };
}

// phantom.json: the generator record (seed, model, and each subject's drawn effects).
nlohmann::json phantom_record_json(const PhantomOptions& options, const PhantomResult& result, const PhantomTemplate& t,
                                   double reference, const nlohmann::json& lesion) {
  nlohmann::json subjects = nlohmann::json::array();
  for (const auto& s : result.subjects) {
    const auto& e = s.effects;
    subjects.push_back({{"id", s.id},
                        {"role", s.role},
                        {"age", s.age},
                        {"pet", s.pet},
                        {"global_scale", e.global_scale},
                        {"field_amplitude", e.field_amplitude},
                        {"field_wave_rad_per_mm", {e.field_wave[0], e.field_wave[1], e.field_wave[2]}},
                        {"field_phase_rad", e.field_phase},
                        {"parcel_amplitude", e.parcel_amplitude},
                        {"parcel_mm", e.parcel_mm},
                        {"noise_fraction", e.noise_fraction},
                        {"fwhm_mm", e.fwhm_mm}});
  }
  return {
      {"generator", std::string("authalic phantom ") + kVersion},
      {"seed", options.seed},
      {"source", result.source},
      {"anatomical_variability", options.anatomical_variability
                                     ? nlohmann::json{{"area_change", options.area_change},
                                                    {"deformation_wavelength_mm", options.deformation_wavelength_mm},
                                                    {"fold_change", options.fold_change},
                                                      {"model", "analysis/phantom_anatomy.h: sphere warp (sphere.reg = exact "
                                                                "correspondence), folding change, 3D deformation carrying "
                                                                "the anatomy, PET and lesion; atlas = the template (atlas/)"}}
                                     : nlohmann::json(false)},
      {"controls", options.controls},
      {"patients", options.patients},
      {"pet_units", "Bq/mL"},
      {"grey_matter_reference_bq_per_ml", reference},
      {"voxel_mm", t.use_shared ? t.healthy.voxel_size().x() : options.voxel_mm},
      {"model", "PET = healthy x global_scale x (1 + field_amplitude cos(k.x + phase)) x (1 + parcel_amplitude U(-1,1) "
                "per parcel_mm cube) x lesion, + noise "
                "(SD = noise_fraction sqrt(value x reference)), then Gaussian blur (fwhm_mm); rounded to 1 Bq/mL; 0 outside the head"},
      {"coordinates", "scanner RAS mm; FreeSurfer surfaces with c_ras = 0 (tkregister RAS = scanner RAS)"},
      {"lesion", lesion},
      {"subjects", subjects},
  };
}

}  // namespace

PhantomResult write_phantom(const std::string& out_dir, const PhantomOptions& options, const ProgressFn& progress) {
  if (options.controls < 0 || options.patients < 0 || options.controls + options.patients == 0) {
    throw InputError("phantom: need at least one subject (--controls N, --patients N, N >= 0)");
  }
  if (options.controls > 2000 || options.patients > 2000) throw InputError("phantom: at most 2000 controls and 2000 patients");
  const std::string out = fs::absolute(out_dir).lexically_normal().string();
  std::error_code ec;
  for (const char* sub : {"", "/surf", "/label", "/truth"}) {
    fs::create_directories(out + sub, ec);
    if (ec) throw InputError(out + sub + ": cannot create the folder (" + ec.message() + "); choose a writable OUT_DIR");
  }

  // Anatomy and healthy PET.
  PhantomResult result;
  const double reference = 8000.0;  // Bq/mL of grey matter in the synthetic model
  const PhantomTemplate t = phantom_template(options, progress, result);
  const Hemisphere& left = t.left;
  const Hemisphere right = mirror_hemisphere(left);
  result.region = plant_region(left, default_region_target(!t.use_shared, options.synthetic_options), options.region_radius_mm,
                               options.region_depth);
  {
    const VectorXd areas = barycentric_vertex_areas(left.white.V, left.white.F);
    for (int v = 0; v < areas.size(); ++v) result.region_area_mm2 += result.region.left_mask[v] ? areas(v) : 0.0;
  }
  report(progress, "phantom", 0.05, "planted region");
  const std::vector<float> multiplier = region_multiplier(t.healthy, left, right, result.region);

  write_hemisphere_files(out, left, result.region, "lh");
  write_hemisphere_files(out, right, result.region, "rh");
  VariabilityTemplate variability;
  if (options.anatomical_variability) {
    if (!t.use_shared)
      throw InputError("phantom --anatomical-variability: needs the fsaverage5 template and spm/PET.nii of --shared "
                       "(../shared/data); give --shared DIR");
    report(progress, "phantom", 0.06, "atlas (the template) and its maps");
    variability = write_atlas_folder(out, options.shared_dir, left, right, result.region);
  }
  write_subjects(out, options, t, variability, multiplier, reference, progress, result);

  // Cohort table, region description, generator record.
  std::ostringstream csv;
  csv << cohort_csv_text(result.subjects, options.anatomical_variability);
  result.cohort_csv = out + "/cohort.csv";
  io::write_file_atomically(result.cohort_csv, csv.str());
  const nlohmann::json lesion = lesion_json(result, left);
  io::write_file_atomically(out + "/truth/lesion.json", lesion.dump(2) + "\n");
  const nlohmann::json record = phantom_record_json(options, result, t, reference, lesion);
  io::write_file_atomically(out + "/phantom.json", record.dump(2) + "\n");
  report(progress, "phantom", 1.0, std::to_string(options.controls + options.patients) + " subjects");
  return result;
}

}  // namespace authalic::analysis
