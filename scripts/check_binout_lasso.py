#!/usr/bin/env python3
"""The independent LSDA reader and writer for lab's binout tests (tests/binout_lasso.rs): lasso-python
2.0.4 (`lasso.dyna.Binout`) and LSTC's own `lsda` module it bundles (`lasso/dyna/lsda_py3.py`).
Run with the python of scripts/lasso-venv.sh. Prints JSON on stdout.

  check_binout_lasso.py dump PATTERN    every variable lasso.dyna.Binout(PATTERN) reads, by its path
                                        in lasso's naming: arrays (dtype, shape, values), texts, lists
  check_binout_lasso.py raw FILE        every variable of an LSDA file (and its %NNN continuations) as
                                        LSTC's Lsda reads it: absolute path -> type code and values
  check_binout_lasso.py write FILE      writes FILE (and FILE%001) with LSTC's Lsda writer: every type,
                                        relative directory changes, several symbol tables, a
                                        continuation file; prints what it wrote, read back by Lsda

Reals are printed with Python's shortest round-trip repr, so a reader can compare them bit for bit.
"""
import json
import sys

from lasso.dyna import Binout
from lasso.dyna.lsda_py3 import Lsda


def name(n):
    return n.decode() if isinstance(n, bytes) else n


def number_list(values):
    return [float(v) if isinstance(v, float) else int(v) for v in values]


def dump(pattern):
    b = Binout(pattern)
    out = {}

    def walk(path):
        r = b.read(*path)
        key = "/".join(path)
        if isinstance(r, list):
            sym = b._get_symbol(b.lsda_root, path) if path else b.lsda_root
            leaves = path and "metadata" not in sym.children and all(c.type != 0 for c in sym.children.values())
            if leaves:
                out[key] = {"kind": "list", "names": sorted(r)}
                return
            for n in sorted(r):
                walk(path + [n])
        elif isinstance(r, str):
            out[key] = {"kind": "text", "value": r}
        else:
            out[key] = {
                "kind": "array",
                "dtype": str(r.dtype),
                "shape": list(r.shape),
                "values": number_list(r.ravel().tolist()),
            }

    walk([])
    return {"top": sorted(b.read()), "entries": out}


def raw(path):
    lsda = Lsda(path, "r")
    out = {}

    def walk(sym, prefix):
        for n, child in sym.children.items():
            p = prefix + "/" + name(n)
            if child.type == 0:
                walk(child, p)
            else:
                values = child.read()
                if child.type == Lsda.LINK:
                    values = list(values) if not isinstance(values, bytes) else list(values)
                out[p] = {"type": child.type, "values": number_list(values) if child.type != Lsda.LINK else values}

    walk(lsda.root, "")
    return out


def write(path):
    w = Lsda(path, "w")
    plan = [
        ("/alpha/metadata", "title", Lsda.I1, [ord(c) for c in "written by LSTC lsda_py3"]),
        ("/alpha/metadata", "ids", Lsda.I4, [7, -3, 2147483647]),
        ("/alpha/d000001", "time", Lsda.R4, [0.1]),
        ("/alpha/d000001", "x_force", Lsda.R4, [1.5, -2.25e-7, 3.4e38]),
        ("/alpha/d000002", "time", Lsda.R4, [0.2]),
        ("/alpha/d000002", "x_force", Lsda.R4, [1.25, 6.0e-5, -1.0]),
        ("/beta/deep/er", "i1", Lsda.I1, [-128, 0, 127]),
        ("/beta/deep/er", "i2", Lsda.I2, [-32768, 32767]),
        ("/beta/deep", "i8", Lsda.I8, [-(2 ** 63), 2 ** 53 + 1]),
        ("/beta", "u1", Lsda.U1, [0, 255]),
        ("/beta", "u2", Lsda.U2, [65535]),
        ("/beta", "u4", Lsda.U4, [4294967295]),
        ("/beta", "u8", Lsda.U8, [2 ** 53]),
        ("/beta", "r8", Lsda.R8, [0.1, -1e-310, 1.7976931348623157e308]),
    ]
    for k, (d, n, t, v) in enumerate(plan):
        w.cd(d)
        w.write(n, t, v)
        if k in (1, 5, 9):
            w.flush()
        if k == 7:
            w.nextfile()
    w.close()
    return raw(path)


if __name__ == "__main__":
    mode, arg = sys.argv[1], sys.argv[2]
    result = {"dump": dump, "raw": raw, "write": write}[mode](arg)
    print(json.dumps(result))
