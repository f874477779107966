#!/usr/bin/env bash
# Fuzzes every file reader with libFuzzer (clang, ASan + UBSan) for SECONDS each (default 60).
#   scripts/fuzz.sh            # 60 s per target
#   scripts/fuzz.sh 600        # longer run
#   FUZZ_TARGETS="gifti nifti" scripts/fuzz.sh 30
#   FUZZ_SEED=0 scripts/fuzz.sh 600   # a random seed (default 1: the same mutation sequence on
#                                     # every run, so a short CI run does not fail by chance)
# Builds into build-fuzz/ (override with FUZZ_BUILD_DIR), writes a seed corpus of small valid
# files made by the project's own writers (plus a few from nibabel when available), then runs
# each target. Crashes, leaks, timeouts (> 10 s per input), out-of-memory (> 2 GB) and
# sanitizer reports fail the script; the offending input is kept in build-fuzz/artifacts/.
# Any crash found becomes a regression test in tests/io/test_fuzz_regressions.cpp.
set -euo pipefail
cd "$(dirname "$0")/.."
SECONDS_PER_TARGET="${1:-60}"
BUILD="${FUZZ_BUILD_DIR:-build-fuzz}"
TARGETS=(${FUZZ_TARGETS:-freesurfer_surface freesurfer_curv freesurfer_label freesurfer_patch gifti nifti mgh ply obj mni_obj stl vtk})
JOBS="${FUZZ_BUILD_JOBS:-2}"
SEED="${FUZZ_SEED:-1}"

if ! command -v clang++ >/dev/null; then
  echo "fuzz.sh: clang++ not found (Debian: apt-get install clang libclang-rt-14-dev libomp-dev)" >&2
  exit 2
fi

CC=clang CXX=clang++ cmake -S . -B "$BUILD" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DAUTHALIC_FUZZ=ON -DAUTHALIC_SANITIZE=ON -DAUTHALIC_BUILD_TESTS=OFF \
  -DCMAKE_C_FLAGS="-fsanitize=fuzzer-no-link" -DCMAKE_CXX_FLAGS="-fsanitize=fuzzer-no-link -Wno-unknown-warning-option" \
  -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O1 -g" >/dev/null
cmake --build "$BUILD" -j"$JOBS" --target fuzz_make_seeds $(printf 'fuzz_%s ' "${TARGETS[@]}")

CORPUS="$BUILD/corpus"
ARTIFACTS="$BUILD/artifacts"
mkdir -p "$CORPUS" "$ARTIFACTS"
export ASAN_OPTIONS="detect_leaks=1:allocator_may_return_null=1"
export UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1"
"$BUILD/tests/fuzz/fuzz_make_seeds" "$CORPUS/seeds" >/dev/null
if /usr/bin/python3 -c 'import nibabel' 2>/dev/null; then
  # Seeds our writers cannot make: NIfTI-2, 4D, scaled int16, qform-only; MGH from nibabel.
  /usr/bin/python3 - "$CORPUS/seeds" <<'EOF'
import sys, numpy as np, nibabel as nib
root = sys.argv[1]
aff = np.array([[-2., 0, 0, 90], [0, 2, 0, -126], [0, 0, 2, -72], [0, 0, 0, 1]])
d = np.arange(12, dtype=np.float32).reshape(3, 2, 2)
nib.save(nib.Nifti2Image(d, aff), f'{root}/nifti/v2.nii')
nib.save(nib.Nifti1Image(np.stack([d, d * 2], -1), aff), f'{root}/nifti/4d.nii')
im = nib.Nifti1Image(d.astype(np.int16), aff); im.header.set_slope_inter(0.5, 1.0); nib.save(im, f'{root}/nifti/scaled.nii')
im = nib.Nifti1Image(d.astype(np.uint8), None); im.set_qform(aff, 1); im.set_sform(None, 0); nib.save(im, f'{root}/nifti/qform.nii')
nib.save(nib.MGHImage(d, aff), f'{root}/mgh/nib.mgh')
EOF
fi

status=0
printf '%-20s %8s %12s %10s  %s\n' target seconds executions corpus result
for t in "${TARGETS[@]}"; do
  mkdir -p "$CORPUS/$t"
  log="$BUILD/fuzz_$t.log"
  dict=()
  [ -f "tests/fuzz/$t.dict" ] && dict=(-dict="tests/fuzz/$t.dict")
  set +e
  "$BUILD/tests/fuzz/fuzz_$t" "$CORPUS/$t" "$CORPUS/seeds/$t" "${dict[@]}" \
    -max_total_time="$SECONDS_PER_TARGET" -seed="$SEED" -timeout=10 -rss_limit_mb=2048 -max_len=65536 \
    -print_final_stats=1 -artifact_prefix="$ARTIFACTS/$t-" >"$log" 2>&1
  rc=$?
  set -e
  execs=$(grep -o 'stat::number_of_executed_units: *[0-9]*' "$log" | grep -o '[0-9]*$' || echo "?")
  files=$(ls "$CORPUS/$t" | wc -l)
  if [ $rc -eq 0 ]; then result="ok"; else result="FAILED (exit $rc, see $log)"; status=1; fi
  printf '%-20s %8s %12s %10s  %s\n' "$t" "$SECONDS_PER_TARGET" "$execs" "$files" "$result"
done
if [ $status -ne 0 ]; then
  echo "fuzz.sh: findings in $ARTIFACTS (reproduce: $BUILD/tests/fuzz/fuzz_TARGET FILE)" >&2
fi
exit $status
