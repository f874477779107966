#!/usr/bin/env bash
# Issue 3 benchmark: the authalic square map on fsaverage5, printed as a table.
#   bench/bench_flatten.sh [BUILD_DIR]     (default: build; needs ../shared/data)
# Inputs: B1 = white_left with the cortex face set of flat_left (9,465 region vertices),
#         B2 = the same on pial_left, B3 = B1 subdivided twice (midpoint; B1's vertices first).
# Beside them: the DLF mesh flow (adaptive flip-preventing step) on B1, with and without the polish
# and from either start (issue 18 part 3), the conformal initial maps,
# and FreeSurfer's own flat map. Every map is also measured by ../shared/tools/evalmap.py
# (independent, nibabel; exact element areas). The maps have the input's vertices (dividing edges
# are flipped, not split), so both measure the same faces.
set -euo pipefail
cd "$(dirname "$0")/.."
build=${1:-build}
bin="$PWD/$build/authalic"
data=../shared/data/fsaverage5
evalmap=../shared/tools/evalmap.py
py=/usr/bin/python3
[ -x "$bin" ] || { echo "bench_flatten: $bin not found; build first (scripts/build.sh)" >&2; exit 2; }
[ -f "$data/white_left.gii.gz" ] || { echo "bench_flatten: $data not found (../shared/data is needed)" >&2; exit 2; }
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

"$bin" subdivide "$data/white_left.gii.gz" "$work/b3.surf.gii" --times 2 --faces-from "$data/flat_left.gii.gz" -q

# run NAME SURFACE3D ARGS... : flatten with /usr/bin/time; leaves $work/NAME.{json,uv.surf.gii,time}
run() {
  local name=$1 surf=$2
  shift 2
  /usr/bin/time -v "$bin" flatten "$surf" "$work/$name.surf.gii" --uv "$work/$name.uv.surf.gii" \
    --initial "$work/$name.init.surf.gii" --metrics "$work/$name.json" -q "$@" 2>"$work/$name.time" || true
}
wall() { awk -F': ' '/Elapsed \(wall clock\)/{print $2}' "$work/$1.time" | awk -F: '{ if (NF==3) print $1*3600+$2*60+$3; else print $1*60+$2 }'; }
cpu() { awk -F': ' '/User time|System time/{t += $2} END {printf "%.2f", t}' "$work/$1.time"; }
rss() { awk -F': ' '/Maximum resident set size/{printf "%.0f", $2/1024}' "$work/$1.time"; }

run B1 "$data/white_left.gii.gz" --faces-from "$data/flat_left.gii.gz"
run B2 "$data/pial_left.gii.gz" --faces-from "$data/flat_left.gii.gz"
run B3 "$work/b3.surf.gii"
# The DLF mesh flow (issue 18 part 3): with the per-face polish (the default), alone (--no-polish:
# it fails the acceptance, exit 3, so --keep-failed writes it for its row), alone from the
# conformal map, and alone with the paper's targets (the surface re-triangulated by the flips).
run B1-mesh "$data/white_left.gii.gz" --faces-from "$data/flat_left.gii.gz" --method mesh --keep-failed
run B1-dlf "$data/white_left.gii.gz" --faces-from "$data/flat_left.gii.gz" --method mesh --no-polish --keep-failed
run B1-dlf-conformal "$data/white_left.gii.gz" --faces-from "$data/flat_left.gii.gz" --method mesh --no-polish --keep-failed --start conformal
run B1-dlf-flowing "$data/white_left.gii.gz" --faces-from "$data/flat_left.gii.gz" --method mesh --no-polish --keep-failed --start conformal --mesh-targets flowing
# Determinism: 1 and 2 threads give byte-identical maps.
"$bin" flatten "$data/white_left.gii.gz" "$work/t1.surf.gii" --faces-from "$data/flat_left.gii.gz" --threads 1 -q
"$bin" flatten "$data/white_left.gii.gz" "$work/t2.surf.gii" --faces-from "$data/flat_left.gii.gz" --threads 2 -q
if cmp -s "$work/t1.surf.gii" "$work/t2.surf.gii"; then same=identical; else same=DIFFERENT; fi
# FreeSurfer's flat map, measured the same way (x,y in mm: metrics rescale it to the unit square).
"$bin" metrics "$data/white_left.gii.gz" "$data/flat_left.gii.gz" --json > "$work/fs.json"

