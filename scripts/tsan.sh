#!/usr/bin/env bash
# ThreadSanitizer check of the OpenMP loops in core/ (issue 8; docs/robustness.md, "Sanitizers").
#
# GCC's libgomp is not instrumented, so TSan reports false races on every parallel region; the
# usual way out is clang with LLVM's OpenMP runtime (Debian libomp-dev), whose OMPT tool Archer
# (libarcher.so, same package) tells TSan about the runtime's barriers, locks and task
# dependencies. This script:
#   1. configures build-tsan with clang, -fsanitize=thread and -fopenmp=libomp and builds only the
#      core library (the CMake test targets depend on the whole app, ITK and VTK included);
#   2. compiles the core tests that run OpenMP code against it (tests/core/*.cpp: flows, sphere
#      map, metrics, grid overlap, Poisson DCT, hard meshes);
#   3. runs them with OMP_NUM_THREADS=2 and Archer; any "WARNING: ThreadSanitizer" fails the script.
# Usage: scripts/tsan.sh [gtest filter]   (JOBS=N for a parallel build; default 1)
set -euo pipefail
cd "$(dirname "$0")/.."
B=build-tsan
JOBS=${JOBS:-1}
FILTER=${1:-*}
ARCHER=$(ls /usr/lib/llvm-*/lib/libarcher.so 2>/dev/null | sort -V | tail -1 || true)
[ -n "$ARCHER" ] || { echo "tsan.sh: libarcher.so not found; install libomp-dev (LLVM OpenMP)" >&2; exit 2; }
LLVM_LIB=$(dirname "$ARCHER")

cmake -S . -B "$B" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DCMAKE_C_COMPILER=clang -DCMAKE_CXX_COMPILER=clang++ \
  -DCMAKE_CXX_FLAGS="-fsanitize=thread -fno-omit-frame-pointer" \
  -DOpenMP_CXX_FLAGS="-fopenmp=libomp" -DOpenMP_CXX_LIB_NAMES=omp -DOpenMP_omp_LIBRARY="$LLVM_LIB/libomp.so" \
  >/dev/null
cmake --build "$B" -j"$JOBS" --target authalic_core

CHOLMOD=$(grep -E '^CHOLMOD_LIBRARY:' "$B/CMakeCache.txt" | cut -d= -f2)
CHOLMOD_INC=$(grep -E '^CHOLMOD_INCLUDE_DIR:' "$B/CMakeCache.txt" | cut -d= -f2)
mkdir -p "$B/tsan-tests"
# An object is rebuilt when its source or any header it included (its -MMD dependency file) is
# newer: a header that changed a struct's layout under an old object gave garbage fields.
stale() {  # OBJ DEPFILE
  [ -f "$1" ] && [ -f "$2" ] || return 0
  local dep
  for dep in $(sed -e 's/^[^:]*://' -e 's/\\$//' "$2"); do
    [ "$dep" -nt "$1" ] && return 0
  done
  return 1
}
objs=()
for src in tests/core/*.cpp tests/common/test_data.cpp; do
  obj="$B/tsan-tests/$(basename "$src" .cpp).o"
  if stale "$obj" "${obj%.o}.d"; then
    echo "tsan.sh: compiling $src" >&2
    clang++ -std=c++17 -O1 -g -fsanitize=thread -fno-omit-frame-pointer -fopenmp=libomp \
      -I. -I"$B/generated" -Itests -isystem /usr/include/eigen3 -isystem "$CHOLMOD_INC" \
      -DAUTHALIC_SHARED_DATA="\"$PWD/../shared/data\"" -DAUTHALIC_SOURCE_DIR="\"$PWD\"" \
      -DAUTHALIC_BINARY="\"$PWD/$B/authalic\"" -MMD -MF "${obj%.o}.d" -c "$src" -o "$obj"
  fi
  objs+=("$obj")
done
clang++ -fsanitize=thread -fopenmp=libomp "${objs[@]}" "$B/core/libauthalic_core.a" "$CHOLMOD" \
  -L"$LLVM_LIB" -Wl,-rpath,"$LLVM_LIB" -lgtest -lgtest_main -lpthread -o "$B/test_core_tsan"

# libomp itself is not instrumented: TSan sees its internal buffers being memset/freed by another
# thread than the one that allocated them (___kmp_free after a parallel region) and its mutexes
# used from CHOLMOD, without the runtime's own happens-before. Those reports (11 on the first
# run, every one with libomp frames on top) are suppressed; a race in project code has project
# frames on top and is not.
printf 'called_from_lib:libomp.so.5\ncalled_from_lib:libomp.so\n' > "$B/tsan.supp"
log="$B/tsan.log"
OMP_NUM_THREADS=2 OMP_TOOL_LIBRARIES="$ARCHER" \
  TSAN_OPTIONS="halt_on_error=0 history_size=4 suppressions=$PWD/$B/tsan.supp print_suppressions=1" \
  "$B/test_core_tsan" --gtest_filter="$FILTER" 2>&1 | tee "$log" | grep -E '^\[ *(OK|FAILED|PASSED|SKIPPED) *\]|WARNING: ThreadSanitizer|SUMMARY|Matched|called_from_lib' || true
races=$(grep -c 'WARNING: ThreadSanitizer' "$log" || true)
echo "tsan.sh: $races ThreadSanitizer report(s); full log in $log"
grep -q '^\[  PASSED  \]' "$log" && ! grep -q '^\[  FAILED  \]' "$log" || { echo "tsan.sh: tests did not pass" >&2; exit 1; }
[ "$races" -eq 0 ]
