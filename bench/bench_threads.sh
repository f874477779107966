#!/usr/bin/env bash
# Two threads against one, paired: the square map of one native-resolution hemisphere
# (../shared/data/fs741 lh.white, cortex label) with --threads 1 and --threads 2 in turn, N pairs
# (default 3), wall and CPU seconds by /usr/bin/time. Prints each pair's ratio and the median;
# the requirement (issue 13): two threads never slower than one (median wall ratio 2/1 <= 1.0).
#   bench/bench_threads.sh [BUILD_DIR] [PAIRS]
set -euo pipefail
cd "$(dirname "$0")/.."
bin="$PWD/${1:-build}/authalic"
pairs=${2:-3}
data=../shared/data/fs741
[ -x "$bin" ] || { echo "bench_threads: $bin not found; build first (scripts/build.sh)" >&2; exit 2; }
[ -f "$data/lh.white.surf.gii" ] || { echo "bench_threads: $data not found (../shared/data is needed)" >&2; exit 2; }
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
echo "bench_threads: load at start $(cut -d' ' -f1-3 /proc/loadavg); OMP_WAIT_POLICY=${OMP_WAIT_POLICY:-unset (authalic sets passive)}"
one() {  # one THREADS -> "wall cpu"
  /usr/bin/time -f "%e %U %S" -o "$work/t" "$bin" flatten "$data/lh.white.surf.gii" "$work/o$1.surf.gii" \
    --label "$data/lh.cortex.label" --threads "$1" -q
  awk '{printf "%.2f %.2f\n", $1, $2 + $3}' "$work/t"
}
ratios=()
for ((p = 1; p <= pairs; ++p)); do
  read -r w1 c1 < <(one 1)
  read -r w2 c2 < <(one 2)
  r=$(awk -v a="$w2" -v b="$w1" 'BEGIN {printf "%.3f", a / b}')
  ratios+=("$r")
  printf "pair %d: 1 thread %s s wall (%s s CPU), 2 threads %s s wall (%s s CPU), wall ratio 2/1 %s\n" "$p" "$w1" "$c1" "$w2" "$c2" "$r"
  cmp -s "$work/o1.surf.gii" "$work/o2.surf.gii" || { echo "bench_threads: 1 and 2 threads wrote different maps" >&2; exit 1; }
done
median=$(printf "%s\n" "${ratios[@]}" | sort -n | awk '{a[NR] = $1} END {print (NR % 2) ? a[(NR + 1) / 2] : (a[NR / 2] + a[NR / 2 + 1]) / 2}')
verdict=$(awk -v m="$median" 'BEGIN {print (m <= 1.0) ? "PASS" : "FAIL"}')
echo "median wall ratio 2 threads / 1 thread: $median (requirement <= 1.0: $verdict); maps identical for 1 and 2 threads"
