#!/usr/bin/env bash
# Benchmarks of the PET analysis (issues 5 and 6): normal projection, ribbon sampling beside
# Connectome Workbench, equal-area elements, normative build/compare. Prints a table with the
# targets; peak memory from /usr/bin/time -v ("Maximum resident set size").
#
#   bench/bench_analysis.sh [path/to/authalic]   (default: $AUTHALIC, else build/authalic)
#
# Inputs are made on the fly in a temporary folder (python3 + numpy + nibabel): a 163,842-vertex
# cortex (fsaverage5 pial subdivided twice, or a sphere when ../shared/data is absent) in a 1 mm
# volume (the ICBM T1 grid: step 0.5 mm, 21 samples over 10 mm), a 150,544-vertex folded square
# for the elements, and 1,000 two-hemisphere element tables at K = 64 for the reference. Then the
# issue-6 validation on the committed phantom (sample_data): `authalic group`, leave-one-out among
# the 20 controls, and the two patients' planted region (a few minutes: 22 subjects' maps).
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
AUTHALIC="$(realpath "${1:-${AUTHALIC:-$ROOT/build/authalic}}")"
SHARED="$ROOT/../shared/data"
PY=/usr/bin/python3
WORK="$(mktemp -d /tmp/authalic-bench-analysis.XXXXXX)"
trap 'rm -rf "$WORK"' EXIT
[ -x "$AUTHALIC" ] || { echo "no authalic executable at $AUTHALIC; build it first" >&2; exit 2; }

echo "authalic: $AUTHALIC"
echo "work dir: $WORK"
echo "preparing inputs ..."
SHARED="$SHARED" WORK="$WORK" $PY - <<'EOF'
import json, os, numpy as np, nibabel as nib
shared, work = os.environ["SHARED"], os.environ["WORK"]
rng = np.random.default_rng(1)

def gifti_surface(path, V, F):
    img = nib.gifti.GiftiImage()
    img.add_gifti_data_array(nib.gifti.GiftiDataArray(V.astype(np.float32), intent="NIFTI_INTENT_POINTSET", datatype="NIFTI_TYPE_FLOAT32"))
    img.add_gifti_data_array(nib.gifti.GiftiDataArray(F.astype(np.int32), intent="NIFTI_INTENT_TRIANGLE", datatype="NIFTI_TYPE_INT32"))
    nib.save(img, path)

def gifti_func(path, x):
    img = nib.gifti.GiftiImage()
    img.add_gifti_data_array(nib.gifti.GiftiDataArray(x.astype(np.float32), intent="NIFTI_INTENT_NONE", datatype="NIFTI_TYPE_FLOAT32"))
    nib.save(img, path)

def subdivide(V, F):
    E = np.sort(np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]]), axis=1)
    uniq, inv = np.unique(E, axis=0, return_inverse=True)
    mid = len(V) + inv.reshape(3, -1).T          # midpoints of edges (01, 12, 20)
    V2 = np.vstack([V, 0.5 * (V[uniq[:, 0]] + V[uniq[:, 1]])])
    a, b, c = F.T
    m01, m12, m20 = mid.T
    F2 = np.vstack([np.c_[a, m01, m20], np.c_[m01, b, m12], np.c_[m20, m12, c], np.c_[m01, m12, m20]])
    return V2, F2

t1 = os.path.join(shared, "mni152/mni_icbm152_t1_tal_nlin_sym_09a_converted.nii.gz")
pial = os.path.join(shared, "fsaverage5/pial_left.gii.gz")
if os.path.exists(t1) and os.path.exists(pial):
    vol = nib.load(t1)
    nib.save(nib.Nifti1Image(np.asarray(vol.dataobj, dtype=np.float32), vol.affine), os.path.join(work, "pet1mm.nii.gz"))
    g = nib.load(pial)
    V, F = g.darrays[0].data.astype(float), g.darrays[1].data.astype(np.int64)
