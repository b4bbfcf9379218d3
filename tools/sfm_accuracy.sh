#!/usr/bin/env bash
# Structure-from-motion accuracy and repeatability (docs/RESULTS.md, "Cameras"):
# for each config, the chain up to sfm (cached), then the sfm stage N times
# afresh; per run the photos registered, the mapper runs' verdict
# (sfm_summary.json "consensus") and, with ground truth, the camera errors
# after a similarity alignment (tools/compare_cameras).
#
#   bash tools/sfm_accuracy.sh [--runs N] [--workspace DIR] CONFIG[=TRUTH] ...
#
# TRUTH is a COLMAP model folder or a Middlebury *_par.txt file; without it the
# ingest stage's ground_truth/ is used when there is one. Extra stage options:
# RELIGHT_SFM_SET="sfm.x=1 sfm.y=2".
set -euo pipefail
cd "$(dirname "$0")/.."
runs=3
root=/tmp/relight_sfm_accuracy
while [ $# -gt 0 ]; do
  case "$1" in
    --runs) runs=$2; shift 2 ;;
    --workspace) root=$2; shift 2 ;;
    *) break ;;
  esac
done
set_args=()
for kv in ${RELIGHT_SFM_SET:-}; do set_args+=(--set "$kv"); done
stage_dir() {  # stage_dir WORKSPACE STAGE: the stage's cache folder from summary.json
  python3 -c 'import json,sys; s=json.load(open(sys.argv[1]))
print(next(x.get("output_dir","") for x in s["stages"] if x["name"]==sys.argv[2]))' "$1/summary.json" "$2"
}
mkdir -p "$root"
printf '%-28s %-4s %-12s %-11s %-12s %-12s %s\n' config run registered consensus "median rot" "max rot" "median centre"
for arg in "$@"; do
  config=${arg%%=*}
  truth=""
  [ "$arg" != "$config" ] && truth=${arg#*=}
  name=$(basename "$config" .yaml)
  ws="$root/$name"
  for ((r = 1; r <= runs; r++)); do
    force=()
    [ "$r" -gt 1 ] && force=(--force sfm)
    if ! build/bin/pipeline run "$config" --workspace "$ws" --until sfm "${set_args[@]}" "${force[@]}" \
        > "$ws.run$r.log" 2>&1; then
      printf '%-28s %-4s %s\n' "$name" "$r" "sfm failed: $(grep -m1 'sfm: error' "$ws.run$r.log" | cut -c1-160)"
      continue
    fi
    sfm=$(stage_dir "$ws" sfm)
    t=$truth
    if [ -z "$t" ]; then
      ingest=$(stage_dir "$ws" ingest)
      [ -e "$ingest/ground_truth/images.txt" ] && t="$ingest/ground_truth"
    fi
    read -r reg total consensus < <(python3 -c 'import json,sys; s=json.load(open(sys.argv[1]))
print(s["num_registered"], s["num_photos"], s.get("consensus","-"))' "$sfm/sfm_summary.json")
    errors="-"
    if [ -n "$t" ]; then
      build/bin/compare_cameras "$sfm/sparse" "$t" --json "$ws.run$r.cameras.json" > /dev/null
      errors=$(python3 -c 'import json,sys; e=json.load(open(sys.argv[1]))
print("%.3f deg     %.3f deg     %.2f %%" % (e["median_rotation_deg"], e["max_rotation_deg"], 100*e["median_center_error_relative"]))' \
        "$ws.run$r.cameras.json")
    fi
    printf '%-28s %-4s %-12s %-11s %s\n' "$name" "$r" "$reg/$total" "$consensus" "$errors"
  done
done
