#pragma once
// Phantom subjects with anatomical variability (issue 14): smooth random diffeomorphic variants of
// a template hemisphere (fsaverage5) whose vertex correspondence with the template is known exactly,
// so element correspondence across subjects can be measured against a ground truth.
//
// A variant is made of three smooth random maps, drawn once per subject:
//  - a sphere warp φ (a small global rotation and four Gaussian bumps of local rotation about
//    random axes, width 0.5 rad on the unit sphere): variant vertex v carries the template anatomy
//    found at φ(s_v), s_v the template sphere position of vertex v. Its sphere.reg is φ(s_v): the
//    registration is exact but not the identity (the variant's vertices sit elsewhere in the
//    anatomy than the template's);
//  - a folding change: the surface moves along its normal by f(x) x sulcal depth, f a smooth random
//    field (sulci deepened in some places, flattened in others);
//  - a 3D deformation D(x) = x + d(x), d a sum of three plane waves (wavelength 120 mm default) scaled so
//    local surface area changes by up to about ±15 %. D is mirror symmetric (the right hemisphere is
//    the mirror of the left; d_x tapers to 0 at the midline), and the subject's PET is the template's
//    PET carried by the same D (sampled at D⁻¹(y), by fixed-point iteration).
#include <cstdint>

#include "analysis/phantom.h"
#include "io/volume_io.h"

namespace authalic::analysis {

struct AnatomyWarp {
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();  // global part of φ
  Eigen::Vector3d bump_centre[4], bump_axis[4];
  double bump_angle[4] = {0, 0, 0, 0};                      // rad, at the bump centre
  double bump_width = 0.5;                                  // rad
  Eigen::Vector3d wave[3], wave_direction[3];               // d: sum a sin(k.x + phase) u
  double wave_amplitude[3] = {0, 0, 0}, wave_phase[3] = {0, 0, 0};  // mm, rad
  Eigen::Vector3d fold_wave = Eigen::Vector3d::Zero();      // f(x) = fold_amplitude sin(k.x + phase)
  double fold_amplitude = 0, fold_phase = 0;
};

// Random warp: rotation angle N(0, 4°), bump angles N(0, 3°), waves of the given wavelength with
// amplitudes chosen so that |∇d| ~ area_change, fold amplitude U(0.5, 1) x fold_change.
// An exactly authalic map has to move a vertex by about area_change x wavelength / 2π to absorb
// such an area change, so the wavelength sets how far elements must move between subjects.
AnatomyWarp draw_anatomy_warp(PhantomRng& rng, double area_change = 0.15, double wavelength_mm = 120.0,
                              double fold_change = 0.12);

// φ(s) on the unit sphere.
Eigen::Vector3d warp_sphere(const AnatomyWarp& w, const Eigen::Vector3d& s);
// D(x) and its inverse (RAS mm, both hemispheres).
Eigen::Vector3d deform(const AnatomyWarp& w, const Eigen::Vector3d& x);
Eigen::Vector3d undeform(const AnatomyWarp& w, const Eigen::Vector3d& y);

struct AnatomyVariant {
  Hemisphere hemisphere;        // white, pial (same faces as the template), cortex mask
  MatrixXd sphere_reg;          // #V x 3, radius 100 (FreeSurfer's)
  std::vector<bool> lesion;     // the template's lesion mask carried over (at φ(s_v))
};

// The variant of the template (left) hemisphere. template_sphere: #V x 3 (any radius), sulc: #V
// (mm, FreeSurfer sign: positive in sulci), lesion: the template's per-vertex lesion mask.
AnatomyVariant anatomy_variant(const Hemisphere& templ, const MatrixXd& template_sphere, const VectorXd& sulc,
                               const std::vector<bool>& lesion, const AnatomyWarp& warp);

// A volume carried by D: out(y) = in(D⁻¹(y)), trilinear (edge voxels clamped), same grid.
io::Volume deform_volume(const io::Volume& in, const AnatomyWarp& warp);

}  // namespace authalic::analysis
