#!/usr/bin/env bash
# The README's picture: the authalic (area-preserving) flat map of the phantom's left hemisphere
# beside the conformal (angle-preserving) initial map, both with a 16 x 16 element grid and shaded
# by sulcal depth. Uses only the synthetic sample_data/ (nothing derived from ../shared/data).
#   scripts/readme_figure.sh [BUILD_DIR] [OUT.png]
# (defaults: build, docs/img/flat_authalic_vs_conformal.png)
set -euo pipefail
cd "$(dirname "$0")/.."
build=${1:-build}
out=${2:-docs/img/flat_authalic_vs_conformal.png}
bin="$build/authalic"
[ -x "$bin" ] || { echo "readme_figure: $bin not found; build first (scripts/build.sh)" >&2; exit 2; }
surface=sample_data/surf/lh.white
label=sample_data/label/lh.cortex.label
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

# Authalic map (the default of `authalic flatten`) and its conformal initial map, both in [0,1]^2.
"$bin" flatten "$surface" "$work/authalic.surf.gii" --label "$label" --uv "$work/authalic_uv.surf.gii" \
  --initial "$work/conformal_uv.surf.gii" -q

mkdir -p "$(dirname "$out")"
"$bin" render "$out" "$work/authalic_uv.surf.gii" "$work/conformal_uv.surf.gii" \
  --sulcal-depth "$surface" --colormap gray_r --grid 16 --width 520 \
  --caption "authalic: equal cortical area per cell" \
  --caption "conformal: areas distorted" -q
echo "readme_figure: wrote $out"
