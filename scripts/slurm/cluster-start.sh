#!/usr/bin/env bash
# Starts a one-node SLURM cluster on this machine (Debian 12, as root, no systemd needed):
# installs slurmctld, slurmd, slurm-client and munge if missing, writes
# /etc/slurm/slurm.conf, starts munged, slurmctld and slurmd if they are not running,
# records the pids of the daemons it started in $STATE/pids/, and waits until slurmd
# has registered and the node is idle. Idempotent: a second run starts nothing.
#   STATE: SLURM_LOCAL_STATE, default /var/spool/slurm-local
# Every line of the configuration, and why, is in docs/scale-out.md ("A one-node
# cluster"). For CI and trying the recipes out; a real cluster has its own admins.
set -euo pipefail
STATE=${SLURM_LOCAL_STATE:-/var/spool/slurm-local}
CONF=/etc/slurm/slurm.conf
t0=$(date +%s%N)
[ "$(id -u)" = 0 ] || { echo "cluster-start: needs root" >&2; exit 1; }

if ! command -v slurmctld >/dev/null || ! command -v slurmd >/dev/null || ! command -v munged >/dev/null \
   || ! command -v sbatch >/dev/null; then
  # No systemd here: the postinsts' service starts fail harmlessly; a temporary
  # policy-rc.d makes them not even try.
  added_policy=
  if [ ! -e /usr/sbin/policy-rc.d ]; then
    printf '#!/bin/sh\nexit 101\n' > /usr/sbin/policy-rc.d && chmod +x /usr/sbin/policy-rc.d
    added_policy=1
  fi
  apt-get update -qq
  # Not slurm-wlm, not with recommends: that is 42 packages instead of 8.
  DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends \
    slurmctld slurmd slurm-client munge >/dev/null
  [ -n "$added_policy" ] && rm -f /usr/sbin/policy-rc.d
fi

install -d -o munge -g munge -m 0755 /run/munge
install -d -o slurm -g slurm "$STATE/ctld" "$STATE/log" "$STATE/run"
mkdir -p "$STATE/d" "$STATE/pids" /etc/slurm

host=$(hostname -s)
node=$(slurmd -C | head -1 | sed -e 's/ UpTime=.*//')   # NodeName=... CPUs=... RealMemory=...
conf=$(cat <<CONF
# Written by wavetrace scripts/slurm/cluster-start.sh: a one-node cluster, no cgroups.
ClusterName=local
SlurmctldHost=$host(127.0.0.1)
AuthType=auth/munge
CredType=cred/munge
AuthInfo=cred_expire=10
SlurmUser=slurm
SlurmdUser=root
SlurmctldPort=6817
SlurmdPort=6818
StateSaveLocation=$STATE/ctld
SlurmdSpoolDir=$STATE/d
SlurmctldPidFile=$STATE/run/slurmctld.pid
SlurmdPidFile=$STATE/run/slurmd.pid
SlurmctldLogFile=$STATE/log/slurmctld.log
SlurmdLogFile=$STATE/log/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
JobCompType=jobcomp/filetxt
JobCompLoc=$STATE/log/jobcomp.log
MinJobAge=3600
MailProg=/bin/true
MpiDefault=none
SwitchType=switch/none
SchedulerType=sched/backfill
SchedulerParameters=batch_sched_delay=0,sched_min_interval=0,sched_interval=5,bf_interval=5
DependencyParameters=kill_invalid_depend
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
ReturnToService=2
JobRequeue=1
RequeueExit=75
$node NodeAddr=127.0.0.1 State=UNKNOWN
PartitionName=local Nodes=$host Default=YES MaxTime=INFINITE State=UP
CONF
)
if [ ! -f "$CONF" ] || [ "$(cat "$CONF")" != "$conf" ]; then
  [ -f "$CONF" ] && ! grep -q '^# Written by wavetrace' "$CONF" && cp "$CONF" "$CONF.before-wavetrace"
  printf '%s\n' "$conf" > "$CONF"
fi

# alive NAME PIDFILE: the pid in PIDFILE runs a process called NAME.
alive() { [ -s "$2" ] && [ "$(cat "/proc/$(cat "$2")/comm" 2>/dev/null)" = "$1" ]; }

if ! alive munged /run/munge/munged.pid; then
  runuser -u munge -- /usr/sbin/munged
  cp /run/munge/munged.pid "$STATE/pids/munged"
fi
munge -n | unmunge >/dev/null
if ! alive slurmctld "$STATE/run/slurmctld.pid"; then
  slurmctld
  for _ in $(seq 50); do alive slurmctld "$STATE/run/slurmctld.pid" && break; sleep 0.1; done
  cp "$STATE/run/slurmctld.pid" "$STATE/pids/slurmctld"
fi
started_d=
if ! alive slurmd "$STATE/run/slurmd.pid"; then
  started_d=$(date +%s)
  slurmd
  for _ in $(seq 50); do alive slurmd "$STATE/run/slurmd.pid" && break; sleep 0.1; done
  cp "$STATE/run/slurmd.pid" "$STATE/pids/slurmd"
fi

# "idle" in sinfo can be slurmctld's saved state from before; wait until this slurmd
# has registered (its SlurmdStartTime is not older than its start).
for _ in $(seq 300); do
  line=$(scontrol -o show node "$host" 2>/dev/null || true)
  state=$(sed -n 's/.*State=\([A-Z+_]*\).*/\1/p' <<<"$line")
  start=$(sed -n 's/.*SlurmdStartTime=\([^ ]*\).*/\1/p' <<<"$line")
  fresh=1
  if [ -n "$started_d" ]; then
    s=$(date -d "$start" +%s 2>/dev/null || echo 0)
    [ "$s" -ge "$((started_d - 1))" ] || fresh=
  fi
  if [ -n "$fresh" ] && [[ "$state" == IDLE* || "$state" == MIXED* || "$state" == ALLOCATED* ]]; then
    echo "cluster-start: node $host $state after $(( ($(date +%s%N) - t0) / 1000000 )) ms"
    exit 0
  fi
  sleep 0.1
done
echo "cluster-start: the node did not come up; see $STATE/log/" >&2
scontrol show node "$host" >&2 || true
exit 1
