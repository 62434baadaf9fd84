#!/usr/bin/env bash
# Writes studies/cantilever-ccx-clamp-tests.csv: cantilever "tests" made by the real solver
# (CalculiX) at a known compliant clamp, for studies/cantilever-ccx-clamp.yaml.
#
# Truth: E = 68,000 MPa, clamp_E = 210,000 MPa (templates/cantilever-ccx/beam-clamp.inp.tera, clamp
# layer of depth h/2), mesh 40 x 16 x 4 (finer than the study's); 3 specimens per design h7..h13,
# each the model's tip deflection x (1 + 0.005 z), z ~ N(0, 1) from ChaCha8 seed 12.
# The generator is examples/make_cantilever_clamp_tests.rs (it renders the study's own template
# through lab's renderer and judges ccx's output with lab's CalculiX adapter).
#
# Needs ccx (Debian: calculix-ccx). Run from anywhere (about a minute with the build):
#     scripts/make_cantilever_clamp_tests.sh [OUT.csv]
set -euo pipefail
cd "$(dirname "$0")/.."
exec cargo run --release --example make_cantilever_clamp_tests -- "$@"
