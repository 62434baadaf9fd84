#!/bin/sh
# Regenerates the scale study's synthetic tests and fixtures/cantilever-scale/: every planned run of
# studies/cantilever-scale.yaml made live with the stand-in solver studies/solvers/beam.py (python3)
# and recorded. See fixtures/README.md. Deterministic: the same sources give the same bytes.
set -eu
cd "$(dirname "$0")/.."
target="${CARGO_TARGET_DIR:-target}"
python3 scripts/make_cantilever_scale_tests.py
cargo build --release --bin lab
find fixtures/cantilever-scale -mindepth 1 -maxdepth 1 -type d -name '[0-9a-f]*' -exec rm -rf {} + 2>/dev/null || true
out="$(mktemp -d)"
trap 'rm -rf "$out"' EXIT
"$target/release/lab" run studies/cantilever-scale.yaml --out "$out" --record fixtures/cantilever-scale --jobs 2
du -sh fixtures/cantilever-scale
