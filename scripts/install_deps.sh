#!/usr/bin/env bash
# Installs the Debian 12 packages Authalic builds, tests and benchmarks with. Idempotent.
set -euo pipefail
SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
PACKAGES=(
  build-essential cmake ninja-build pkg-config git
  libeigen3-dev libsuitesparse-dev libvtk9-dev libinsighttoolkit5-dev
  libopenblas0-serial                      # the BLAS under CHOLMOD's supernodal factorisations (20k+ unknowns); serial: no threads
  libnifti2-dev libgiftiio-dev zlib1g-dev libpng-dev libssl-dev libexpat1-dev
  libcli11-dev nlohmann-json3-dev libgtest-dev libcsv-dev
  libboost-dev                             # Boost.Math (header-only): the t distribution of healthy z-scores
  python3 python3-nibabel python3-numpy python3-scipy
  python3-vtk9                             # scripts/mesh_families.py: voxelised and decimated surfaces (tests, bench)
  clang libclang-rt-14-dev libomp-dev      # libFuzzer targets (scripts/fuzz.sh), ThreadSanitizer
  connectome-workbench                     # wb_command: reference values for the sampling tests
  chromium                                 # headless screenshot of the HTML report (test)
  libcairo2-dev fonts-dejavu-core          # every picture and the PDF report (Cairo, DejaVu Sans)
  poppler-utils                            # pdftoppm/pdfinfo: the PDF report's test and bench
  snakemake                                # workflow/Snakefile (cohorts beyond one machine; tested)
)
export DEBIAN_FRONTEND=noninteractive
missing=()
for p in "${PACKAGES[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  echo "install_deps: installing ${#missing[@]} packages: ${missing[*]}" >&2
  $SUDO apt-get -o DPkg::Lock::Timeout=600 update -qq
  $SUDO apt-get -o DPkg::Lock::Timeout=600 install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
fi
echo "install_deps: all ${#PACKAGES[@]} packages present" >&2
# The report's interactive 3D viewer (Niivue, BSD-2), pinned by version and integrity checksum in
# report_assets/package-lock.json; its dist/niivue.umd.js is inlined into every HTML report.
if command -v npm >/dev/null 2>&1; then
  (cd "$(dirname "$0")/../report_assets" && npm ci --ignore-scripts --no-audit --no-fund --loglevel=error)
  echo "install_deps: report_assets/node_modules/@niivue/niivue installed" >&2
else
  echo "install_deps: npm not found: reports are written without the interactive 3D view (install nodejs and npm, then rerun)" >&2
fi
