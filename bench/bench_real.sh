#!/usr/bin/env bash
# Real-mesh benchmark: the authalic square map on a real subject's native-resolution FreeSurfer
# surfaces (../shared/data/fs741: 164,000 vertices per hemisphere, uncut cortex labels).
#   bench/bench_real.sh [BUILD_DIR]     (default: build; needs ../shared/data)
# Inputs: R1 = lh.cortex.label (90 % of the white area, one boundary loop: the medial wall's
# border), R2 = lh.cortex96_mask.shape.gii (96 %: almost a closed sphere); each on lh.white and
# lh.pial; and the sphere of the closed lh.white and lh.pial. Every map is measured by
# `authalic metrics` (inside flatten / sphere) and independently by
# ../shared/tools/evalmap.py --inserted auto. A map that fails its acceptance exits 3 and is
# written with --keep-failed, so its numbers are printed too. Prints one row per input and the
# requirements with PASS/FAIL.
set -euo pipefail
cd "$(dirname "$0")/.."
build=${1:-build}
bin="$PWD/$build/authalic"
data=../shared/data/fs741
evalmap=../shared/tools/evalmap.py
py=/usr/bin/python3
[ -x "$bin" ] || { echo "bench_real: $bin not found; build first (scripts/build.sh)" >&2; exit 2; }
[ -f "$data/lh.white.surf.gii" ] || { echo "bench_real: $data not found (../shared/data is needed)" >&2; exit 2; }
work=$(mktemp -d)
load_start=$(cut -d" " -f1-3 /proc/loadavg)
trap 'rm -rf "$work"' EXIT

# run NAME SURFACE REGION : flatten with /usr/bin/time; leaves $work/NAME.{json,uv.surf.gii,time,code}
run() {
  local name=$1 surf=$2 region=$3
  set +e
  /usr/bin/time -v "$bin" flatten "$surf" "$work/$name.surf.gii" --uv "$work/$name.uv.surf.gii" --label "$region" \
    --metrics "$work/$name.json" --keep-failed -q 2>"$work/$name.time"
  echo $? >"$work/$name.code"
  set -e
}
for s in white pial; do
  run "R1-$s" "$data/lh.$s.surf.gii" "$data/lh.cortex.label"
  run "R2-$s" "$data/lh.$s.surf.gii" "$data/lh.cortex96_mask.shape.gii"
done
# The sphere (default route) of the closed white and pial surfaces, measured by evalmap --domain sphere.
for s in white pial; do
  set +e
  /usr/bin/time -v "$bin" sphere "$data/lh.$s.surf.gii" "$work/S-$s.sphere.surf.gii" --metrics "$work/S-$s.json" --keep-failed -q \
    2>"$work/S-$s.time"
  echo $? >"$work/S-$s.code"
  set -e
  $py "$evalmap" "$data/lh.$s.surf.gii" "$work/S-$s.sphere.surf.gii" --domain sphere --json >"$work/S-$s.eval.json" 2>/dev/null ||
    echo '{}' >"$work/S-$s.eval.json"
done
# The one-surface 2:1 rectangle: the closed white hemisphere cut open along its inferior-medial path.
set +e
/usr/bin/time -v "$bin" rectangle "$work/W.rect.surf.gii" --surface "$data/lh.white.surf.gii" --cut-surface --metrics "$work/W.json" \
  --keep-failed -q 2>"$work/W.time"
echo $? >"$work/W.code"
set -e
# evalmap measures it on the surface cut open (--cut-surface: the map's own vertices, the cut's
# copies included); evalmap's --inserted auto knows split vertices, not a cut's copies, and would
# drop the faces along the cut (CV 0.0149 for 0.0096).
$py "$evalmap" "$work/W.rect.cut.surf.gii" "$work/W.rect.surf.gii" --domain rect --json >"$work/W.eval.json" 2>/dev/null ||
  echo '{}' >"$work/W.eval.json"
for n in R1-white R1-pial R2-white R2-pial; do
  surf="$data/lh.${n#*-}.surf.gii"
  if [ -f "$work/$n.uv.surf.gii" ]; then
    $py "$evalmap" "$surf" "$work/$n.uv.surf.gii" --domain square --k 32 --inserted auto --json >"$work/$n.eval.json" 2>/dev/null ||
      echo '{}' >"$work/$n.eval.json"
  else
    echo '{}' >"$work/$n.eval.json"
  fi
done

