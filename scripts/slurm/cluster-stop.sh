#!/usr/bin/env bash
# Stops the one-node cluster that cluster-start.sh started: cancels every job left in it
# (slurmd's SIGTERM would leave running tasks alone), then sends SIGTERM to slurmd,
# slurmctld and munged, in that order, by the pids cluster-start.sh recorded in
# $STATE/pids/ (after checking /proc/PID/comm), and SIGKILL after 20 s. It never stops
# a daemon it did not start. --purge also removes $STATE and the slurm.conf it wrote.
set -uo pipefail
STATE=${SLURM_LOCAL_STATE:-/var/spool/slurm-local}
[ -d "$STATE/pids" ] || { echo "cluster-stop: nothing recorded in $STATE/pids"; exit 0; }
if command -v scancel >/dev/null && [ -s "$STATE/pids/slurmctld" ]; then
  jobs=$(squeue -h -o %A 2>/dev/null | sort -u)
  # shellcheck disable=SC2086 # one argument per job id
  [ -n "$jobs" ] && scancel --quiet $jobs
  for _ in $(seq 50); do [ -z "$(squeue -h 2>/dev/null)" ] && break; sleep 0.2; done
fi
for name in slurmd slurmctld munged; do
  f="$STATE/pids/$name"
  [ -s "$f" ] || continue
  pid=$(cat "$f")
  if [ "$(cat "/proc/$pid/comm" 2>/dev/null)" = "$name" ]; then
    kill -TERM "$pid"
    for _ in $(seq 200); do [ -d "/proc/$pid" ] || break; sleep 0.1; done
    if [ -d "/proc/$pid" ]; then
      echo "cluster-stop: $name ($pid) ignored SIGTERM for 20 s: SIGKILL" >&2
      kill -KILL "$pid"
    fi
    echo "cluster-stop: stopped $name ($pid)"
  fi
  rm -f "$f"
done
if [ "${1:-}" = --purge ]; then
  rm -rf "$STATE"
  grep -q '^# Written by wavetrace' /etc/slurm/slurm.conf 2>/dev/null && rm -f /etc/slurm/slurm.conf
fi
exit 0