else:
    aff = np.eye(4); aff[:3, 3] = -90
    x = np.indices((181, 217, 181)).astype(np.float32)
    nib.save(nib.Nifti1Image((100 + x[0] - x[1] + 0.5 * x[2]).astype(np.float32), aff), os.path.join(work, "pet1mm.nii.gz"))
    V = np.array([[1,0,0],[-1,0,0],[0,1,0],[0,-1,0],[0,0,1],[0,0,-1]], float)
    F = np.array([[0,2,4],[2,1,4],[1,3,4],[3,0,4],[2,0,5],[1,2,5],[3,1,5],[0,3,5]])
    while len(V) < 40000:
        V, F = subdivide(V, F); V = V / np.linalg.norm(V, axis=1)[:, None]
    V = 60 * V
for _ in range(2 if len(V) < 40000 else 0):
    V, F = subdivide(V, F)
gifti_surface(os.path.join(work, "cortex150k.surf.gii"), V, F)

# Folded square: 388 x 388 vertices; map = the grid, surface = a folded sheet.
n = 388
u, v = np.meshgrid(np.linspace(0, 1, n), np.linspace(0, 1, n))
uv = np.c_[u.ravel(), v.ravel(), np.zeros(n * n)]
i, j = np.meshgrid(np.arange(n - 1), np.arange(n - 1))
a = (j * n + i).ravel()
Fq = np.vstack([np.c_[a, a + 1, a + n + 1], np.c_[a, a + n + 1, a + n]])
S = np.c_[150 * uv[:, 0], 150 * uv[:, 1], 8 * np.sin(40 * uv[:, 0]) * np.cos(30 * uv[:, 1])]
gifti_surface(os.path.join(work, "sheet.surf.gii"), S, Fq)
gifti_surface(os.path.join(work, "sheet_map.surf.gii"), uv, Fq)
gifti_func(os.path.join(work, "sheet_values.func.gii"), 1 + 0.1 * np.sin(S[:, 0] / 9) + 0.01 * rng.standard_normal(n * n))

# 1,000 element tables, K = 64, left + right (8,192 rows each).
K = 64
ids = np.arange(K * K)
prefix = {h: [f"{e},{h},{e // K},{e % K},{50 + (e % 7):.6g},{-40 + e % K:.6g},{-80 + e // K:.6g},{20:.6g}," for e in ids] for h in ("left", "right")}
header = "id,hemisphere,row,col,area_mm2,centroid_x_mm,centroid_y_mm,centroid_z_mm,value,n_vertices\n"
os.makedirs(os.path.join(work, "tables"))
paths = []
base = 1 + 0.1 * np.sin(ids / 50.0)
for s in range(1001):
    sid = f"c{s:04d}" if s < 1000 else "patient"
    vals = base * rng.normal(1, 0.05) + rng.normal(0, 0.03, size=(2, K * K))
    if s == 1000:
        vals[0, 1000:1200] *= 0.75
    lines = [header]
    for b, h in enumerate(("left", "right")):
        lines += [p + repr(float(x)) + ",40\n" for p, x in zip(prefix[h], vals[b])]
    path = os.path.join(work, "tables", f"sub-{sid}_elements.csv")
    open(path, "w").write("".join(lines))
    json.dump({"format": "authalic-element-table", "version": 1, "domain": "square", "k": K, "rows": K, "cols": K,
               "hemispheres": ["left", "right"], "normalisation": "global", "units": "ratio to the global cortical mean",
               "subject_id": sid, "age": 50 + s % 30, "metadata": {}}, open(path[:-4] + ".json", "w"))
    if s < 1000:
        paths.append(path)
open(os.path.join(work, "tables_1000.txt"), "w").write("\n".join(paths) + "\n")
open(os.path.join(work, "tables_250.txt"), "w").write("\n".join(paths[:250]) + "\n")
print(f"cortex: {len(V)} vertices; sheet: {n*n} vertices; tables: 1000 + 1 patient")
EOF

