#pragma once
// A plausible Desikan-Killiany-style parcellation of a synthetic hemisphere (the sample's
// phantom, analysis/phantom.h), so the sample's report can name regions as it does for a
// FreeSurfer subject. Not an atlas: each cortex vertex takes the nearest of fixed seed points
// placed where the Desikan regions lie on a real hemisphere, in coordinates normalised to the
// hemisphere's bounding box (anterior-posterior a, inferior-superior s), seeds on the lateral or
// medial face (or both) matching the vertex's face. Medial-wall vertices are "unknown".
#include "analysis/phantom.h"
#include "io/freesurfer_annot.h"

namespace authalic::analysis {

io::Annotation synthetic_parcellation(const Hemisphere& hemisphere);

}  // namespace authalic::analysis
