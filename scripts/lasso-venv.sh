#!/usr/bin/env bash
# Creates the Python virtual environment with lasso-python (`lasso.dyna.Binout`, which bundles
# LSTC's own `lsda` module, `lasso/dyna/lsda_py3.py`): the independent LSDA reader and writer that
# tests/binout_lasso.rs runs scripts/check_binout_lasso.py with (issue 32: real binout files read
# equal, and crushsim's binout read back equal).
#
#   scripts/lasso-venv.sh [DIR]     # default: target/lasso-venv (inside the ignored build area)
#
# Idempotent: an existing venv that already imports the pinned versions is left as it is. About
# 350 MB (lasso-python pulls pandas, scipy, scikit-learn, h5py, plotly); 40-90 s to install. The
# last line printed is the venv's python, which the tests find by themselves at the default place
# (or through LAB_LASSO_PYTHON).
set -euo pipefail
cd "$(dirname "$0")/.."
PINS="lasso-python==2.0.4 numpy==2.4.6"
DIR=${1:-target/lasso-venv}
PY="$DIR/bin/python"
CHECK="import importlib.metadata as m, sys; sys.exit(any(m.version(p.split('==')[0]) != p.split('==')[1] for p in '$PINS'.split()))"
if [ -x "$PY" ] && "$PY" -c "$CHECK" 2>/dev/null; then
    echo "lasso-venv: $PINS already in $DIR" >&2
else
    rm -rf "$DIR"
    mkdir -p "$(dirname "$DIR")"
    python3 -m venv "$DIR"
    # shellcheck disable=SC2086 # the pins are separate words
    "$PY" -m pip install --quiet --disable-pip-version-check $PINS
    "$PY" -c "from lasso.dyna import Binout; from lasso.dyna.lsda_py3 import Lsda" # fails here, not in the test
    echo "lasso-venv: installed $PINS in $DIR" >&2
fi
echo "$(cd "$DIR" && pwd)/bin/python"
