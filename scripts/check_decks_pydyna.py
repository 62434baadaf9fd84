#!/usr/bin/env python3
"""Reads rendered LS-DYNA keyword decks with PyDyna (ansys-dyna-core), an LS-DYNA keyword reader
lab does not share any code with, and checks them against what lab planned for each run.

    python check_decks_pydyna.py MANIFEST.json REPORT.json

Run with the virtual environment's python (scripts/pydyna-venv.sh); tests/deck_pydyna.rs writes
the manifest and reads the report. The manifest is JSON:

    {"decks": [{
        "name": "C3T8 sample 0",              # for messages
        "deck": "/abs/out/runs/<key>/main.k",  # the deck lab gives the solver
        "title": "honeycomb tube crush C3T8",  # expected *TITLE
        "parameters": {"SIGY": 185.0, ...},     # expected *PARAMETER values (type R)
        "fields": [{"keyword": "MatPlasticKinematic", "id_field": "mid", "id": 1,
                    "field": "sigy", "ref": "&SIGY", "expected": 185.0}, ...],
        "include": {"file": "../../meshes/C3T8-....k", "nodes": 53808,
                    "elements": {"1": 50400, "2": 25200}}   # what the include must hold
    }, ...]}

Per deck it checks:
  * every keyword parses into a typed PyDyna keyword: none left in the loader's unprocessed list,
    no raw string in the deck, in the main file or in the expanded includes, and no warning from
    the reader (an undefined &name only warns, and reads as NaN);
  * the *INCLUDE expands: after Deck.expand no *INCLUDE is left (PyDyna keeps one it cannot find
    without a word), the included file is the one planned, and its *NODE / *ELEMENT_SHELL hold the
    planned counts per part; every shell's nodes are defined and every shell's part is a *PART of
    the deck;
  * every planned *PARAMETER reads back (type R, once) equal to the planned value, both as the
    card's text and as PyDyna's parameter set resolves it;
  * every planned field reads back equal to the planned value and holds the planned &name
    reference (PyDyna records the references it substituted, per keyword).

Numbers are compared with a relative tolerance of 5e-8 (absolute 1e-12 for zero): half a unit in
the 8th significant digit, the most a 10-character field with a sign and a point can show. lab
renders every number exactly or fails, so any difference beyond that is a real one.

Keywords PyDyna has no class for: none in the honeycomb template (0.12.1 types all 28 of its
keywords, *TITLE and *KEYWORD/*END are handled by the Deck itself). The template's *CRUSHSIM_TEST
is not an LS-DYNA keyword (a switch of the stand-in solver, rendered only in crushsim's own failure
tests) and would fail here, as it should: it must never reach a real solver. Add a keyword to
UNSUPPORTED_OK only if PyDyna lacks its type, with the reason.

The report is JSON: {"version": ..., "decks": [{"name", "deck", "problems": [...], "seconds"}]}.
Exit code 0 when no deck has a problem, 1 otherwise, 2 on a bad manifest.
"""

import hashlib
import json
import math
import os
import sys
import time
import warnings
from collections import Counter
from importlib import metadata

# Keyword names (as written, e.g. "*FOO_BAR") that PyDyna has no class for and that may therefore
# stay unparsed, each with the reason. Empty: every keyword lab's honeycomb template writes is typed.
UNSUPPORTED_OK: dict = {}

REL_TOL = 5e-8
ABS_TOL = 1e-12


def close(a, b):
    """Equal within the fixed-width field's rounding (see the module's doc)."""
    if a is None or b is None:
        return False
    try:
        a, b = float(a), float(b)
    except (TypeError, ValueError):
        return False
    return math.isfinite(a) and math.isclose(a, b, rel_tol=REL_TOL, abs_tol=ABS_TOL)


def keyword_name(kw):
    """The keyword as written, e.g. *MAT_PLASTIC_KINEMATIC, for a typed keyword or a raw string."""
    if isinstance(kw, str):
        return kw.strip().splitlines()[0].strip() if kw.strip() else "<empty>"
    sub = getattr(kw, "subkeyword", "")
    name = kw.keyword if not sub or sub == kw.keyword else f"{kw.keyword}_{sub}"
    return "*" + name


def unparsed(keywords, where):
    """Problems for the keywords PyDyna kept as raw strings."""
    problems = []
    for kw in keywords:
        if isinstance(kw, str):
            name = keyword_name(kw)
            if name.upper() in UNSUPPORTED_OK:
                continue
            problems.append(f"{where}: keyword {name} was not parsed into a typed keyword")
    return problems


def reader_warnings(caught):
    """Problems for the reader's warnings (an undefined &name, a field it could not convert)."""
    return [
        f"reader warning: {w.message}"
        for w in caught
        if not issubclass(w.category, (DeprecationWarning, PendingDeprecationWarning, FutureWarning))
    ]


def resolve_include(filename, run_dir):
    """The file an *INCLUDE names, found the way Deck.expand finds it (relative to the run directory)."""
    path = os.path.join(run_dir, filename)
    return os.path.normpath(path) if os.path.isfile(path) else None


