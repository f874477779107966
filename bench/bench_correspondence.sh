#!/usr/bin/env bash
# Issue 14: do elements mean the same anatomy in every subject? On a phantom with anatomical
# variability (20 controls + 2 patients, each a smooth random variant of fsaverage5 with local area
# changes up to about 15 %, a folding change and a non-trivial but exact sphere.reg; `authalic
# phantom --anatomical-variability`), prints per correspondence mode:
#  - the share of each subject's cortical area (left hemisphere, barycentric vertex areas of its white
#    surface) whose vertices fall into the same element (K = 32) as their corresponding atlas point
#    (the atlas map at the point sphere.reg names; the phantom's truth/lh.atlas_uv.func.gii), and the
#    area-weighted median displacement in elements: per-subject mode (today's default) and atlas mode
#    (run --atlas: >= 90 % required) and registration mode (run --atlas without sphere.reg: the
#    subject's map aligned to the atlas's by sulcal depth; >= 85 % required);
#  - the ceiling of any equal-area map on this phantom: atlas mode refined by optimal transport (the
#    least-displacement authalic map from the exact correspondence), and registration mode's share
#    as a percentage of it;
#  - every atlas- and registration-mode map's element CV (<= 0.005) and flips (0), from the run sidecars;
#  - the normative validation in atlas and in registration mode: each patient's -25 % region recovered (>= 90 % of the
#    elements fully inside it flagged hypo), and the mean over controls (leave-one-out: each against
#    a reference of the other 19) of the share of elements at |z| >= 2, beside what the t distribution
#    predicts for that reference (z = (x - mean) / (SD sqrt(1 + 1/n)) ~ t with n - 1 df; required
#    within 1.5 percentage points).
#  - registration mode on the native real subject (fs741 lh.white against fsaverage5): CPU, peak
#    memory, depth alignment and distortion, beside its per-subject map.
#   bench/bench_correspondence.sh [AUTHALIC]   (needs ../shared/data and /usr/bin/python3 with nibabel, scipy)
set -euo pipefail
ROOT="$(cd "$(dirname "$0")/.." && pwd)"
AUTHALIC="$(realpath "${1:-${AUTHALIC:-$ROOT/build/authalic}}")"
SHARED="$ROOT/../shared/data"
PY=/usr/bin/python3
[ -x "$AUTHALIC" ] || { echo "bench_correspondence: $AUTHALIC not found; build first (scripts/build.sh)" >&2; exit 2; }
[ -f "$SHARED/fsaverage5/white_left.gii.gz" ] || { echo "bench_correspondence: $SHARED/fsaverage5 missing" >&2; exit 2; }
WORK=$(mktemp -d)
trap 'rm -rf "$WORK"' EXIT
CONTROLS=${CONTROLS:-20}
SEED=${SEED:-1}  # another phantom draw: SEED=2 bench/bench_correspondence.sh

t0=$(date +%s)
"$AUTHALIC" phantom "$WORK/ph" --anatomical-variability --controls "$CONTROLS" --patients 2 --seed "$SEED" --shared "$SHARED" -q
t1=$(date +%s)
"$AUTHALIC" group "$WORK/ph/cohort.csv" "$WORK/own" --jobs 2 --k 32 --force -q >/dev/null || echo "per-subject group: exit $?"
t2=$(date +%s)
"$AUTHALIC" group "$WORK/ph/cohort.csv" "$WORK/atl" --jobs 2 --k 32 --force -q --atlas "$WORK/ph/atlas" >/dev/null || echo "atlas group: exit $?"
t3=$(date +%s)
# Registration mode: the same cohort without its sphere.reg columns (as GIFTI from a pipeline
# without FreeSurfer's registration would be), mapped with the atlas.
$PY -c 'import csv, sys
rows = list(csv.DictReader(open(sys.argv[1])))
keep = [k for k in rows[0] if not k.endswith("_sphere_reg")]
w = csv.DictWriter(open(sys.argv[2], "w", newline=""), fieldnames=keep, extrasaction="ignore")
w.writeheader(); w.writerows(rows)' "$WORK/ph/cohort.csv" "$WORK/ph/cohort_noreg.csv"
"$AUTHALIC" group "$WORK/ph/cohort_noreg.csv" "$WORK/reg" --jobs 2 --k 32 --force -q --atlas "$WORK/ph/atlas" >/dev/null || echo "registration group: exit $?"
t4=$(date +%s)
echo "phantom (seed $SEED) $((t1 - t0)) s; group per-subject $((t2 - t1)) s; group atlas $((t3 - t2)) s; group registration $((t4 - t3)) s"

