#!/usr/bin/env bash
# Creates the Python environment of the Bayesian benchmark's numpy/scipy reference
# (benches/koh_reference.py): a virtual environment with numpy and scipy from the Python registry.
# Usage: scripts/bench-venv.sh [DIR]   (default target/bench-venv); prints DIR/bin/python.
set -euo pipefail
dir="${1:-target/bench-venv}"
if [ ! -x "$dir/bin/python" ]; then
  python3 -m venv "$dir"
  "$dir/bin/pip" install --quiet numpy scipy
fi
echo "$dir/bin/python"
