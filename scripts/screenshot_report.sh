#!/usr/bin/env bash
# Renders an HTML report to a PNG with headless Chromium (Debian package `chromium`), offline:
#   scripts/screenshot_report.sh REPORT.html OUT.png [WIDTH HEIGHT]
# Exit codes: 0 ok, 2 bad arguments or missing input, 3 chromium missing or failed.
set -euo pipefail
if [ $# -lt 2 ] || [ $# -gt 4 ]; then
  echo "usage: $0 REPORT.html OUT.png [WIDTH HEIGHT]" >&2
  exit 2
fi
report=$1
out=$2
width=${3:-1200}
height=${4:-2000}
if [ ! -f "$report" ]; then
  echo "$0: $report: no such file" >&2
  exit 2
fi
browser=""
for candidate in chromium chromium-browser google-chrome; do
  if command -v "$candidate" >/dev/null 2>&1; then
    browser=$(command -v "$candidate")
    break
  fi
done
if [ -z "$browser" ]; then
  echo "$0: chromium not found; install the Debian package 'chromium'" >&2
  exit 3
fi
abs_report=$(realpath "$report")
out_dir=$(dirname "$out")
mkdir -p "$out_dir"
abs_out="$(realpath "$out_dir")/$(basename "$out")"
profile=$(mktemp -d)
tmp_png="$(realpath "$out_dir")/.$(basename "$out").tmp.$$.png"
trap 'rm -rf "$profile" "$tmp_png"' EXIT
# Offline and deterministic: no network services, no GPU, a throw-away profile.
if ! timeout 120 "$browser" --headless --no-sandbox --disable-gpu --disable-quic --no-first-run \
  --disable-background-networking --disable-component-update --disable-sync --disable-extensions \
  --use-gl=angle --use-angle=swiftshader --enable-unsafe-swiftshader --virtual-time-budget=15000 \
  --hide-scrollbars --user-data-dir="$profile" --window-size="$width,$height" \
  --screenshot="$tmp_png" "file://$abs_report" >"$profile/chromium.log" 2>&1; then
  echo "$0: chromium failed:" >&2
  tail -n 20 "$profile/chromium.log" >&2
  exit 3
fi
if [ ! -s "$tmp_png" ]; then
  echo "$0: chromium wrote no screenshot" >&2
  tail -n 20 "$profile/chromium.log" >&2
  exit 3
fi
mv -f "$tmp_png" "$abs_out"  # atomic: the PNG appears complete or not at all
echo "$abs_out"
