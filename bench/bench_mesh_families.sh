#!/usr/bin/env bash
# Maps of mesh families FreeSurfer does not write, made from the real data (scripts/mesh_families.py):
# the native white surface with coordinate noise, decimated by VTK's quadric decimation, voxelised
# and remeshed by marching cubes at 0.4, 0.5 and 1 mm (as surfaces from a segmentation are; 0.4 mm: ~1M
# vertices, the size of the default --max-vertices), MNI152's whole-brain
# surface, and a synthetic bulb on a narrow neck; and the native white and pial surfaces with other
# cortex labels (grown, shrunk, ragged, a ball cut out), as other subjects' labels differ. For each: `flatten` of its cortex (the label
# carried over by nearest vertex) and `sphere` of the closed surface, with exit code, flips,
# element CV (32x32 square, 64x32 sphere), per-face mean |ln area ratio|, CPU seconds and peak
# memory. A refusal (exit 2: not a closed genus-0 manifold) or a failed acceptance (exit 3) is a row
# with its message, not an error of the bench.
#   bench/bench_mesh_families.sh [AUTHALIC]   (needs ../shared/data, /usr/bin/python3 with nibabel, scipy, vtk)
set -euo pipefail
ROOT="$(cd "$(dirname "$0")/.." && pwd)"
AUTHALIC="$(realpath "${1:-${AUTHALIC:-$ROOT/build/authalic}}")"
SHARED="$ROOT/../shared/data"
PY=/usr/bin/python3
[ -f "$AUTHALIC" ] && [ -x "$AUTHALIC" ] || { echo "bench_mesh_families: $AUTHALIC is not the authalic executable; build first (scripts/build.sh)" >&2; exit 2; }
[ -f "$SHARED/fs741/lh.white.surf.gii" ] || { echo "bench_mesh_families: $SHARED/fs741 missing" >&2; exit 2; }
WORK=$(mktemp -d)
trap 'rm -rf "$WORK"' EXIT
GEN="$PY $ROOT/scripts/mesh_families.py"
WHITE="$SHARED/fs741/lh.white.surf.gii"
LABEL="$SHARED/fs741/lh.cortex.label"
MNI="$SHARED/mni152/mni_icbm152"

cp "$WHITE" "$WORK/white.surf.gii"
cp "$LABEL" "$WORK/white.label"
$GEN noise "$WHITE" "$WORK/noise01.surf.gii" --sigma 0.1 --seed 1
$GEN noise "$WHITE" "$WORK/noise03.surf.gii" --sigma 0.3 --seed 1
cp "$LABEL" "$WORK/noise01.label"
cp "$LABEL" "$WORK/noise03.label"
for r in 50 85 95; do $GEN decimate "$WHITE" "$LABEL" "$WORK/decimated$r.surf.gii" --reduction "0.$r"; done
$GEN voxelise "$WHITE" "$LABEL" "$WORK/voxel04.surf.gii" --voxel 0.4
$GEN voxelise "$WHITE" "$LABEL" "$WORK/voxel05.surf.gii" --voxel 0.5
$GEN voxelise "$WHITE" "$LABEL" "$WORK/voxel10.surf.gii" --voxel 1.0
$GEN hull "${MNI}_gm_tal_nlin_sym_09a_converted.nii.gz" "${MNI}_wm_tal_nlin_sym_09a_converted.nii.gz" "$WORK/mni_hull.surf.gii" --sigma 2
$GEN bulb "$WORK/bulb.surf.gii"
$GEN labels "$WHITE" "$LABEL" "$WORK/label_" --seed 1

# run NAME COMMAND...: one row (the map's metrics JSON is $WORK/NAME.json).
run() {
  local name=$1; shift
  local status=0
  /usr/bin/time -f "%U %S %M" -o "$WORK/$name.time" "$AUTHALIC" "$@" --metrics "$WORK/$name.json" -q 2>"$WORK/$name.err" || status=$?
  $PY - "$WORK" "$name" "$status" <<'PYEOF'
import json, os, sys
work, name, status = sys.argv[1], sys.argv[2], int(sys.argv[3])
user, system, kb = open(os.path.join(work, name + ".time")).read().split()[-3:]
cpu, mem = float(user) + float(system), int(kb) / 1024
if status == 0:
    m = json.load(open(os.path.join(work, name + ".json")))["metrics"]
    print(f"{name:22s} exit 0  flips {m['flips']}  element CV {m['element_cv']:.4f}  per-face {m['face_ln_area_abs']['mean']:.4f}  "
          f"{cpu:6.1f} s CPU  {mem:5.0f} MB")
else:
    msg = open(os.path.join(work, name + ".err")).read().strip().splitlines()[-1]
    print(f"{name:22s} exit {status}  {cpu:6.1f} s CPU  {msg[:220]}")
PYEOF
}

vertices() { $PY -c 'import nibabel, sys; print(len(nibabel.load(sys.argv[1]).darrays[0].data))' "$1"; }
echo "mesh families (vertices): $(for m in white noise01 noise03 decimated50 decimated85 decimated95 voxel04 voxel05 voxel10 mni_hull bulb; do echo -n "$m $(vertices "$WORK/$m.surf.gii"), "; done)"
echo "flatten (cortex label carried by nearest vertex; 32x32 elements; default --max-vertices, 1M):"
for m in white noise01 noise03 decimated50 decimated85 decimated95 voxel04 voxel05 voxel10; do
  run "flatten_$m" flatten "$WORK/$m.surf.gii" "$WORK/flat_$m.surf.gii" --label "$WORK/$m.label"
done
echo "sphere (closed surfaces; 64x32 elements):"
for m in white noise01 noise03 decimated85 voxel05 voxel10 mni_hull bulb; do
  run "sphere_$m" sphere "$WORK/$m.surf.gii" "$WORK/sphere_$m.surf.gii"
done
echo "flatten with other cortex labels (fs741 white and pial; 0/1 masks, cleaned up as FreeSurfer labels are):"
for l in grown2 grown5 shrunk3 shrunk10 ragged cut12mm; do
  for s in white pial; do
    run "labels_${l}_$s" flatten "$SHARED/fs741/lh.$s.surf.gii" "$WORK/flat_${l}_$s.surf.gii" --label "$WORK/label_$l.txt"
  done
done