AUTHALIC="$AUTHALIC" PH="$WORK/ph" OWN="$WORK/own" ATL="$WORK/atl" REG="$WORK/reg" VAL="$WORK/val" $PY - <<'PYEOF'
import csv, json, os, subprocess
import numpy as np, nibabel as nib
from scipy import stats
exe, ph, own, atl, reg, val = (os.environ[k] for k in ("AUTHALIC", "PH", "OWN", "ATL", "REG", "VAL"))
os.makedirs(val)
K = 32
rows = list(csv.DictReader(open(os.path.join(ph, "cohort.csv"))))
controls = [r["subject_id"] for r in rows if r["role"] == "control"]
patients = [r["subject_id"] for r in rows if r["role"] == "patient"]

def sh(*args):
    r = subprocess.run([exe, *args], capture_output=True, text=True)
    if r.returncode != 0:
        raise SystemExit(f"{' '.join(args[:2])} failed (exit {r.returncode}): {r.stderr.strip()}")
    return r.stdout

def vertex_areas(V, F):
    a = 0.5 * np.linalg.norm(np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]]), axis=1)
    out = np.zeros(len(V))
    for c in range(3):
        np.add.at(out, F[:, c], a / 3)
    return out

def correspondence(run_dir, sid):
    flat = nib.load(os.path.join(run_dir, f"sub-{sid}", f"sub-{sid}_hemi-L_space-authalic_flat.surf.gii"))
    xy = flat.darrays[0].data[:, :2].astype(float)
    F = flat.darrays[1].data.astype(int)
    uv = (xy - xy.min(axis=0)) / (xy.max(axis=0) - xy.min(axis=0))   # the square's sides are reached
    V, _ = nib.freesurfer.read_geometry(os.path.join(ph, f"sub-{sid}", "surf", "lh.white"))
    n = len(V)
    F = F[(F < n).all(axis=1)]
    w = vertex_areas(V, F)
    truth = np.column_stack([d.data for d in nib.load(os.path.join(ph, f"sub-{sid}", "truth", "lh.atlas_uv.func.gii")).darrays])
    cell = lambda p: np.clip(np.floor(p * K).astype(int), 0, K - 1)
    same = (cell(uv[:n]) == cell(truth)).all(axis=1)
    shift = np.linalg.norm(uv[:n] - truth, axis=1) * K
    m = w > 0
    order = np.argsort(shift[m])
    cum = np.cumsum(w[m][order])
    median = shift[m][order][np.searchsorted(cum, cum[-1] / 2)]
    return (w * same).sum() / w.sum(), median

subjects = controls + patients
bars = {"atlas": 90, "registration": 85}
share_of = {}  # mode -> per-subject same-element share
for name, d in (("per-subject", own), ("atlas", atl), ("registration", reg)):
    res = np.array([correspondence(d, s) for s in subjects])
    share_of[name] = res[:, 0]
    share = 100 * res[:, 0]
    print(f"{name:12s} mode: same element as the corresponding atlas cortex: mean {share.mean():.1f} %, worst {share.min():.1f} %, "
          f"best {share.max():.1f} % of the cortical area ({len(subjects)} subjects); median displacement "
          f"{np.median(res[:, 1]):.2f} elements (worst subject {res[:, 1].max():.2f})"
          + (f"   [required: >= {bars[name]} % for every subject: " + ("PASS" if share.min() >= bars[name] else "FAIL") + "]" if name in bars else ""))

# The ceiling for an equal-area map: atlas mode refined by optimal transport (flatten --refine omt:
# among authalic maps the one that moves area the least from its start, here the exact
# correspondence). If it keeps no more area in the same element than atlas mode, what atlas mode
# loses is what the equal-area constraint costs, not a shortfall of the method.
ceil = os.path.join(val, "omt")
atl_share, reg_share = share_of["atlas"], share_of["registration"]
for s in subjects:
    os.makedirs(os.path.join(ceil, f"sub-{s}"), exist_ok=True)
    sd = os.path.join(ph, f"sub-{s}")
    sh("flatten", os.path.join(sd, "surf", "lh.white"), os.path.join(ceil, f"sub-{s}", f"sub-{s}_hemi-L_space-authalic_flat.surf.gii"),
       "--label", os.path.join(sd, "label", "lh.cortex.label"), "--sphere-reg", os.path.join(sd, "surf", "lh.sphere.reg"),
       "--atlas", os.path.join(ph, "atlas"), "--refine", "omt", "--quiet")