# CGAL 5.5's Discrete_authalic_parameterizer_3 with an arc-length square border (Debian libcgal-dev,
# built here for the benchmark only), on the same regions.
cgal=none
if [ -f /usr/include/CGAL/Surface_mesh_parameterization/Discrete_authalic_parameterizer_3.h ]; then
  g++ -O2 -std=c++17 -DCGAL_EIGEN3_ENABLED -I/usr/include/eigen3 bench/cgal_authalic.cpp -o "$work/cgal_authalic"
  cgal=built
  for n in B1 B2 B3; do
    surf="$data/white_left.gii.gz"; faces="$data/flat_left.gii.gz"
    [ $n = B2 ] && surf="$data/pial_left.gii.gz"
    [ $n = B3 ] && surf="$work/b3.surf.gii" && faces="$work/b3.surf.gii"
    $py bench/cgal_io.py off "$surf" "$faces" "$work/$n.off" "$work/$n.idx.npy"
    /usr/bin/time -v "$work/cgal_authalic" "$work/$n.off" "$work/$n.cgal.txt" 2>"$work/$n-cgal.time"
    $py bench/cgal_io.py uv "$surf" "$faces" "$work/$n.cgal.txt" "$work/$n.idx.npy" "$work/$n-cgal.uv.surf.gii"
    "$bin" metrics "$surf" "$work/$n-cgal.uv.surf.gii" --json > "$work/$n-cgal.json"
  done
fi

for n in B1 B2 B3 B1-mesh B1-dlf B1-dlf-conformal B1-dlf-flowing; do
  surf="$data/white_left.gii.gz"; [ $n = B2 ] && surf="$data/pial_left.gii.gz"; [ $n = B3 ] && surf="$work/b3.surf.gii"
  $py "$evalmap" "$surf" "$work/$n.uv.surf.gii" --domain square --k 32 --json > "$work/$n.eval.json"
done
$py "$evalmap" "$data/white_left.gii.gz" "$work/B1.init.surf.gii" --domain square --k 32 --json > "$work/B1-conformal.eval.json"

WALL_B1=$(wall B1) WALL_B2=$(wall B2) WALL_B3=$(wall B3) WALL_MESH=$(wall B1-mesh) WALL_DLF=$(wall B1-dlf) \
WALL_DLFC=$(wall B1-dlf-conformal) WALL_DLFF=$(wall B1-dlf-flowing) \
RSS_B1=$(rss B1) RSS_B2=$(rss B2) RSS_B3=$(rss B3) RSS_MESH=$(rss B1-mesh) RSS_DLF=$(rss B1-dlf) \
RSS_DLFC=$(rss B1-dlf-conformal) RSS_DLFF=$(rss B1-dlf-flowing) SAME=$same WORK=$work CGAL=$cgal \
CPU_B1=$(cpu B1) CPU_B2=$(cpu B2) CPU_B3=$(cpu B3) CPU_MESH=$(cpu B1-mesh) CPU_DLF=$(cpu B1-dlf) \
CPU_DLFC=$(cpu B1-dlf-conformal) CPU_DLFF=$(cpu B1-dlf-flowing) \
PYTHONPATH=bench $py - <<'EOF'
import json, os, numpy as np, nibabel as nib
from requirements import Requirements
w = os.environ['WORK']
J = lambda n: json.load(open(f'{w}/{n}'))
def uv(n):
    return np.asarray([a.data for a in nib.load(f'{w}/{n}.uv.surf.gii').darrays if a.intent == 1008][0], float)[:, :2]
rows = []
def row(name, m, wall, rss, iters, ev):
    f, v = m['face_ln_area_abs'], m.get('vertex_ln_area_abs', {})
    rows.append((name, wall, rss, iters, m['flips'], f['mean'], f['p95'], v.get('mean', float('nan')), v.get('p99', float('nan')),
                 v.get('max', float('nan')), m['element_cv'], m['lambda']['mean'],
                 ev.get('element_area_cv', float('nan')) if ev else float('nan'), ev['ln_area_ratio_abs_mean'] if ev else float('nan')))
res = {}
names = {'B1-mesh': 'B1 DLF mesh flow + polish', 'B1-dlf': 'B1 DLF mesh flow alone',
         'B1-dlf-conformal': 'B1 DLF alone, conformal start', 'B1-dlf-flowing': 'B1 DLF alone, conformal, flowing targets'}
for n, key in [('B1', 'B1'), ('B2', 'B2'), ('B3', 'B3'), ('B1-mesh', 'MESH'), ('B1-dlf', 'DLF'), ('B1-dlf-conformal', 'DLFC'),
               ('B1-dlf-flowing', 'DLFF')]:
    j = J(f'{n}.json'); fl = j['flow']
    res[n] = j
    row(names.get(n, f'{n} authalic'), j['metrics'], os.environ['WALL_' + key] + ' (cpu ' + os.environ['CPU_' + key] + ')', os.environ['RSS_' + key],
        f"{fl['iterations']}+{fl['polish_iterations']}", J(f'{n}.eval.json'))
