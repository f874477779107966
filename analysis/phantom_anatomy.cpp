// Phantom subjects with anatomical variability (see analysis/phantom_anatomy.h).
#include "analysis/phantom_anatomy.h"

#include <algorithm>
#include <cmath>

#include "core/atlas_map.h"

namespace authalic::analysis {

namespace {

constexpr double kDeg = M_PI / 180.0;
constexpr double kMidlineTaperMm = 8.0;

Eigen::Vector3d random_unit(PhantomRng& rng) {
  Eigen::Vector3d u(rng.normal(), rng.normal(), rng.normal());
  return u.normalized();
}

// The left-hemisphere field d_L(x); d_x tapers to 0 at the midline so the mirrored field is continuous.
Eigen::Vector3d left_displacement(const AnatomyWarp& w, const Eigen::Vector3d& x) {
  Eigen::Vector3d d = Eigen::Vector3d::Zero();
  for (int k = 0; k < 3; ++k) d += w.wave_amplitude[k] * std::sin(w.wave[k].dot(x) + w.wave_phase[k]) * w.wave_direction[k];
  d.x() *= std::tanh(std::max(0.0, -x.x()) / kMidlineTaperMm);
  return d;
}

// d(x): d_L on the left (x < 0), its mirror image on the right.
Eigen::Vector3d displacement(const AnatomyWarp& w, const Eigen::Vector3d& x) {
  if (x.x() <= 0) return left_displacement(w, x);
  Eigen::Vector3d d = left_displacement(w, Eigen::Vector3d(-x.x(), x.y(), x.z()));
  d.x() = -d.x();
  return d;
}

float trilinear(const io::Volume& v, const Eigen::Vector3d& ijk) {
  int i0[3];
  double t[3];
  for (int a = 0; a < 3; ++a) {
    const double c = std::clamp(ijk[a], 0.0, static_cast<double>(v.dims[a] - 1));
    i0[a] = std::min(static_cast<int>(std::floor(c)), std::max(v.dims[a] - 2, 0));
    t[a] = v.dims[a] > 1 ? c - i0[a] : 0.0;
  }
  double out = 0;
  for (int c = 0; c < 8; ++c) {
    const int di = c & 1, dj = (c >> 1) & 1, dk = (c >> 2) & 1;
    const double wgt = (di ? t[0] : 1 - t[0]) * (dj ? t[1] : 1 - t[1]) * (dk ? t[2] : 1 - t[2]);
    if (wgt == 0) continue;
    out += wgt * v.at(std::min(i0[0] + di, v.dims[0] - 1), std::min(i0[1] + dj, v.dims[1] - 1), std::min(i0[2] + dk, v.dims[2] - 1));
  }
  return static_cast<float>(out);
}

}  // namespace

AnatomyWarp draw_anatomy_warp(PhantomRng& rng, double area_change, double wavelength_mm, double fold_change) {
  AnatomyWarp w;
  w.rotation = Eigen::AngleAxisd(4.0 * kDeg * rng.normal(), random_unit(rng)).toRotationMatrix();
  for (int k = 0; k < 4; ++k) {
    w.bump_centre[k] = random_unit(rng);
    w.bump_axis[k] = random_unit(rng);
    w.bump_angle[k] = 3.0 * kDeg * rng.normal();
  }
  // One wave of amplitude a and wavenumber |k| stretches by up to a |k| along its direction; three
  // of them with a |k| = area_change / 2 change local surface area by up to about ± area_change.
  const double kk = 2 * M_PI / wavelength_mm;
  for (int k = 0; k < 3; ++k) {
    w.wave[k] = kk * random_unit(rng);
    w.wave_direction[k] = random_unit(rng);
    w.wave_amplitude[k] = (0.5 + 0.5 * rng.uniform()) * area_change / kk;
    w.wave_phase[k] = 2 * M_PI * rng.uniform();
  }
  w.fold_wave = kk * random_unit(rng);
  w.fold_amplitude = fold_change * (0.5 + 0.5 * rng.uniform());
  w.fold_phase = 2 * M_PI * rng.uniform();
  return w;
}

Eigen::Vector3d warp_sphere(const AnatomyWarp& w, const Eigen::Vector3d& s_in) {
  const Eigen::Vector3d s = w.rotation * s_in.normalized();
  Eigen::Vector3d out = s;
  for (int k = 0; k < 4; ++k) {
    const double g = std::exp(-(s - w.bump_centre[k]).squaredNorm() / (2 * w.bump_width * w.bump_width));
    out += w.bump_angle[k] * g * w.bump_axis[k].cross(s);  // a small rotation about the bump's axis
  }
  return out.normalized();
}

Eigen::Vector3d deform(const AnatomyWarp& w, const Eigen::Vector3d& x) { return x + displacement(w, x); }

Eigen::Vector3d undeform(const AnatomyWarp& w, const Eigen::Vector3d& y) {
  Eigen::Vector3d x = y;  // x = y - d(x): a contraction, since |∇d| < 1 (about 0.5 at most)
  for (int it = 0; it < 40; ++it) x = y - displacement(w, x);
  return x;
}

AnatomyVariant anatomy_variant(const Hemisphere& templ, const MatrixXd& template_sphere, const VectorXd& sulc,
                               const std::vector<bool>& lesion, const AnatomyWarp& warp) {
  const MatrixXd S = normalize_to_unit_sphere(template_sphere, "template sphere");
  const Eigen::Index n = S.rows();
  MatrixXd Q(n, 3);
  for (Eigen::Index v = 0; v < n; ++v) Q.row(v) = warp_sphere(warp, S.row(v).transpose()).transpose();
  // The template's anatomy (white, pial, sulcal depth, lesion, cortex) at φ(s_v).
  MatrixXd values(n, 8);
  values << templ.white.V, templ.pial.V, sulc, VectorXd::Zero(n);
  for (Eigen::Index v = 0; v < n; ++v) values(v, 7) = lesion[static_cast<std::size_t>(v)] ? 1.0 : 0.0;
  const MatrixXd at = interpolate_on_sphere(SpherePointLocator(S, templ.white.F), values, Q);
  MatrixXi cortex_faces(templ.white.F.rows(), 3);
  Eigen::Index nc = 0;
  for (Eigen::Index f = 0; f < templ.white.F.rows(); ++f)
    if (templ.cortex[templ.white.F(f, 0)] && templ.cortex[templ.white.F(f, 1)] && templ.cortex[templ.white.F(f, 2)])
      cortex_faces.row(nc++) = templ.white.F.row(f);
  std::vector<char> inside;
  interpolate_on_sphere(SpherePointLocator(S, cortex_faces.topRows(nc)), S, Q, &inside);

  AnatomyVariant out;
  Hemisphere& h = out.hemisphere;
  h.left = templ.left;
  h.white = {at.leftCols(3), templ.white.F};
  h.pial = {at.middleCols(3, 3), templ.pial.F};
  // Folding change along the white surface's normal, the same offset for white and pial.
  const MatrixXd N = vertex_normals(h.white.V, h.white.F);
  for (Eigen::Index v = 0; v < n; ++v) {
    const Eigen::Vector3d x = h.white.V.row(v).transpose();
    const double f = warp.fold_amplitude * std::sin(warp.fold_wave.dot(x) + warp.fold_phase);
    const Eigen::Vector3d offset = f * at(v, 6) * N.row(v).transpose();
    h.white.V.row(v) = deform(warp, x + offset).transpose();
    h.pial.V.row(v) = deform(warp, h.pial.V.row(v).transpose() + offset).transpose();
  }
  h.cortex.assign(inside.begin(), inside.end());
  out.sphere_reg = 100.0 * Q;
  out.lesion.resize(static_cast<std::size_t>(n));
  for (Eigen::Index v = 0; v < n; ++v) out.lesion[static_cast<std::size_t>(v)] = inside[static_cast<std::size_t>(v)] && at(v, 7) >= 0.5;
  return out;
}

io::Volume deform_volume(const io::Volume& in, const AnatomyWarp& warp) {
  io::Volume out = in;
  const Eigen::Matrix4d ras2vox = in.vox2ras.inverse();
#pragma omp parallel for schedule(static)
  for (int k = 0; k < in.dims[2]; ++k)
    for (int j = 0; j < in.dims[1]; ++j)
      for (int i = 0; i < in.dims[0]; ++i) {
        const Eigen::Vector3d y = (in.vox2ras * Eigen::Vector4d(i, j, k, 1.0)).head<3>();
        const Eigen::Vector3d ijk = (ras2vox * undeform(warp, y).homogeneous()).head<3>();
        out.data[static_cast<std::size_t>(i) + static_cast<std::size_t>(in.dims[0]) * (j + static_cast<std::size_t>(in.dims[1]) * k)] =
            trilinear(in, ijk);
      }
  return out;
}

}  // namespace authalic::analysis
