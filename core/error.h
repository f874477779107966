#pragma once
// Errors that reach the user. The CLI maps InputError to exit code 2 and ProcessingError to 3,
// printing what() as one line: "<file>: <what is wrong>; <what to do>".
#include <stdexcept>
#include <string>

namespace authalic {

// The input is unusable (missing, corrupt, wrong topology, wrong size, ...).
struct InputError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// The input was fine but the computation could not deliver a trustworthy result.
struct ProcessingError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

}  // namespace authalic
