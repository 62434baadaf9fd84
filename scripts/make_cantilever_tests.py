#!/usr/bin/env python3
"""Writes studies/cantilever-tests.csv: the paper's "tests" for the cantilever (Qiu et al. 2018, Sec. 3).

The tests are the Timoshenko tip deflection (Eq. 11) with the true E0 = 68,000 MPa and, as the paper
assumes, zero measurement error: one test per design, h = 7 ... 13 mm.
    y_test(h) = 4 F L^3 / (E b h^3) + F L (4 + 5 nu) / (2 E b h)
Run from the repository root:  python3 scripts/make_cantilever_tests.py
"""
F, L, b, nu, E0 = 600.0, 20.0, 2.0, 0.36, 68_000.0

def timoshenko(h):
    return 4 * F * L**3 / (E0 * b * h**3) + F * L * (4 + 5 * nu) / (2 * E0 * b * h)

with open("studies/cantilever-tests.csv", "w") as out:
    out.write("design,h,deflection\n")
    for h in range(7, 14):
        out.write(f"h{h},{h},{timoshenko(h):.15g}\n")
