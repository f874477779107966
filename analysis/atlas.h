#pragma once
// Atlas correspondence inputs (issue 14): which atlas a map is made in, read from files, its
// authalic square map computed once (core/atlas_map.h), and the identity recorded in every output
// so that maps (and the normative references built from them) of different modes or atlases are
// never compared.
//
// An atlas hemisphere is: its white surface (mm), its sphere (FreeSurfer ?h.sphere, any radius:
// sphere.reg and the atlas sphere are compared on the unit sphere) and its cortex region (a label or
// a surface on the same vertices whose faces are the cortex, analysis/cortex_region.h).
#include <string>

#include "analysis/elements.h"
#include "core/atlas_map.h"
#include "core/progress.h"

namespace authalic::analysis {

struct AtlasFiles {
  std::string white, sphere, cortex;
};

// A FreeSurfer-layout atlas folder (e.g. $FREESURFER_HOME/subjects/fsaverage): surf/<h>.white,
// surf/<h>.sphere, label/<h>.cortex.label, h "lh" or "rh". Throws InputError naming the missing file.
AtlasFiles atlas_files_from_dir(const std::string& dir, const std::string& hemi);

// The correspondence mode of a map, as recorded in sidecars, element tables and references:
// kPerSubjectCorrespondence or "atlas <identity>", identity = the first 16 hex digits of the SHA-256 of the
// three atlas files' SHA-256s (the same atlas files give the same identity wherever they lie).
std::string atlas_identity(const AtlasFiles& files);
std::string atlas_mode(const AtlasFiles& files);
// Registration mode (no sphere.reg: the subject's own map aligned to the atlas's by an
// area-preserving deformation, core/atlas_map.h square_map_registered): "registration <identity>".
std::string registration_mode(const AtlasFiles& files);

struct Atlas {
  AtlasFiles files;
  std::string identity;  // atlas_identity(files)
  AtlasSquare square;    // its authalic map with sphere positions
  std::string note;      // the cortex label's clean-up, if any
};

// Reads the atlas and computes its authalic square map (fsaverage5: < 1 s; fsaverage: ~ 30 s, so
// `run` computes it once per hemisphere). Throws InputError naming the file.
Atlas load_atlas(const AtlasFiles& files, const ProgressFn& progress = {});

// Correspondence check (issue 14 benchmark): the share of a subject's cortical area (barycentric
// vertex areas of V, F) whose vertices fall into the same element of a K x K grid as the atlas point
// they correspond to. UV: the subject's map (#V x 2, unit square); atlas_UV_at: the atlas map
// evaluated at each vertex's corresponding atlas point (#V x 2). *median_shift (optional): the
// area-weighted median |UV - atlas_UV_at| in elements.
double same_element_share(const MatrixXd& UV, const MatrixXd& atlas_UV_at, const MatrixXd& V, const MatrixXi& F, int k,
                          double* median_shift = nullptr);

}  // namespace authalic::analysis
