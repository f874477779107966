#!/usr/bin/env bash
# Issue 18 part 2 benchmark: the disk domain beside the square on the same inputs, B1 (fsaverage5
# white_left with flat_left's cortex faces) and R1 (fs741 lh.white with lh.cortex.label; its pial,
# R1p, on the disk too, held to the map's acceptance, CV <= 0.01): time,
# peak memory (MB), per-face and per-vertex mean |ln area ratio|, element CV (32 x 32), flips; each disk map's
# element CV and per-face error also from bench/disk_elements.py (an independent estimate;
# evalmap.py has no disk). Ends with PASS/FAIL for the requirements (0 flips, CV <= 0.005).
#   bench/bench_disk.sh [BUILD_DIR]      (about 2 minutes)
set -euo pipefail
cd "$(dirname "$0")/.."
bin="$PWD/${1:-build}/authalic"
fs5=../shared/data/fsaverage5
fs741=../shared/data/fs741
py=/usr/bin/python3
[ -x "$bin" ] || { echo "bench_disk: $bin not found; build first (scripts/build.sh)" >&2; exit 2; }
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
run() {  # NAME SURFACE DOMAIN N REGION_ARGS...
  local name=$1 surf=$2 domain=$3 n=$4
  shift 4
  /usr/bin/time -f "%e %U %S %M" -o "$work/$name.t" "$bin" flatten "$surf" "$work/$name.surf.gii" --uv "$work/$name.uv.surf.gii" \
    --metrics "$work/$name.json" --domain "$domain" --threads 1 -q "$@"
  if [ "$domain" = disk ]; then "$py" bench/disk_elements.py "$surf" "$work/$name.uv.surf.gii" --n "$n" >"$work/$name.ind.json"; fi
}
run B1-square "$fs5/white_left.gii.gz" square 0 --faces-from "$fs5/flat_left.gii.gz"
run B1-disk "$fs5/white_left.gii.gz" disk 32 --faces-from "$fs5/flat_left.gii.gz"
run R1-square "$fs741/lh.white.surf.gii" square 0 --label "$fs741/lh.cortex.label"
run R1-disk "$fs741/lh.white.surf.gii" disk 16 --label "$fs741/lh.cortex.label"
# The native pial: its thin triangles fold in the concentric carry next to the circle.
run R1p-disk "$fs741/lh.pial.surf.gii" disk 16 --label "$fs741/lh.cortex.label"
PYTHONPATH=bench "$py" - "$work" <<'PY'
import json, sys, os
from requirements import Requirements
w = sys.argv[1]
print(f"{'map':<10} {'CPU s':>6} {'MB':>5} {'per-face':>9} {'per-vertex':>10} {'element CV':>10} {'flips':>5} {'inserted':>8}  independent (disk_elements.py): CV, per-face")
rows = {}
for name in ['B1-square', 'B1-disk', 'R1-square', 'R1-disk', 'R1p-disk']:
    j = json.load(open(f'{w}/{name}.json')); m = j['metrics']
    t = open(f'{w}/{name}.t').read().split(); cpu = float(t[1]) + float(t[2])
    ind = json.load(open(f'{w}/{name}.ind.json')) if os.path.exists(f'{w}/{name}.ind.json') else None
    rows[name] = m
    extra = f"  {ind['element_cv']:.5f}, {ind['face_ln_area_abs_mean']:.5f} (n = {ind['subdivision']})" if ind else ''
    print(f"{name:<10} {cpu:6.2f} {float(t[3]) / 1024:5.0f} {m['face_ln_area_abs']['mean']:9.5f} {m['vertex_ln_area_abs']['mean']:10.5f} "
          f"{m['element_cv']:10.5f} {m['flips']:5d} {j.get('disk', {}).get('inserted_vertices', 0):8d}{extra}")
req = Requirements('issue 18 part 2: the disk')
for s in ['B1', 'R1']:
    req(f'{s} disk flips', rows[f'{s}-disk']['flips'], 0)
    req(f'{s} disk element CV', rows[f'{s}-disk']['element_cv'], 0.005)
req('R1 pial disk flips', rows['R1p-disk']['flips'], 0)
req('R1 pial disk element CV (the acceptance)', rows['R1p-disk']['element_cv'], 0.01)
sys.exit(0 if req.ok else 1)
PY
