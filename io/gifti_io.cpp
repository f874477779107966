// GIFTI through gifticlib. gifti_io.h pulls in nifti1_io.h, so this translation unit must never
// include nifti2_io.h (measured clash, see io/CMakeLists.txt). Arrays are located by NIFTI intent
// (POINTSET 1008, TRIANGLE 1009), never by position: real files store triangles first too.
// Debian's gifti_io.h has no extern "C" guard.
extern "C" {
#include <gifti_io.h>
}
#include <Eigen/LU>
#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <memory>
#include <mutex>
#include <system_error>
#include <vector>

#include "io/atomic_file.h"
#include "io/io_internal.h"
#include "io/surface_formats.h"

namespace authalic::io::detail {

namespace {

constexpr int kIntentPointset = NIFTI_INTENT_POINTSET;  // 1008
constexpr int kIntentTriangle = NIFTI_INTENT_TRIANGLE;  // 1009

// gifticlib's XML parser reports a parse error on stderr ("** no element found at line N") even at
// verbosity 0; our own one-line error says what is wrong, so its stderr is silenced while it parses.
class QuietStderr {
 public:
  QuietStderr() : saved_(dup(2)) {
    std::fflush(stderr);
    const int devnull = open("/dev/null", O_WRONLY);
    if (saved_ >= 0 && devnull >= 0) dup2(devnull, 2);
    if (devnull >= 0) close(devnull);
  }
  ~QuietStderr() {
    std::fflush(stderr);
    if (saved_ >= 0) {
      dup2(saved_, 2);
      close(saved_);
    }
  }
  QuietStderr(const QuietStderr&) = delete;
  QuietStderr& operator=(const QuietStderr&) = delete;

