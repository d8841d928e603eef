#!/usr/bin/env bash
# A single-node Slurm on this machine, for checking the submitit path for real.
#   bash tools/slurm_local.sh start   munged + slurmctld + slurmd, config in $SLURM_DIR
#   bash tools/slurm_local.sh check   start, a 2-job sweep through hydra/launcher=slurm, stop
#   bash tools/slurm_local.sh stop    stop the daemons this script started
# Needs root and Debian's slurm-wlm and munge (installed here with apt-get when missing).
# Slurm commands find this cluster through SLURM_CONF=$SLURM_DIR/slurm.conf.
set -euo pipefail
cd "$(dirname "$0")/.."
SLURM_DIR=${SLURM_DIR:-/tmp/catpose-slurm}
export SLURM_CONF=$SLURM_DIR/slurm.conf
HOST=$(hostname -s)
CPUS=$(nproc)
MEM_MB=$(( $(awk '/MemTotal/ {print $2}' /proc/meminfo) / 1024 / 2 ))

need() {
  if ! command -v slurmctld >/dev/null || ! command -v munged >/dev/null; then
    [ "$(id -u)" = 0 ] || { echo "slurm_local: slurm-wlm and munge are missing and installing them needs root" >&2; exit 2; }
    apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq slurm-wlm munge
  fi
}

start() {
  need
  mkdir -p "$SLURM_DIR"/{state,spool,log}
  cat > "$SLURM_CONF" <<CONF
# written by tools/slurm_local.sh: one node ($HOST), one partition, no accounting, no cgroups
ClusterName=catpose
SlurmctldHost=$HOST
SlurmUser=root
SlurmdUser=root
SlurmctldPort=16817
SlurmdPort=16818
AuthType=auth/munge
StateSaveLocation=$SLURM_DIR/state
SlurmdSpoolDir=$SLURM_DIR/spool
SlurmctldPidFile=$SLURM_DIR/slurmctld.pid
SlurmdPidFile=$SLURM_DIR/slurmd.pid
SlurmctldLogFile=$SLURM_DIR/log/slurmctld.log
SlurmdLogFile=$SLURM_DIR/log/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
SchedulerType=sched/backfill
MpiDefault=none
SwitchType=switch/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
ReturnToService=2
NodeName=$HOST CPUs=$CPUS RealMemory=$MEM_MB State=UNKNOWN
PartitionName=local Nodes=$HOST Default=YES MaxTime=INFINITE State=UP
CONF
  if ! pgrep -x munged >/dev/null; then
    mkdir -p /run/munge /var/log/munge /var/lib/munge
    chown munge:munge /run/munge /var/log/munge /var/lib/munge
    runuser -u munge -- /usr/sbin/munged
    touch "$SLURM_DIR/munged.started"  # stop ends only the munged this script started
  fi
  munge -n | unmunge >/dev/null  # fails here, with munge's message, when munged does not answer
  [ -f "$SLURM_DIR/slurmctld.pid" ] && kill -0 "$(cat "$SLURM_DIR/slurmctld.pid")" 2>/dev/null || slurmctld -f "$SLURM_CONF"
  [ -f "$SLURM_DIR/slurmd.pid" ] && kill -0 "$(cat "$SLURM_DIR/slurmd.pid")" 2>/dev/null || slurmd -f "$SLURM_CONF"
  for _ in $(seq 30); do
    sinfo -h -o %T 2>/dev/null | grep -qE '^idle|^mixed|^alloc' && { sinfo; return 0; }
    sleep 1
  done
  echo "slurm_local: the node did not come up; logs in $SLURM_DIR/log:" >&2
  tail -n 20 "$SLURM_DIR"/log/*.log >&2 || true
  exit 1
}

stop() {
  for _ in $(seq 30); do  # let finished jobs' steps end before their daemons go
    [ -z "$(squeue -h 2>/dev/null)" ] && break
    sleep 1
  done
  for d in slurmd slurmctld; do
    [ -f "$SLURM_DIR/$d.pid" ] && kill "$(cat "$SLURM_DIR/$d.pid")" 2>/dev/null || true
  done
  if [ -f "$SLURM_DIR/munged.started" ] && [ -f /run/munge/munged.pid ]; then
    kill "$(cat /run/munge/munged.pid)" 2>/dev/null || true
    rm -f "$SLURM_DIR/munged.started"
  fi
}

check() {
  start
  trap stop EXIT  # the daemons go when the check ends, passed or not
  export PYTHONWARNINGS=ignore  # submitit warns at every poll that sacct has no accounting storage here
  out=$(mktemp -d)
  # two jobs (seeds 0 and 1), one Slurm job each; a failed job makes the sweep exit non-zero
  .venv/bin/bench run -m hydra/launcher=slurm hydra.launcher.partition=local hydra.launcher.cpus_per_task=1 \
    hydra.launcher.mem_gb=1 hydra.launcher.timeout_min=10 method=icp dataset=synthetic limit=2 seed=0,1 \
    progress=false output_root="$out"
  sweep=$(ls -d "$out"/multirun/sweep/* | head -n 1)
  [ "$(ls "$sweep"/*/job.json | wc -l)" = 2 ] || { echo "slurm_local: expected 2 job.json in $sweep" >&2; exit 1; }
  .venv/bin/bench table --sweep "$sweep"
  # a sweep with a failing job (modelnet40 without dataset.root) must exit non-zero
  if .venv/bin/bench run -m hydra/launcher=slurm hydra.launcher.partition=local hydra.launcher.cpus_per_task=1 \
      hydra.launcher.mem_gb=1 hydra.launcher.timeout_min=10 method=icp dataset=synthetic,modelnet40 limit=1 \
      progress=false output_root="$out" hydra.job.name=failing; then
    echo "slurm_local: a sweep with a failed job exited 0" >&2; exit 1
  fi
  echo "slurm_local: 2-job sweep through Slurm passed ($sweep); a failed job failed its sweep"
}

case "${1:-check}" in
  start) start ;;
  stop) stop ;;
  check) check ;;
  *) echo "usage: bash tools/slurm_local.sh start|check|stop" >&2; exit 2 ;;
esac
