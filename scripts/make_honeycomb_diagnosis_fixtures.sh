#!/bin/sh
# Regenerates fixtures/honeycomb-diagnosis/: the synthetic tests (tests/) for the designs of
# studies/honeycomb-diagnosis.yaml from the same documented truth as fixtures/honeycomb, then a
# recording of every run of that study and of studies/honeycomb-diagnosis-curves.yaml (both sampled
# sequentially: screening, probes and solver-in-the-loop runs; a run both ask for is recorded once)
# made live with the stand-in solver crushsim. Leaves fixtures/honeycomb alone (scripts/make_honeycomb_fixtures.sh).
# See fixtures/README.md. Deterministic: the same sources give the same bytes.
set -eu
cd "$(dirname "$0")/.."
target="${CARGO_TARGET_DIR:-target}"
dir=fixtures/honeycomb-diagnosis
designs="C6T5:6:0.05,C6T65:6:0.065,C6T8:6:0.08,C3T5:3:0.05,C3T65:3:0.065,C3T8:3:0.08,C3T7:3:0.07,C6T10:6:0.1,C3T10:3:0.1"
specimens=8   # see fixtures/README.md: 3 per design cannot make the ~2 % pattern significant
cargo build --release --bins --example make_honeycomb_tests
bin="$(cd "$target/release" && pwd)"
mkdir -p "$dir"
rm -rf "$dir/tests"
find "$dir" -mindepth 1 -maxdepth 1 -type d -name '[0-9a-f]*' -exec rm -rf {} +
"$bin/examples/make_honeycomb_tests" "$dir/tests" "$bin/crushsim" "$designs" "$specimens"
out="$(mktemp -d)"
trap 'rm -rf "$out"' EXIT
PATH="$bin:$PATH" "$bin/lab" run studies/honeycomb-diagnosis.yaml --out "$out/response" --record "$dir"
PATH="$bin:$PATH" "$bin/lab" run studies/honeycomb-diagnosis-curves.yaml --out "$out/curves" --record "$dir"
du -sh "$dir"