omt_share = np.array([correspondence(ceil, s)[0] for s in subjects])
print(f"atlas mode + optimal transport (least-displacement authalic map from the exact correspondence): mean "
      f"{100 * omt_share.mean():.1f} %, worst {100 * omt_share.min():.1f} % (atlas mode {100 * atl_share.mean():.1f} %; "
      f"largest gain of a subject {100 * (omt_share - atl_share).max():+.1f} points)")
print(f"registration mode against that ceiling: {100 * reg_share.mean() / omt_share.mean():.1f} % of its mean share "
      f"(the issue's bars imply 85 / 90 = 94.4 %: {'PASS' if reg_share.mean() / omt_share.mean() >= 85 / 90 else 'FAIL'})")

own_cv = [json.load(open(os.path.join(own, f"sub-{s}", f"sub-{s}_hemi-{h}_space-authalic_flat.json")))["metrics"]["element_area_cv"]
          for s in subjects for h in "LR"]
print(f"per-subject-mode maps ({len(own_cv)}): element CV median {np.median(own_cv):.4f}, max {max(own_cv):.4f} (for comparison)")


def map_acceptance(name, d):
    cvs, flips = [], []
    for s in subjects:
        for h in "LR":
            j = json.load(open(os.path.join(d, f"sub-{s}", f"sub-{s}_hemi-{h}_space-authalic_flat.json")))
            cvs.append((j["metrics"]["element_area_cv"], f"{s} {h}")); flips.append(j["metrics"]["flips"])
            assert j["parameters"]["correspondence"].startswith(name + " "), j["parameters"]["correspondence"]
    cv_values = np.array([c for c, _ in cvs])
    print(f"{name}-mode maps ({len(cvs)}): element CV median {np.median(cv_values):.4f}, max {max(cvs)[0]:.4f} ({max(cvs)[1]}; "
          f"{int((cv_values > 0.005).sum())} above 0.005: {'PASS' if cv_values.max() <= 0.005 else 'FAIL'}), "
          f"flips max {max(flips)} (0: {'PASS' if max(flips) == 0 else 'FAIL'})")


def normative_validation(name, d):
    table = lambda s: os.path.join(d, f"sub-{s}", f"sub-{s}_elements.tsv")
    fractions = []
    for s in controls:
        ref = os.path.join(val, f"{name}-loo-{s}.json")
        sh("normative", "build", ref, *[table(c) for c in controls if c != s], "--quiet")
        j = json.loads(sh("normative", "compare", ref, table(s), os.path.join(val, f"{name}-cmp-{s}"), "--json", "--quiet"))
        fractions.append((j["counts"]["hypo"] + j["counts"]["hyper"]) / j["counts"]["compared"])
    f = 100 * np.array(fractions)
    n_ref = len(controls) - 1
    predicted = 100 * 2 * stats.t.sf(2.0, n_ref - 1)
    print(f"{name} mode, controls, leave-one-out ({len(controls)} controls, each vs the other {n_ref}): mean {f.mean():.2f} % of "
          f"elements at |z| >= 2 (largest {f.max():.1f} %); t distribution ({n_ref - 1} df, predictive SD): {predicted:.2f} %; "
          f"difference {f.mean() - predicted:+.2f} pp (within 1.5: {'PASS' if abs(f.mean() - predicted) <= 1.5 else 'FAIL'})")
    for p in patients:
        sh("normative", "compare", os.path.join(d, "normative.json"), table(p), os.path.join(val, f"{name}-{p}"), "--quiet")
        z = np.asarray(nib.load(os.path.join(val, f"{name}-{p}_z.nii.gz")).dataobj, dtype=float)
        inside = found = outside = false = 0
        for b, (hemi, fs) in enumerate((("L", "lh"), ("R", "rh"))):
            out = os.path.join(val, f"{name}-truth-{p}-{fs}")
            sh("elements", os.path.join(ph, f"sub-{p}", "surf", f"{fs}.white"),
               os.path.join(d, f"sub-{p}", f"sub-{p}_hemi-{hemi}_space-authalic_flat.surf.gii"),
               os.path.join(ph, f"sub-{p}", "truth", f"{fs}.lesion.label.gii"), out, "--k", str(K), "--quiet")
            for e in csv.DictReader(open(out + ".tsv"), delimiter="\t"):
                t, zz = float(e["value"]), z[int(e["col"]), int(e["row"]), b]
                if t >= 1 - 1e-9:
                    inside += 1; found += zz <= -2
                elif t <= 1e-12:
                    outside += 1; false += abs(zz) >= 2
        print(f"{p} (-25 % region) vs {len(controls)} controls, {name} mode: {found} of {inside} elements fully inside flagged "
              f"hypo = {100 * found / max(inside, 1):.1f} % (>= 90 %: {'PASS' if found >= 0.9 * inside else 'FAIL'}); "
              f"{100 * false / max(outside, 1):.1f} % of the elements outside flagged")
        # Clusters beyond the controls' chance clusters (analysis/normative.h): p_controls < 0.05.
        clusters = json.load(open(os.path.join(val, f"{name}-{p}.json")))["clusters"]
        beyond = [c for c in clusters if c["p_controls"] is not None and c["p_controls"] < 0.05]
        rest = sorted(c["p_controls"] for c in clusters if c["p_controls"] is not None and c["p_controls"] >= 0.05)
        print(f"{p}, {name} mode: {len(beyond)} of {len(clusters)} clusters beyond every control's chance clusters ("
              + ", ".join(f"{c['hemisphere']} {c['sign']} {c['num_elements']} elements, p {c['p_controls']:.3f}" for c in beyond)
              + f"); the others' p from {rest[0] if rest else float('nan'):.2f}")


