#!/usr/bin/env bash
# One command: set up, build, and run the whole pipeline on the built-in
# synthetic demo scene (configs/synthetic_tiny.yaml). Prints where the report is.
set -euo pipefail
cd "$(dirname "$0")/.."
bash tools/setup_debian.sh
bash tools/build.sh -DRELIGHT_BUILD_BENCHMARKS=OFF
build/bin/pipeline run configs/synthetic_tiny.yaml "$@"
