// The map's target domain (see core/domain.h).
#include "core/domain.h"

#include <algorithm>
#include <sstream>

#include "core/concentric_map.h"
#include "core/error.h"

namespace authalic {

std::string to_string(DomainKind kind) {
  switch (kind) {
    case DomainKind::Square: return "square";
    case DomainKind::Rectangle: return "rectangle";
    case DomainKind::Sphere: return "sphere";
    case DomainKind::Disk: return "disk";
  }
  return "square";
}

DomainKind parse_domain_kind(const std::string& name, const std::string& what) {
  if (name == "square") return DomainKind::Square;
  if (name == "rectangle" || name == "rect") return DomainKind::Rectangle;
  if (name == "sphere") return DomainKind::Sphere;
  if (name == "disk") return DomainKind::Disk;
  throw InputError(what + ": unknown domain '" + name + "'; use square, rectangle, sphere or disk");
}

double wrap_rectangle_perimeter(double s, double width) {
  const double p = rectangle_perimeter(width);
  s = std::fmod(s, p);
  if (s < 0) s += p;
  return s;
}

int rectangle_side(double s, double w) {
  s = wrap_rectangle_perimeter(s, w);
  if (s < w) return kSideBottom;
  if (s < w + 1.0) return kSideRight;
  if (s < 2.0 * w + 1.0) return kSideTop;
  return kSideLeft;
}

Eigen::Vector2d rectangle_perimeter_point(double s, double w) {
  s = wrap_rectangle_perimeter(s, w);
  if (s < w) return {s, 0.0};
  if (s < w + 1.0) return {w, s - w};
  if (s < 2.0 * w + 1.0) return {w - (s - w - 1.0), 1.0};
  return {0.0, 1.0 - (s - 2.0 * w - 1.0)};
}

Eigen::Vector3d Domain::constrain(const Eigen::Vector3d& p) const {
  if (!planar()) {
    const double r = p.norm();
    return r > 0 ? Eigen::Vector3d(p / r) : Eigen::Vector3d(0, 0, 1);
  }
  if (kind == DomainKind::Disk) {
    const double r = std::hypot(p.x(), p.y());
    return r > 1 ? Eigen::Vector3d(p.x() / r, p.y() / r, 0.0) : Eigen::Vector3d(p.x(), p.y(), 0.0);
  }
  return {std::clamp(p.x(), 0.0, width()), std::clamp(p.y(), 0.0, 1.0), 0.0};
}

Eigen::Vector2d Domain::grid_coordinates(const double* p) const {
  if (!planar()) {
    const double r = std::sqrt(p[0] * p[0] + p[1] * p[1] + p[2] * p[2]);
    const double z = r > 0 ? p[2] / r : 0.0;
    return {(std::atan2(p[1], p[0]) + M_PI) / (2 * M_PI), (z + 1) / 2};
  }
  if (kind == DomainKind::Disk) return (concentric_disk_to_square(p[0], p[1]).array() + 1.0) / 2.0;
  return {p[0] / width(), p[1]};
}

int Domain::element_of_point(int k, const double* point) const {
  const Eigen::Vector2d uv = grid_coordinates(point);
  const int cols = element_cols(k), rows = element_rows(k);
  const int col = std::clamp(static_cast<int>(std::floor(uv.x() * cols)), 0, cols - 1);
  const int row = std::clamp(static_cast<int>(std::floor(uv.y() * rows)), 0, rows - 1);
  return row * cols + col;
}

std::vector<OverlapPiece> Domain::element_overlap(const MatrixXd& D, const MatrixXi& F, int k) const {
  if (!planar()) {
    SphereGridSpec s;
    s.sectors = element_cols(k);
    s.bands = element_rows(k);
    return sphere_grid_overlap(D, F, s);
  }
  if (kind == DomainKind::Disk) return disk_grid_overlap(D, F, element_cols(k), element_rows(k));
  GridSpec g;
  g.cols = element_cols(k);
  g.rows = element_rows(k);
  g.width = width();
  g.height = 1.0;
  return grid_overlap(D, F, g);
}

double disk_map_radius(const MatrixXd& D, const MatrixXi& F, std::string* problem) {
  double rmax = 0;
  Eigen::Vector2d lo = Eigen::Vector2d::Constant(INFINITY), hi = -lo;
  for (Eigen::Index f = 0; f < F.rows(); ++f)
    for (int c = 0; c < 3; ++c) {
      const Eigen::Vector2d p = D.row(F(f, c)).head<2>().transpose();
      rmax = std::max(rmax, p.norm()), lo = lo.cwiseMin(p), hi = hi.cwiseMax(p);
    }
  const Eigen::Vector2d centre = (lo + hi) / 2;
  problem->clear();
  if (!(rmax > 0) || !(centre.norm() <= 0.05 * rmax)) {
    std::ostringstream s;
    s << "not a disk map centred at the origin (bounding-box centre (" << centre.x() << ", " << centre.y()
      << ") for radius " << rmax << ")";
    *problem = s.str();
  }
  return rmax;
}

bool Domain::same_part(int k, int col1, int col2) const {
  if (!has_seam()) return true;
  // A column belongs to the part its centre lies in.
  const auto centre_x = [&](int c) { return (c + 0.5) * width() / element_cols(k); };
  return part_of_x(centre_x(col1)) == part_of_x(centre_x(col2));
}

}  // namespace authalic