for name, d in (("atlas", atl), ("registration", reg)):
    map_acceptance(name, d)
    normative_validation(name, d)
PYEOF

# Registration mode on the native-resolution real subject (fs741 lh.white, no sphere.reg) against
# fsaverage5, one thread: CPU, peak memory, the depth alignment and the map's distortion, beside the
# same surface mapped per subject.
FS741="$SHARED/fs741"
FS5="$SHARED/fsaverage5"
ATLAS5=(--atlas-surface "$FS5/white_left.gii.gz" --atlas-sphere "$FS5/sphere_left.gii.gz" --atlas-faces-from "$FS5/flat_left.gii.gz")
for mode in per-subject registration; do
  extra=()
  [ "$mode" = registration ] && extra=(--register "${ATLAS5[@]}")
  set +e
  /usr/bin/time -f "%U %S %M" -o "$WORK/fs741.$mode.t" "$AUTHALIC" flatten "$FS741/lh.white.surf.gii" "$WORK/fs741.$mode.surf.gii" \
    --label "$FS741/lh.cortex.label" --threads 1 --json -q "${extra[@]}" >"$WORK/fs741.$mode.json"
  code=$?
  set -e
  MODE=$mode CODE=$code T="$WORK/fs741.$mode.t" J="$WORK/fs741.$mode.json" $PY - <<'PYEOF'
import json, os
user, sys_, rss = open(os.environ["T"]).read().split()[-3:]
if os.environ["CODE"] != "0":
    print(f"fs741 lh.white {os.environ['MODE']}: exit {os.environ['CODE']} (FAIL)")
    raise SystemExit
j = json.load(open(os.environ["J"]))
m, c = j["metrics"], j["correspondence"]
line = (f"fs741 lh.white ({m['vertices']} vertices) {os.environ['MODE']:12s}: {float(user) + float(sys_):.1f} s CPU, "
        f"{int(rss) / 1024:.0f} MB peak; element CV {m['element_cv']:.4f}, per-face mean |ln area ratio| "
        f"{m['face_ln_area_abs']['mean']:.4f}, per-vertex {m['vertex_ln_area_abs']['mean']:.4f}, flips {m['flips']}")
if "depth_correlation_before" in c:
    line += (f"; depth correlation with the atlas {c['depth_correlation_before']:.2f} -> {c['depth_correlation_after']:.2f} "
             f"in {c['registration_iterations']} steps, vertices moved median "
             f"{c['registration_displacement_elements']['median']:.2f} elements; flow afterwards median "
             f"{c['flow_displacement_elements']['median']:.3f}")
    line += "   [authalic: " + ("PASS" if m["element_cv"] <= 0.005 and m["flips"] == 0 else "FAIL") + "]"
print(line)
PYEOF
done
