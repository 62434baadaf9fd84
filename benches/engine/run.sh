#!/usr/bin/env bash
# Run-engine overhead: 2,000 runs of a trivial solver (`cp input.txt output.txt`) three ways, on the
# same machine, at 2 at a time:
#   1. lab run --jobs 2      (render, hash, run store with fsynced commits, supervision, parsing)
#   2. GNU parallel -j 2 --joblog  (the same commands, pre-rendered directories, one shell per job)
#   3. a bare spawn loop      (Python: subprocess.run of the same argv, 2 threads, nothing else)
# Per-run cost = wall time / 2,000. lab's calibration and diagnosis after the sweep are measured by a
# second `lab run` that reuses every run, and subtracted.
# Needs: a release build of lab (cargo build --release), GNU parallel, python3.
# Usage: benches/engine/run.sh [RUNS]   (default 2000; prints a Markdown table)
set -euo pipefail
root=$(cd "$(dirname "$0")/../.." && pwd)
lab="$root/target/release/lab"
runs=${1:-2000}
per_design=$((runs / 2))
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

mkdir -p "$work/study"
cat > "$work/study/bench.yaml" <<YAML
name: engine-bench
design:
  h: {unit: mm}
parameters:
  E: {min: 50000, max: 80000, unit: MPa}
simulation:
  solver:
    adapter: command
    templates: [input.txt.tera]
    command: [cp, input.txt, output.txt]
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
printf 'design,h,y\na,1,60000\nb,2,30000\n' > "$work/study/tests.csv"

now() { date +%s.%N; }
t0=$(now); "$lab" run "$work/study/bench.yaml" --out "$work/out" --jobs 2 > /dev/null; t1=$(now)
"$lab" run "$work/study/bench.yaml" --out "$work/out" --jobs 2 > /dev/null; t2=$(now)
lab_total=$(echo "$t1 - $t0" | bc -l); lab_after=$(echo "$t2 - $t1" | bc -l)

mkdir -p "$work/dirs"
for i in $(seq 1 "$runs"); do mkdir "$work/dirs/$i"; echo "y = $i" > "$work/dirs/$i/input.txt"; done
t3=$(now); (cd "$work/dirs" && seq 1 "$runs" | parallel -j 2 --joblog "$work/joblog" 'cd {} && cp input.txt output.txt'); t4=$(now)
find "$work/dirs" -name output.txt -delete
t5=$(now)
python3 - "$work/dirs" "$runs" <<'PY'
import subprocess, sys
from concurrent.futures import ThreadPoolExecutor
root, n = sys.argv[1], int(sys.argv[2])
def one(i):
    subprocess.run(["cp", "input.txt", "output.txt"], cwd=f"{root}/{i}", check=True)
with ThreadPoolExecutor(2) as pool:
    list(pool.map(one, range(1, n + 1)))
PY
t6=$(now)

ms() { echo "scale=3; 1000 * ($1) / $runs" | bc -l; }
echo "| way ($runs runs, 2 at a time) | wall [s] | per run [ms] |"
echo "|---|---|---|"
printf '| lab run --jobs 2 (sweep only: total %.2f s minus %.2f s of fitting and calibration) | %.2f | %s |\n' "$lab_total" "$lab_after" "$(echo "$lab_total - $lab_after" | bc -l)" "$(ms "$lab_total - $lab_after")"
printf '| GNU parallel -j 2 --joblog | %.2f | %s |\n' "$(echo "$t4 - $t3" | bc -l)" "$(ms "$t4 - $t3")"
printf '| bare spawn loop (Python, 2 threads) | %.2f | %s |\n' "$(echo "$t6 - $t5" | bc -l)" "$(ms "$t6 - $t5")"
