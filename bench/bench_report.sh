#!/usr/bin/env bash
# Report generation on the sample patient (issue 16): runs `authalic run` on sample_data's
# patient01 (the README's main job) three times and prints the "report (HTML and PDF)" step's
# wall time from the run's --json step_seconds (its median), with the sizes of the HTML and the
# PDF. Requirements: report <= 2 s, HTML <= 8 MB.
#
#   bench/bench_report.sh [path/to/authalic]   (default: $AUTHALIC, else build/authalic)
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
AUTHALIC="$(realpath "${1:-${AUTHALIC:-$ROOT/build/authalic}}")"
[ -x "$AUTHALIC" ] || { echo "no authalic executable at $AUTHALIC; build it first" >&2; exit 2; }
WORK="$(mktemp -d /tmp/authalic-bench-report.XXXXXX)"
trap 'rm -rf "$WORK"' EXIT
S="$ROOT/sample_data"
times=()
for i in 1 2 3; do
  "$AUTHALIC" run --json --id patient01 --lh-white "$S/surf/lh.white" --lh-pial "$S/surf/lh.pial" \
    --rh-white "$S/surf/rh.white" --rh-pial "$S/surf/rh.pial" --lh-cortex "$S/label/lh.cortex.label" \
    --rh-cortex "$S/label/rh.cortex.label" --pet "$S/sub-patient01/sub-patient01_pet.nii.gz" \
    --normative "$S/normative.json" --age 68.2 --out "$WORK" --force > "$WORK/run.json"
  times+=("$(/usr/bin/python3 -c 'import json,sys; print(json.load(open(sys.argv[1]))["step_seconds"]["report (HTML and PDF)"])' "$WORK/run.json")")
done
median=$(printf '%s\n' "${times[@]}" | sort -g | sed -n 2p)
html="$WORK/sub-patient01/sub-patient01_report.html"
pdf="$WORK/sub-patient01/sub-patient01_report.pdf"
html_mb=$(/usr/bin/python3 -c "import os,sys; print(f'{os.path.getsize(sys.argv[1]) / 1e6:.2f}')" "$html")
pdf_mb=$(/usr/bin/python3 -c "import os,sys; print(f'{os.path.getsize(sys.argv[1]) / 1e6:.2f}')" "$pdf")
pages=$(pdfinfo "$pdf" 2>/dev/null | awk '/^Pages:/ {print $2}')
printf '%-44s %10s %10s %s\n' "measure" "value" "target" "ok"
ok() { /usr/bin/python3 -c "import sys; print('yes' if float(sys.argv[1]) <= float(sys.argv[2]) else 'NO')" "$1" "$2"; }
printf '%-44s %10s %10s %s\n' "report generation, s (median of 3: ${times[*]})" "$median" "2" "$(ok "$median" 2)"
printf '%-44s %10s %10s %s\n' "HTML size, MB" "$html_mb" "8" "$(ok "$html_mb" 8)"
printf '%-44s %10s %10s %s\n' "PDF size, MB (pages: ${pages:-?})" "$pdf_mb" "-" "-"
