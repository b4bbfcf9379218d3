#!/usr/bin/env bash
# One command: set up, build, and run the whole test suite (unit and integration),
# then a one-minute run of the parser fuzz targets (fuzz/README.md).
set -euo pipefail
cd "$(dirname "$0")/.."
bash tools/setup_debian.sh
bash tools/build.sh -DRELIGHT_BUILD_BENCHMARKS=OFF
ctest --test-dir build --output-on-failure -j "$(nproc)" "$@"
bash fuzz/run.sh 60