for n in ['B1', 'B2', 'B3']:
    row(f'{n} conformal (initial)', J(f'{n}.json')['initial_metrics'], '-', '-', '-', J('B1-conformal.eval.json') if n == 'B1' else None)
row('FreeSurfer flat_left', J('fs.json'), '-', '-', '-', None)
if os.environ['CGAL'] == 'built':
    for n in ['B1', 'B2', 'B3']:
        t = open(f'{w}/{n}-cgal.time').read()
        wall = [l.split(': ')[1] for l in t.splitlines() if 'Elapsed (wall clock)' in l][0].split(':')
        rss = [l.split(': ')[1] for l in t.splitlines() if 'Maximum resident' in l][0]
        row(f'{n} CGAL discrete authalic', J(f'{n}-cgal.json'), f'{float(wall[-2]) * 60 + float(wall[-1]):.2f}', f'{int(rss) // 1024}', '-', None)
else:
    print('(CGAL rows skipped: Debian libcgal-dev is not installed)')
hdr = ('map', 'wall s', 'RSS MB', 'iter', 'flips', 'face mean', 'face p95', 'vert mean', 'vert p99', 'vert max', 'CV 32x32', 'mean Λ', 'evalmap CV', 'evalmap face')
print('| ' + ' | '.join(hdr) + ' |')
print('|' + '|'.join(['---'] * len(hdr)) + '|')
for r in rows:
    print('| ' + ' | '.join(x if isinstance(x, str) else (str(x) if isinstance(x, int) else f'{x:.4f}') for x in r) + ' |')
# Resolution independence: B1's vertices mapped on B1 and on B3 (their first vertices).
u1, u3 = uv('B1'), uv('B3')
used = np.unique(np.asarray([a.data for a in nib.load(f'{w}/B1.uv.surf.gii').darrays if a.intent == 1009][0]))
used = used[used < 10242]
d = np.linalg.norm(u1[used] - u3[used], axis=1)
print()
print(f'resolution independence (B1 vs B3 on B1\'s {len(used)} region vertices): mean |Δuv| = {d.mean():.4f}, max {d.max():.4f}')
print(f'threads: 1 vs 2 threads give {os.environ["SAME"]} outputs; seconds (initial map / flow) B1 {res["B1"]["seconds"]["initial_map"]:.2f}/{res["B1"]["seconds"]["flow"]:.2f},'
      f' B3 {res["B3"]["seconds"]["initial_map"]:.2f}/{res["B3"]["seconds"]["flow"]:.2f}')
print(f'load average at the end: {open("/proc/loadavg").read().split()[0:3]} on {os.cpu_count()} cores (other work makes every wall time larger;'
      ' cpu = user + system seconds of the process, all threads)')
print()
req = Requirements('issue 3')
for n in ['B1', 'B2', 'B3']:
    m = res[n]['metrics']
    req(f'{n} flips', m['flips'], 0)
    req(f'{n} element CV', m['element_cv'], 0.01)
    req(f'{n} per-vertex mean', m['vertex_ln_area_abs']['mean'], 0.01)
    req(f'{n} per-vertex p99', m['vertex_ln_area_abs']['p99'], 0.04)
    req(f'{n} per-face mean', m['face_ln_area_abs']['mean'], 0.08 if n == 'B2' else 0.06)
req('B1 wall s', float(os.environ['WALL_B1']), 1.0)
req('B2 wall s', float(os.environ['WALL_B2']), 1.0)
req('B3 wall s', float(os.environ['WALL_B3']), 10.0)
req('B3 peak MB', float(os.environ['RSS_B3']), 1536)
req('resolution independence', d.mean(), 0.01)
print(f'  {"PASS" if os.environ["SAME"] == "identical" else "FAIL"}  1 vs 2 threads: {os.environ["SAME"]}')
print()
for n in ['B1-dlf', 'B1-dlf-conformal', 'B1-dlf-flowing']:
    fl = res[n]['flow']
    print(f'{names[n]}: {fl["iterations"]} steps, stopped: {fl["stop_reason"]} ({fl["stall_detail"]})')
req = Requirements('issue 18 part 3 (the DLF mesh flow alone on B1, from the default start)')
m, fl = res['B1-dlf']['metrics'], res['B1-dlf']['flow']
req('B1 DLF flips', m['flips'], 0)
req('B1 DLF element CV', m['element_cv'], 0.02)
req('B1 DLF evalmap element CV', J('B1-dlf.eval.json')['element_area_cv'], 0.02)
req('B1 DLF steps', fl['iterations'], 200)
req('B1 DLF + polish per-vertex mean (acceptance)', res['B1-mesh']['metrics']['vertex_ln_area_abs']['mean'], 0.01)
EOF
