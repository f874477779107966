#!/usr/bin/env bash
# Sphere and 2:1 rectangle maps (issue 4): wall time, peak memory, iterations and distortion,
# printed as tables with the issue's requirements checked.
#   bench/bench_sphere.sh            binary: $AUTHALIC, default build/authalic
# Inputs (../shared/data/fsaverage5): S1 = white_left, S2 = pial_left, S3 = S1 subdivided twice
# (`authalic subdivide --times 2`); FreeSurfer's sphere_left measured with `authalic metrics`
# against S1 and S2; the conformal initial map (Haker + Moebius centring) of each input.
# Rectangle: two hemispheres (B1 = white_left with flat_left's cortex faces, and its mirror image
# as the right hemisphere: x negated, triangles reversed, written here with nibabel) and the
# one-surface form on S1. Cross-check: ../shared/tools/evalmap.py on S1's sphere and on the
# one-surface rectangle (its element CV is a Monte Carlo estimate with a sampling floor ~0.01).
# Times: `authalic sphere IN OUT` alone (reading, mapping, writing; metrics are computed in a third,
# untimed run); the machine may be shared, so each input runs with the OpenMP default and with
# OMP_NUM_THREADS=2; RSS is the larger of the two. Determinism: S1 with --threads 1 and --threads 2 must give identical output.
set -euo pipefail
cd "$(dirname "$0")/.."
bin=${AUTHALIC:-build/authalic}
data=../shared/data/fsaverage5
evalmap=../shared/tools/evalmap.py
[ -x "$bin" ] || { echo "bench_sphere: $bin not found; build first or set AUTHALIC" >&2; exit 2; }
[ -f "$data/white_left.gii.gz" ] || { echo "bench_sphere: $data not found (shared data)" >&2; exit 2; }
py=""
for p in python3 /usr/bin/python3; do
  if command -v "$p" >/dev/null && "$p" -c 'import numpy, nibabel' 2>/dev/null; then py=$p; break; fi
done
[ -n "$py" ] || { echo "bench_sphere: needs python3 with numpy and nibabel" >&2; exit 2; }
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

# evalmap_check WHAT SURFACE MAP DOMAIN AUTHALIC_JSON: the independent evalmap.py metrics of MAP
# beside the ones authalic wrote in AUTHALIC_JSON (Lambda and extent where evalmap gives them).
evalmap_check() {
  "$py" "$evalmap" "$2" "$3" --domain "$4" --k 32 --json >"$work/check.eval.json"
  "$py" - "$1" "$work/check.eval.json" "$5" <<'EOF'
import json, sys
what, e, m = sys.argv[1], json.load(open(sys.argv[2])), json.load(open(sys.argv[3]))["metrics"]
extra = ""
if "qc_lambda_mean" in e and "lambda" in m:
    extra = f"Lambda {e['qc_lambda_mean']:.3f} (authalic {m['lambda']['mean']:.3f}), extent {e['extent']}, "
print(f"evalmap.py on {what}: flips {e['flips']} (authalic {m['flips']}), per-face |ln ar| "
      f"{e['ln_area_ratio_abs_mean']:.4f} (authalic {m['face_ln_area_abs']['mean']:.4f}), {extra}element CV "
      f"{e['element_area_cv']:.4f} Monte Carlo (authalic exact {m['element_cv']:.4f})")
EOF
}

# timed NAME ENV... -- ARGS...: runs $bin ARGS under /usr/bin/time -v; sets wall (s) and rss (MB).
timed() {
  local name=$1
  shift
  local envs=()
  while [ "$1" != "--" ]; do envs+=("$1"); shift; done
  shift
  if ! env "${envs[@]}" /usr/bin/time -v "$bin" "$@" >"$work/$name.out" 2>"$work/$name.time"; then
    echo "bench_sphere: '$bin $*' failed:" >&2
    tail -5 "$work/$name.time" >&2
    exit 1
  fi
  wall=$(awk -F': ' '/Elapsed \(wall clock\)/{n = split($2, t, ":"); s = 0; for (i = 1; i <= n; i++) s = s * 60 + t[i]; printf "%.2f", s}' "$work/$name.time")
  rss=$(awk -F': ' '/Maximum resident set size/{printf "%.0f", $2 / 1024}' "$work/$name.time")
}

"$bin" subdivide "$data/white_left.gii.gz" "$work/s3.surf.gii" --times 2 -q

declare -A surf=([S1]="$data/white_left.gii.gz" [S2]="$data/pial_left.gii.gz" [S3]="$work/s3.surf.gii")
declare -A face_max=([S1]=0.06 [S2]=0.08 [S3]=0.06)
declare -A time_max=([S1]=2 [S2]=2 [S3]=15)

echo "## authalic sphere (element CV over 64 x 32 equal-area cells; |ln ar| = per-face mean |ln area ratio|)"
echo
printf "| %-26s | %8s | %8s | %9s | %7s | %5s | %5s | %7s | %7s | %6s | %s\n" \
  map vertices "wall (s)" "OMP=2 (s)" "RSS MB" iters flips "|ln ar|" "elem CV" Lambda requirement
