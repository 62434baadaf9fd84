#!/bin/sh
# Regenerates fixtures/honeycomb/: the synthetic tests (tests/) from the documented truth, then a
# recording of every planned run of studies/honeycomb.yaml made live with the stand-in solver
# crushsim. See fixtures/README.md. Deterministic: the same sources give the same bytes.
set -eu
cd "$(dirname "$0")/.."
target="${CARGO_TARGET_DIR:-target}"
cargo build --release --bins --example make_honeycomb_tests
bin="$(cd "$target/release" && pwd)"
rm -rf fixtures/honeycomb/tests
find fixtures/honeycomb -mindepth 1 -maxdepth 1 -type d -name '[0-9a-f]*' -exec rm -rf {} +
"$bin/examples/make_honeycomb_tests" fixtures/honeycomb/tests "$bin/crushsim"
out="$(mktemp -d)"
trap 'rm -rf "$out"' EXIT
PATH="$(cd "$bin" && pwd):$PATH" "$bin/lab" run studies/honeycomb.yaml --out "$out" --record fixtures/honeycomb
du -sh fixtures/honeycomb
