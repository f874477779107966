#pragma once
// Text for XML and HTML documents (the report, Workbench spec files): & < > " ' as entities.
#include <string>

namespace authalic::io {

std::string markup_escape(const std::string& text);

}  // namespace authalic::io
