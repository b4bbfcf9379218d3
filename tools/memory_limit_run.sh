#!/usr/bin/env bash
# Runs a command inside a memory cgroup with a hard limit, as a machine with
# that much memory would run it (page cache included: the kernel must evict
# to stay under it; anonymous memory over it is killed by the OOM killer).
# Used by docs/BENCHMARKS.md to show that a stage's memory is bounded.
#
#   sudo bash tools/memory_limit_run.sh LIMIT_MIB COMMAND [ARGS...]
#
# Needs root and a writable memory controller (cgroup v2 with +memory in the
# root's subtree_control, or cgroup v1's memory hierarchy). Prints the
# command's exit status, whether the OOM killer fired and the group's peak
# usage (page cache included) when the controller reports it.
set -euo pipefail
if [[ $# -lt 2 ]]; then
  echo "usage: $0 LIMIT_MIB COMMAND [ARGS...]" >&2
  exit 2
fi
limit_mib=$1
shift
bytes=$((limit_mib * 1024 * 1024))
name="relight-memlimit-$$"
if [[ -f /sys/fs/cgroup/cgroup.controllers ]] && grep -qw memory /sys/fs/cgroup/cgroup.controllers; then
  group="/sys/fs/cgroup/$name"
  mkdir "$group"
  echo "$bytes" > "$group/memory.max"
  echo 0 > "$group/memory.swap.max" 2>/dev/null || true
  version=2
elif [[ -d /sys/fs/cgroup/memory ]]; then
  group="/sys/fs/cgroup/memory/$name"
  mkdir "$group"
  echo "$bytes" > "$group/memory.limit_in_bytes"
  version=1
else
  echo "$0: no memory cgroup controller found under /sys/fs/cgroup" >&2
  exit 2
fi
cleanup() { rmdir "$group" 2>/dev/null || true; }
trap cleanup EXIT
status=0
( echo "$BASHPID" > "$group/cgroup.procs" && exec "$@" ) || status=$?
if [[ $version == 2 ]]; then
  oom=$(awk '$1 == "oom_kill" {print $2}' "$group/memory.events")
  peak=$(cat "$group/memory.peak" 2>/dev/null || echo "")
else
  oom=$(awk '$1 == "oom_kill" {print $2}' "$group/memory.oom_control" 2>/dev/null || echo "")
  peak=$(cat "$group/memory.max_usage_in_bytes")
fi
peak_text="not reported"
[[ -n $peak ]] && peak_text="$((peak / 1048576)) MiB (page cache included)"
echo "memory_limit_run: limit ${limit_mib} MiB, exit status ${status}, oom kills ${oom:-unknown}, peak usage ${peak_text}"
exit "$status"
