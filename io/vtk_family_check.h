#pragma once
// Checks run on the bytes of a VTK-family surface file before VTK's readers see it (issue 17).
// VTK 9.1's readers trust the counts in a header: a truncated PLY crashes vtkPLYReader, huge
// counts allocate gigabytes or loop for minutes, and the OBJ reader turns "nan" or "abc" into 0.
// Every function throws an InputError naming `path` for input VTK would crash on or misread.
#include <cstddef>
#include <string>
#include <string_view>

namespace authalic::io::detail {

// Largest declared vertex and face counts accepted in any VTK-family file (cortical surfaces
// have < 1M). The fuzz targets lower them to stay below libFuzzer's memory limit.
extern std::size_t g_max_vtk_vertices;
extern std::size_t g_max_vtk_faces;

// Tokens of the text formats (these checks and io/mni_obj_io.cpp): a whole token as a double
// (strtod must consume all of it); the same, finite and within +-1e30; a whole token as an
// integer (a leading '+' allowed); a token quoted for a message (cut after 40 characters).
bool parse_number(std::string_view tok, double& out);
bool parse_finite(std::string_view tok, double& out);
bool parse_integer(std::string_view tok, long long& out);
std::string quoted(std::string_view tok);

// PLY header and body layout: element counts against the file size, then one walk over the
// body (binary: every list length; ASCII: one line per element with numbers only; faces: at
// least 3 corners, each an existing vertex).
void check_ply(const std::string& bytes, const std::string& path);
// OBJ: every v/vt/vn line holds finite numbers, every f/l/p index points at a declared vertex.
void check_obj(const std::string& bytes, const std::string& path);
// A checked OBJ's geometry only: its v lines and its f lines with each corner's vertex index
// (texture and normal indices, vt/vn lines and everything else dropped). vtkOBJReader gives a
// face corner with its own normal or texture coordinate a point of its own: an OBJ with one
// normal per face came out as a triangle soup, its vertex numbering lost.
std::string obj_geometry_only(const std::string& bytes);
// STL: binary files are exactly 84 + 50 n bytes; ASCII vertex lines hold three finite numbers.
void check_stl(const std::string& bytes, const std::string& path);
// VTK XML PolyData: the Piece counts are bounded (and fit the file when not compressed), arrays
// have 1 to 16 components (Points exactly 3), and every block header in front of array data
// declares sizes that fit the data.
void check_vtp(const std::string& bytes, const std::string& path);
// Legacy VTK POLYDATA: walks the geometry sections and returns a copy holding only the header,
// POINTS, POLYGONS and TRIANGLE_STRIPS (attributes, FIELD and METADATA blocks dropped: they are
// not used and their declared sizes would need their own checks).
std::string sanitize_legacy_vtk(const std::string& bytes, const std::string& path);

}  // namespace authalic::io::detail