 private:
  int saved_;
};

// gifticlib keeps global state (verbosity, buffers); serialise our calls into it.
std::mutex& gifti_mutex() {
  static std::mutex m;
  return m;
}

struct GiftiDeleter {
  void operator()(gifti_image* g) const { gifti_free_image(g); }
};
using GiftiPtr = std::unique_ptr<gifti_image, GiftiDeleter>;

// Element (row, col) of a 2D array of any supported type, honouring the index order.
double da_value(const giiDataArray* da, long long row, long long col, long long rows, long long cols) {
  const long long idx = da->ind_ord == GIFTI_IND_ORD_COL_MAJOR ? col * rows + row : row * cols + col;
  switch (da->datatype) {
    case NIFTI_TYPE_FLOAT32: return static_cast<const float*>(da->data)[idx];
    case NIFTI_TYPE_FLOAT64: return static_cast<const double*>(da->data)[idx];
    case NIFTI_TYPE_INT32: return static_cast<const std::int32_t*>(da->data)[idx];
    case NIFTI_TYPE_UINT8: return static_cast<const std::uint8_t*>(da->data)[idx];
    case NIFTI_TYPE_INT16: return static_cast<const std::int16_t*>(da->data)[idx];
    case NIFTI_TYPE_INT8: return static_cast<const std::int8_t*>(da->data)[idx];
    case NIFTI_TYPE_UINT16: return static_cast<const std::uint16_t*>(da->data)[idx];
    case NIFTI_TYPE_UINT32: return static_cast<const std::uint32_t*>(da->data)[idx];
    default: return std::nan("");
  }
}

bool supported_type(int t) {
  switch (t) {
    case NIFTI_TYPE_FLOAT32: case NIFTI_TYPE_FLOAT64: case NIFTI_TYPE_INT32: case NIFTI_TYPE_UINT8:
    case NIFTI_TYPE_INT16: case NIFTI_TYPE_INT8: case NIFTI_TYPE_UINT16: case NIFTI_TYPE_UINT32:
      return true;
    default:
      return false;
  }
}

// rows x cols of an array, checked against the data gifticlib actually holds.
void shape(const std::string& path, int index, const giiDataArray* da, long long* rows, long long* cols) {
  if (da->num_dim < 1 || da->num_dim > 6)
    fail(path, "data array " + std::to_string(index) + " has " + std::to_string(da->num_dim) + " dimensions", "the GIFTI file is corrupt");
  long long product = 1;
  for (int d = 0; d < da->num_dim; ++d) {
    if (da->dims[d] < 0) fail(path, "data array " + std::to_string(index) + " has a negative dimension", "the GIFTI file is corrupt");
    product *= da->dims[d];
    if (product > (1LL << 40)) fail(path, "data array " + std::to_string(index) + " is implausibly large", "the GIFTI file is corrupt");
  }
  if (!supported_type(da->datatype))
    fail(path, "data array " + std::to_string(index) + " has unsupported data type " + std::to_string(da->datatype),
         "GIFTI data types are UINT8, INT32 and FLOAT32");
  int nbyper = 0, swapsize = 0;
  gifti_datatype_sizes(da->datatype, &nbyper, &swapsize);
  if (!da->data || da->nvals != product || da->nbyper != nbyper)
    fail(path, "data array " + std::to_string(index) + " has no data or its size does not match its dimensions",
         "the GIFTI file is truncated or corrupt");
  *rows = da->dims[0];
  *cols = da->num_dim >= 2 ? product / std::max<long long>(1, da->dims[0]) : 1;
}

std::string meta_value(const giiMetaData& md, const char* name) {
  for (int i = 0; i < md.length; ++i)
    if (md.name && md.name[i] && md.value && md.value[i] && std::strcmp(md.name[i], name) == 0) return md.value[i];
  return {};
}

void copy_meta(const giiMetaData& md, std::map<std::string, std::string>* out) {
  for (int i = 0; i < md.length; ++i)
    if (md.name && md.name[i]) (*out)[md.name[i]] = (md.value && md.value[i]) ? md.value[i] : "";
}

// gifticlib allocates each array from its declared dimensions before decoding the data: check the
// declared sizes first, so a corrupt Dim0="4000000000" is a clear error, not a huge allocation.
void check_declared_sizes(const std::string& xml, const std::string& path) {
  std::size_t pos = 0;
  long long arrays = 0;
  while ((pos = xml.find("<DataArray", pos)) != std::string::npos) {
    const std::size_t end = xml.find('>', pos);
    const std::string tag = xml.substr(pos, end == std::string::npos ? std::string::npos : end - pos);
    pos += 10;
    ++arrays;
    long double product = 1;
    for (int d = 0; d < 6; ++d) {
      const std::string key = "Dim" + std::to_string(d) + "=\"";
      const std::size_t at = tag.find(key);
      if (at == std::string::npos) continue;
      const long double v = std::strtold(tag.c_str() + at + key.size(), nullptr);
      product *= v < 1 ? 1 : v;
    }
    if (product * 8 > static_cast<long double>(g_max_decompressed_bytes))
      fail(path, "a data array declares " + std::to_string(static_cast<long long>(std::min<long double>(product, 9e18L))) +
                     " values, more than the size limit",
           "the GIFTI file is corrupt");
  }
  const std::size_t at = xml.find("NumberOfDataArrays=\"");
  if (at != std::string::npos) {
    const long double n = std::strtold(xml.c_str() + at + 20, nullptr);
    if (n < 0 || n > arrays)
      fail(path, "declares " + std::to_string(static_cast<long long>(std::min<long double>(n, 9e18L))) + " data arrays but holds " +
                     std::to_string(arrays),
           "the GIFTI file is truncated or corrupt");
  }
}

// gifticlib's expat callbacks assume the document follows the GIFTI DTD and crash on some that do
// not (found by fuzzing: a <Value> outside <MD> dereferences NULL inside gifticlib). So the XML is
// parsed once with expat here and its element structure checked against the DTD
// (gifti.projects.nitrc.org/gifti.dtd) before gifticlib sees it.
struct StructureCheck {
  struct Frame {
    std::string name;
    std::vector<std::string> children;
    bool cdata_ended = false;  // a CDATA section of this element has closed
  };
  bool in_cdata = false;
  std::vector<Frame> stack;
  std::string error;
  bool seen_root = false;

