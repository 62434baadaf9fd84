#!/usr/bin/env python3
"""Writes studies/cantilever-scale-tests.csv: synthetic tests for the scale study
(studies/cantilever-scale.yaml), ten designs (depth h, length L) of a cantilever under F = 600 N.

Truth: E = 68,000 MPa, G = 26,000 MPa, Cr = 200,000 MPa (the clamp's modulus), a = 0.3 mm (the
load point's offset), through the same closed form as the study's solver (studies/solvers/beam.py):
    l = L - a
    y = 4 F l^3 / (E b h^3) + F l / (5/6 G b h) + 4 F l^2 / (Cr b h^2)
times (1 + 0.003 z), z standard normal from Python's random seeded with 2026 (test scatter).
Run from the repository root:  python3 scripts/make_cantilever_scale_tests.py
"""
import random

F, b = 600.0, 2.0
E, G, Cr, a = 68_000.0, 26_000.0, 200_000.0, 0.3
DESIGNS = [  # name, h, L: eight training designs, then two validation designs
    ("h7L15", 7, 15), ("h7L30", 7, 30), ("h10L20", 10, 20), ("h13L15", 13, 15),
    ("h13L30", 13, 30), ("h8L25", 8, 25), ("h12L22", 12, 22), ("h10L28", 10, 28),
    ("h9L18", 9, 18), ("h11L26", 11, 26),
]


def deflection(h, L):
    l = L - a
    return 4 * F * l**3 / (E * b * h**3) + F * l / (5 / 6 * G * b * h) + 4 * F * l**2 / (Cr * b * h**2)


rng = random.Random(2026)
with open("studies/cantilever-scale-tests.csv", "w") as out:
    out.write("design,h,L,deflection\n")
    for name, h, L in DESIGNS:
        out.write(f"{name},{h},{L},{deflection(h, L) * (1 + 0.003 * rng.gauss(0, 1)):.12g}\n")
