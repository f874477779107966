#include "io/workbench_spec.h"

#include "io/atomic_file.h"
#include "io/markup_escape.h"

namespace authalic::io {

std::string workbench_spec_xml(const std::vector<SpecEntry>& entries) {
  // The layout wb_command -add-to-spec-file writes: one DataFile element per file, the path as
  // its text, Selected so that wb_view loads it.
  std::string xml = "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<CaretSpecFile Version=\"1.0\">\n  <MetaData>\n  </MetaData>\n";
  for (const SpecEntry& e : entries)
    xml += "  <DataFile Structure=\"" + markup_escape(e.structure) + "\" DataFileType=\"" + markup_escape(e.type) +
           "\" Selected=\"true\">\n    " + markup_escape(e.file) + "\n  </DataFile>\n";
  xml += "</CaretSpecFile>\n";
  return xml;
}

void write_workbench_spec(const std::string& path, const std::vector<SpecEntry>& entries) {
  write_file_atomically(path, workbench_spec_xml(entries));
}

}  // namespace authalic::io