class IncludeCache:
    """What Deck.expand read from an included file, by the file's content (sha256).

    A run's mesh is shared by every run of its design (and equal for equal cell sizes), and reading
    one takes PyDyna 1-3 s: the first deck that includes a given content is expanded by
    Deck.expand, and the later decks that include a byte-identical file reuse what it read. Only a
    content that defines no parameter and references none is cached (its keywords then read the
    same in any deck). Set LAB_PYDYNA_EXPAND_EVERY=1 to expand every deck instead.
    """

    def __init__(self):
        self.by_hash = {}
        self.every = os.environ.get("LAB_PYDYNA_EXPAND_EVERY") == "1"
        self.expanded = 0

    def read(self, deck, run_dir, target):
        with open(target, "rb") as f:
            digest = hashlib.sha256(f.read()).hexdigest()
        if not self.every and digest in self.by_hash:
            return self.by_hash[digest], []
        problems = []
        refs_before = len(deck.parameters._refs)
        params_before = dict(deck.parameters.get_global_params())
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            expanded = deck.expand(cwd=run_dir)
        self.expanded += 1
        problems += reader_warnings(caught)
        left = [kw.filename for kw in expanded.all_keywords if not isinstance(kw, str) and kw.keyword == "INCLUDE"]
        if left:
            problems.append(f"*INCLUDE not expanded by Deck.expand (from {run_dir}): {left}")
        raw_main = Counter(kw for kw in deck.all_keywords if isinstance(kw, str))
        raw_all = Counter(kw for kw in expanded.all_keywords if isinstance(kw, str))
        mine = [
            kw for kw in expanded.all_keywords
            if not isinstance(kw, str) and kw.included_from and os.path.normpath(kw.included_from) == target
        ]
        summary = {
            "raw": list((raw_all - raw_main).elements()),
            "keywords": Counter(keyword_name(kw) for kw in mine),
            "nodes": 0,
            "node_ids": set(),
            "shells": Counter(),
            "shell_nodes": set(),
        }
        for kw in mine:
            if type(kw).__name__ == "Node":
                summary["nodes"] += len(kw.nodes)
                summary["node_ids"].update(int(n) for n in kw.nodes["nid"])
            elif type(kw).__name__ == "ElementShell":
                els = kw.elements
                summary["shells"].update(str(int(p)) for p in els["pid"])
                for col in ("n1", "n2", "n3", "n4"):
                    summary["shell_nodes"].update(int(n) for n in els[col].dropna())
        pure = len(deck.parameters._refs) == refs_before and deck.parameters.get_global_params() == params_before
        if not problems and pure and not self.every:
            self.by_hash[digest] = summary
        return summary, problems


