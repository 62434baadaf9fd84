#!/usr/bin/env bash
# The reduced OpenRadioss model's mesh/speed check (docs/openradioss.md), run once: design C6T5 at
# the baseline with the study's model, the mesh refined, the speed halved and no mass scaling
# (examples/make_honeycomb_openradioss_tests.rs, `check`), against the specimens' scatter in
# fixtures/honeycomb-openradioss/tests. Prints a Markdown table; resumable (runs already finished in
# target/openradioss-check are reused). About 30 minutes of one core.
set -euo pipefail
cd "$(dirname "$0")/.."
target="${CARGO_TARGET_DIR:-target}"
eval "$("${OPENRADIOSS_INSTALL:-../shared/tools/openradioss/install.sh}" "$PWD/$target/openradioss")"
nice -n 10 cargo build --release --example make_honeycomb_openradioss_tests
nice -n 10 "$target/release/examples/make_honeycomb_openradioss_tests" check "$target/openradioss-check" \
    fixtures/honeycomb-openradioss/tests/experiments.csv
