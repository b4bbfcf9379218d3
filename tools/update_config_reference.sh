#!/usr/bin/env bash
# Regenerates the option reference in configs/README.md from the option
# structs themselves (`pipeline options --markdown`), so the docs never drift
# (tests/pipeline_cli_test.cc checks it).
set -euo pipefail
cd "$(dirname "$0")/.."
bin=${1:-build/bin/pipeline}
marker='<!-- BEGIN GENERATED OPTION REFERENCE -->'
head=$(sed "/$marker/q" configs/README.md)
{
  printf '%s\n' "$head"
  echo
  "$bin" options --markdown
  echo '<!-- END GENERATED OPTION REFERENCE -->'
} > configs/README.md.new
mv configs/README.md.new configs/README.md
echo "updated configs/README.md"
