// Memory guard: estimates of the peak memory of the maps and the --max-memory check.
#include "app/memory_guard.h"

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>

#include "core/error.h"

namespace authalic::app {

namespace {

// Peak resident set size measured with /usr/bin/time -v (Release build, 2 cores; docs/robustness.md,
// "Memory"). Square map (`authalic flatten`, region vertices n), 2 threads, 2026-12-07:
//   B3 (n = 149,233) 362 MB, fs741 white remeshed at 0.6 mm (393k) 923 MB, B1 subdivided three
//   times (596,929) 1,399 MB, remeshed at 0.4 mm (887k) 1,843 MB: 70 MB + 2.0-2.2 kB per vertex
//   (the supernodal factor's fill grows as n log n, slowly); used: 70 MB + 3.0 kB/vertex, at
//   least 1.33x every measurement. (Until 2026-12-07: 70 MB + 6.0 n^1.5 bytes, fitted when the
//   factorisations were simplicial: B1 x3 took 2.36 GB then; it overestimated 887k 2.7x.)
// Sphere map (`authalic sphere`): S1 (10,242) 82.3 MB, S3 (163,842) 270.9 MB, S4 (655,362) 770.1 MB:
//   at most 70 MB + 1,228 bytes/vertex; used: 90 MB + 1,550 bytes/vertex.
constexpr double kSquareFixed = 70e6;       // bytes: executable, libraries, grid fields at 512^2
constexpr double kSquarePerVertex = 3000;   // bytes per region vertex
constexpr double kSphereFixed = 90e6;
constexpr double kSpherePerVertex = 1550;

std::string gb(double bytes) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.2f GB", bytes / 1e9);
  return buf;
}

}  // namespace

double physical_memory_bytes() {
  const long pages = ::sysconf(_SC_PHYS_PAGES), page = ::sysconf(_SC_PAGESIZE);
  if (pages <= 0 || page <= 0) return 0;
  return static_cast<double>(pages) * static_cast<double>(page);
}

double cgroup_memory_limit_bytes(const std::string& root) {
  // cgroup v2: memory.max ("max" = none); v1: memory/memory.limit_in_bytes (a huge number = none).
  for (const std::string& file : {root + "/memory.max", root + "/memory/memory.limit_in_bytes"}) {
    std::ifstream in(file);
    std::string text;
    if (!(in >> text) || text == "max") continue;
    char* end = nullptr;
    const double v = std::strtod(text.c_str(), &end);
    if (end != text.c_str() && *end == '\0' && v > 0 && v < 1e18) return v;
  }
  return 0;
}

double available_memory_bytes() {
  const double physical = physical_memory_bytes(), cgroup = cgroup_memory_limit_bytes("/sys/fs/cgroup");
  return cgroup > 0 && (physical <= 0 || cgroup < physical) ? cgroup : physical;
}

double square_map_memory_bytes(long long vertices, int grid_resolution, double width) {
  // The grid flow keeps ~8 double fields of (W r) x r cells; 512^2 is part of kSquareFixed.
  const double cells = width * grid_resolution * static_cast<double>(grid_resolution);
  const double extra_grid = std::max(0.0, cells - 512.0 * 512.0) * 8 * sizeof(double);
  return kSquareFixed + extra_grid + kSquarePerVertex * static_cast<double>(vertices);
}

double sphere_map_memory_bytes(long long vertices) { return kSphereFixed + kSpherePerVertex * static_cast<double>(vertices); }

void add_max_memory_option(CLI::App& sub, double* limit_gb) {
  sub.add_option("--max-memory", *limit_gb,
                 "Refuse up front (exit 2) when the map's estimated peak memory exceeds this many GB (default: 75% of "
                 "the memory available: the physical RAM, or the cgroup limit when lower, as under SLURM or a container)")
      ->check(CLI::Validator(
          [](std::string& value) -> std::string {
            // CLI::PositiveNumber printed its upper bound, DBL_MAX, in 300 digits.
            char* end = nullptr;
            const double x = std::strtod(value.c_str(), &end);
            return value.empty() || end != value.c_str() + value.size() || !(x > 0 && x < 1e9) ? "'" + value + "' is not a positive number of GB"
                                                                                           : std::string();
          },
          "GB"));
}

void check_memory(const std::string& what, long long vertices, double needed_bytes, double limit_gb) {
  const double available = available_memory_bytes();
  const bool by_default = !(limit_gb > 0);
  const double limit = by_default ? 0.75 * available : limit_gb * 1e9;
  if (!(limit > 0) || needed_bytes <= limit) return;
  throw InputError(what + ": the map of " + std::to_string(vertices) + " vertices would need about " + gb(needed_bytes) +
                   " of memory, more than the limit of " + gb(limit) +
                   (by_default ? " (75% of the " + gb(available) + " available: RAM or the cgroup limit)" : std::string(" (--max-memory)")) +
                   "; use a machine with more memory, raise --max-memory, or map a coarser surface");
}

}  // namespace authalic::app
