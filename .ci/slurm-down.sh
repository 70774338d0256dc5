#!/usr/bin/env bash
# Stops the one-node SLURM cluster of .ci/slurm-up.sh in DIR (default /tmp/xpflow-slurm): slurmd,
# slurmctld and munged, each by the pid in its pid file, waiting for each to exit.
set -uo pipefail
DIR=${1:-/tmp/xpflow-slurm}
for pidfile in "$DIR/slurmd.pid" "$DIR/slurmctld.pid" "$DIR/munge/munged.pid"; do
    [ -s "$pidfile" ] || continue
    pid=$(cat "$pidfile")
    if kill "$pid" 2>/dev/null; then
        for _ in $(seq 1 50); do
            kill -0 "$pid" 2>/dev/null || break
            sleep 0.1
        done
        echo "slurm-down: stopped $(basename "$pidfile" .pid) (pid $pid)" >&2
    fi
    rm -f "$pidfile"
done
