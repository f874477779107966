#!/usr/bin/env bash
# Issue 18 part 1 benchmark: the optimal-transport refinement (`flatten --refine omt`) beside the
# default authalic map, on B1 (fsaverage5 white, flat_left's cortex faces), S1 (its sphere, `sphere
# --refine omt` refines the square route's square part) and R1 (the real
# subject's native white surface with its cortex label, ../shared/data/fs741). Prints time, flips,
# element CV (authalic and evalmap.py), per-face / per-vertex |ln area ratio|, mean Λ (Zou et al.
# 2011 eq. 23) and the transport cost ∫|x − T(x)|² dμ / ∫dμ from the conformal initial map, then
# the issue's bars: element CV within 10 % of the default, 0 flips, ≤ 5 s on B1, a lower cost,
# and mean Λ lower by ≥ 25 % (not met: the default map is already within 0.6 % of the optimal
# cost, docs/maps.md "Optimal-transport refinement").
#   bench/bench_transport.sh [BUILD_DIR]
set -euo pipefail
cd "$(dirname "$0")/.."
build=${1:-build}
bin="$PWD/$build/authalic"
data=../shared/data
evalmap=../shared/tools/evalmap.py
[ -x "$bin" ] || { echo "bench_transport: $bin not found; build first (scripts/build.sh)" >&2; exit 2; }
[ -f "$data/fsaverage5/white_left.gii.gz" ] || { echo "bench_transport: $data not found" >&2; exit 2; }
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

# run NAME SURFACE REFINE ARGS...: flatten under /usr/bin/time, then evalmap on its unit-square map.
run() {
  local name=$1 surf=$2 refine=$3
  shift 3
  /usr/bin/time -v "$bin" flatten "$surf" "$work/$name.surf.gii" --uv "$work/$name.uv.surf.gii" \
    --metrics "$work/$name.json" --refine "$refine" -q "$@" 2>"$work/$name.time"
  /usr/bin/python3 "$evalmap" "$surf" "$work/$name.uv.surf.gii" --domain square --k 32 --json > "$work/$name.eval.json"
}
for refine in none omt; do
  /usr/bin/time -v "$bin" sphere "$data/fsaverage5/white_left.gii.gz" "$work/S1-$refine.surf.gii" --refine $refine \
    --metrics "$work/S1-$refine.json" -q 2>"$work/S1-$refine.time"
  run "B1-$refine" "$data/fsaverage5/white_left.gii.gz" $refine --faces-from "$data/fsaverage5/flat_left.gii.gz"
  run "R1-$refine" "$data/fs741/lh.white.surf.gii" $refine --label "$data/fs741/lh.cortex.label"
done

WORK=$work /usr/bin/python3 - <<'PY'
import json, os, re
w = os.environ['WORK']
def timing(n):
    t = open(f'{w}/{n}.time').read()
    wall = re.search(r'Elapsed \(wall clock\) time.*: (.*)', t).group(1).split(':')
    sec = sum(float(x) * 60 ** i for i, x in enumerate(reversed(wall)))
    cpu = sum(float(x) for x in re.findall(r'(?:User|System) time \(seconds\): (.*)', t))
    return sec, cpu, int(re.search(r'Maximum resident set size \(kbytes\): (\d+)', t).group(1)) // 1024
print('| map | wall s | cpu s | RSS MB | flips | CV 32x32 | evalmap CV | face mean | vertex mean | mean Λ | evalmap Λ | transport cost | OT steps |')
print('|' + '---|' * 13)
res = {}
for mesh in ['B1', 'R1']:
    for refine in ['none', 'omt']:
        n = f'{mesh}-{refine}'
        j, e = json.load(open(f'{w}/{n}.json')), json.load(open(f'{w}/{n}.eval.json'))
        m, t = j['metrics'], j['transport']
        res[n] = (j, e, timing(n))
        wall, cpu, rss = res[n][2]
        steps = t['omt']['iterations'] if 'omt' in t else '-'
        print(f"| {mesh} {'default' if refine == 'none' else '+ OMT'} | {wall:.2f} | {cpu:.2f} | {rss} | {m['flips']} | "
              f"{m['element_cv']:.5f} | {e['element_area_cv']:.5f} | {m['face_ln_area_abs']['mean']:.4f} | "
              f"{m['vertex_ln_area_abs']['mean']:.4f} | {m['lambda']['mean']:.4f} | {e['qc_lambda_mean']:.4f} | "
              f"{t['cost_from_initial_map']:.6f} | {steps} |")
for refine in ['none', 'omt']:
    j = json.load(open(f'{w}/S1-{refine}.json'))
    m, (wall, cpu, rss) = j['metrics'], timing(f'S1-{refine}')
    t = j.get('square_route_transport', {})
    print(f"| S1 sphere {'default' if refine == 'none' else '+ OMT'} | {wall:.2f} | {cpu:.2f} | {rss} | {m['flips']} | "
          f"{m['element_cv']:.5f} (64x32) | - | {m['face_ln_area_abs']['mean']:.4f} | {m['vertex_ln_area_abs']['mean']:.4f} | "
          f"{m['lambda']['mean']:.4f} | - | {t.get('cost_after_refinement', float('nan')):.6f} (square part) | {t.get('iterations', '-')} |")
print()
ok = lambda c: 'PASS' if c else 'FAIL'
for mesh in ['B1', 'R1']:
    (j0, e0, _), (j1, e1, (wall, _, _)) = res[f'{mesh}-none'], res[f'{mesh}-omt']
    m0, m1 = j0['metrics'], j1['metrics']
    c0, c1 = j0['transport']['cost_from_initial_map'], j1['transport']['cost_from_initial_map']
    drop = 1 - m1['lambda']['mean'] / m0['lambda']['mean']
    print(f"{mesh}: flips {m1['flips']} (= 0): {ok(m1['flips'] == 0)}; element CV {m1['element_cv']:.5f} within 10 % of "
          f"{m0['element_cv']:.5f} (or lower): {ok(m1['element_cv'] <= 1.1 * m0['element_cv'])}; transport cost "
          f"{c0:.6f} -> {c1:.6f} ({100 * (c1 / c0 - 1):+.2f} %, lower): {ok(c1 < c0)}")
    print(f"{mesh}: mean Λ {m0['lambda']['mean']:.4f} -> {m1['lambda']['mean']:.4f} (lowered by {100 * drop:.1f} %; the "
          f"issue asked >= 25 %): {ok(drop >= 0.25)} -- the default map is already the optimal-transport map to within "
          f"{100 * (c0 / c1 - 1):.2f} % of its cost")
    if mesh == 'B1':
        print(f"B1: refined map in {wall:.2f} s wall (<= 5 s): {ok(wall <= 5)}")
PY
