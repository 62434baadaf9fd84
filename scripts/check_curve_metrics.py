#!/usr/bin/env python3
"""Independent check of lab's curve metrics and CFC filter (issue 24), run by
tests/curve_metrics_reference.rs with the venv that scripts/curves-venv.sh makes.

    check_curve_metrics.py MANIFEST.json REPORT.json

The manifest (written by the Rust test) lists
  - "pairs": {"name", "a", "b", "lab": {...}, optional "window": [s0, s1], "points": N}: two
    test-machine CSVs (header row, then displacement,force) and what `lab compare A B --json`
    printed for them. The reference is similaritymeasures 1.5.0 with A as exp_data, B as num_data:
    pcm, frechet_dist(p=2), dtw(...)[0], area_between_two_curves; on the raw points, or with a
    window on both curves interpolated (np.interp) at np.linspace(s0, s1, N). mse is LS-OPT's
    mean of ((B - A) / max|A|)^2 on that grid, or without a window on N strokes over the overlap
    of the two loading strokes (none when a stroke goes back there).
  - "filters": {"name", "signal", "dt", "cfc", "lab"}: a JSON file of input samples and lab's
    output. The reference filter is built here from the SAE J211-1 Appendix C formulas and run
    with scipy.signal.lfilter forward, then on the reversed output, each pass started in the
    steady state of its first input (zi = lfilter_zi(b, a) * x[0]).
  - "curve_filters": {"name", "curve", "speed", "cfc", "lab": {"displacement", "force"}}: a CSV
    filtered by lab::extract::cfc::filter_curve; the reference resamples it at its median stroke
    spacing (np.interp) and filters with dt = spacing / speed as above.

Agreement: |lab - reference| <= 1e-9 |reference| + 1e-12 per metric; for filter outputs
max |lab - reference| <= 1e-9 max |reference|. Writes REPORT.json with every value and the
largest relative differences; exits 1 when anything disagrees.
"""
import json
import math
import sys
import time
from importlib import metadata

import numpy as np
from scipy import signal

import similaritymeasures as sm

REL, ABS = 1e-9, 1e-12


def load_curve(path):
    data = np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)
    return data[:, :2].copy()


def reference_metrics(exp, num):
    return {
        "pcm": float(sm.pcm(exp, num)),
        "frechet": float(sm.frechet_dist(exp, num, p=2)),
        "dtw": float(sm.dtw(exp, num)[0]),
        "area": float(sm.area_between_two_curves(exp, num)),
    }


def loading_part(curve):
    """Samples up to the largest stroke, after any standing start (repeated first strokes but the
    last); the stroke must increase strictly there for np.interp to mean anything."""
    k = int(np.argmax(curve[:, 0]))
    part = curve[: k + 1]
    start = 0
    while start + 1 < len(part) and part[start + 1, 0] == part[0, 0]:
        start += 1
    part = part[start:]
    if np.any(np.diff(part[:, 0]) <= 0):
        raise ValueError("stroke not strictly increasing over the loading part")
    return part


def on_grid(curve, s0, s1, points):
    part = loading_part(curve)
    s = np.linspace(s0, s1, points)
    return np.column_stack([s, np.interp(s, part[:, 0], part[:, 1])])


def ls_opt_mse(t, c):
    return float(np.mean(((c - t) / np.max(np.abs(t))) ** 2))


def overlap_mse(exp, num, points):
    """MSE on the overlap of the two loading strokes; None when a stroke goes back there."""
    s0 = max(exp[0, 0], num[0, 0])
    s1 = min(np.max(exp[:, 0]), np.max(num[:, 0]))
    try:
        return ls_opt_mse(on_grid(exp, s0, s1, points)[:, 1], on_grid(num, s0, s1, points)[:, 1])
    except ValueError:
        return None


def close(lab, ref):
    if lab is None or ref is None or math.isnan(ref):
        return lab is None and (ref is None or math.isnan(ref))
    return abs(lab - ref) <= REL * abs(ref) + ABS


def rel_diff(lab, ref):
    if lab is None or ref is None:
        return None
    return abs(lab - ref) / max(abs(ref), 1e-300)


def j211(dt, cfc):
    wd = 2.0 * math.pi * cfc * 2.0775
    wa = math.tan(wd * dt / 2.0)
    den = 1.0 + math.sqrt(2.0) * wa + wa * wa
    a0 = wa * wa / den
    b1 = -2.0 * (wa * wa - 1.0) / den
    b2 = (-1.0 + math.sqrt(2.0) * wa - wa * wa) / den
    return np.array([a0, 2.0 * a0, a0]), np.array([1.0, -b1, -b2])