echo "|----------------------------|----------|----------|-----------|---------|-------|-------|---------|---------|--------|------------"
fail=0
for s in S1 S2 S3; do
  # Timed: the map alone (read, map, write), OpenMP default and 2 threads; then, untimed, the
  # same map with its metrics and the conformal initial map.
  timed "$s.omp2" OMP_NUM_THREADS=2 -- sphere "${surf[$s]}" "$work/$s.omp2.surf.gii" -q
  wall2=$wall rss2=$rss
  timed "$s" -- sphere "${surf[$s]}" "$work/$s.plain.surf.gii" -q
  [ "$rss2" -gt "$rss" ] && rss=$rss2
  "$bin" sphere "${surf[$s]}" "$work/$s.sphere.surf.gii" --metrics "$work/$s.json" -q
  # The flow route beside it, with its conformal initial map.
  "$bin" sphere "${surf[$s]}" "$work/$s.flow.surf.gii" --route flow --metrics "$work/$s.flow.json" \
    --conformal "$work/$s.conformal.surf.gii" -q --keep-failed || true
  row=$("$py" - "$work/$s.json" "$s" "$wall" "$wall2" "$rss" "${face_max[$s]}" "${time_max[$s]}" "$work/$s.flow.json" 2>"$work/$s.status" <<'EOF'
import json, sys
j = json.load(open(sys.argv[1])); s, wall, wall2, rss, fmax, tmax = sys.argv[2:8]
jf = json.load(open(sys.argv[8]))
m = j["metrics"]; c = jf["conformal_metrics"]; mf = jf["metrics"]
ok = (m["flips"] == 0 and m["element_cv"] <= 0.01 and m["face_ln_area_abs"]["mean"] <= float(fmax)
      and float(wall) <= float(tmax) and float(rss) <= 2048)
req = f"flips 0, CV<=0.01, |ln ar|<={fmax}, <={tmax} s, <=2 GB: " + ("PASS" if ok else "FAIL")
fmt = "| {:<26} | {:>8} | {:>8} | {:>9} | {:>7} | {:>5} | {:>5} | {:>7.4f} | {:>7.4f} | {:>6.3f} | {}"
print(fmt.format(f"{s} authalic ({j['route']} route)", j["vertices"], wall, wall2, rss, "-", m["flips"],
                 m["face_ln_area_abs"]["mean"], m["element_cv"], m["lambda"]["mean"], req))
print(fmt.format(f"{s} flow route", j["vertices"], "", "", "", jf["flow"]["iterations"], mf["flips"],
                 mf["face_ln_area_abs"]["mean"], mf["element_cv"], mf["lambda"]["mean"], ""))
print(fmt.format(f"{s} conformal initial map", j["vertices"], "", "", "", "", c["flips"],
                 c["face_ln_area_abs"]["mean"], c["element_cv"], c["lambda"]["mean"], ""))
if not ok: print("FAIL", file=sys.stderr)
EOF
  )
  echo "$row"
  if grep -q FAIL "$work/$s.status"; then fail=1; fi
  if [ "$s" != S3 ]; then
    "$bin" metrics "${surf[$s]}" "$data/sphere_left.gii.gz" --domain sphere --k 32 --json >"$work/$s.fs.json"
    "$py" - "$work/$s.fs.json" "$s" <<'EOF'
import json, sys
m = json.load(open(sys.argv[1]))
print("| {:<26} | {:>8} | {:>8} | {:>9} | {:>7} | {:>5} | {:>5} | {:>7.4f} | {:>7.4f} | {:>6.3f} | {}".format(
    f"{sys.argv[2]} FreeSurfer sphere_left", m["vertices"], "", "", "", "", m["flips"], m["face_ln_area_abs"]["mean"],
    m["element_cv"], m["lambda"]["mean"], ""))
EOF
  fi
done

