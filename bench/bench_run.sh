#!/usr/bin/env bash
# Issue 7 benchmark: `authalic run` wall time and peak memory, with the log's per-step times.
#   bench/bench_run.sh [BUILD_DIR]     (default: build)
# Rows: the embedded phantom patient (the README's main job; target <= 5 s) and, with
# ../shared/data, fsaverage5 (left white/pial with flat_left's cortex face set, and its mirror
# image x -> -x as the right hemisphere) with SPM's PET template (target <= 10 s).
set -euo pipefail
cd "$(dirname "$0")/.."
build=${1:-build}
bin="$PWD/$build/authalic"
[ -x "$bin" ] || { echo "bench_run: $bin not found; build first (scripts/build.sh)" >&2; exit 2; }
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

timed() {  # NAME TARGET ARGS...: runs authalic run, prints a table row and the per-step log
  local name=$1 target=$2
  shift 2
  if ! /usr/bin/time -v "$bin" run "$@" --out "$work/$name" -q 2>"$work/$name.time"; then
    echo "bench_run: $name failed:" >&2
    grep -v '^\s' "$work/$name.time" >&2
    exit 1
  fi
  local wall rss
  wall=$(awk -F': ' '/Elapsed \(wall clock\)/{print $2}' "$work/$name.time" | awk -F: '{ if (NF==3) print $1*3600+$2*60+$3; else print $1*60+$2 }')
  rss=$(awk -F': ' '/Maximum resident set size/{printf "%.0f", $2/1024}' "$work/$name.time")
  printf '| %-40s | %8s | %8s | %s |\n' "$name" "$wall" "$rss" "$target"
  LOGS+=("$name" "$(cat "$work/$name"/sub-*/sub-*_log.txt)")
}
LOGS=()
echo "| run                                      | wall (s) | RSS (MB) | target |"
echo "|------------------------------------------|----------|----------|--------|"
timed phantom-patient01 '<= 5 s' --id patient01 \
  --lh-white sample_data/surf/lh.white --lh-pial sample_data/surf/lh.pial \
  --rh-white sample_data/surf/rh.white --rh-pial sample_data/surf/rh.pial \
  --lh-cortex sample_data/label/lh.cortex.label --rh-cortex sample_data/label/rh.cortex.label \
  --pet sample_data/sub-patient01/sub-patient01_pet.nii.gz --normative sample_data/normative.json
if [ -f ../shared/data/fsaverage5/white_left.gii.gz ]; then
  d=../shared/data/fsaverage5
  for name in white pial flat; do
    gunzip -c "$d/${name}_left.gii.gz" >"$work/lh.$name.surf.gii"
    /usr/bin/python3 bench/mirror_hemisphere.py "$d/${name}_left.gii.gz" "$work/rh.$name.surf.gii"
  done
  timed fsaverage5-lh+mirror-spm-pet '<= 10 s' --id fsaverage5 \
    --lh-white "$work/lh.white.surf.gii" --lh-pial "$work/lh.pial.surf.gii" \
    --rh-white "$work/rh.white.surf.gii" --rh-pial "$work/rh.pial.surf.gii" \
    --lh-cortex "$work/lh.flat.surf.gii" --rh-cortex "$work/rh.flat.surf.gii" --pet ../shared/data/spm/PET.nii
fi
echo
echo "targets: phantom <= 5 s, fsaverage5 <= 10 s (issue 7); load average at the end: $(cut -d' ' -f1-3 /proc/loadavg) on $(nproc) cores"
for ((i = 0; i < ${#LOGS[@]}; i += 2)); do
  echo
  echo "run log of ${LOGS[i]}:"
  echo "${LOGS[i + 1]}"
done
