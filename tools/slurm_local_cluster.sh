#!/usr/bin/env bash
# A single-node Slurm cluster on this machine (munge, slurmctld, slurmd on
# localhost), for trying `pipeline.executor: slurm` and for its CI test
# (tests/slurm_integration_test.cc). Needs root and Debian's slurm-wlm and munge
# (tools/setup_debian.sh installs them). Everything but munge lives in DIR; the
# config is DIR/slurm.conf, so the machine's /etc/slurm is left alone.
#
#   bash tools/slurm_local_cluster.sh start DIR   # prints: export SLURM_CONF=DIR/slurm.conf
#   SLURM_CONF=DIR/slurm.conf pipeline run configs/synthetic_tiny.yaml --set pipeline.executor=slurm
#   bash tools/slurm_local_cluster.sh stop DIR
#
# On a real cluster none of this is needed: run `pipeline` on a login node (docs/SLURM.md).
set -euo pipefail

usage() { echo "usage: $0 start|stop DIR" >&2; exit 2; }
[[ $# -eq 2 ]] || usage
action=$1
dir=$(mkdir -p "$2" && cd "$2" && pwd)
export SLURM_CONF="$dir/slurm.conf"

stop_daemons() {
  for name in slurmd slurmctld; do
    if [[ -f "$dir/$name.pid" ]]; then
      pid=$(cat "$dir/$name.pid")
      kill "$pid" 2>/dev/null || true
      for _ in $(seq 50); do kill -0 "$pid" 2>/dev/null || break; sleep 0.1; done
      rm -f "$dir/$name.pid"
    fi
  done
}

case "$action" in
  stop)
    stop_daemons
    exit 0
    ;;
  start) ;;
  *) usage ;;
esac

for tool in munged slurmctld slurmd sinfo; do
  command -v "$tool" >/dev/null || { echo "$0: '$tool' is missing: run bash tools/setup_debian.sh" >&2; exit 1; }
done
[[ $(id -u) -eq 0 ]] || { echo "$0: needs root (slurmd runs jobs as their user)" >&2; exit 1; }

# munge: one per machine; start it unless it answers.
if ! munge -n 2>/dev/null | unmunge >/dev/null 2>&1; then
  [[ -f /etc/munge/munge.key ]] || mungekey --create --keyfile=/etc/munge/munge.key
  chown munge:munge /etc/munge/munge.key 2>/dev/null || true
  chmod 0400 /etc/munge/munge.key
  mkdir -p /run/munge /var/log/munge /var/lib/munge
  chown -R munge:munge /run/munge /var/log/munge /var/lib/munge 2>/dev/null || true
  if id munge >/dev/null 2>&1; then
    runuser -u munge -- munged --force
  else
    munged --force
  fi
  for _ in $(seq 50); do munge -n 2>/dev/null | unmunge >/dev/null 2>&1 && break; sleep 0.1; done
  munge -n | unmunge >/dev/null || { echo "$0: munged does not answer" >&2; exit 1; }
fi

stop_daemons
host=$(hostname -s)
cpus=$(nproc)
mem_mib=$(( $(awk '/MemTotal/ {print $2}' /proc/meminfo) / 1024 - 1024 ))
mkdir -p "$dir/state" "$dir/spool"
cat > "$dir/slurm.conf" <<EOF
# Written by tools/slurm_local_cluster.sh: one node, this machine.
ClusterName=relight-local
SlurmctldHost=$host
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
SlurmctldPort=16817
SlurmdPort=16818
StateSaveLocation=$dir/state
SlurmdSpoolDir=$dir/spool
SlurmctldPidFile=$dir/slurmctld.pid
SlurmdPidFile=$dir/slurmd.pid
SlurmctldLogFile=$dir/slurmctld.log
SlurmdLogFile=$dir/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
MpiDefault=none
ReturnToService=2
SchedulerType=sched/backfill
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
MinJobAge=600
NodeName=$host CPUs=$cpus RealMemory=$mem_mib State=UNKNOWN
PartitionName=local Nodes=ALL Default=YES MaxTime=INFINITE State=UP
EOF
# -i: ignore state a killed earlier cluster in DIR left behind.
slurmctld -i
slurmd
for _ in $(seq 100); do
  state=$(sinfo -h -o %T 2>/dev/null || true)
  [[ $state == idle* || $state == mixed* ]] && break
  sleep 0.2
done
[[ $state == idle* || $state == mixed* ]] || {
  echo "$0: the node did not come up (state '$state'); logs: $dir/slurmctld.log $dir/slurmd.log" >&2
  exit 1
}
echo "export SLURM_CONF=$dir/slurm.conf"
