#!/bin/sh
# The scale study's whole command: four parameters, eight tested designs, 400 emulator
# runs replayed from fixtures/cantilever-scale, three methods, report. Needs hyperfine (Debian
# package) and a release build. Figures in docs/benchmarks.md.
set -eu
cd "$(dirname "$0")/.."
target="${CARGO_TARGET_DIR:-target}"
cargo build --release --bin lab
out="$(mktemp -d)"
trap 'rm -rf "$out"' EXIT
hyperfine -N --runs "${RUNS:-3}" \
  "$target/release/lab run studies/cantilever-scale.yaml --replay fixtures/cantilever-scale --out $out/scale"
