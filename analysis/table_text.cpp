#include "analysis/table_text.h"

#include <charconv>
#include <cmath>
#include <fstream>
#include <sstream>

#include "core/error.h"

namespace authalic::analysis {

void append_number(std::string& out, double x) {
  if (std::isnan(x)) {
    out += "nan";
    return;
  }
  if (std::isinf(x)) {
    out += x > 0 ? "inf" : "-inf";
    return;
  }
  char buf[32];
  const auto r = std::to_chars(buf, buf + sizeof buf, x);
  out.append(buf, r.ptr);
}

bool read_text_file(const std::string& path, std::string& text) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return false;
  in.seekg(0, std::ios::end);
  const std::streamoff size = in.tellg();
  if (size < 0) return false;
  in.seekg(0, std::ios::beg);
  text.resize(static_cast<std::size_t>(size));
  if (size > 0 && !in.read(text.data(), size)) return false;
  return true;
}

std::string short_json_error(const std::string& what) {
  std::string s = what.substr(0, what.find("; last read:"));
  if (s.size() > 300) s = s.substr(0, 297) + "...";
  return s;
}

CsvCursor::CsvCursor(std::string_view text, std::string path, char delimiter)
    : text_(text), path_(std::move(path)), delimiter_(delimiter) {
  if (text_.substr(0, 3) == "\xEF\xBB\xBF") next_ = 3;  // UTF-8 byte-order mark (spreadsheets)
}

void CsvCursor::load_line() {
  pos_ = next_;
  std::size_t nl = text_.find('\n', pos_);
  if (nl == std::string_view::npos) nl = text_.size();
  next_ = nl < text_.size() ? nl + 1 : nl;
  line_end_ = nl;
  if (line_end_ > pos_ && text_[line_end_ - 1] == '\r') --line_end_;
  at_end_of_fields_ = false;
  ++line_;
}

void CsvCursor::expect_header(std::string_view header) {
  if (next_ >= text_.size()) fail("the file is empty; expected the header '" + std::string(header) + "'");
  load_line();
  const std::string_view got = text_.substr(pos_, line_end_ - pos_);
  if (got != header)
    fail("unexpected header '" + std::string(got.substr(0, 200)) + "'; expected '" + std::string(header) + "'");
}

bool CsvCursor::next_line() {
  while (next_ < text_.size()) {
    load_line();
    if (line_end_ > pos_) return true;
  }
  return false;
}

std::string_view CsvCursor::field() {
  if (at_end_of_fields_) fail("too few fields");
  const std::size_t comma = text_.find(delimiter_, pos_);
  std::size_t end = (comma == std::string_view::npos || comma > line_end_) ? line_end_ : comma;
  const std::string_view f = text_.substr(pos_, end - pos_);
  if (end == line_end_) {
    at_end_of_fields_ = true;
    pos_ = line_end_;
  } else {
    pos_ = end + 1;
  }
  return f;
}

int CsvCursor::integer() {
  const std::string_view f = field();
  int v = 0;
  const auto r = std::from_chars(f.data(), f.data() + f.size(), v);
  if (r.ec != std::errc() || r.ptr != f.data() + f.size()) fail("'" + std::string(f) + "' is not an integer");
  return v;
}

double CsvCursor::number() {
  const std::string_view f = field();
  if (f.empty()) return std::nan("");
  double v = 0;
  const auto r = std::from_chars(f.data(), f.data() + f.size(), v);
  if (r.ec != std::errc() || r.ptr != f.data() + f.size()) fail("'" + std::string(f) + "' is not a number");
  return v;
}

void CsvCursor::skip() { field(); }

void CsvCursor::end_line() {
  if (!at_end_of_fields_) fail("too many fields");
}

void CsvCursor::fail(const std::string& problem) const {
  throw InputError(path_ + ":" + std::to_string(line_) + ": " + problem + "; the table is corrupt or not an authalic table");
}

}  // namespace authalic::analysis
