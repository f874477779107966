#include "io/registration.h"

#include <stdexcept>

#include "core/error.h"
#include "io/itk_register.h"

namespace authalic::io {
namespace {

detail::PlainVolume plain(const Volume& v) {
  detail::PlainVolume p;
  p.dims = v.dims;
  p.data = &v.data;
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) p.vox2ras[4 * r + c] = v.vox2ras(r, c);
  return p;
}

}  // namespace

RigidRegistration register_rigid(const Volume& t1, const Volume& pet) {
  if (t1.data.size() != t1.num_voxels() || pet.data.size() != pet.num_voxels())
    throw ProcessingError("registration: give 3D volumes (one frame)");
  detail::PlainRigidResult r;
  try {
    r = detail::itk_register_rigid(plain(t1), plain(pet));
  } catch (const std::exception& e) {
    throw ProcessingError(std::string(e.what()) + "; check that the PET and the T1 show the same head");
  }
  RigidRegistration out;
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j) out.t1_to_pet(i, j) = r.fixed_to_moving_ras[4 * i + j];
  out.metric = r.metric;
  out.iterations = r.iterations;
  out.stop_condition = r.stop_condition;
  return out;
}

}  // namespace authalic::io
