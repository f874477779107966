#!/usr/bin/env bash
# Issue 18 part 3: the DLF mesh flow (`flatten --method mesh`) beside the default grid flow, on
# B1 (fsaverage5 white_left, the cortex faces of flat_left) and R1 (fs741 lh.white inside
# lh.cortex.label, 164,000 vertices). For each: the flow alone (--no-polish; it fails the
# acceptance, exit 3, so --keep-failed writes it), the flow + polish (the --method mesh default),
# and the grid method. Prints CPU, peak memory, steps, stop reason, flips, element CV (ours and
# ../shared/tools/evalmap.py's), per-vertex and per-face mean |ln area ratio|, then PASS/FAIL for
# the issue's bar (the flow alone on B1: 0 flips, element CV <= 0.02 within 200 steps).
#   bench/bench_dlf.sh [BUILD_DIR]     (default: build; needs ../shared/data)
set -euo pipefail
cd "$(dirname "$0")/.."
build=${1:-build}
bin="$PWD/$build/authalic"
py=/usr/bin/python3
fs5=../shared/data/fsaverage5 fs741=../shared/data/fs741
[ -x "$bin" ] || { echo "bench_dlf: $bin not found; build first (scripts/build.sh)" >&2; exit 2; }
[ -f "$fs741/lh.white.surf.gii" ] || { echo "bench_dlf: ../shared/data not found" >&2; exit 2; }
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

# run NAME SURFACE ARGS... : one flatten at 1 thread with /usr/bin/time; $work/NAME.{json,uv.surf.gii,time}
run() {
  local name=$1 surf=$2
  shift 2
  /usr/bin/time -v "$bin" flatten "$surf" "$work/$name.surf.gii" --uv "$work/$name.uv.surf.gii" --metrics "$work/$name.json" \
    --threads 1 --keep-failed -q "$@" 2>"$work/$name.time" || true
  echo "$surf" >"$work/$name.surface"
}
for m in dlf dlf-polish grid; do
  args=(--method mesh --no-polish)
  [ $m = dlf-polish ] && args=(--method mesh)
  [ $m = grid ] && args=(--method grid)
  run "B1-$m" "$fs5/white_left.gii.gz" --faces-from "$fs5/flat_left.gii.gz" "${args[@]}"
  run "R1-$m" "$fs741/lh.white.surf.gii" --label "$fs741/lh.cortex.label" "${args[@]}"
done
for f in "$work"/*.json; do
  n=$(basename "$f" .json)
  "$py" ../shared/tools/evalmap.py "$(cat "$work/$n.surface")" "$work/$n.uv.surf.gii" --domain square --k 32 --json >"$work/$n.eval.json"
done

WORK=$work PYTHONPATH=bench "$py" - <<'EOF'
import json, os
from requirements import Requirements
w = os.environ['WORK']
def timing(n):
    t = {}
    for line in open(f'{w}/{n}.time'):
        k, _, v = line.strip().partition(': ')
        t[k] = v
    return float(t['User time (seconds)']) + float(t['System time (seconds)']), int(t['Maximum resident set size (kbytes)']) / 1024
hdr = ('map', 'CPU s', 'peak MB', 'steps', 'stop', 'flips', 'element CV', 'evalmap CV', 'per-vertex', 'per-face', 'acceptance')
print('| ' + ' | '.join(hdr) + ' |')
print('|' + '|'.join(['---'] * len(hdr)) + '|')
res = {}
for mesh in ('B1', 'R1'):
    for m, label in (('dlf', 'DLF alone'), ('dlf-polish', 'DLF + polish'), ('grid', 'grid + polish (default)')):
        n = f'{mesh}-{m}'
        j, e = json.load(open(f'{w}/{n}.json')), json.load(open(f'{w}/{n}.eval.json'))
        res[n] = (j, e)
        cpu, mb = timing(n)
        fl, mm = j['flow'], j['metrics']
        print(f"| {mesh} {label} | {cpu:.2f} | {mb:.0f} | {fl['iterations']}+{fl['polish_iterations']} | {fl['stop_reason']} | {mm['flips']} | "
              f"{mm['element_cv']:.4f} | {e['element_area_cv']:.4f} | {mm['vertex_ln_area_abs']['mean']:.4f} | "
              f"{mm['face_ln_area_abs']['mean']:.4f} | {'passed' if j['acceptance']['passed'] else 'FAILED'} |")
print()
for n in ('B1-dlf', 'R1-dlf'):
    print(f"{n}: stopped {res[n][0]['flow']['stop_reason']}: {res[n][0]['flow']['stall_detail']}")
req = Requirements('issue 18 part 3')
j, e = res['B1-dlf']
req('B1 DLF alone flips', j['metrics']['flips'], 0)
req('B1 DLF alone element CV', j['metrics']['element_cv'], 0.02)
req('B1 DLF alone element CV (evalmap)', e['element_area_cv'], 0.02)
req('B1 DLF alone steps', j['flow']['iterations'], 200)
for n in ('B1-dlf-polish', 'R1-dlf-polish'):
    req(f'{n} passes the acceptance (1 = no)', 0 if res[n][0]['acceptance']['passed'] else 1, 0)
EOF
