// The memory guard's limit (issue 15 item 13): the cgroup limit counts as well as the physical RAM,
// so a SLURM job or a container with less memory than the machine refuses up front instead of
// being killed halfway through a map.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "app/memory_guard.h"
#include "common/test_data.h"

namespace fs = std::filesystem;

TEST(MemoryGuard, CgroupLimitsAreReadForV2AndV1) {
  const std::string dir = authalic::test::temp_dir("memory_guard_cgroup");
  fs::create_directories(dir + "/v2");
  std::ofstream(dir + "/v2/memory.max") << "2147483648\n";
  EXPECT_DOUBLE_EQ(authalic::app::cgroup_memory_limit_bytes(dir + "/v2"), 2147483648.0);
  std::ofstream(dir + "/v2/memory.max") << "max\n";
  EXPECT_EQ(authalic::app::cgroup_memory_limit_bytes(dir + "/v2"), 0.0);  // no limit
  fs::create_directories(dir + "/v1/memory");
  std::ofstream(dir + "/v1/memory/memory.limit_in_bytes") << "1073741824\n";
  EXPECT_DOUBLE_EQ(authalic::app::cgroup_memory_limit_bytes(dir + "/v1"), 1073741824.0);
  std::ofstream(dir + "/v1/memory/memory.limit_in_bytes") << "9223372036854771712\n";  // v1's "unlimited"
  EXPECT_EQ(authalic::app::cgroup_memory_limit_bytes(dir + "/v1"), 0.0);
  EXPECT_EQ(authalic::app::cgroup_memory_limit_bytes(dir + "/none"), 0.0);
  // The limit used is never more than the RAM.
  const double available = authalic::app::available_memory_bytes(), physical = authalic::app::physical_memory_bytes();
  EXPECT_GT(available, 0.0);
  EXPECT_LE(available, physical);
}
