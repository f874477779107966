#!/usr/bin/env bash
# Debug build with AddressSanitizer + UndefinedBehaviorSanitizer, then the whole test suite on it.
# -O1 keeps the Eigen-heavy tests fast enough while keeping frames and line numbers.
# The native-resolution map tests (fs741 and the meshes made from it, 160k-630k vertices:
# NativeResolution* in ctest) run in the release suite; under the sanitizers each takes many
# minutes (the voxelised surface's sphere: over 10), so they run here only with
#   SANITIZE_ALL=1 scripts/sanitize.sh
# (their code paths -- flow, polish, untangling, the sphere -- are also run by the smaller tests).
set -euo pipefail
cd "$(dirname "$0")/.."
cmake -S . -B build-asan -G Ninja -DCMAKE_BUILD_TYPE=Debug -DAUTHALIC_SANITIZE=ON \
  -DCMAKE_CXX_FLAGS_DEBUG="-g -O1" >/dev/null
cmake --build build-asan -j"$(nproc)"
export ASAN_OPTIONS=detect_leaks=1:abort_on_error=1:strict_string_checks=1
export UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
# Third-party leaks only (fontconfig, through Cairo): scripts/lsan.supp says which and why.
export LSAN_OPTIONS="suppressions=$PWD/scripts/lsan.supp:print_suppressions=0"  # no "Suppressions used" report in the output tests compare
exclude=()
[ "${SANITIZE_ALL:-0}" = 1 ] || exclude=(-E NativeResolution)
ctest --test-dir build-asan --output-on-failure -j"$(nproc)" --timeout 1200 "${exclude[@]}"
