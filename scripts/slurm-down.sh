#!/usr/bin/env bash
# Stops the Slurm started by scripts/slurm-up.sh, by the PIDs it recorded (never by name).
set -uo pipefail
DIR=${LAB_SLURM_DIR:-/tmp/lab-slurm}
[ -f "$DIR/pids" ] || { echo "no $DIR/pids: nothing to stop" >&2; exit 0; }
tac "$DIR/pids" | while read -r name pid; do
    if kill -0 "$pid" 2>/dev/null; then
        kill "$pid" && echo "stopped $name ($pid)" >&2
        for _ in $(seq 50); do kill -0 "$pid" 2>/dev/null || break; sleep 0.1; done
    fi
done
rm -f "$DIR/pids"
