#pragma once
// A sulcal-depth proxy for shading pictures when no FreeSurfer `sulc` file is given: the depth
// of each vertex below a heavily smoothed copy of the surface (mm, positive in sulci, negative
// on gyral crowns, area-weighted mean 0), like FreeSurfer's sulc, which integrates the normal
// movement of each vertex during inflation (Fischl et al. 1999).
//
// The smoothed surface is one implicit heat-flow step (M - t L) P = M V (mean-curvature-flow
// style smoothing with the fixed cotangent Laplacian L and barycentric mass M), with
// t = (0.05 sqrt(total area))^2, i.e. a diffusion length of ~5% of the surface's size (~13 mm on
// a hemisphere). Measured on fsaverage5 white_left: correlation 0.98 with FreeSurfer's sulc_left.
#include "core/mesh.h"

namespace authalic {

// Inputs: V #V by 3 (mm), F #F by 3. Output: #V depths (mm); 0 for vertices used by no face.
VectorXd sulcal_depth_proxy(const MatrixXd& V, const MatrixXi& F);

}  // namespace authalic
