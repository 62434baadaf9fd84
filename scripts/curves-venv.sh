#!/usr/bin/env bash
# Creates the Python virtual environment with similaritymeasures (Jekel) and the numpy/scipy it
# runs on: the independent reference that tests/curve_metrics_reference.rs runs
# scripts/check_curve_metrics.py with (curve metrics and the SAE J211 CFC filter, issue 24).
#
#   scripts/curves-venv.sh [DIR]     # default: target/curves-venv (inside the ignored build area)
#
# Idempotent: an existing venv that already imports the pinned versions is left as it is. About
# 240 MB; 20-40 s to install. numpy and scipy are pinned too: the check compares to 1e-9, and the
# reference's sums (numpy's pairwise summation) are part of what is compared. The last line
# printed is the venv's python, which the test finds by itself at the default place (or through
# LAB_CURVES_PYTHON).
set -euo pipefail
cd "$(dirname "$0")/.."
PINS="similaritymeasures==1.5.0 numpy==2.4.6 scipy==1.17.1"
DIR=${1:-target/curves-venv}
PY="$DIR/bin/python"
CHECK="import importlib.metadata as m, sys; sys.exit(any(m.version(p.split('==')[0]) != p.split('==')[1] for p in '$PINS'.split()))"
if [ -x "$PY" ] && "$PY" -c "$CHECK" 2>/dev/null; then
    echo "curves-venv: $PINS already in $DIR" >&2
else
    rm -rf "$DIR"
    mkdir -p "$(dirname "$DIR")"
    python3 -m venv "$DIR"
    # shellcheck disable=SC2086 # the pins are separate words
    "$PY" -m pip install --quiet --disable-pip-version-check $PINS
    "$PY" -c "import similaritymeasures, scipy.signal" # fails here, not in the test, when the install is broken
    echo "curves-venv: installed $PINS in $DIR" >&2
fi
echo "$(cd "$DIR" && pwd)/bin/python"
