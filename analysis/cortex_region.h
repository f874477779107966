#pragma once
// The cortex region of a hemisphere as faces of its white surface, read from a region file of
// either kind (io::read_region_file tells them apart by content):
//  - a face set (a surface on the same vertices whose triangles are the cortex, e.g. FreeSurfer's
//    flat patch as GIFTI) is taken as it is and must be one disk;
//  - a label or mask (vertices: FreeSurfer .label, .label.gii, 0/1 .shape.gii) is turned into its
//    whole triangles and cleaned up into one disk (core/region.h: islands dropped, small holes
//    filled, pinch vertices resolved).
// Used by `run` (and so `group`) and `rectangle --lh-cortex/--rh-cortex`. Throws InputError naming
// the file when the region is not one disk or does not belong to the surface.
#include <string>

#include "core/mesh.h"

namespace authalic::analysis {

struct CortexRegion {
  MatrixXi F;        // faces of the white surface inside the region
  TopologyReport topology;  // of F: one oriented disk (core/mesh.h require_disk), for the map not to check again
  std::string note;  // a label's clean-up ("<name> cortex <file>: N label vertices, ... mm^2; ..."); empty for a face set
};

// white: the hemisphere's surface (mm); white_path, cortex_path: for messages; name: "left"/"right".
CortexRegion read_cortex_region(const TriMesh& white, const std::string& white_path, const std::string& cortex_path,
                                const std::string& name);

}  // namespace authalic::analysis
