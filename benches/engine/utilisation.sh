#!/usr/bin/env bash
# Solver-slot utilisation of the local executor: RUNS runs of a solver that takes 1 s (python3
# sleeps 1 s, writes its output and logs its own process's start and end; argv, no shell) through
# `lab run --jobs 2`. Utilisation = the solvers' own time / (2 slots x wall), for two walls:
#   the window from the first solver start to the last solver end (gaps between runs only), and
#   lab's whole wall time minus its fitting and calibration (measured by a second `lab run` that
#   reuses every run), which also counts start-up, planning and rendering.
# Target: >= 98 %. Needs a release build of lab (cargo build --release) and python3.
# Usage: benches/engine/utilisation.sh [RUNS]   (default 40; prints a Markdown table)
set -euo pipefail
root=$(cd "$(dirname "$0")/../.." && pwd)
lab="$root/target/release/lab"
runs=${1:-40}
per_design=$((runs / 2))
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

mkdir -p "$work/study"
cat > "$work/study/bench.yaml" <<YAML
name: utilisation-bench
design:
  h: {unit: mm}
parameters:
  E: {min: 50000, max: 80000, unit: MPa}
simulation:
  solver:
    adapter: command
    templates: [input.txt.tera]
    command: [python3, $work/solver.py]
    timeout: 60
  response:
    file: output.txt
    regex: "y = (\\\\S+)"
  sampling: {method: lhs, count: $per_design, seed: 1, check_runs: 0}
  surrogate: linear
experiments:
  file: tests.csv
  response: y
training: [a, b]
calibration:
  methods: [least_squares]
YAML
printf 'y = {{ E / h }}\n' > "$work/study/input.txt.tera"
# The "solver": sleeps 1 s, writes its output, and logs its own span: from its process's creation
# (/proc/self/stat starttime, so interpreter start-up counts as solver time) to its end.
printf 'design,h,y\na,1,60000\nb,2,30000\n' > "$work/study/tests.csv"
cat > "$work/solver.py" <<PY
import os, shutil, time
time.sleep(1)
shutil.copy("input.txt", "output.txt")
ticks = os.sysconf("SC_CLK_TCK")
since_boot = int(open("/proc/self/stat").read().rsplit(")", 1)[1].split()[19]) / ticks
start = time.time() - (time.clock_gettime(time.CLOCK_BOOTTIME) - since_boot)
with open("$work/solver.log", "a") as log:
    log.write(f"{start} {time.time()}\\n")
PY

now() { date +%s.%N; }
t0=$(now); "$lab" run "$work/study/bench.yaml" --out "$work/out" --jobs 2 > /dev/null; t1=$(now)
"$lab" run "$work/study/bench.yaml" --out "$work/out" --jobs 2 > /dev/null; t2=$(now)

python3 - "$work/solver.log" "$work/out/results" "$runs" "$t0" "$t1" "$t2" <<'PY'
import json, pathlib, sys
log, results, runs = pathlib.Path(sys.argv[1]), pathlib.Path(sys.argv[2]), int(sys.argv[3])
t0, t1, t2 = map(float, sys.argv[4:7])
spans = [tuple(map(float, line.split())) for line in log.read_text().splitlines()]
assert len(spans) == runs == len(list(results.glob("*.json"))), "every run exactly once"
busy = sum(end - start for start, end in spans)
window = max(e for _, e in spans) - min(s for s, _ in spans)
sweep = (t1 - t0) - (t2 - t1)
print(f"| what ({runs} runs, solver {busy / runs:.3f} s each, --jobs 2) | wall [s] | solver-slot utilisation |")
print("|---|---|---|")
print(f"| first solver start to last solver end | {window:.2f} | {100 * busy / (2 * window):.1f} % |")
print(f"| whole `lab run` minus its fitting and calibration ({t2 - t1:.2f} s) | {sweep:.2f} | {100 * busy / (2 * sweep):.1f} % |")
PY
