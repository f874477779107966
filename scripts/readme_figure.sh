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
if ! "$bin" flatten --help >/dev/null 2>&1; then
  echo "readme_figure: this authalic has no 'flatten' subcommand yet" >&2
  exit 3
fi
surface=sample_data/surf/lh.white
label=sample_data/label/lh.cortex.label
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

# Authalic map (the default of `authalic flatten`), its uv in [0,1]^2.
"$bin" flatten "$surface" "$work/authalic.surf.gii" --label "$label" --uv "$work/authalic_uv.surf.gii" -q

# Conformal initial map: the same command stopped before the area-restoring flow.
help=$("$bin" flatten --help)
conformal_args=()
for candidate in "--conformal" "--method conformal" "--initial-only" "--no-flow" "--iterations 0"; do
  flag=${candidate%% *}
  if grep -q -- "$flag\b" <<<"$help"; then
    read -r -a conformal_args <<<"$candidate"
    break
  fi
done
if [ ${#conformal_args[@]} -eq 0 ]; then
  echo "readme_figure: 'authalic flatten' has no option for the conformal initial map" >&2
  exit 3
fi
"$bin" flatten "$surface" "$work/conformal.surf.gii" --label "$label" --uv "$work/conformal_uv.surf.gii" \
  "${conformal_args[@]}" -q

mkdir -p "$(dirname "$out")"
"$bin" render "$out" "$work/authalic_uv.surf.gii" "$work/conformal_uv.surf.gii" \
  --sulcal-depth "$surface" --colormap gray_r --grid 16 --width 520 \
  --caption "authalic: every cell holds the same cortical area" \
  --caption "conformal: angles kept, areas distorted" -q
echo "readme_figure: wrote $out"