# `run` on the subject: the left hemisphere and its mirror image (x -> -x, faces reversed) as the
# right, SPM's PET template as the PET (its space does not match the subject; fine for this check).
$py - "$data" "$work" <<'PYEOF'
import sys, numpy as np, nibabel as nib
data, work = sys.argv[1], sys.argv[2]
for s in ("white", "pial"):
    g = nib.load(f"{data}/lh.{s}.surf.gii")
    V = g.darrays[0].data.copy(); F = g.darrays[1].data.copy()
    V[:, 0] *= -1; F = F[:, [0, 2, 1]]
    nib.save(nib.gifti.GiftiImage(darrays=[
        nib.gifti.GiftiDataArray(V.astype(np.float32), intent="NIFTI_INTENT_POINTSET", datatype="NIFTI_TYPE_FLOAT32"),
        nib.gifti.GiftiDataArray(F.astype(np.int32), intent="NIFTI_INTENT_TRIANGLE", datatype="NIFTI_TYPE_INT32")]),
        f"{work}/rh.{s}.surf.gii")
PYEOF
set +e
/usr/bin/time -v "$bin" run --id fs741 --lh-white "$data/lh.white.surf.gii" --lh-pial "$data/lh.pial.surf.gii" \
  --rh-white "$work/rh.white.surf.gii" --rh-pial "$work/rh.pial.surf.gii" --lh-cortex "$data/lh.cortex.label" \
  --rh-cortex "$data/lh.cortex.label" --pet ../shared/data/spm/PET.nii --out "$work/run" -q 2>"$work/run.time"
echo $? >"$work/run.code"
set -e

PYTHONPATH=bench $py - "$work" "$load_start" <<'EOF'
import json, os, re, sys
from requirements import Requirements
work = sys.argv[1]
def timing(name):
    t = open(os.path.join(work, name + ".time")).read()
    wall = re.search(r"Elapsed \(wall clock\) time \(h:mm:ss or m:ss\): (\S+)", t).group(1).split(":")
    wall = sum(float(x) * 60 ** i for i, x in enumerate(reversed(wall)))
    cpu = sum(float(x) for x in re.findall(r"(?:User|System) time \(seconds\): (\S+)", t))
    rss = int(re.search(r"Maximum resident set size \(kbytes\): (\d+)", t).group(1)) / 1024
    return wall, cpu, rss
def ev(j, *keys):
    for k in keys:
        if not isinstance(j, dict) or k not in j: return float("nan")
        j = j[k]
    return j
print("| map | exit | wall s | cpu s | RSS MB | flips | element CV 32x32 | per-face mean | per-vertex mean | per-vertex p99 | stretch-energy steps | evalmap flips | evalmap CV 32 | evalmap face mean |")
print("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|")
reqs = []
for n in ["R1-white", "R1-pial", "R2-white", "R2-pial"]:
    code = int(open(os.path.join(work, n + ".code")).read())
    wall, cpu, rss = timing(n)
    p = os.path.join(work, n + ".json")
    j = json.load(open(p)) if os.path.exists(p) else {}
    e = json.load(open(os.path.join(work, n + ".eval.json")))
    m = j.get("metrics", {})
    cv, face = m.get("element_cv", float("nan")), ev(m, "face_ln_area_abs", "mean")
    vm, vp = ev(m, "vertex_ln_area_abs", "mean"), ev(m, "vertex_ln_area_abs", "p99")
    flips = j.get("flips", "-")
    its = ev(j, "initial_map", "stretch_energy", "iterations")
    print(f"| {n} | {code} | {wall:.2f} | {cpu:.2f} | {rss:.0f} | {flips} | {cv:.5f} | {face:.4f} | {vm:.4f} | {vp:.4f} | {its} | "
          f"{e.get('flips', 'nan')} | {e.get('element_area_cv_k32', float('nan')):.5f} | {e.get('ln_area_ratio_abs_mean', float('nan')):.4f} |")
    reqs += [(f"{n} exit code", code, 0), (f"{n} flips", flips if flips != "-" else 1e9, 0),
             (f"{n} element CV", cv, 0.005), (f"{n} per-vertex mean", vm, 0.01), (f"{n} per-face mean", face, 0.05),
             (f"{n} wall s", wall, 15.0), (f"{n} peak MB", rss, 1536)]
