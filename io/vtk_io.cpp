// VTK-family surfaces (.vtk legacy, .vtp XML PolyData, .ply, .obj, .stl) through VTK's readers and
// writers (no rendering modules). Polygons are fan-triangulated here and STL triangle soups are
// welded by exact coordinate match, so only VTK's IO modules are needed.
#include <vtkCallbackCommand.h>
#include <vtkCellArray.h>
#include <vtkCommand.h>
#include <vtkErrorCode.h>
#include <vtkIdList.h>
#include <vtkNew.h>
#include <vtkOBJReader.h>
#include <vtkOBJWriter.h>
#include <vtkLogger.h>
#include <vtkOutputWindow.h>
#include <vtkPLYReader.h>
#include <vtkPLYWriter.h>
#include <vtkPoints.h>
#include <vtkPolyData.h>
#include <vtkPolyDataReader.h>
#include <vtkPolyDataWriter.h>
#include <vtkSTLReader.h>
#include <vtkSTLWriter.h>
#include <vtkSmartPointer.h>
#include <vtkXMLPolyDataReader.h>
#include <vtkXMLPolyDataWriter.h>

#include <array>
#include <cmath>
#include <map>
#include <mutex>
#include <system_error>
#include <vector>

#include "io/atomic_file.h"
#include "io/io_internal.h"
#include "io/surface_formats.h"
#include "io/vtk_family_check.h"

