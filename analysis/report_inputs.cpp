// Inputs of the clinical report (see analysis/report_inputs.h).
#include "analysis/report_inputs.h"

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>

#include "core/error.h"

namespace authalic::analysis {

namespace {

// x_pet.nii.gz -> x_pet.json (BIDS: the sidecar shares the data file's name without extensions).
std::string sidecar_path(const std::string& pet) {
  const std::filesystem::path p(pet);
  std::string name = p.filename().string();
  for (const char* ext : {".nii.gz", ".nii", ".mgz", ".mgh"}) {
    const std::string e = ext;
    if (name.size() > e.size() && name.compare(name.size() - e.size(), e.size(), e) == 0) {
      name.erase(name.size() - e.size());
      return (p.parent_path() / (name + ".json")).string();
    }
  }
  return "";
}

std::string text_of(const nlohmann::json& j) {
  if (j.is_string()) return j.get<std::string>();
  if (j.is_number()) return human_number(j.get<double>());
  return "";
}

}  // namespace

std::string human_number(double value) {
  if (!std::isfinite(value)) return "unknown";
  char buf[64];
  std::snprintf(buf, sizeof(buf), "%.1f", value);
  std::string s = buf;
  if (s.size() > 2 && s.compare(s.size() - 2, 2, ".0") == 0) s.erase(s.size() - 2);
  return s;
}

ScanDetails scan_details_from_sidecar(const std::string& pet_path) {
  ScanDetails d;
  const std::string path = sidecar_path(pet_path);
  if (path.empty() || !std::filesystem::is_regular_file(path)) return d;
  std::ifstream f(path);
  std::stringstream s;
  s << f.rdbuf();
  nlohmann::json j = nlohmann::json::parse(s.str(), nullptr, false);
  if (j.is_discarded() || !j.is_object())
    throw InputError(path + ": the PET's BIDS sidecar is not a JSON object; fix it or move it away");
  d.sidecar = path;
  if (j.contains("TracerName")) d.tracer = text_of(j["TracerName"]);
  if (j.contains("InjectedRadioactivity")) {
    d.dose = text_of(j["InjectedRadioactivity"]);
    if (!d.dose.empty()) d.dose += " " + (j.contains("InjectedRadioactivityUnits") ? text_of(j["InjectedRadioactivityUnits"]) : "MBq");
  }
  for (const char* key : {"AcquisitionDateTime", "ScanDate", "SeriesDate", "AcquisitionDate"}) {
    if (d.scan_date.empty() && j.contains(key)) d.scan_date = text_of(j[key]).substr(0, 10);  // the date part
  }
  return d;
}

int drop_small_clusters(Comparison& c, int min_elements) {
  std::vector<ElementCluster> kept;
  std::map<int, int> new_id;  // old id -> new id (0 = dropped)
  for (ElementCluster& cl : c.clusters) {
    if (static_cast<int>(cl.elements.size()) >= min_elements) {
      new_id[cl.id] = static_cast<int>(kept.size()) + 1;
      cl.id = new_id[cl.id];
      kept.push_back(std::move(cl));
    } else {
      new_id[cl.id] = 0;
    }
  }
  const int dropped = static_cast<int>(c.clusters.size() - kept.size());
  c.clusters = std::move(kept);
  for (int& id : c.cluster)
    if (id > 0) id = new_id.count(id) ? new_id[id] : 0;
  return dropped;
}

}  // namespace authalic::analysis
