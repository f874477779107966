// `authalic run --t1`: the PET is registered to the T1 before sampling. With the phantom's own PET
// standing in for the T1 the registration must find the identity (within a voxel's fraction) and
// the element values must equal those of a run without --t1.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <sstream>

#include "common/test_data.h"

using authalic::test::authalic_binary;
using authalic::test::run_command;

namespace {

std::string slurp(const std::string& path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

// The value column of an element TSV (header: id hemisphere row col area_mm2 cx cy cz value n).
std::vector<double> element_values(const std::string& csv) {
  std::istringstream in(slurp(csv));
  std::string line;
  std::getline(in, line);
  std::vector<double> v;
  while (std::getline(in, line)) {
    std::istringstream row(line);
    std::string cell;
    for (int c = 0; c <= 8 && std::getline(row, cell, '\t'); ++c)
      if (c == 8) v.push_back(cell.empty() || cell == "nan" ? std::nan("") : std::stod(cell));
  }
  return v;
}

}  // namespace

TEST(RunRegister, T1RegistrationOfAnAlignedPetChangesNothing) {
  const std::string s = std::string(AUTHALIC_SOURCE_DIR) + "/sample_data/";
  const std::string dir = authalic::test::temp_dir("run_register");
  const std::string pet = s + "sub-control01/sub-control01_pet.nii.gz";
  const std::string common = " run --id c01 --lh-white " + s + "surf/lh.white --lh-pial " + s + "surf/lh.pial --rh-white " + s +
                             "surf/rh.white --rh-pial " + s + "surf/rh.pial --lh-cortex " + s + "label/lh.cortex.label --rh-cortex " +
                             s + "label/rh.cortex.label --pet " + pet + " --no-report --no-rectangle -q --out ";
  std::string out;
  ASSERT_EQ(run_command(authalic_binary() + common + dir + "/plain", &out), 0) << out;
  ASSERT_EQ(run_command(authalic_binary() + common + dir + "/registered --t1 " + pet, &out), 0) << out;
  const std::string log = slurp(dir + "/registered/sub-c01/sub-c01_log.txt");
  EXPECT_NE(log.find("PET registered to the T1"), std::string::npos) << log;
  const auto a = element_values(dir + "/plain/sub-c01/sub-c01_elements.tsv");
  const auto b = element_values(dir + "/registered/sub-c01/sub-c01_elements.tsv");
  ASSERT_EQ(a.size(), b.size());
  ASSERT_GT(a.size(), 100u);
  double worst = 0;
  for (std::size_t i = 0; i < a.size(); ++i)
    if (std::isfinite(a[i]) && std::isfinite(b[i])) worst = std::max(worst, std::abs(a[i] - b[i]));
  EXPECT_LT(worst, 0.01) << "the registration of a PET to itself should be (nearly) the identity";
}
