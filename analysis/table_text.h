#pragma once
// Small, fast text helpers for the element and normative tables: shortest round-trip number
// formatting (std::to_chars) and a CSV cursor that parses numbers with std::from_chars (no locale,
// no allocation per field), so 1,000 element tables of 8,192 rows read in well under a second.
#include <string>
#include <string_view>

namespace authalic::analysis {

// Appends the shortest decimal text that reads back to exactly x; NaN as "nan", infinities as
// "inf"/"-inf".
void append_number(std::string& out, double x);
// Whole file into `text`; false when it cannot be opened or read.
bool read_text_file(const std::string& path, std::string& text);
// A JSON library error for a one-line message: its "; last read: '...'" tail dropped (in a
// truncated file it quotes the whole unfinished token, kilobytes of a reference's base64) and the
// rest cut at 300 characters.
std::string short_json_error(const std::string& what);

// Reads a delimited table (comma-separated by default, tab-separated with delimiter '\t') with a
// header line, field by field. Errors throw InputError "<path>:<line>: <problem>".
class CsvCursor {
 public:
  CsvCursor(std::string_view text, std::string path, char delimiter = ',');
  // Checks the header line (exact match after trimming a trailing '\r' and a UTF-8 BOM).
  void expect_header(std::string_view header);
  // Moves to the next non-empty line; false at the end of the text.
  bool next_line();
  std::string_view field();   // the next field as text
  int integer();
  double number();            // accepts "nan", "inf", "-inf" and an empty field (NaN)
  void skip();                // skips the next field (it must exist)
  void end_line();            // checks that the line has no more fields
  [[noreturn]] void fail(const std::string& problem) const;
  int line_number() const { return line_; }

 private:
  std::string_view text_;
  std::string path_;
  char delimiter_ = ',';
  std::size_t pos_ = 0;       // start of the unread part of the current line
  std::size_t line_end_ = 0;  // end of the current line (excluding '\r\n')
  std::size_t next_ = 0;      // start of the next line
  bool at_end_of_fields_ = false;
  int line_ = 0;
  void load_line();
};

}  // namespace authalic::analysis
