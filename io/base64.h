#pragma once
// Base64 (RFC 4648, standard alphabet, '=' padding): the report's embedded pictures and the VTK
// XML reader's inline data arrays.
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

namespace authalic::io {

// Value 0..63 of a base64 digit, -1 for any other character ('=' included).
int base64_digit(char c);

std::string base64_encode(const std::vector<std::uint8_t>& bytes);
// Strict: the length must be a multiple of 4, padding only at the end; throws
// std::invalid_argument otherwise.
std::vector<std::uint8_t> base64_decode(const std::string& text);
// Lenient prefix decoder: decodes from the start of `text` until the first non-digit ('=' or
// any other) or until `want` bytes are out; returns the number of bytes written to `out`.
std::size_t base64_prefix(std::string_view text, unsigned char* out, std::size_t want);

}  // namespace authalic::io