print("\n| sphere | exit | wall s | RSS MB | route | corner placements | flips | element CV 64x32 | elements / mean | per-face mean | per-vertex mean | evalmap flips | evalmap CV | evalmap face mean |")
print("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|")
for s in ["white", "pial"]:
    n = "S-" + s
    code = int(open(os.path.join(work, n + ".code")).read())
    wall, cpu, rss = timing(n)
    p = os.path.join(work, n + ".json")
    j = json.load(open(p)) if os.path.exists(p) else {}
    e = json.load(open(os.path.join(work, n + ".eval.json")))
    m = j.get("metrics", {})
    cv, face, vm = m.get("element_cv", float("nan")), ev(m, "face_ln_area_abs", "mean"), ev(m, "vertex_ln_area_abs", "mean")
    flips = m.get("flips", 1e9)
    placements = len(ev(j, "square_route", "corner_placements_tried")) if isinstance(ev(j, "square_route", "corner_placements_tried"), list) else "-"
    print(f"| {s} | {code} | {wall:.2f} | {rss:.0f} | {j.get('route', '-')} | {placements} | {flips} | {cv:.5f} | "
          f"{m.get('element_min_over_mean', float('nan')):.3f}-{m.get('element_max_over_mean', float('nan')):.3f} | {face:.4f} | {vm:.4f} | "
          f"{e.get('flips', 'nan')} | {e.get('element_area_cv', float('nan')):.5f} | {e.get('ln_area_ratio_abs_mean', float('nan')):.4f} |")
    reqs += [(f"sphere {s} exit code", code, 0), (f"sphere {s} flips", flips, 0), (f"sphere {s} evalmap flips", e.get("flips", 1e9), 0),
             (f"sphere {s} element CV", cv, 0.005), (f"sphere {s} per-face mean", face, 0.05), (f"sphere {s} wall s", wall, 15.0)]
code = int(open(os.path.join(work, "W.code")).read())
wall, cpu, rss = timing("W")
j = json.load(open(os.path.join(work, "W.json"))) if os.path.exists(os.path.join(work, "W.json")) else {}
e = json.load(open(os.path.join(work, "W.eval.json")))
m = j.get("metrics", {})
cv, face, flips = m.get("element_cv", float("nan")), ev(m, "face_ln_area_abs", "mean"), m.get("flips", 1e9)
limit = ev(j, "acceptance", "limits", "element_cv_64x32")
print(f"\none-surface rectangle of the closed white hemisphere: exit {code}, {wall:.1f} s wall, {rss:.0f} MB, flips {flips}, "
      f"element CV 64x32 {cv:.5f} (limit {limit:.4f}), elements {m.get('element_min_over_mean', float('nan')):.3f}-"
      f"{m.get('element_max_over_mean', float('nan')):.3f} x the mean, per-face mean {face:.4f}; evalmap flips {e.get('flips', 'nan')}, "
      f"CV {e.get('element_area_cv', float('nan')):.5f}")
reqs += [("rectangle --surface white exit code", code, 0), ("rectangle --surface white flips", flips, 0),
         ("rectangle --surface white evalmap flips", e.get("flips", 1e9), 0), ("rectangle --surface white element CV", cv, 0.01)]
code = int(open(os.path.join(work, "run.code")).read())
wall, cpu, rss = timing("run")
log = os.path.join(work, "run", "sub-fs741", "sub-fs741_log.txt")
cvs = re.findall(r"element-area CV ([0-9.e-]+)", open(log).read()) if os.path.exists(log) else []
report = os.path.exists(os.path.join(work, "run", "sub-fs741", "sub-fs741_report.html"))
print(f"\nrun on the subject (left + mirror, SPM PET): exit {code}, {wall:.1f} s wall, {cpu:.1f} s cpu, {rss:.0f} MB, "
      f"report {'written' if report else 'missing'}; element CV left/right square, rectangle (64x32): {', '.join(cvs) or '-'}")
reqs += [("run exit code", code, 0), ("run wall s", wall, 60.0), ("run report missing (1 = missing)", 0 if report else 1, 0)]
if len(cvs) == 3:
    reqs += [("rectangle (two hemispheres) element CV", float(cvs[2]), 0.005)]
print(f"\nload average (1, 5, 15 min) at the start: {sys.argv[2]}, at the end: {' '.join(open('/proc/loadavg').read().split()[:3])} "
      f"on {os.cpu_count()} cores (the wall-time rows assume a quiet machine: other work makes every one larger)")
print()
req = Requirements('real-mesh issue')
for name, value, limit in reqs:
    req(name, value, limit)
EOF
