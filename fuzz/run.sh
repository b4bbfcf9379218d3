#!/usr/bin/env bash
# Builds the fuzz targets (clang, libFuzzer + ASan + UBSan) into build-fuzz/ and
# runs each for an equal share of SECONDS (default 60: the CI run). The seed
# corpus in fuzz/corpus/<target>/ is read, never written: new inputs go to
# build-fuzz/corpus/<target>/, crashes to build-fuzz/artifacts/. Exits non-zero
# when a target crashes, leaks or hits undefined behaviour; the log of each run
# is build-fuzz/logs/<target>.log. The random seed is fixed (-seed=1; a later
# -seed=N among the extra arguments overrides it), so CI replays the same
# inputs up to its time limit instead of failing at random on a new find.
#
#   bash fuzz/run.sh            # a minute in all (CI)
#   bash fuzz/run.sh 3600 -jobs=2 -workers=2   # an hour; extra arguments go to every target
set -euo pipefail
cd "$(dirname "$0")/.."
seconds=${1:-60}
shift || true
build=build-fuzz
cmake -S fuzz -B "$build" -G Ninja -DCMAKE_CXX_COMPILER=clang++ >/dev/null
cmake --build "$build"
targets=(config colmap_text colmap_binary mesh_ply mesh_obj mesh_off observations colmap_mat)
share=$(( seconds / ${#targets[@]} ))
(( share >= 1 )) || share=1
mkdir -p "$build/artifacts" "$build/logs"
failed=()
for t in "${targets[@]}"; do
  mkdir -p "$build/corpus/$t"
  if ASAN_OPTIONS=detect_leaks=1 UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
      "$build/fuzz_$t" -seed=1 -max_total_time="$share" -timeout=10 -rss_limit_mb=2048 -print_final_stats=1 \
      -artifact_prefix="$build/artifacts/$t-" "$@" "$build/corpus/$t" "fuzz/corpus/$t" >"$build/logs/$t.log" 2>&1; then
    runs=$(grep -o 'stat::number_of_executed_units: *[0-9]*' "$build/logs/$t.log" | grep -o '[0-9]*$' | tail -1)
    echo "fuzz: $t: ${runs:-?} executions in ${share} s, no crash"
  else
    echo "fuzz: $t: FAILED; see $build/logs/$t.log and $build/artifacts/" >&2
    tail -n 40 "$build/logs/$t.log" >&2
    failed+=("$t")
  fi
done
if (( ${#failed[@]} > 0 )); then
  echo "fuzz: ${#failed[@]} target(s) failed: ${failed[*]}" >&2
  exit 1
fi
echo "fuzz: ${#targets[@]} passed, 0 failed"
