"""A small stand-in solver for `lab`'s solver studies: the cantilever of Qiu et al. (2018), Sec. 3.

Run in a run directory as `python3 beam.py [INPUT]` (default `beam.txt`). The input holds
`name = number` lines (`#` starts a comment): h, F, L, b and either E (Young's modulus) or C
(compliance 1/E, which makes the response exactly linear in the parameter). Writes `output.txt`:

    tip deflection (Euler-Bernoulli)
    y = <4 F L^3 / (E b h^3), full precision>

`shear = s` (optional, default 0; needs nu, Poisson's ratio) adds s times the Timoshenko shear
term F L (4 + 5 nu) / (2 E b h) (Qiu et al. 2018, Eq. 11): s = 1 is the Timoshenko beam, and the
response is linear in s (a model extension for lab's diagnosis).

Four-parameter form (for the scale study, studies/cantilever-scale.yaml): `G` (shear modulus)
replaces the nu-based shear term by F l / (k G b h), k = 5/6; `Cr` (the clamp's modulus) adds the
root rotation of a compliant clamp, 4 F l^2 / (Cr b h^2); `a` (the load point's offset from the
tip) makes the lever l = L - a in every term. Without them the response is as above.

`fail = 1` in the input makes it exit with code 3 (for failure handling). For lab's own tests:
LAB_TEST_SOLVER_LOG names a file to which one line `start <run directory name>` is appended per
run, and LAB_TEST_SOLVER_SLEEP makes each run take that many more seconds.
"""

import os
import sys
import time


def read(path):
    values = {}
    with open(path) as f:
        for line in f:
            line = line.split("#", 1)[0].strip()
            if line:
                name, value = (part.strip() for part in line.split("=", 1))
                values[name] = float(value)
    return values


def main():
    log = os.environ.get("LAB_TEST_SOLVER_LOG")
    if log:
        fd = os.open(log, os.O_WRONLY | os.O_APPEND | os.O_CREAT, 0o644)
        os.write(fd, f"start {os.path.basename(os.getcwd())}\n".encode())
        os.close(fd)
    v = read(sys.argv[1] if len(sys.argv) > 1 else "beam.txt")
    time.sleep(float(os.environ.get("LAB_TEST_SOLVER_SLEEP", "0")))
    if v.get("fail") == 1:
        print("beam: asked to fail", file=sys.stderr)
        sys.exit(3)
    compliance = v["C"] if "C" in v else 1.0 / v["E"]
    lever = v["L"] - v.get("a", 0.0)
    y = 4.0 * v["F"] * lever ** 3 * compliance / (v["b"] * v["h"] ** 3)
    shear = v.get("shear", 0.0)
    if shear != 0.0:
        y += shear * v["F"] * lever * (4.0 + 5.0 * v["nu"]) * compliance / (2.0 * v["b"] * v["h"])
    title = "Timoshenko" if shear == 1.0 else "Euler-Bernoulli" if shear == 0.0 else f"Euler-Bernoulli + {shear!r} x shear"
    if "G" in v:
        y += v["F"] * lever / (5.0 / 6.0 * v["G"] * v["b"] * v["h"])
        title = "Timoshenko, shear modulus G"
    if "Cr" in v:
        y += 4.0 * v["F"] * lever ** 2 / (v["Cr"] * v["b"] * v["h"] ** 2)
        title += ", compliant clamp"
    with open("output.txt", "w") as f:
        f.write(f"tip deflection ({title})\ny = {y!r}\n")


if __name__ == "__main__":
    main()
