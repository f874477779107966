#pragma once
// Progress reporting without I/O: long computations call a ProgressFn; the app decides whether
// and how to show it (terminal bar, log line, nothing for --quiet).
#include <functional>
#include <string>

namespace authalic {

// stage: short name ("flow", "sampling"); fraction in [0,1], or < 0 for an unknown total;
// message: free text (e.g. "iteration 12, max |ln ratio| 0.034").
using ProgressFn = std::function<void(const std::string& stage, double fraction, const std::string& message)>;

inline void report(const ProgressFn& fn, const std::string& stage, double fraction, const std::string& message = {}) {
  if (fn) fn(stage, fraction, message);
}

}  // namespace authalic
