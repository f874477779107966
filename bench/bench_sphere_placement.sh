#!/usr/bin/env bash
# How much the sphere's square route depends on where the square's corners fall on the seam around
# the cap (core/sphere_map.h, kCornerOffsets). For each surface, `sphere --seam-corner O` for several
# first placements O (share of the seam's length past its most anterior vertex; 0 is the default):
# the placements the route tried (a pocket, an element more than 10 % off its share, makes it try
# the next), the element CV and the worst element of each, and of the sphere kept.
#   bench/bench_sphere_placement.sh [BUILD_DIR]    (default: build; needs ../shared/data)
set -euo pipefail
cd "$(dirname "$0")/.."
build=${1:-build}
bin="$PWD/$build/authalic"
data=../shared/data
py=/usr/bin/python3
[ -x "$bin" ] || { echo "bench_sphere_placement: $bin not found; build first (scripts/build.sh)" >&2; exit 2; }
[ -f "$data/fs741/lh.white.surf.gii" ] || { echo "bench_sphere_placement: $data not found (../shared/data is needed)" >&2; exit 2; }
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

echo "| surface | first placement | exit | wall s | placements tried: element CV (worst element / mean) | kept: element CV | worst element |"
echo "|---|---|---|---|---|---|---|"
row() {
  local name=$1 surf=$2 offset=$3 start status=0
  start=$(date +%s.%N)
  "$bin" sphere "$surf" "$work/s.surf.gii" --seam-corner "$offset" --metrics "$work/m.json" --keep-failed -q 2>"$work/err" || status=$?
  $py - "$work/m.json" "$name" "$offset" "$status" "$start" "$(date +%s.%N)" <<'PY'
import json, sys
path, name, offset, status, start, end = sys.argv[1:]
m = json.load(open(path))
tried = m["square_route"]["corner_placements_tried"]
t = "; ".join(f"{p['corner_offset_of_seam_length']:.4g}: {p['element_cv_64x32']:.4f} ({p['element_min_over_mean']:.2f}-{p['element_max_over_mean']:.2f})" for p in tried)
mm = m["metrics"]
print(f"| {name} | {float(offset):.3f} | {status} | {float(end) - float(start):.1f} | {t} | {mm['element_cv']:.4f} | "
      f"{mm['element_min_over_mean']:.2f}-{mm['element_max_over_mean']:.2f} |")
PY
}
for o in 0 0.125 0.25 0.375 0.5 0.625 0.75 0.875; do row "fsaverage5 white" "$data/fsaverage5/white_left.gii.gz" $o; done
for o in 0 0.125 0.25 0.375 0.5 0.625 0.75 0.875; do row "fsaverage5 pial" "$data/fsaverage5/pial_left.gii.gz" $o; done
for o in 0 0.125 0.625 0.75; do row "fs741 white" "$data/fs741/lh.white.surf.gii" $o; done
for o in 0 0.125 0.625 0.75; do row "fs741 pial" "$data/fs741/lh.pial.surf.gii" $o; done
