#pragma once
// Cohort lists for group runs: a CSV with a header naming the columns
//   subject_id,role,age,pet,lh_white,lh_pial,rh_white,rh_pial,lh_cortex,rh_cortex
// (extra columns are ignored; paths are relative to the CSV's folder; role is control or patient).
// Optional columns: t1 (the T1 MRI: the PET is registered to it, run --t1), sex (F, M or O;
// female, male, other accepted; recorded in the report) and lh_sphere_reg, rh_sphere_reg
// (FreeSurfer ?h.sphere.reg: with group --atlas the maps are made in atlas correspondence).
#include <string>
#include <vector>

namespace authalic::app {

struct CohortSubject {
  int line = 0;  // in the cohort file, for messages
  std::string id, role;
  double age = 0;
  std::string pet, lh_white, lh_pial, rh_white, rh_pial, lh_cortex, rh_cortex;  // absolute paths
  std::string t1;   // optional, absolute path
  std::string sex;  // optional: "F", "M" or "O"
  std::string lh_sphere_reg, rh_sphere_reg;  // optional, absolute paths
};

// Throws InputError naming the file and line for a missing column, an empty id, a duplicate id,
// an unknown role or a missing file.
std::vector<CohortSubject> read_cohort(const std::string& path);

}  // namespace authalic::app