def check_deck(spec, cache):
    from ansys.dyna.core import Deck

    problems = []
    path = spec["deck"]
    run_dir = os.path.dirname(os.path.abspath(path))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        deck = Deck()
        with open(path, encoding="utf-8") as f:
            result = deck.loads(f.read())
    problems += reader_warnings(caught)
    for name in result._unprocessed_keywords:
        if name.upper() not in UNSUPPORTED_OK:
            problems.append(f"main deck: keyword {name} is unprocessed")
    problems += unparsed(deck.all_keywords, "main deck")
    # Deck.expand warns about these too, but a cached include skips it: ask the parameter set.
    unresolved = sorted({name for name, _ in deck.parameters.get_all_unresolved_param_names()})
    if unresolved:
        problems.append(f"undefined parameter reference(s): {', '.join('&' + n for n in unresolved)}")
    typed = [kw for kw in deck.all_keywords if not isinstance(kw, str)]
    if "title" in spec and deck.title != spec["title"]:
        problems.append(f"*TITLE reads {deck.title!r}, planned {spec['title']!r}")

    # --- includes
    includes = [kw.filename for kw in typed if kw.keyword == "INCLUDE"]
    inc = spec.get("include")
    if inc is not None and includes != [inc["file"]]:
        problems.append(f"*INCLUDE names {includes}, planned [{inc['file']!r}]")
    nodes = [kw for kw in typed if type(kw).__name__ == "Node"]
    shells = [kw for kw in typed if type(kw).__name__ == "ElementShell"]
    node_ids = set()
    for kw in nodes:
        node_ids.update(int(n) for n in kw.nodes["nid"])
    shell_nodes, shell_parts = set(), set()
    for kw in shells:
        for col in ("n1", "n2", "n3", "n4"):
            shell_nodes.update(int(n) for n in kw.elements[col].dropna())
        shell_parts.update(int(p) for p in kw.elements["pid"])
    for name in includes:
        target = resolve_include(name, run_dir)
        if target is None:
            problems.append(f"*INCLUDE {name}: no such file from {run_dir}")
            continue
        summary, found = cache.read(deck, run_dir, target)
        problems += found
        problems += unparsed(summary["raw"], f"include {name}")
        if not summary["keywords"]:
            problems.append(f"*INCLUDE {name}: Deck.expand read no keyword from it")
        node_ids |= summary["node_ids"]
        shell_nodes |= summary["shell_nodes"]
        shell_parts.update(int(p) for p in summary["shells"])
        if inc is not None and len(includes) == 1:  # the planned include, by whatever name
            if summary["nodes"] != inc["nodes"]:
                problems.append(f"include {name}: {summary['nodes']} nodes read, planned {inc['nodes']}")
            planned = {str(k): v for k, v in inc["elements"].items()}
            if dict(summary["shells"]) != planned:
                problems.append(f"include {name}: shells per part {dict(summary['shells'])}, planned {planned}")
    part_ids = set()
    for kw in typed:
        if type(kw).__name__ == "Part":  # a table of parts
            part_ids.update(int(p) for p in kw.parts["pid"])
        elif type(kw).__name__ == "PartInertia":  # one part
            part_ids.add(int(kw.pid))
    missing = shell_nodes - node_ids
    if missing:
        problems.append(f"{len(missing)} shell node(s) not defined, e.g. {sorted(missing)[:5]}")
    if shell_parts - part_ids:
        problems.append(f"shells on undefined part(s) {sorted(shell_parts - part_ids)}")

    # --- *PARAMETER
    cards = Counter()
    values = {}
    for kw in deck.all_keywords:
        if isinstance(kw, str) or type(kw).__name__ != "Parameter":
            continue
        for i in range(len(kw.parameters)):
            row = kw.parameters[i]
            kind, _, pname = str(row.name).strip().partition(" ")
            pname = pname.strip().upper()
            cards[pname] += 1
            values[pname] = (kind.strip().upper(), row.val)
    for pname, want in spec.get("parameters", {}).items():
        pname = pname.upper()
        if cards[pname] != 1:
            problems.append(f"*PARAMETER {pname}: defined {cards[pname]} times")
            continue
        kind, text = values[pname]
        if kind != "R":
            problems.append(f"*PARAMETER {pname}: type {kind}, planned R (real)")
        if not close(text, want):
            problems.append(f"*PARAMETER {pname} reads {text!r}, planned {want!r}")
        try:
            resolved = deck.parameters.get(pname)
        except KeyError:
            resolved = None
        if not close(resolved, want):
            problems.append(f"*PARAMETER {pname} resolves to {resolved!r}, planned {want!r}")

    # --- fields and their references
    refs = deck.parameters._refs  # URI "<id(keyword)>/card.../field" -> "&NAME", as substituted
    for f in spec.get("fields", []):
        found = [
            kw
            for kw in typed
            if type(kw).__name__ == f["keyword"] and getattr(kw, f["id_field"], None) is not None
            and close(getattr(kw, f["id_field"]), f["id"])
        ]
        label = f"{f['keyword']} {f['id_field']}={f['id']} {f['field']}"
        if len(found) != 1:
            problems.append(f"{label}: {len(found)} such keywords")
            continue
        kw = found[0]
        got = getattr(kw, f["field"], None)
        if not close(got, f["expected"]):
            problems.append(f"{label} reads {got!r}, planned {f['expected']!r}")
        if f.get("ref"):
            prefix = f"{id(kw)}/"
            held = Counter(r.upper() for u, r in refs.items() if u.startswith(prefix))
            wanted = sum(
                1 for g in spec["fields"]
                if g["keyword"] == f["keyword"] and g["id"] == f["id"] and (g.get("ref") or "").upper() == f["ref"].upper()
            )
            if held[f["ref"].upper()] < wanted:
                problems.append(
                    f"{label}: {wanted} reference(s) {f['ref']} planned, the keyword holds {dict(held) or 'none'}"
                )
    return problems


def main(argv):
    if len(argv) != 3:
        print(__doc__.split("\n\n")[1], file=sys.stderr)
        return 2
    try:
        with open(argv[1], encoding="utf-8") as f:
            manifest = json.load(f)
        decks = manifest["decks"]
    except (OSError, ValueError, KeyError) as e:
        print(f"check_decks_pydyna: bad manifest {argv[1]}: {e}", file=sys.stderr)
        return 2
    started = time.monotonic()
    import ansys.dyna.core  # noqa: F401  (import time is reported apart from the decks')

    version = metadata.version("ansys-dyna-core")
    imported = time.monotonic() - started
    report = {"version": version, "import_seconds": imported, "decks": []}
    cache = IncludeCache()
    failed = 0
    for spec in decks:
        t = time.monotonic()
        try:
            problems = check_deck(spec, cache)
        except Exception as e:  # a reader crash is a finding about that deck, not the end of the run
            problems = [f"reader error: {type(e).__name__}: {e}"]
        seconds = time.monotonic() - t
        report["decks"].append({"name": spec["name"], "deck": spec["deck"], "problems": problems, "seconds": seconds})
        status = "ok" if not problems else "FAILED"
        print(f"{status:6} {spec['name']} ({seconds:.2f} s)")
        for p in problems:
            print(f"         {p}")
        failed += bool(problems)
    total = time.monotonic() - started
    report["seconds"] = total
    report["includes_expanded"] = cache.expanded
    with open(argv[2], "w", encoding="utf-8") as f:
        json.dump(report, f, indent=1)
    print(f"ansys-dyna-core {version}: {len(decks)} deck(s) read in {total:.1f} s; {len(decks) - failed} passed, {failed} failed")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