# Determinism: --threads 1 and --threads 2 give the same sphere.
"$bin" sphere "${surf[S1]}" "$work/t1.surf.gii" --threads 1 -q
"$bin" sphere "${surf[S1]}" "$work/t2.surf.gii" --threads 2 -q
same=$("$py" -c '
import sys, nibabel as nib, numpy as np
a, b = (nib.load(f).darrays[0].data for f in sys.argv[1:3])
print("identical" if np.array_equal(a, b) else "DIFFERENT (max %g)" % np.abs(a - b).max())' "$work/t1.surf.gii" "$work/t2.surf.gii")
[ "$same" = identical ] || fail=1
echo
echo "S1 with --threads 1 and --threads 2: $same output"

# Independent check of the S1 row.
echo
evalmap_check "S1's sphere" "${surf[S1]}" "$work/S1.sphere.surf.gii" sphere "$work/S1.json"

# ---- rectangle -----------------------------------------------------------------------------
"$py" - "$data/white_left.gii.gz" "$data/flat_left.gii.gz" "$work/rh.white.surf.gii" "$work/rh.faces.surf.gii" <<'EOF'
import sys, numpy as np, nibabel as nib
from nibabel.gifti import GiftiImage, GiftiDataArray
for src, dst in ((sys.argv[1], sys.argv[3]), (sys.argv[2], sys.argv[4])):
    g = nib.load(src)
    P = np.array([a.data for a in g.darrays if a.intent == 1008][0], np.float32)
    T = np.array([a.data for a in g.darrays if a.intent == 1009][0], np.int32)
    P[:, 0] = -P[:, 0]          # mirror image: x negated ...
    T = T[:, [0, 2, 1]].copy()  # ... and triangles reversed, so normals still point outward
    out = GiftiImage()
    out.add_gifti_data_array(GiftiDataArray(P, intent="NIFTI_INTENT_POINTSET", datatype="NIFTI_TYPE_FLOAT32"))
    out.add_gifti_data_array(GiftiDataArray(T, intent="NIFTI_INTENT_TRIANGLE", datatype="NIFTI_TYPE_INT32"))
    nib.save(out, dst)
EOF
timed rect2 -- rectangle "$work/brain" --lh "$data/white_left.gii.gz" --lh-faces-from "$data/flat_left.gii.gz" \
  --rh "$work/rh.white.surf.gii" --rh-faces-from "$work/rh.faces.surf.gii" --metrics "$work/rect2.json" -q
wall_r2=$wall rss_r2=$rss
timed rect1 -- rectangle "$work/whole.surf.gii" --surface "$data/white_left.gii.gz" --metrics "$work/rect1.json" --cut-surface -q
wall_r1=$wall rss_r1=$rss
echo
echo "## authalic rectangle [0, 2] x [0, 1] (element CV over 64 x 32 cells; covered = sum |signed area| of the map)"
echo
"$py" - "$work" "$wall_r2" "$rss_r2" "$wall_r1" "$rss_r1" <<'EOF' 2>"$work/rect.status"
import json, sys, numpy as np, nibabel as nib
work, w2, r2, w1, r1 = sys.argv[1:6]
def covered(files):
    total = 0.0
    for f in files:
        g = nib.load(f)
        P = np.asarray([a.data for a in g.darrays if a.intent == 1008][0], float)
        T = np.asarray([a.data for a in g.darrays if a.intent == 1009][0], np.int64)
        d, e = P[T[:, 1], :2] - P[T[:, 0], :2], P[T[:, 2], :2] - P[T[:, 0], :2]
        total += np.abs(0.5 * (d[:, 0] * e[:, 1] - d[:, 1] * e[:, 0])).sum()
    return total
fmt = "| {:<30} | {:>8} | {:>7} | {:>9} | {:>5} | {:>7} | {:>7} | {:>6} | {:>22} | {:>8} | {}"
print(fmt.format("map", "wall (s)", "RSS MB", "iters", "flips", "|ln ar|", "elem CV", "Lambda", "extent", "covered", "requirement"))
print("|--------------------------------|----------|---------|-----------|-------|---------|---------|--------|------------------------|----------|------------")
bad = False
for name, js, wall, rss, files in (
        ("two hemispheres: B1 + mirror", "rect2.json", w2, r2, [f"{work}/brain.lh.surf.gii", f"{work}/brain.rh.surf.gii"]),
        ("one surface: S1 cut open", "rect1.json", w1, r1, [f"{work}/whole.surf.gii"])):
    j = json.load(open(f"{work}/{js}")); m = j["metrics"]
    parts = [j["left"], j["right"]] if "left" in j else [j["part"]]
    iters = "+".join(str(p["flow"]["iterations"]) for p in parts)
    ext = [round(x, 9) for x in j["extent"]]
    cov = covered(files)
    ok = m["flips"] == 0 and m["element_cv"] <= 0.01 and ext == [0.0, 0.0, 2.0, 1.0] and abs(cov - 2.0) < 1e-4
    bad |= not ok
    print(fmt.format(name, wall, rss, iters, m["flips"], f"{m['face_ln_area_abs']['mean']:.4f}", f"{m['element_cv']:.4f}",
                     f"{m['lambda']['mean']:.3f}", str(ext), f"{cov:.6f}",
                     "flips 0, CV<=0.01, 2:1 covered: " + ("PASS" if ok else "FAIL")))
    if "split_x" in j: print(f"|   (parts meet on x = {j['split_x']:.6f}; left {parts[0]['area_mm2']:.1f} mm^2, right {parts[1]['area_mm2']:.1f} mm^2)")
if bad: print("FAIL", file=sys.stderr)
EOF
if grep -q FAIL "$work/rect.status"; then fail=1; fi
echo
evalmap_check "the one-surface rectangle" "$work/whole.cut.surf.gii" "$work/whole.surf.gii" rect "$work/rect1.json"
echo
if [ "$fail" = 0 ]; then echo "all requirements met"; else echo "SOME REQUIREMENTS MISSED (see FAIL above)"; fi
exit "$fail"
