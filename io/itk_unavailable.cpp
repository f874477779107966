// Stand-ins for io/itk_*.cpp in clang builds (libFuzzer, ThreadSanitizer with libomp). Debian's
// ITK 5.2 headers were configured for GCC only: itk_compiler_detection.h stops with "Unsupported
// compiler" under clang (measured). io/CMakeLists.txt compiles this file instead of the ITK ones
// when the compiler is clang; every GCC build has the real DICOM and registration code.
#include <stdexcept>

#include "core/error.h"
#include "io/itk_dicom.h"
#include "io/itk_register.h"

namespace authalic::io::detail {

bool itk_is_dicom_directory(const std::string&) { return false; }

DicomSeries itk_read_dicom_series(const std::string& directory) {
  throw InputError(directory + ": DICOM series need the GCC build (this binary was built with clang, where Debian's ITK "
                   "headers do not compile); use build/authalic or convert the series to NIfTI (dcm2niix)");
}

void itk_write_dicom_series(const std::string& directory, const std::array<int, 3>&, const std::vector<float>&,
                            const std::array<double, 16>&) {
  throw std::runtime_error(directory + ": DICOM writing needs the GCC build (Debian's ITK headers reject clang)");
}

PlainRigidResult itk_register_rigid(const PlainVolume&, const PlainVolume&) {
  throw std::runtime_error("registration needs the GCC build (this binary was built with clang, where Debian's ITK "
                           "headers do not compile); use build/authalic");
}

}  // namespace authalic::io::detail
