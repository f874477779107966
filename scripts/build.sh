#!/usr/bin/env bash
# Release build into build/ (the executable lands at build/authalic). Under CI=true warnings are
# errors (AUTHALIC_WERROR), so a warning fails CI instead of scrolling by.
set -euo pipefail
cd "$(dirname "$0")/.."
werror=OFF
[ "${CI:-}" = true ] && werror=ON
cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=Release -DAUTHALIC_WERROR="$werror" >/dev/null
cmake --build build -j"$(nproc)"
