#pragma once
// Connectome Workbench spec files (.spec, CaretSpecFile XML 1.0): the list of data files that
// wb_view opens together. Paths are written as given, relative to the spec file's folder.
#include <string>
#include <vector>

namespace authalic::io {

struct SpecEntry {
  std::string structure;  // Workbench structure: "CortexLeft", "CortexRight", "Invalid" (volumes)
  std::string type;       // DataFileType: "SURFACE", "METRIC", "LABEL", "VOLUME", ...
  std::string file;       // path relative to the spec file's folder
};

// The spec document for `entries`, in order (a surface before the per-vertex files on it).
std::string workbench_spec_xml(const std::vector<SpecEntry>& entries);
// Writes it atomically.
void write_workbench_spec(const std::string& path, const std::vector<SpecEntry>& entries);

}  // namespace authalic::io