# run NAME CMD...: runs CMD under /usr/bin/time -v; sets WALL (s), RSS (MB), OUT (stdout).
run() {
  local name="$1"; shift
  local t0 t1
  t0=$(date +%s.%N)
  OUT="$(/usr/bin/time -v -o "$WORK/$name.time" "$@" 2> "$WORK/$name.err")" || { cat "$WORK/$name.err" >&2; exit 3; }
  t1=$(date +%s.%N)
  WALL=$(echo "$t1 - $t0" | bc -l)
  RSS=$(awk -F: '/Maximum resident set size/ {printf "%.0f", $2 / 1024}' "$WORK/$name.time")
}
json() { echo "$OUT" | $PY -c "import json,sys; print(json.load(sys.stdin)$1)"; }

ROWS=()
# row NAME COMPUTE CPU WALL RSS NOTE
row() { ROWS+=("$(printf '%-46s %9s %9s %9s %9s  %s' "$1" "$2" "$3" "$4" "$5" "$6")"); }

run sample "$AUTHALIC" sample "$WORK/pet1mm.nii.gz" "$WORK/cortex150k.surf.gii" "$WORK/np.func.gii" --json --png "$WORK/np.png"
row "normal projection ($(json "['vertices']") v x $(json "['samples_per_vertex']") samples)" \
    "$(printf %.3f "$(json "['sampling_seconds']")")" "$(printf %.3f "$(json "['sampling_cpu_seconds']")")" "$(printf %.2f "$WALL")" "$RSS" \
    "<= 0.5 s (sampling)"

run elements "$AUTHALIC" elements "$WORK/sheet.surf.gii" "$WORK/sheet_map.surf.gii" "$WORK/sheet_values.func.gii" "$WORK/el" --k 64 --json
row "elements K=64 (150,544 vertices)" "$(printf %.3f "$(json "['elements_seconds']")")" \
    "$(printf %.3f "$(json "['elements_cpu_seconds']")")" "$(printf %.2f "$WALL")" "$RSS" \
    "<= 0.5 s (elements); CV $(printf %.4f "$(json "['element_area_cv']")")"

run build250 "$AUTHALIC" normative build "$WORK/ref250.json" --list "$WORK/tables_250.txt" --json
row "normative build, 250 tables K=64 x 2 hemis" "$(printf %.2f "$(json "['seconds']")")" "$(printf %.2f "$(json "['cpu_seconds']")")" \
    "$(printf %.2f "$WALL")" "$RSS" "memory vs N: compare with 1,000"
run build "$AUTHALIC" normative build "$WORK/ref.json" --list "$WORK/tables_1000.txt" --json
row "normative build, 1,000 tables K=64 x 2 hemis" "$(printf %.2f "$(json "['seconds']")")" "$(printf %.2f "$(json "['cpu_seconds']")")" \
    "$(printf %.2f "$WALL")" "$RSS" "<= 5 s, memory independent of N"
run compare "$AUTHALIC" normative compare "$WORK/ref.json" "$WORK/tables/sub-patient_elements.csv" "$WORK/cmp" --json
row "normative compare (8,192 elements)" "$(printf %.3f "$(json "['seconds']")")" "$(printf %.3f "$(json "['cpu_seconds']")")" \
    "$(printf %.3f "$WALL")" "$RSS" \
    "<= 0.2 s; $(json "['counts']['hypo']") hypo elements (200 planted), $(json "['clusters'].__len__()") clusters"