namespace authalic::io::detail {

namespace {

// vtkErrorCode's enum only (its string table lives in VTK::CommonMisc, which we do not link).

// "vtkPLYReader (0x1234): Cannot read geometry" from VTK's "ERROR: In file, line N\n..." text.
std::string readable_vtk_message(const char* text) {
  std::string msg;
  std::size_t start = 0;
  const std::string all = text ? text : "";
  while (start < all.size()) {
    std::size_t end = all.find_first_of("\r\n", start);
    if (end == std::string::npos) end = all.size();
    const std::string line = all.substr(start, end - start);
    start = end + 1;
    if (line.empty() || line.rfind("ERROR: In ", 0) == 0 || line.find("Warning: In ") != std::string::npos) continue;
    msg = line;
    break;
  }
  // Drop the "ClassName (0x55d0...): " prefix: the address means nothing to a user.
  const std::size_t paren = msg.find(" (0x");
  const std::size_t colon = msg.find("): ", paren == std::string::npos ? 0 : paren);
  if (paren != std::string::npos && colon != std::string::npos) msg = msg.substr(0, paren) + ": " + msg.substr(colon + 3);
  return msg.substr(0, 300);
}

struct ErrorCollector;
// The collector of the read running on this thread: VTK helper objects without an observer
// (parsers, arrays) and generic warnings report through the global output window instead.
thread_local ErrorCollector* t_active_collector = nullptr;

// Collects VTK error/warning messages of one algorithm (and of anything reporting through the
// output window on this thread meanwhile) instead of printing them.
struct ErrorCollector {
  std::string messages;
  vtkNew<vtkCallbackCommand> callback;
  ErrorCollector* previous = t_active_collector;
  void record(const char* text) {
    if (messages.empty()) messages = readable_vtk_message(text);
    if (messages.empty()) messages = "unspecified VTK error";
  }
  explicit ErrorCollector(vtkObject* object) {
    callback->SetClientData(this);
    callback->SetCallback([](vtkObject*, unsigned long, void* client, void* call) {
      static_cast<ErrorCollector*>(client)->record(static_cast<const char*>(call));
    });
    object->AddObserver(vtkCommand::ErrorEvent, callback);
    object->AddObserver(vtkCommand::WarningEvent, callback);
    t_active_collector = this;
  }
  ~ErrorCollector() { t_active_collector = previous; }
  ErrorCollector(const ErrorCollector&) = delete;
  ErrorCollector& operator=(const ErrorCollector&) = delete;
};

// Once per process: VTK's output window never prints (a corrupt file once printed a warning per
// missing vertex), and what reaches it counts as a failure of the read running on that thread.
void silence_vtk_output() {
  static std::once_flag once;
  std::call_once(once, [] {
    // VTK 9 also logs every error through vtkLogger, whose stderr sink prints it with a
    // timestamp whatever the output window does (an empty .vtp printed 12 lines before ours).
    vtkLogger::SetStderrVerbosity(vtkLogger::VERBOSITY_OFF);
    vtkOutputWindow* window = vtkOutputWindow::GetInstance();
    window->SetDisplayModeToNever();
    vtkNew<vtkCallbackCommand> relay;
    relay->SetCallback([](vtkObject*, unsigned long, void*, void* call) {
      if (t_active_collector) t_active_collector->record(static_cast<const char*>(call));
    });
    window->AddObserver(vtkCommand::ErrorEvent, relay);
    window->AddObserver(vtkCommand::WarningEvent, relay);
  });
}

TriMesh from_polydata(vtkPolyData* pd, const std::string& path) {
  TriMesh m;
  if (!pd || !pd->GetPoints()) return m;
  const vtkIdType np = pd->GetNumberOfPoints();
  m.V.resize(np, 3);
  for (vtkIdType i = 0; i < np; ++i) {
    double p[3];
    pd->GetPoint(i, p);
    m.V.row(i) << p[0], p[1], p[2];
  }
  std::vector<std::array<int, 3>> tris;
  auto add = [&](vtkIdType a, vtkIdType b, vtkIdType c) {
    if (a < 0 || b < 0 || c < 0 || a >= np || b >= np || c >= np)
      fail(path, "a cell uses a point index outside 0.." + std::to_string(np - 1), "the file is corrupt");
    tris.push_back({static_cast<int>(a), static_cast<int>(b), static_cast<int>(c)});
  };
  vtkNew<vtkIdList> ids;
  if (vtkCellArray* polys = pd->GetPolys()) {
    polys->InitTraversal();
    while (polys->GetNextCell(ids)) {
      // Fan triangulation keeps the polygon's orientation (exact for convex polygons).
      for (vtkIdType k = 1; k + 1 < ids->GetNumberOfIds(); ++k) add(ids->GetId(0), ids->GetId(k), ids->GetId(k + 1));
    }
  }
  if (vtkCellArray* strips = pd->GetStrips()) {
    strips->InitTraversal();
    while (strips->GetNextCell(ids)) {
      for (vtkIdType k = 0; k + 2 < ids->GetNumberOfIds(); ++k) {
        if (k % 2 == 0)
          add(ids->GetId(k), ids->GetId(k + 1), ids->GetId(k + 2));
        else
          add(ids->GetId(k + 1), ids->GetId(k), ids->GetId(k + 2));
      }
    }
  }
  m.F.resize(static_cast<Eigen::Index>(tris.size()), 3);
  for (std::size_t f = 0; f < tris.size(); ++f) m.F.row(static_cast<Eigen::Index>(f)) << tris[f][0], tris[f][1], tris[f][2];
  return m;
}

vtkSmartPointer<vtkPolyData> to_polydata(const TriMesh& mesh) {
  auto pd = vtkSmartPointer<vtkPolyData>::New();
  vtkNew<vtkPoints> pts;
  pts->SetDataTypeToFloat();
  pts->SetNumberOfPoints(mesh.num_vertices());
  for (int i = 0; i < mesh.num_vertices(); ++i) pts->SetPoint(i, mesh.V(i, 0), mesh.V(i, 1), mesh.V(i, 2));
  vtkNew<vtkCellArray> polys;
  for (int f = 0; f < mesh.num_faces(); ++f) {
    const vtkIdType tri[3] = {mesh.F(f, 0), mesh.F(f, 1), mesh.F(f, 2)};
    polys->InsertNextCell(3, tri);
  }
  pd->SetPoints(pts);
  pd->SetPolys(polys);
  return pd;
}

// Reads `file` (the user's file or a sanitized copy of it); messages name `path`.
template <class Reader>
TriMesh run_reader(const std::string& file, const std::string& path, const std::string& format) {
  silence_vtk_output();
  vtkNew<Reader> reader;
  TriMesh mesh;
  {
    ErrorCollector errors(reader);
    reader->SetFileName(file.c_str());
    reader->Update();
    if (!errors.messages.empty() || reader->GetErrorCode() != vtkErrorCode::NoError) {
      const std::string why = errors.messages.empty() ? "VTK error code " + std::to_string(reader->GetErrorCode()) : errors.messages;
      fail(path, "VTK could not read it as " + format + ": " + why, "the file is corrupt or not " + format);
    }
    mesh = from_polydata(reader->GetOutput(), path);
  }
  for (Eigen::Index i = 0; i < mesh.V.rows(); ++i)
    if (!mesh.V.row(i).allFinite())
      fail(path, "vertex " + std::to_string(i) + " has a non-finite coordinate (NaN or Inf)", "the " + format + " file is corrupt; re-create it");
  return mesh;
}

}  // namespace

TriMesh read_vtk_family(const std::string& path, const std::string& format) {
  require_readable(path);
  if (format == "vtk") {
    // VTK reads a geometry-only copy whose every declared size has been checked.
    const TempFile copy(".vtk");
    copy.write(sanitize_legacy_vtk(read_file(path), path));
    return run_reader<vtkPolyDataReader>(copy.path(), path, "legacy VTK");
  }
  if (format == "vtp") {
    check_vtp(read_file(path), path);
    return run_reader<vtkXMLPolyDataReader>(path, path, "VTK XML PolyData");
  }
  if (format == "ply") {
    check_ply(read_file(path), path);
    return run_reader<vtkPLYReader>(path, path, "PLY");
  }
  if (format == "obj") {
    const std::string bytes = read_file(path);
    check_obj(bytes, path);
    const TempFile copy(".obj");
    copy.write(obj_geometry_only(bytes));
    return run_reader<vtkOBJReader>(copy.path(), path, "OBJ");
  }
  if (format == "stl") {
    check_stl(read_file(path), path);
    return run_reader<vtkSTLReader>(path, path, "STL");
  }
  fail(path, "unknown VTK-family format '" + format + "'", "use .vtk, .vtp, .ply, .obj or .stl");
}

int merge_coincident_vertices(TriMesh& mesh) {
  std::map<std::array<double, 3>, int> first;
  VectorXi remap(mesh.num_vertices());
  std::vector<int> kept;
  for (int i = 0; i < mesh.num_vertices(); ++i) {
    const std::array<double, 3> key{mesh.V(i, 0), mesh.V(i, 1), mesh.V(i, 2)};
    const auto [it, inserted] = first.emplace(key, static_cast<int>(kept.size()));
    if (inserted) kept.push_back(i);
    remap[i] = it->second;
  }
  const int merged = mesh.num_vertices() - static_cast<int>(kept.size());
  if (merged == 0) return 0;
  MatrixXd V(static_cast<Eigen::Index>(kept.size()), 3);
  for (std::size_t k = 0; k < kept.size(); ++k) V.row(static_cast<Eigen::Index>(k)) = mesh.V.row(kept[k]);
  for (int f = 0; f < mesh.num_faces(); ++f)
    for (int c = 0; c < 3; ++c) mesh.F(f, c) = remap[mesh.F(f, c)];
  mesh.V = std::move(V);
  return merged;
}

namespace {

template <class Writer, class Configure>
void run_writer(vtkPolyData* pd, const std::string& tmp, const std::string& format, Configure configure) {
  silence_vtk_output();
  vtkNew<Writer> writer;
  ErrorCollector errors(writer);
  configure(writer.GetPointer());
  writer->SetInputData(pd);
  writer->SetFileName(tmp.c_str());
  const int ok = writer->Write();
  const unsigned long code = writer->GetErrorCode();
  if (code == vtkErrorCode::OutOfDiskSpaceError) throw std::system_error(ENOSPC, std::generic_category(), "VTK writer");
  if (!ok || code != vtkErrorCode::NoError || !errors.messages.empty())
    throw std::runtime_error("VTK could not write " + format + ": " +
                             (errors.messages.empty() ? "VTK error code " + std::to_string(code) : errors.messages));
}

}  // namespace

void write_vtk_family(const std::string& path, const TriMesh& mesh, const std::string& format) {
  const vtkSmartPointer<vtkPolyData> pd = to_polydata(mesh);
  write_atomically(path, [&](const std::string& tmp) {
    if (format == "vtk") {
      run_writer<vtkPolyDataWriter>(pd, tmp, format, [](vtkPolyDataWriter* w) { w->SetFileTypeToBinary(); });
    } else if (format == "vtp") {
      run_writer<vtkXMLPolyDataWriter>(pd, tmp, format, [](vtkXMLPolyDataWriter* w) { w->SetDataModeToAppended(); });
    } else if (format == "ply") {
      run_writer<vtkPLYWriter>(pd, tmp, format, [](vtkPLYWriter* w) { w->SetFileTypeToBinary(); });
    } else if (format == "obj") {
      run_writer<vtkOBJWriter>(pd, tmp, format, [](vtkOBJWriter*) {});
    } else if (format == "stl") {
      run_writer<vtkSTLWriter>(pd, tmp, format, [](vtkSTLWriter* w) { w->SetFileTypeToBinary(); });
    } else {
      throw std::runtime_error("unknown surface output format " + format);
    }
  });
}

}  // namespace authalic::io::detail
