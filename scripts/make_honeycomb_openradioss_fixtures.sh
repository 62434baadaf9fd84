#!/usr/bin/env bash
# Makes fixtures/honeycomb-openradioss/ with OpenRadioss (see fixtures/README.md):
#   1. the "measured" tests (tests/): the study's deck at the documented truth, one OpenRadioss run
#      per specimen (examples/make_honeycomb_openradioss_tests.rs);
#   2. a recording of every run `lab run studies/honeycomb-openradioss.yaml` plans, made live;
#   3. standin/<run key>/: the stand-in crushsim's rcforc and nodout on each recorded run's deck,
#      for the report's comparison of the two solvers.
# Resumable: specimens already run (target/openradioss-tests/), runs already finished
# (target/openradioss-fixtures-out/) and recordings already there are not run again, so after a
# change of the study's plan this records only the new runs. OpenRadioss comes from
# ../shared/tools/openradioss/install.sh (or OPENRADIOSS_INSTALL); one solver at a time, one thread,
# under nice (LAB_JOBS raises the number of runs at once).
set -euo pipefail
cd "$(dirname "$0")/.."
target="${CARGO_TARGET_DIR:-target}"
install="${OPENRADIOSS_INSTALL:-../shared/tools/openradioss/install.sh}"
eval "$("$install" "$PWD/$target/openradioss")"
nice -n 10 cargo build --release --bins --example make_honeycomb_openradioss_tests
bin="$(cd "$target/release" && pwd)"
fixtures=fixtures/honeycomb-openradioss
mkdir -p "$fixtures"

# 1. the tests
nice -n 10 "$bin/examples/make_honeycomb_openradioss_tests" "$fixtures/tests" "$target/openradioss-tests"

# 2. the recordings (lab exits 1 when a method fails; the recordings are made before that)
out="$target/openradioss-fixtures-out"
# On a machine without that directory, a replay of the recordings fills its store first, so that the
# live run below makes only the runs they lack (a replay fails those, and the live run redoes them).
if [ ! -d "$out" ]; then
    "$bin/lab" run studies/honeycomb-openradioss.yaml --replay "$fixtures" --out "$out" >/dev/null 2>&1 || true
fi
nice -n 10 "$bin/lab" run studies/honeycomb-openradioss.yaml --out "$out" --record "$fixtures" \
    --jobs "${LAB_JOBS:-1}" || echo "lab run exited $? (recordings kept)"

# 3. the stand-in on the same decks: each recorded run's rendered deck and mesh, run by crushsim
standin="$fixtures/standin"
scratch="$(mktemp -d)"
trap 'rm -rf "$scratch"' EXIT
mkdir -p "$standin" "$scratch/runs"
ln -s "$PWD/$out/meshes" "$scratch/meshes"
for rec in "$fixtures"/*/manifest.json; do
    key="$(basename "$(dirname "$rec")")"
    [ -f "$standin/$key/nodout" ] && continue
    # Only runs made live here have their deck in $out (a replayed one does not): a recording made
    # by an earlier run of this script without its stand-in is left as it is.
    if [ ! -f "$out/runs/$key/main.k" ]; then
        echo "recording $key: its deck is not in $out (recorded earlier), no stand-in run" >&2
        continue
    fi
    mkdir -p "$scratch/runs/$key"
    cp "$out/runs/$key/main.k" "$scratch/runs/$key/"
    (cd "$scratch/runs/$key" && "$bin/crushsim" i=main.k ncpu=1 >/dev/null)
    mkdir -p "$standin/$key"
    cp "$scratch/runs/$key/rcforc" "$scratch/runs/$key/nodout" "$standin/$key/"
done
du -sh "$fixtures"
