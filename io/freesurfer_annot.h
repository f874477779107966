#pragma once
// FreeSurfer surface annotations (`?h.aparc.annot`, `?h.aparc.a2009s.annot`, ...): one label
// per vertex plus a colour table naming the labels. Binary, big-endian (FreeSurfer's
// read_annotation.m / nibabel.freesurfer.read_annot):
//   int32 n; n x (int32 vertex, int32 value); int32 tag = 1 (a colour table follows);
//   colour table, new format: int32 version = -2, int32 max_structure, int32 len + file name,
//     int32 entries, entries x (int32 index, int32 len + name, int32 r, g, b, transparency);
//   old format: int32 entries (> 0), int32 len + file name, entries x (int32 len + name, r, g, b, t).
// A vertex's value is r + 256 g + 65536 b of its label's colour; a value matching no entry
// (FreeSurfer writes 0 or -1 for the medial wall) means "no label".
#include <array>
#include <string>
#include <vector>

#include "core/mesh.h"

namespace authalic::io {

struct Annotation {
  VectorXi label;                               // per vertex: index into names, -1 = no label
  std::vector<std::string> names;               // e.g. "precuneus"
  std::vector<std::array<int, 4>> colours;      // r, g, b, transparency (0-255)
};

// Throws InputError naming the file for anything that is not a complete annotation, and when
// `num_vertices` >= 0 does not match the file's vertex count (an annotation of another surface).
Annotation read_freesurfer_annotation(const std::string& path, int num_vertices = -1);
// Writes the new (version -2) format, as nibabel's write_annot does; atomically.
void write_freesurfer_annotation(const std::string& path, const Annotation& annotation);

}  // namespace authalic::io
