#!/usr/bin/env python3
"""Writes studies/cantilever-ccx-root-tests.csv: cantilever "tests" carrying an effect the CalculiX
solid model (studies/cantilever-ccx-root.yaml) lacks: a compliant clamp (root rotation).

The tests are the Timoshenko tip deflection (E0 = 68,000 MPa, as studies/cantilever-tests.csv) plus
the tip deflection of a rotational spring at the root whose stiffness grows with the section's
bending resistance b h^2 (a clamp that yields locally at its edges):
    theta = k F L / (E0 b h^2),   y_root = theta L = k F L^2 / (E0 b h^2),   k = 0.5
The solid model is fully clamped, so it has shear deformation but no root rotation: the discrepancy
left after calibrating E has the shape 1/h^2. Run from the repository root:
    python3 scripts/make_cantilever_root_tests.py
"""
F, L, b, nu, E0, K = 600.0, 20.0, 2.0, 0.36, 68_000.0, 0.5


def test(h):
    timoshenko = 4 * F * L**3 / (E0 * b * h**3) + F * L * (4 + 5 * nu) / (2 * E0 * b * h)
    return timoshenko + K * F * L**2 / (E0 * b * h**2)


with open("studies/cantilever-ccx-root-tests.csv", "w") as out:
    out.write("design,h,deflection\n")
    for h in range(7, 14):
        out.write(f"h{h},{h},{test(h):.15g}\n")