def cfc_reference(x, dt, cfc):
    b, a = j211(dt, cfc)
    zi = signal.lfilter_zi(b, a)
    y, _ = signal.lfilter(b, a, x, zi=zi * x[0])
    r = y[::-1]
    z, _ = signal.lfilter(b, a, r, zi=zi * r[0])
    return z[::-1]


def check_pairs(pairs, problems, worst):
    out = []
    for p in pairs:
        exp, num = load_curve(p["a"]), load_curve(p["b"])
        if "window" in p:
            s0, s1 = p["window"]
            exp, num = on_grid(exp, s0, s1, p["points"]), on_grid(num, s0, s1, p["points"])
        ref = reference_metrics(exp, num)
        if "window" in p:
            ref["mse"] = ls_opt_mse(exp[:, 1], num[:, 1])
        else:
            ref["mse"] = overlap_mse(exp, num, p.get("points", 200))
        row = {"name": p["name"], "points": [len(exp), len(num)], "reference": ref, "lab": {}}
        for key, r in ref.items():
            lab = p["lab"].get(key)
            row["lab"][key] = lab
            d = rel_diff(lab, r)
            if d is not None:
                worst[key] = max(worst.get(key, 0.0), d)
            if not close(lab, r):
                problems.append(f"{p['name']}: {key} lab {lab!r} reference {r!r}")
        out.append(row)
    return out


def check_filters(filters, problems, worst):
    out = []
    for f in filters:
        with open(f["signal"]) as fh:
            x = np.array(json.load(fh), dtype=float)
        ref = cfc_reference(x, f["dt"], f["cfc"])
        lab = np.array(f["lab"], dtype=float)
        d = float(np.max(np.abs(lab - ref)) / np.max(np.abs(ref)))
        worst["filter"] = max(worst.get("filter", 0.0), d)
        if lab.shape != ref.shape or not d <= REL:
            problems.append(f"{f['name']}: filter differs by {d:.3e} of its largest value")
        out.append({"name": f["name"], "samples": len(x), "max_rel_diff": d})
    return out


def check_curve_filters(items, problems, worst):
    out = []
    for f in items:
        part = loading_part(load_curve(f["curve"]))
        d = part[:, 0]
        h = float(np.median(np.diff(d)))
        steps = max(round((d[-1] - d[0]) / h), 1)
        s = np.linspace(d[0], d[-1], steps + 1)
        force = cfc_reference(np.interp(s, d, part[:, 1]), (d[-1] - d[0]) / steps / f["speed"], f["cfc"])
        lab_s = np.array(f["lab"]["displacement"], dtype=float)
        lab_f = np.array(f["lab"]["force"], dtype=float)
        if lab_s.shape != s.shape:
            problems.append(f"{f['name']}: {len(lab_s)} grid points, reference {len(s)}")
            continue
        ds = float(np.max(np.abs(lab_s - s)) / np.max(np.abs(s)))
        dfv = float(np.max(np.abs(lab_f - force)) / np.max(np.abs(force)))
        worst["filter_curve"] = max(worst.get("filter_curve", 0.0), ds, dfv)
        if not (ds <= REL and dfv <= REL):
            problems.append(f"{f['name']}: stroke differs by {ds:.3e}, force by {dfv:.3e}")
        out.append({"name": f["name"], "points": len(s), "max_rel_diff": max(ds, dfv)})
    return out


def main():
    manifest_path, report_path = sys.argv[1], sys.argv[2]
    started = time.perf_counter()
    with open(manifest_path) as fh:
        manifest = json.load(fh)
    problems, worst = [], {}
    report = {
        "similaritymeasures": metadata.version("similaritymeasures"),
        "numpy": np.__version__,
        "scipy": metadata.version("scipy"),
        "tolerance": {"relative": REL, "absolute": ABS},
        "pairs": check_pairs(manifest.get("pairs", []), problems, worst),
        "filters": check_filters(manifest.get("filters", []), problems, worst),
        "curve_filters": check_curve_filters(manifest.get("curve_filters", []), problems, worst),
    }
    report["worst_relative_difference"] = worst
    report["problems"] = problems
    report["seconds"] = time.perf_counter() - started
    with open(report_path, "w") as fh:
        json.dump(report, fh, indent=1)
    for p in problems:
        print("DISAGREE", p)
    print(f"checked {len(report['pairs'])} pairs, {len(report['filters'])} filters, "
          f"{len(report['curve_filters'])} curve filters; worst relative differences {worst}")
    sys.exit(1 if problems else 0)


if __name__ == "__main__":
    main()
