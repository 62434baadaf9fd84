#!/usr/bin/env python3
"""Writes studies/honeycomb-ccx-tests.csv: synthetic crush "tests" for studies/honeycomb-ccx.yaml.

They are NOT measurements: each design's value is the CalculiX quarter-cell model itself
(templates/honeycomb-ccx/cell.inp.tera, the study's constants and response) at the truth
sigma_y = 185 MPa (the paper's true yield stress), times (1 + e) with e ~ Normal(0, 0.03), three
replicates per design, seed 6. So a calibration should find about 185 MPa up to the model's own
scatter (fold pattern switches, ~10 %) and the noise. The model value comes from two runs at
sigma_y = 184.99 and 185.01 MPa (a study needs a range), made by `lab run` on a copy of the study.

Needs `ccx` and a release build of lab. Run from the repository root (about 40 s):
    python3 scripts/make_honeycomb_ccx_tests.py [path/to/lab]
"""
import json
import os
import random
import re
import subprocess
import sys
import tempfile

TRUTH, NOISE, REPLICATES, SEED = 185.0, 0.03, 3, 6
DESIGNS = [("C3T7", 3, 0.07), ("C3T8", 3, 0.08), ("C4T7", 4, 0.07)]
STUDY, CSV = "studies/honeycomb-ccx.yaml", "studies/honeycomb-ccx-tests.csv"
lab = sys.argv[1] if len(sys.argv) > 1 else os.path.join(os.environ.get("CARGO_TARGET_DIR", "target"), "release/lab")

# A copy of the study beside it (its paths are relative to the study file), at the truth only, with a
# placeholder tests file that names every design.
text = open(STUDY).read()
text = re.sub(r"sigma_y: \{min: 100, max: 250", f"sigma_y: {{min: {TRUTH - 0.01}, max: {TRUTH + 0.01}", text)
text = re.sub(r"sampling: \{[^}]*\}", "sampling: {method: lhs, count: 2, seed: 1, check_runs: 0}", text)
text = text.replace("honeycomb-ccx-tests.csv", ".truth-tests.csv")
text = re.sub(r"training: .*", "training: [" + ", ".join(d for d, _, _ in DESIGNS) + "]", text)
text = re.sub(r"validation: .*\n", "", text)
with open("studies/.truth-tests.csv", "w") as f:
    f.write("design,c,t,force\n" + "".join(f"{d},{c},{t},1\n" for d, c, t in DESIGNS))
with open("studies/.truth.yaml", "w") as f:
    f.write(text)
try:
    with tempfile.TemporaryDirectory() as out:
        subprocess.run([lab, "run", "studies/.truth.yaml", "--out", out, "--jobs", "2"], check=False,
                       stdout=subprocess.DEVNULL)
        results = json.load(open(os.path.join(out, "results.json")))
finally:
    os.remove("studies/.truth.yaml")
    os.remove("studies/.truth-tests.csv")

# Least squares within [184.99, 185.01]: its predictions are the surrogate (a line through the two
# runs) at about 185, i.e. the runs' mean to within the runs' slope x 0.01 MPa.
predicted = {p["design"]: p["predicted"] for p in results["calibration"]["least_squares"]["predictions"]}
rng = random.Random(SEED)
with open(CSV, "w") as out:
    out.write("design,c,t,force\n")
    for d, c, t in DESIGNS:
        model = predicted[d]
        print(f"{d}: model at sigma_y = {TRUTH}: {model:.4f} N")
        for _ in range(REPLICATES):
            out.write(f"{d},{c},{t},{model * (1 + rng.gauss(0, NOISE)):.4f}\n")
