#pragma once
// Memory guard (issue 8): before a map starts, its peak memory is estimated from the mesh size and
// compared with a limit (--max-memory GB; default 75% of the memory available: the physical RAM,
// or the cgroup limit when lower, as a SLURM job or a container has). A surface too large
// for the limit is refused up front with the memory it would need, instead of being killed by the
// kernel's OOM killer halfway through.
//
// The estimates are fitted to the peak resident set size (/usr/bin/time -v) of `authalic flatten`
// on B1 / B3 / B4 (70 MB + 6.0 n^1.5 bytes) and of `authalic sphere` on S1 / S3 / S4 (90 MB +
// 1,550 bytes per vertex), fsaverage5 white_left subdivided 0, 2 and 3 times; see
// docs/robustness.md, "Memory".
#include <CLI/CLI.hpp>

#include <string>

namespace authalic::app {

// Physical RAM in bytes (sysconf), 0 when unknown.
double physical_memory_bytes();
// The memory limit of the cgroup under `root` (v2 memory.max, or v1 memory/memory.limit_in_bytes),
// bytes; 0 when there is none.
double cgroup_memory_limit_bytes(const std::string& root);
// min(physical RAM, cgroup limit of /sys/fs/cgroup), bytes.
double available_memory_bytes();

// Estimated peak memory (bytes) of `authalic flatten` (square map, grid flow with a
// grid_resolution^2 x width grid) on a region of `vertices` vertices, and of `authalic sphere`.
double square_map_memory_bytes(long long vertices, int grid_resolution = 512, double width = 1.0);
double sphere_map_memory_bytes(long long vertices);

// Adds --max-memory GB to a subcommand (*limit_gb < 0 = the default, 75% of the available memory).
void add_max_memory_option(CLI::App& sub, double* limit_gb);

// Throws InputError("<what>: the map of <vertices> vertices would need about X GB of memory, more
// than the limit of Y GB (...)") when needed_bytes exceeds the limit.
void check_memory(const std::string& what, long long vertices, double needed_bytes, double limit_gb);

}  // namespace authalic::app