  static bool allowed(const std::string& parent, const std::string& child) {
    if (parent.empty()) return child == "GIFTI";
    if (parent == "GIFTI") return child == "MetaData" || child == "LabelTable" || child == "DataArray";
    if (parent == "MetaData") return child == "MD";
    if (parent == "MD") return child == "Name" || child == "Value";
    if (parent == "LabelTable") return child == "Label";
    if (parent == "DataArray") return child == "MetaData" || child == "CoordinateSystemTransformMatrix" || child == "Data";
    if (parent == "CoordinateSystemTransformMatrix") return child == "DataSpace" || child == "TransformedSpace" || child == "MatrixData";
    return false;  // Name, Value, Label, Data, DataSpace, ... hold text only
  }
  // The children an element must end up with, in order (DTD content models).
  static std::string check_children(const Frame& f) {
    const auto& c = f.children;
    auto count = [&](const char* n) { return std::count(c.begin(), c.end(), n); };
    if (f.name == "MD" && !(c.size() == 2 && c[0] == "Name" && c[1] == "Value")) return "<MD> must hold exactly <Name> then <Value>";
    if (f.name == "CoordinateSystemTransformMatrix" &&
        !(c.size() == 3 && c[0] == "DataSpace" && c[1] == "TransformedSpace" && c[2] == "MatrixData"))
      return "<CoordinateSystemTransformMatrix> must hold <DataSpace>, <TransformedSpace>, <MatrixData>";
    if (f.name == "DataArray") {
      if (count("Data") != 1 || c.back() != "Data") return "<DataArray> must end with exactly one <Data>";
      if (count("MetaData") > 1 || (count("MetaData") == 1 && c.front() != "MetaData")) return "<DataArray> has a misplaced <MetaData>";
    }
    if (f.name == "GIFTI") {
      if (count("MetaData") > 1 || count("LabelTable") > 1) return "<GIFTI> has more than one <MetaData> or <LabelTable>";
      bool data_seen = false;
      for (const auto& n : c) {
        if (n == "DataArray") data_seen = true;
        else if (data_seen) return "<GIFTI> has <" + n + "> after a <DataArray>";
      }
    }
    return {};
  }
  static void XMLCALL start(void* user, const XML_Char* name, const XML_Char**) {
    auto* self = static_cast<StructureCheck*>(user);
    if (!self->error.empty()) return;
    const std::string parent = self->stack.empty() ? std::string() : self->stack.back().name;
    if (parent.empty() && self->seen_root) {
      self->error = "more than one root element";
      return;
    }
    if (!allowed(parent, name)) {
      self->error = "element <" + std::string(name) + "> is not allowed " + (parent.empty() ? "as the root" : "inside <" + parent + ">");
      return;
    }
    if (!self->stack.empty()) self->stack.back().children.push_back(name);
    self->stack.push_back({name, {}});
    self->seen_root = true;
  }
  // gifticlib calls exit() (the whole process ends, found by fuzzing) when any character data,
  // even whitespace, follows a CDATA section inside one element: "<Name><![CDATA[a]]> </Name>".
  static void XMLCALL cdata_start(void* user) { static_cast<StructureCheck*>(user)->in_cdata = true; }
  static void XMLCALL cdata_end(void* user) {
    auto* self = static_cast<StructureCheck*>(user);
    self->in_cdata = false;
    if (!self->stack.empty()) self->stack.back().cdata_ended = true;
  }
  static void XMLCALL text(void* user, const XML_Char*, int) {
    auto* self = static_cast<StructureCheck*>(user);
    if (!self->error.empty() || self->in_cdata || self->stack.empty() || !self->stack.back().cdata_ended) return;
    self->error = "text after a CDATA section inside <" + self->stack.back().name + "> (gifticlib cannot read it)";
  }
  static void XMLCALL end(void* user, const XML_Char*) {
    auto* self = static_cast<StructureCheck*>(user);
    if (!self->error.empty() || self->stack.empty()) return;
    const std::string problem = check_children(self->stack.back());
    if (!problem.empty()) self->error = problem;
    self->stack.pop_back();
  }
};

void check_gifti_structure(const std::string& xml, const std::string& path) {
  StructureCheck check;
  XML_Parser parser = XML_ParserCreate(nullptr);
  if (!parser) throw std::runtime_error(path + ": cannot create an XML parser");
  XML_SetUserData(parser, &check);
  XML_SetElementHandler(parser, StructureCheck::start, StructureCheck::end);
  XML_SetCdataSectionHandler(parser, StructureCheck::cdata_start, StructureCheck::cdata_end);
  XML_SetCharacterDataHandler(parser, StructureCheck::text);
  const int ok = XML_Parse(parser, xml.data(), static_cast<int>(std::min<std::size_t>(xml.size(), INT32_MAX)), 1);
  std::string xml_error;
  if (ok != XML_STATUS_OK)
    xml_error = std::string(XML_ErrorString(XML_GetErrorCode(parser))) + " at line " + std::to_string(XML_GetCurrentLineNumber(parser));
  XML_ParserFree(parser);
  if (!check.error.empty()) fail(path, "invalid GIFTI structure: " + check.error, "the file is corrupt or not GIFTI");
  if (!xml_error.empty()) fail(path, "invalid XML: " + xml_error, "the file is truncated or corrupt");
}

}  // namespace

bool looks_like_gifti(const std::string& bytes) {
  const std::string head = bytes.substr(0, 4096);
  return head.find("<GIFTI") != std::string::npos;
}

GiftiContents read_gifti(const std::string& path) {
  std::string bytes = read_file(path);
  const bool gz = is_gzip(bytes);
  if (gz) bytes = gunzip(bytes, path);
  if (!looks_like_gifti(bytes)) fail(path, "not a GIFTI file (no <GIFTI> element near the start)", "give a .gii or .gii.gz file");
  // gifticlib would open external data files named inside the XML: refuse rather than follow them.
  if (bytes.find("ExternalFileBinary") != std::string::npos)
    fail(path, "GIFTI data stored in an external file (ExternalFileBinary) is not supported",
         "re-save it with the data embedded (e.g. nibabel or wb_command -gifti-convert BASE64_BINARY)");
  if (bytes.size() > static_cast<std::size_t>(INT32_MAX)) fail(path, "GIFTI XML larger than 2 GiB", "the file is not a plausible surface");
  check_declared_sizes(bytes, path);
  check_gifti_structure(bytes, path);
  // gifticlib reads only uncompressed files from disk: inflate .gii.gz to a private temporary .gii.
  std::unique_ptr<TempFile> tmp;
  std::string file = path;
  if (gz) {
    tmp = std::make_unique<TempFile>(".gii");
    tmp->write(bytes);
    file = tmp->path();
  }
  GiftiPtr gim;
  {
    std::lock_guard<std::mutex> lock(gifti_mutex());
    gifti_set_verb(0);
    const QuietStderr quiet;
    gim.reset(gifti_read_image(file.c_str(), 1));
  }
  if (!gim) fail(path, "gifticlib could not parse it (invalid GIFTI XML or data encoding)", "the file is corrupt or not GIFTI");
  if (gim->numDA < 0 || (gim->numDA > 0 && !gim->darray)) fail(path, "GIFTI file has an invalid data-array list", "the file is corrupt");

  GiftiContents out;
  copy_meta(gim->meta, &out.metadata);
  int pointset = -1, triangles = -1;
  std::vector<int> data_arrays;
  for (int i = 0; i < gim->numDA; ++i) {
    const giiDataArray* da = gim->darray[i];
    if (!da) fail(path, "data array " + std::to_string(i) + " is missing", "the file is corrupt");
    if (da->intent == kIntentPointset) {
      if (pointset < 0) pointset = i;
    } else if (da->intent == kIntentTriangle) {
      if (triangles < 0) triangles = i;
    } else {
      data_arrays.push_back(i);
    }
  }
  if ((pointset >= 0) != (triangles >= 0))
    fail(path, pointset >= 0 ? "GIFTI file has a pointset (intent 1008) but no triangle array (intent 1009)"
                             : "GIFTI file has a triangle array (intent 1009) but no pointset (intent 1008)",
         "a surface needs both; re-create the file");
  if (pointset >= 0) {
    const giiDataArray* p = gim->darray[pointset];
    const giiDataArray* t = gim->darray[triangles];
    long long pr, pc, tr, tc;
    shape(path, pointset, p, &pr, &pc);
    shape(path, triangles, t, &tr, &tc);
    if (p->num_dim != 2 || pc != 3)
      fail(path, "pointset is not #V x 3 (dimensions " + std::to_string(pr) + " x " + std::to_string(pc) + ")", "the GIFTI file is corrupt");
    if (t->num_dim != 2 || tc != 3)
      fail(path, "triangle array is not #F x 3 (dimensions " + std::to_string(tr) + " x " + std::to_string(tc) + ")", "the GIFTI file is corrupt");
    if (t->datatype == NIFTI_TYPE_FLOAT32 || t->datatype == NIFTI_TYPE_FLOAT64)
      fail(path, "triangle array has a floating-point type", "triangle indices must be integers (NIFTI_TYPE_INT32)");
    out.has_mesh = true;
    out.mesh.V.resize(pr, 3);
    for (long long i = 0; i < pr; ++i)
      for (int c = 0; c < 3; ++c) out.mesh.V(i, c) = da_value(p, i, c, pr, 3);
    out.mesh.F.resize(tr, 3);
    for (long long i = 0; i < tr; ++i)
      for (int c = 0; c < 3; ++c) {
        const double v = da_value(t, i, c, tr, 3);
        out.mesh.F(i, c) = (v >= 0 && v < 2147483647.0) ? static_cast<int>(v) : -1;
      }
    validate_mesh(out.mesh, path, "GIFTI");
    copy_meta(p->meta, &out.metadata);
    // The pointset's dataspace is its first coordinate system's. Among its transforms, the one to
    // scanner space (as FreeSurfer's mris_convert writes for tkregister surfaces, possibly after
    // another, e.g. to Talairach) tells where the coordinates are in the scanner.
    if (p->numCS > 0 && p->coordsys && p->coordsys[0] && p->coordsys[0]->dataspace) out.dataspace = p->coordsys[0]->dataspace;
    for (int k = 0; k < p->numCS && p->coordsys; ++k) {
      const giiCoordSystem* cs = p->coordsys[k];
      if (!cs) continue;
      const std::string dataspace = cs->dataspace ? cs->dataspace : "";
      const std::string xformspace = cs->xformspace ? cs->xformspace : "";
      if (xformspace != "NIFTI_XFORM_SCANNER_ANAT" || dataspace == xformspace || dataspace != out.dataspace) continue;
      Eigen::Matrix4d m;
      for (int r = 0; r < 4; ++r)
        for (int c = 0; c < 4; ++c) m(r, c) = cs->xform[r][c];
      if (m.allFinite() && m.row(3).isApprox(Eigen::RowVector4d(0, 0, 0, 1)) && std::abs(m.block<3, 3>(0, 0).determinant()) > 1e-12) {
        out.to_scanner = m;
        break;
      }
    }
  }
  // Per-vertex arrays: all of one length (1D, or #V x 1).
  long long length = -1;
  for (const int i : data_arrays) {
    const giiDataArray* da = gim->darray[i];
    long long r, c;
    shape(path, i, da, &r, &c);
    if (c != 1) continue;  // vector-valued arrays (e.g. RGBA) are not per-vertex scalars
    if (length >= 0 && r != length)
      fail(path, "data arrays have different lengths (" + std::to_string(length) + " and " + std::to_string(r) + ")", "the GIFTI file is inconsistent");
    if (out.has_mesh && r != out.mesh.V.rows())
      fail(path, "data array " + std::to_string(i) + " has " + std::to_string(r) + " values but the pointset has " +
                     std::to_string(out.mesh.V.rows()) + " vertices",
           "the GIFTI file is inconsistent");
    length = r;
  }
  std::vector<int> columns;
  for (const int i : data_arrays) {
    long long r, c;
    shape(path, i, gim->darray[i], &r, &c);
    if (c == 1) columns.push_back(i);
  }
  out.columns.resize(std::max<long long>(length, 0), static_cast<Eigen::Index>(columns.size()));
  for (std::size_t k = 0; k < columns.size(); ++k) {
    const giiDataArray* da = gim->darray[columns[k]];
    for (long long r = 0; r < length; ++r) out.columns(r, static_cast<Eigen::Index>(k)) = da_value(da, r, 0, length, 1);
    std::string name = meta_value(da->meta, "Name");
    if (name.empty()) name = "column " + std::to_string(k);
    out.column_names.push_back(name);
    out.column_intents.push_back(da->intent);
    if (da->intent == NIFTI_INTENT_LABEL) out.columns_are_labels = true;
  }
  const giiLabelTable& lt = gim->labeltable;
  if (lt.length > 0 && lt.key && lt.label)
    for (int i = 0; i < lt.length; ++i) out.label_table[lt.key[i]] = lt.label[i] ? lt.label[i] : "";
  return out;
}

namespace {

giiDataArray* add_array(const std::string& path, gifti_image* gim, int intent, int datatype, int rows, int cols) {
  if (gifti_add_empty_darray(gim, 1) != 0) throw std::runtime_error(path + ": gifticlib could not add a data array");
  giiDataArray* da = gim->darray[gim->numDA - 1];
  da->intent = intent;
  da->datatype = datatype;
  da->ind_ord = GIFTI_IND_ORD_ROW_MAJOR;
  da->num_dim = cols > 1 ? 2 : 1;
  da->dims[0] = rows;
  da->dims[1] = cols > 1 ? cols : 0;
  for (int d = 2; d < 6; ++d) da->dims[d] = 0;
  da->encoding = GIFTI_ENCODING_B64GZ;
  da->endian = gifti_get_this_endian();
  int nbyper = 0, swapsize = 0;
  gifti_datatype_sizes(datatype, &nbyper, &swapsize);
  da->nbyper = nbyper;
  da->nvals = static_cast<long long>(rows) * std::max(cols, 1);
  da->data = std::calloc(static_cast<std::size_t>(std::max<long long>(da->nvals, 1)), static_cast<std::size_t>(nbyper));
  if (!da->data) throw std::runtime_error(path + ": out of memory for a GIFTI data array");
  return da;
}

void add_meta(giiMetaData* md, const std::string& name, const std::string& value) {
  if (!value.empty()) gifti_add_to_meta(md, name.c_str(), value.c_str(), 1);
}

// Writes gim to `path` (the atomic temporary name). For .gii.gz the XML goes to a sibling file,
// is read back, gzipped and written under `path`. The XML is verified by reading it back with
// gifticlib: gifticlib ignores fwrite errors, so a full disk would otherwise pass unnoticed.
void write_gim(gifti_image* gim, const std::string& final_path, const std::string& path) {
  const bool gz = ends_with(lower_filename(final_path), ".gz");
  // Removes the intermediate XML of a .gii.gz on every exit path.
  struct Unlink {
    std::string p;
    ~Unlink() {
      if (!p.empty()) ::unlink(p.c_str());
    }
  } xml_tmp;
  const std::string xml = gz ? path + ".xml.gii" : path;
  if (gz) xml_tmp.p = xml;
  std::lock_guard<std::mutex> lock(gifti_mutex());
  gifti_set_verb(0);
  // zlib's fastest level: 3-4x faster than its default 6 for files about 10 % larger (benchmark
  // B3: writing the map was 14 % of its time at level 6).
  gifti_set_zlevel(1);
  if (gifti_write_image(gim, xml.c_str(), 1) != 0) throw std::runtime_error("gifticlib failed to write " + xml);
  GiftiPtr back(gifti_read_image(xml.c_str(), 1));
  bool same = back && back->numDA == gim->numDA;
  for (int i = 0; same && i < gim->numDA; ++i)
    same = back->darray[i] && back->darray[i]->data && back->darray[i]->nvals == gim->darray[i]->nvals;
  if (!same) {
    const int err = errno;
    throw std::system_error(err ? err : EIO, std::generic_category(), "GIFTI file did not read back complete (disk full?)");
  }
  if (gz) {
    const std::string text = read_file(xml);
    const std::string packed = gzip(text);
    FILE* f = std::fopen(path.c_str(), "wb");
    if (!f) throw std::system_error(errno, std::generic_category(), "open");
    const std::size_t n = std::fwrite(packed.data(), 1, packed.size(), f);
    const int err = errno;
    const bool closed = std::fclose(f) == 0;
    if (n != packed.size() || !closed) throw std::system_error(err ? err : EIO, std::generic_category(), "write");
  }
}

}  // namespace

void write_gifti_surface(const std::string& path, const TriMesh& mesh, const SurfaceWriteOptions& options) {
  write_atomically(path, [&](const std::string& tmp) {
    GiftiPtr gim(gifti_create_image(0, NIFTI_INTENT_NONE, NIFTI_TYPE_FLOAT32, 0, nullptr, 0));
    if (!gim) throw std::runtime_error("gifticlib could not create an image");
    add_meta(&gim->meta, "generator", "authalic");
    // The pointset's own keys go on the pointset array, where Workbench reads a surface's structure
    // and type (a copy at file level shows "Structure: Invalid" in wb_command -file-information).
    std::map<std::string, std::string> pointset_meta;
    for (const auto& [k, v] : options.metadata)
      if (k == "AnatomicalStructurePrimary" || k == "AnatomicalStructureSecondary" || k == "GeometricType")
        pointset_meta[k] = v;
      else
        add_meta(&gim->meta, k, v);
    if (!options.anatomical_structure.empty()) pointset_meta["AnatomicalStructurePrimary"] = options.anatomical_structure;
    if (!options.geometric_type.empty()) pointset_meta["GeometricType"] = options.geometric_type;

    giiDataArray* p = add_array(path, gim.get(), kIntentPointset, NIFTI_TYPE_FLOAT32, mesh.num_vertices(), 3);
    auto* pv = static_cast<float*>(p->data);
    for (int i = 0; i < mesh.num_vertices(); ++i)
      for (int c = 0; c < 3; ++c) pv[3 * i + c] = static_cast<float>(mesh.V(i, c));
    for (const auto& [k, v] : pointset_meta) add_meta(&p->meta, k, v);
    if (gifti_add_empty_CS(p) != 0) throw std::runtime_error("gifticlib could not add a coordinate system");
    giiCoordSystem* cs = p->coordsys[p->numCS - 1];
    const std::string space = options.space.empty() ? "NIFTI_XFORM_UNKNOWN" : options.space;
    std::free(cs->dataspace);
    std::free(cs->xformspace);
    cs->dataspace = gifti_strdup(space.c_str());
    Eigen::Matrix4d xform = Eigen::Matrix4d::Identity();
    if (options.volume_geometry.valid && space != "NIFTI_XFORM_SCANNER_ANAT") {
      // tkregister RAS -> scanner RAS, as FreeSurfer's mris_convert records it.
      xform.block<3, 1>(0, 3) = options.volume_geometry.cras;
      cs->xformspace = gifti_strdup("NIFTI_XFORM_SCANNER_ANAT");
    } else {
      cs->xformspace = gifti_strdup(space.c_str());
    }
    for (int r = 0; r < 4; ++r)
      for (int c = 0; c < 4; ++c) cs->xform[r][c] = xform(r, c);

    giiDataArray* t = add_array(path, gim.get(), kIntentTriangle, NIFTI_TYPE_INT32, mesh.num_faces(), 3);
    auto* tv = static_cast<std::int32_t*>(t->data);
    for (int f = 0; f < mesh.num_faces(); ++f)
      for (int c = 0; c < 3; ++c) tv[3 * f + c] = mesh.F(f, c);
    write_gim(gim.get(), path, tmp);
  });
}

void write_gifti_columns(const std::string& path, const MatrixXd& values, const FuncWriteOptions& options, int intent,
                         const std::map<int, std::string>* label_table) {
  if (!options.column_names.empty() && static_cast<Eigen::Index>(options.column_names.size()) != values.cols())
    throw InputError(path + ": " + std::to_string(options.column_names.size()) + " column names for " + std::to_string(values.cols()) +
                     " columns; nothing written");
  write_atomically(path, [&](const std::string& tmp) {
    GiftiPtr gim(gifti_create_image(0, NIFTI_INTENT_NONE, NIFTI_TYPE_FLOAT32, 0, nullptr, 0));
    if (!gim) throw std::runtime_error("gifticlib could not create an image");
    add_meta(&gim->meta, "generator", "authalic");
    add_meta(&gim->meta, "AnatomicalStructurePrimary", options.anatomical_structure);
    for (const auto& [k, v] : options.metadata) add_meta(&gim->meta, k, v);
    const bool labels = label_table != nullptr;
    for (Eigen::Index c = 0; c < values.cols(); ++c) {
      giiDataArray* da = add_array(path, gim.get(), intent, labels ? NIFTI_TYPE_INT32 : NIFTI_TYPE_FLOAT32, static_cast<int>(values.rows()), 1);
      for (Eigen::Index r = 0; r < values.rows(); ++r) {
        if (labels)
          static_cast<std::int32_t*>(da->data)[r] = static_cast<std::int32_t>(std::lround(values(r, c)));
        else
          static_cast<float*>(da->data)[r] = static_cast<float>(values(r, c));
      }
      if (!options.column_names.empty()) add_meta(&da->meta, "Name", options.column_names[static_cast<std::size_t>(c)]);
    }
    if (labels) {
      giiLabelTable& lt = gim->labeltable;
      lt.length = static_cast<int>(label_table->size());
      lt.key = static_cast<int*>(std::calloc(label_table->size(), sizeof(int)));
      lt.label = static_cast<char**>(std::calloc(label_table->size(), sizeof(char*)));
      lt.rgba = static_cast<float*>(std::calloc(4 * label_table->size(), sizeof(float)));
      if (!lt.key || !lt.label || !lt.rgba) throw std::runtime_error("out of memory for the label table");
      int i = 0;
      for (const auto& [key, name] : *label_table) {
        lt.key[i] = key;
        lt.label[i] = gifti_strdup(name.c_str());
        // A fixed, distinguishable colour per key (golden-angle hue); key 0 transparent.
        const double h = std::fmod(key * 0.618033988749895, 1.0);
        lt.rgba[4 * i + 0] = static_cast<float>(0.5 + 0.5 * std::cos(2 * M_PI * h));
        lt.rgba[4 * i + 1] = static_cast<float>(0.5 + 0.5 * std::cos(2 * M_PI * (h + 1.0 / 3)));
        lt.rgba[4 * i + 2] = static_cast<float>(0.5 + 0.5 * std::cos(2 * M_PI * (h + 2.0 / 3)));
        lt.rgba[4 * i + 3] = key == 0 ? 0.0f : 1.0f;
        ++i;
      }
    }
    write_gim(gim.get(), path, tmp);
  });
}

}  // namespace authalic::io::detail
