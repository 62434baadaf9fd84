#!/bin/sh
# Fresh draws of studies/honeycomb-diagnosis.yaml's synthetic tests (same truth: sigma_y = 185 MPa,
# ETAN = 200 MPa; same designs and specimen counts; seeds FIRST..FIRST+N-1 instead of the fixtures'
# 2018), each run live with crushsim through the whole loop. Prints one line per seed: the verdict,
# the cause, the loop's sigma_y and etan with their 95 % intervals, and the solver runs it took.
# Cases the fixtures are not. SAMPLING replaces the study's `simulation.sampling` (e.g.
# SAMPLING='{method: lhs, count: 2, seed: 1, check_runs: 1}', its former fixed design), SURROGATE its
# `simulation.surrogate` (e.g. SAMPLING='{method: sequential, batch: 3, seed: 1, across_designs: true}'
# SURROGATE=gp: one emulator across the designs).
#
#   scripts/honeycomb-diagnosis-seeds.sh [N [FIRST]]     # default 10 seeds from 1
set -eu
cd "$(dirname "$0")/.."
n=${1:-10}; first=${2:-1}
target="${CARGO_TARGET_DIR:-target}"
cargo build --release --bins --example make_honeycomb_tests >/dev/null 2>&1
bin="$(cd "$target/release" && pwd)"
designs=$(sed -n 's/^designs="\(.*\)"/\1/p' scripts/make_honeycomb_diagnosis_fixtures.sh)
work=$(mktemp -d); trap 'rm -rf "$work"' EXIT
seed=$first
while [ "$seed" -lt $((first + n)) ]; do
    d="$work/$seed"; mkdir -p "$d"
    HONEYCOMB_TESTS_SEED=$seed "$bin/examples/make_honeycomb_tests" "$d/tests" "$bin/crushsim" "$designs" 8 >/dev/null
    sed -e "s|\.\./templates|$PWD/templates|; s|\.\./fixtures/honeycomb-diagnosis/tests|$d/tests|g; /replay:/d" \
        studies/honeycomb-diagnosis.yaml > "$d/study.yaml"
    if [ -n "${SAMPLING:-}" ]; then
        sed -i "s|^  sampling: .*\$|  sampling: $SAMPLING|" "$d/study.yaml"
    fi
    if [ -n "${SURROGATE:-}" ]; then
        sed -i "s|^  surrogate: .*\$|  surrogate: $SURROGATE|" "$d/study.yaml"
    fi
    PATH="$bin:$PATH" "$bin/lab" run "$d/study.yaml" --out "$d/out" --jobs 2 >/dev/null 2>&1 || true
    python3 - "$d/out/results.json" "$seed" <<'PY'
import json, sys
r = json.load(open(sys.argv[1]))
d = r["diagnosis"]
x = (d.get("extensions") or [{}])[0]
def f(name):
    v, i = x.get("parameters", {}).get(name), (x.get("interval95") or {}).get(name)
    return "-" if v is None else f"{v:.1f} [{i[0]:.1f}, {i[1]:.1f}]" if i else f"{v:.1f}"
print(f"seed {sys.argv[2]}: {d['verdict']:<18} cause {d.get('cause')!s:<17} extended {x.get('hypothesis')!s:<17} "
      f"sigma_y {f('sigma_y')}  etan {f('etan')}  runs {r['runs']['planned']}")
PY
    seed=$((seed + 1))
done
