#!/usr/bin/env bash
# Times the relight stage of a finished workspace with each renderer, in the same session, on the same
# cached inputs (docs/BENCHMARKS.md, "Relighting: transport against Monte Carlo"):
#
#   build/bin/pipeline run configs/synthetic_tiny.yaml --workspace /tmp/ws/tiny
#   bash tools/relight_time.sh /tmp/ws/tiny
#
# Prints per renderer the stage's wall time, its render time and the time per render kind; the outputs go
# to a temporary folder (the workspace's cache is not touched).
set -euo pipefail
ws=${1:?usage: relight_time.sh WORKSPACE [BUILD_DIR]}
build=${2:-build}
stages="$ws/stages"
for s in ingest sfm mesh visibility inverse relight; do
  [ -e "$stages/$s" ] || { echo "relight_time.sh: $stages/$s is missing: run the pipeline first" >&2; exit 2; }
done
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
inputs=()
for s in ingest sfm mesh visibility inverse; do inputs+=("--input=$s=$(readlink -f "$stages/$s")"); done
for renderer in transport monte_carlo; do
  mkdir -p "$out/$renderer"
  start=$(date +%s.%N)
  "$build/bin/relight" --config "$stages/relight/config.yaml" --set "relight.renderer=$renderer" \
    --output "$out/$renderer" "${inputs[@]}" --threads=0 > "$out/$renderer.log" 2>&1
  end=$(date +%s.%N)
  python3 - "$out/$renderer/relight_summary.json" "$renderer" "$start" "$end" <<'PY'
import collections, json, sys
summary = json.load(open(sys.argv[1]))
kinds = collections.Counter()
for r in summary["renders"]:
    kinds[r["kind"]] += r["seconds"]
wall = float(sys.argv[4]) - float(sys.argv[3])
print(f"{sys.argv[2]:12s} stage {wall:7.1f} s   renders {sum(kinds.values()):7.1f} s   " +
      "  ".join(f"{k} {v:.1f}" for k, v in sorted(kinds.items()) if v > 0))
PY
done
