#!/usr/bin/env bash
# SfM and MVS time per photo of two builds on one scene, measured in the same
# session (docs/BENCHMARKS.md, "Geometry time per photo"): a baseline
# `pipeline` (e.g. a worktree of an older commit) and the current one, run
# alternately ROUNDS times. Per round and build:
#   sfm        the sfm stage at the config's options, afresh (--force sfm)
#   sfm (gt)   the sfm stage with the true cameras (sfm.mode=ground_truth)
#   mvs (gt)   the mvs stage on those cameras (rerun after the forced sfm)
# Seconds are the stages' own (summary.json), divided by the photo count. A
# stage that fails (e.g. SfM that registers too few photos) is timed all the same
# and marked. The synthesize and ingest stages run once per build, untimed.
#
#   bash tools/geometry_time.sh [--rounds N] [--workspace DIR] [--sfm-only] BASE_PIPELINE NEW_PIPELINE SCENE
#
# --sfm-only times the sfm stage alone (the two other columns stay empty).
#
# SCENE is a config, or a folder holding images/ and ground_truth/ (a
# synthesize stage's output folder): photos any build can ingest, for a
# baseline that predates the generator options of the scene's config.
set -euo pipefail
cd "$(dirname "$0")/.."
rounds=1
root=/tmp/relight_geometry_time
sfm_only=0
while [ $# -gt 0 ]; do
  case "$1" in
    --rounds) rounds=$2; shift 2 ;;
    --workspace) root=$2; shift 2 ;;
    --sfm-only) sfm_only=1; shift ;;
    *) break ;;
  esac
done
[ $# -eq 3 ] || { echo "usage: $0 [--rounds N] [--workspace DIR] [--sfm-only] BASE_PIPELINE NEW_PIPELINE SCENE" >&2; exit 2; }
bins=("$1" "$2")
labels=(baseline current)
config=$3
mkdir -p "$root"
if [ -d "$config" ]; then
  scene=$(cd "$config" && pwd)
  config="$root/scene.yaml"
  printf 'ingest:\n  images: %s/images\n  ground_truth: %s/ground_truth\n' "$scene" "$scene" >"$config"
fi
stage() {  # stage WORKSPACE NAME: "seconds status" of a stage from summary.json
  python3 -c 'import json,sys; s=json.load(open(sys.argv[1]))
x=next(x for x in s["stages"] if x["name"]==sys.argv[2]); print(x["seconds"], x["status"])' "$1/summary.json" "$2"
}
photos() {  # number of ingested photos
  python3 -c 'import json,sys; s=json.load(open(sys.argv[1]))
d=next(x["output_dir"] for x in s["stages"] if x["name"]=="ingest")
print(len(json.load(open(d+"/manifest.json"))["photos"]))' "$1/summary.json"
}
for i in 0 1; do
  ws="$root/${labels[$i]}"
  "${bins[$i]}" run "$config" --workspace "$ws" --until ingest >"$ws.log" 2>&1 || { cat "$ws.log" >&2; exit 1; }
done
n=$(photos "$root/baseline")
echo "config $config, $n photos, $(nproc) cores; seconds per photo (stage seconds / $n)"
printf '%-6s %-9s %-22s %-22s %-22s\n' round build "sfm" "sfm (gt cameras)" "mvs (gt cameras)"
for ((r = 1; r <= rounds; r++)); do
  for i in 0 1; do
    ws="$root/${labels[$i]}"
    "${bins[$i]}" run "$config" --workspace "$ws" --until sfm --force sfm >>"$ws.log" 2>&1 || true
    read -r sfm_s sfm_status <<<"$(stage "$ws" sfm)"
    gt_s=0 gt_status=- mvs_s=0 mvs_status=-
    if [ "$sfm_only" -eq 0 ]; then
      # A forced sfm reruns everything after it, mvs included.
      "${bins[$i]}" run "$config" --workspace "$ws" --set sfm.mode=ground_truth --until mvs --force sfm >>"$ws.log" 2>&1 || true
      read -r gt_s gt_status <<<"$(stage "$ws" sfm)"
      read -r mvs_s mvs_status <<<"$(stage "$ws" mvs)"
    fi
    printf '%-6s %-9s %-22s %-22s %-22s\n' "$r" "${labels[$i]}" \
      "$(awk -v s="$sfm_s" -v n="$n" 'BEGIN{printf "%.2f", s/n}') ($sfm_status)" \
      "$(awk -v s="$gt_s" -v n="$n" 'BEGIN{printf "%.2f", s/n}') ($gt_status)" \
      "$(awk -v s="$mvs_s" -v n="$n" 'BEGIN{printf "%.2f", s/n}') ($mvs_status)"
  done
done
