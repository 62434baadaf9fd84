#!/usr/bin/env bash
# Creates the Python virtual environment with PyDyna (ansys-dyna-core), the independent LS-DYNA
# keyword reader that tests/deck_pydyna.rs runs scripts/check_decks_pydyna.py with.
#
#   scripts/pydyna-venv.sh [DIR]     # default: target/pydyna-venv (inside the ignored build area)
#
# Idempotent: an existing venv that already imports the pinned version is left as it is. About
# 420 MB with its dependencies (pandas, numpy, ansys-dpf-core); one to two minutes to install.
# The last line printed is the venv's python, which the test finds by itself at the default place
# (or through LAB_PYDYNA_PYTHON).
set -euo pipefail
cd "$(dirname "$0")/.."
VERSION=0.12.1
DIR=${1:-target/pydyna-venv}
PY="$DIR/bin/python"
if [ -x "$PY" ] && "$PY" -c "import importlib.metadata as m, sys; sys.exit(m.version('ansys-dyna-core') != '$VERSION')" 2>/dev/null; then
    echo "pydyna-venv: ansys-dyna-core $VERSION already in $DIR" >&2
else
    rm -rf "$DIR"
    mkdir -p "$(dirname "$DIR")"
    python3 -m venv "$DIR"
    "$PY" -m pip install --quiet --disable-pip-version-check "ansys-dyna-core==$VERSION"
    "$PY" -c "from ansys.dyna.core import Deck" # fails here, not in the test, when the install is broken
    echo "pydyna-venv: installed ansys-dyna-core $VERSION in $DIR" >&2
fi
echo "$(cd "$DIR" && pwd)/bin/python"