# Ribbon mode on fsaverage5 beside Connectome Workbench (issue 5: Workbench ~5.7 s).
if [ -f "$SHARED/spm/PET.nii" ] && [ -f "$SHARED/fsaverage5/pial_left.gii.gz" ]; then
  zcat "$SHARED/fsaverage5/pial_left.gii.gz" > "$WORK/pial.surf.gii"
  zcat "$SHARED/fsaverage5/white_left.gii.gz" > "$WORK/white.surf.gii"
  run ribbon "$AUTHALIC" sample "$SHARED/spm/PET.nii" "$WORK/pial.surf.gii" "$WORK/rib.func.gii" --ribbon "$WORK/white.surf.gii" --json
  row "ribbon, fsaverage5 (10,242 v), spm/PET.nii" "$(printf %.3f "$(json "['sampling_seconds']")")" \
      "$(printf %.3f "$(json "['sampling_cpu_seconds']")")" "$(printf %.2f "$WALL")" "$RSS" "authalic (Workbench: ~5.7 s in the issue)"
  if command -v wb_command > /dev/null; then
    run wb wb_command -volume-to-surface-mapping "$SHARED/spm/PET.nii" "$WORK/pial.surf.gii" "$WORK/wb.func.gii" \
        -ribbon-constrained "$WORK/white.surf.gii" "$WORK/pial.surf.gii"
    R=$($PY -c "
import nibabel as nib, numpy as np
a = nib.load('$WORK/wb.func.gii').darrays[0].data.astype(float); b = nib.load('$WORK/rib.func.gii').darrays[0].data.astype(float)
m = a != 0; print('%.4f' % np.corrcoef(a[m], b[m])[0, 1])")
    row "ribbon, same, wb_command -ribbon-constrained" "-" "-" "$(printf %.2f "$WALL")" "$RSS" "Workbench 1.5.0; Pearson with ours $R (>= 0.98)"
  else
    row "ribbon, wb_command -ribbon-constrained" "-" "-" "-" "-" "wb_command not installed (connectome-workbench)"
  fi
fi

# Issue 6 validation on the phantom cohort (the committed sample_data: 20 controls, 2 patients with
# a -25 % region): `authalic group`, then leave-one-out (each control against a reference built from
# the other 19) and the patients against the 20-control reference, with the command-line tools.
# "Fully inside" the region: the element's value of the ground-truth indicator (1 on planted
# vertices, linear on triangles; `authalic elements` on the patient's own flat map) is 1; outside: 0.
run group "$AUTHALIC" group "$ROOT/sample_data/cohort.csv" "$WORK/grp" --jobs 2 --k 32 --force --json
row "group: sample_data, 20 controls + 2 patients" "-" "-" "$(printf %.1f "$WALL")" "$RSS" \
    "$(json "['failed']") failed; reference exit $(json "['reference_exit_code']")"
VALIDATION=$(AUTHALIC="$AUTHALIC" SAMPLE="$ROOT/sample_data" GRP="$WORK/grp" VAL="$WORK/val" $PY - <<'EOF'
import csv, json, os, subprocess, sys, numpy as np, nibabel as nib
exe, sample, grp, val = (os.environ[k] for k in ("AUTHALIC", "SAMPLE", "GRP", "VAL"))
os.makedirs(val)
def sh(*args):
    r = subprocess.run([exe, *args], capture_output=True, text=True)
    if r.returncode != 0:
        sys.exit(f"bench_analysis: {' '.join(args[:2])} exited {r.returncode}: {r.stderr.strip()}")
    return r.stdout
rows = list(csv.DictReader(open(os.path.join(sample, "cohort.csv"))))
controls = [r["subject_id"] for r in rows if r["role"] == "control"]
patients = [r["subject_id"] for r in rows if r["role"] == "patient"]
table = lambda s: os.path.join(grp, f"sub-{s}", f"sub-{s}_elements.tsv")
fractions = []
for s in controls:
    ref = os.path.join(val, f"reference-without-{s}.json")
    sh("normative", "build", ref, *[table(c) for c in controls if c != s], "--quiet")
    j = json.loads(sh("normative", "compare", ref, table(s), os.path.join(val, f"loo-{s}"), "--json", "--quiet"))
    fractions.append((j["counts"]["hypo"] + j["counts"]["hyper"]) / j["counts"]["compared"])
f = 100 * np.array(fractions)
print(f"loo|leave-one-out, {len(controls)} controls (vs other {len(controls)-1})|mean {f.mean():.1f}%, largest {f.max():.1f}% "
      f"flagged at |z|>=2 (<= 5%); {int((f > 5).sum())} control(s) above 5%; for comparison, Gaussian element values "
      f"would give 6.1% on average (t, 18 df, predictive SD)")
for p in patients:
    d = os.path.join(grp, f"sub-{p}")
    inside = outside = found = false = 0
    sh("normative", "compare", os.path.join(grp, "normative.json"), table(p), os.path.join(val, p), "--quiet")
    sh("normative", "compare", os.path.join(grp, "normative.json"), table(p), os.path.join(val, p + "-norescale"),
       "--quiet", "--no-rescale")
    z = np.asarray(nib.load(os.path.join(val, f"{p}_z.nii.gz")).dataobj, dtype=float)
    z0 = np.asarray(nib.load(os.path.join(val, f"{p}-norescale_z.nii.gz")).dataobj, dtype=float)
    false0 = 0
    # Clusters beyond the controls' chance clusters (p_controls < 0.05) and where their elements lie.
    summary = json.load(open(os.path.join(val, f"{p}.json")))
    significant = {c["id"] for c in summary["clusters"] if c["p_controls"] is not None and c["p_controls"] < 0.05}
    sig_elements = {(r["hemisphere"], int(r["row"]), int(r["col"])) for r in csv.DictReader(open(os.path.join(val, f"{p}_abnormal.csv")))
                    if int(r["cluster"]) in significant}
    sig_in = sig_partly = sig_out = 0
    for b, (hemi, fs) in enumerate((("L", "lh"), ("R", "rh"))):
        out = os.path.join(val, f"truth-{p}-{fs}")
        sh("elements", os.path.join(sample, "surf", f"{fs}.white"), os.path.join(d, f"sub-{p}_hemi-{hemi}_space-authalic_flat.surf.gii"),
           os.path.join(sample, "truth", f"{fs}.lesion.label.gii"), out, "--k", "32", "--quiet")
        for e in csv.DictReader(open(out + ".tsv"), delimiter="\t"):
            t, zz = float(e["value"]), z[int(e["col"]), int(e["row"]), b]
            if (("left", "right")[b], int(e["row"]), int(e["col"])) in sig_elements:
                if t >= 1 - 1e-9: sig_in += 1
                elif t <= 1e-12: sig_out += 1
                else: sig_partly += 1
            if t >= 1 - 1e-9:
                inside += 1; found += zz <= -2
            elif t <= 1e-12:
                outside += 1; false += abs(zz) >= 2; false0 += abs(z0[int(e["col"]), int(e["row"]), b]) >= 2
    print(f"pat|{p} vs 20 controls (-25% region)|{found} of {inside} elements fully inside flagged hypo = {100*found/inside:.1f}% "
          f"(>= 90%); {false} of {outside} elements outside flagged = {100*false/outside:.1f}% (<= 5%); "
          f"{100*false0/outside:.1f}% with --no-rescale")
    pvals = sorted(c["p_controls"] for c in summary["clusters"] if c["p_controls"] is not None)
    print(f"chance|{p}: clusters beyond the controls' chance clusters|{len(significant)} of {len(summary['clusters'])} "
          f"clusters at p_controls < 0.05 (leave-one-out over {summary['chance_clusters'].get('controls', 0)} controls); "
          f"their elements: {sig_in} fully inside the region, {sig_partly} partly, {sig_out} outside; the other clusters' p: "
          f"{', '.join(f'{x:.2f}' for x in pvals if x >= 0.05)}")
EOF
)
while IFS='|' read -r _ name note; do row "$name" "-" "-" "-" "-" "$note"; done <<< "$VALIDATION"

echo
printf '%-46s %9s %9s %9s %9s  %s\n' "benchmark" "step (s)" "CPU (s)" "wall (s)" "RSS (MB)" "target / note"
printf '%s\n' "------------------------------------------------------------------------------------------------------------------"
printf '%s\n' "${ROWS[@]}"
echo "threads: ${OMP_NUM_THREADS:-all} of $(nproc) cores; step = in-process wall time of the step (sample/elements: the"
echo "computation alone; normative: the whole command incl. file I/O); CPU = CPU seconds of all threads in that step (what"
echo "it costs on an idle machine, whatever the load); wall = whole process incl. start-up (~0.2 s of shared-library"
echo "loading for any authalic command) and file I/O; RSS = peak resident memory of the process"
echo "load average at the end: $(cut -d' ' -f1-3 /proc/loadavg) (other builds running make every number larger)"
