#!/usr/bin/env bash
# Phantom cohort generation: wall time, peak memory and size on disk, printed as a table.
#   bench/bench_phantom.sh [BUILD_DIR]   (default: build)
# Rows: the committed synthetic sample (20 controls + 2 patients, 3 mm), and, when ../shared/data is
# present, a cohort from fsaverage5 + spm/PET.nii (2 mm grid).
set -euo pipefail
cd "$(dirname "$0")/.."
build=${1:-build}
bin="$build/authalic"
[ -x "$bin" ] || { echo "bench_phantom: $bin not found; build first (scripts/build.sh)" >&2; exit 2; }
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

run() {  # name, args...
  local name=$1
  shift
  local out="$work/$name"
  /usr/bin/time -v "$bin" phantom "$out" -q "$@" 2>"$work/$name.time"
  local wall rss bytes files
  wall=$(awk -F': ' '/Elapsed \(wall clock\)/{print $2}' "$work/$name.time")
  rss=$(awk -F': ' '/Maximum resident set size/{printf "%.0f", $2/1024}' "$work/$name.time")
  bytes=$(du -sb "$out" | cut -f1)
  files=$(find "$out" -type f | wc -l)
  printf "| %-34s | %9s | %8s | %8.2f | %5d |\n" "$name" "$wall" "$rss" "$(echo "$bytes/1048576" | bc -l)" "$files"
}

echo "| cohort                             | wall      | RSS (MB) | size (MB)| files |"
echo "|------------------------------------|-----------|----------|----------|-------|"
run "synthetic-20c-2p-3mm" --synthetic --controls 20 --patients 2 --seed 1
# Determinism across thread counts: the same seed with 1 and 2 threads gives identical files.
"$bin" phantom "$work/t1" -q --synthetic --controls 1 --patients 1 --seed 3 --threads 1
"$bin" phantom "$work/t2" -q --synthetic --controls 1 --patients 1 --seed 3 --threads 2
if diff -r "$work/t1" "$work/t2" >/dev/null; then same="identical"; else same="DIFFERENT"; fi
if [ -f ../shared/data/spm/PET.nii ]; then
  run "shared-fsaverage5-spm-2c-2p-2mm" --controls 2 --patients 2 --seed 1 --shared ../shared/data
fi
echo
echo "1 vs 2 threads: $same files"
