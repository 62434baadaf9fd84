#!/usr/bin/env python3
"""Writes studies/simple-machine.csv: the "simple machine" of Brynjarsdottir & O'Hagan (2014).

The real process is zeta(x) = beta x / (1 + x/a) with beta = 0.65, a = 20 (a saturating machine);
the simulation is eta(x, theta) = theta x. Eleven equally spaced inputs x in [0.2, 4], no noise,
one test per input. Run from the repository root:  python3 scripts/make_simple_machine.py
"""
BETA, A = 0.65, 20.0

with open("studies/simple-machine.csv", "w") as out:
    out.write("design,x,work\n")
    for i in range(11):
        x = 0.2 + i * (4.0 - 0.2) / 10
        out.write(f"x{i},{x:.15g},{BETA * x / (1 + x / A):.15g}\n")
