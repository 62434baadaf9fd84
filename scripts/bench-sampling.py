#!/usr/bin/env python3
"""Runs to the answer: sequential sampling against fixed Latin hypercubes (6, 12 and 24 samples per
design), median over seeds, live with the stand-in solver crushsim (every solver run counted).

    scripts/bench-sampling.py [--seeds 10] [--studies honeycomb,honeycomb-diagnosis,...] [--methods sequential,lhs6,...]

Needs a release build (`cargo build --release`: target/release/lab and crushsim). Each study is
copied with its `simulation.sampling` line replaced and its `replay` line dropped (so it runs live),
into target/bench-sampling/, one output directory per (study, method, seed). Prints a Markdown table
(docs/benchmarks.md keeps the figures) and writes target/bench-sampling/summary-METHODS.json.

A run "answers" when the diagnosis names the study's documented cause and, for the main job, the
extended model's yield stress is within 3 % of 185 MPa and ETAN within 20 % of 200 MPa (the truth in
fixtures/README.md). The planner's wall time per batch comes from results.json
`sampling.sequence[].planning_seconds`.
"""
import argparse
import json
import os
import re
import statistics
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
BIN = ROOT / "target" / "release"
WORK = ROOT / "target" / "bench-sampling"
CAUSE = {
    "honeycomb": "strain hardening in the fold hinges",
    "honeycomb-diagnosis": "strain hardening",
    "honeycomb-diagnosis-curves": "strain hardening",
}
METHODS = {
    "lhs6": "{method: lhs, count: 6, seed: %d, check_runs: 1}",
    "lhs12": "{method: lhs, count: 12, seed: %d, check_runs: 2}",
    "lhs24": "{method: lhs, count: 24, seed: %d, check_runs: 5}",
    "sequential": "{method: sequential, batch: 3, seed: %d}",
    # One emulator across the designs (needs `surrogate: gp` in the study).
    "across": "{method: sequential, batch: 3, seed: %d, across_designs: true}",
}


def study_copy(name, method, seed):
    text = (ROOT / "studies" / f"{name}.yaml").read_text()
    text = re.sub(r"(?m)^  sampling: .*$", "  sampling: " + METHODS[method] % seed, text)
    text = re.sub(r"(?m)^  replay: .*\n", "", text)
    text = text.replace("../", f"{ROOT}/")
    path = WORK / f"{name}-{method}-{seed}.yaml"
    path.write_text(text)
    return path


def run(name, method, seed):
    study = study_copy(name, method, seed)
    out = WORK / f"{name}-{method}-{seed}"
    env = dict(os.environ, PATH=f"{BIN}:/usr/bin:/bin")
    p = subprocess.run([str(BIN / "lab"), "run", str(study), "--out", str(out), "--jobs", "2"],
                       env=env, capture_output=True, text=True)
    if p.returncode not in (0, 1):
        sys.exit(f"{study}: lab exited {p.returncode}\n{p.stderr[-2000:]}")
    r = json.loads((out / "results.json").read_text())
    d = r["diagnosis"]
    ext = d.get("extended") or {}
    params = ext.get("parameters", {})
    right = d.get("cause") == CAUSE[name]
    if name == "honeycomb" and right:
        right = abs(params.get("sigma_y", 0) / 185 - 1) <= 0.03 and abs(params.get("etan", 0) / 200 - 1) <= 0.2
    planning = [b.get("planning_seconds", 0.0) for b in (r.get("sampling") or {}).get("sequence", [])]
    return {"runs": r["runs"]["succeeded"] + r["runs"].get("failed", 0), "right": right,
            "verdict": d.get("verdict"), "cause": d.get("cause"), "parameters": params,
            "planning": [t for t in planning if t > 0]}


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--seeds", type=int, default=10)
    ap.add_argument("--studies", default="honeycomb,honeycomb-diagnosis,honeycomb-diagnosis-curves")
    ap.add_argument("--methods", default=",".join(METHODS), help="a subset of " + ", ".join(METHODS))
    args = ap.parse_args()
    WORK.mkdir(parents=True, exist_ok=True)
    summary = {}
    print("| study | sampling | median runs | right answers | planner s/batch (median, max) |")
    print("|---|---|---|---|---|")
    for name in args.studies.split(","):
        for method in args.methods.split(","):
            rows = [run(name, method, s) for s in range(1, args.seeds + 1)]
            summary[f"{name}/{method}"] = rows
            plan = [t for r in rows for t in r["planning"]]
            timing = f"{statistics.median(plan):.3f}, {max(plan):.3f}" if plan else "-"
            print(f"| {name} | {method} | {statistics.median(r['runs'] for r in rows):g} | "
                  f"{sum(r['right'] for r in rows)}/{len(rows)} | {timing} |", flush=True)
    (WORK / f"summary-{args.methods.replace(',', '-')}.json").write_text(json.dumps(summary, indent=1))


if __name__ == "__main__":
    main()
