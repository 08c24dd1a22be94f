#!/usr/bin/env python3
"""The equal-time tables of docs/results.md (and README's headline), from `lodestar bench` output.

A table in a Markdown file is generated when it sits between two markers:

    <!-- results: grid T=60 pool=out/pool-60 dining=out/dining-60 -->
    | integrator | pool | dining |
    ...
    <!-- /results -->

Each `column=DIR` names a bench output directory (its `report.csv`); `grid` makes one row per
integrator (in the bench's order; the union over the columns) and one column per bench, each
cell "median MSE (speed-up over the bench's first integrator) [median passes]", the lowest MSE
of each column in bold. Keys in capitals (such as `T=60`) are labels for the reader and are
ignored. The reports behind the tables of docs/results.md are kept in docs/results-data/
(`report.csv` of each bench, a few kilobytes), so `update` reproduces the file as committed;
`scripts/test_results.py` checks that it does.

    scripts/results.py table pool=out/pool-60 dining=out/dining-60   # print one table
    scripts/results.py update docs/results.md README.md              # regenerate every marked table

`update` fails, naming the file, line and directory, when a marked table's bench output is
missing, and leaves the file untouched.
"""

import csv
import os
import re
import sys

MARKER = re.compile(r"^<!-- results: (\w+)((?: [^ ]+)*) -->$")
END = "<!-- /results -->"


class ResultsError(Exception):
    pass


def medians(directory):
    """{integrator: (mse, speedup, passes)} of the median rows of DIR/report.csv, in order."""
    path = os.path.join(directory, "report.csv")
    try:
        with open(path, newline="") as f:
            rows = list(csv.DictReader(f))
    except OSError as e:
        raise ResultsError(f"{path}: cannot read the bench report ({e.strerror})")
    out = {}
    for r in rows:
        if r.get("run") == "median":
            out[r["integrator"]] = (float(r["mse"]), float(r["speedup"]), float(r["passes"]))
    if not out:
        raise ResultsError(f"{path}: no median rows (is it a `lodestar bench` report?)")
    return out


def passes(p):
    return f"{p:.0f}" if p == int(p) else f"{p:.1f}"


def grid(columns):
    """The grid table of `columns`, a list of (name, directory)."""
    data = [(name, medians(d)) for name, d in columns]
    integrators = []
    for _, m in data:
        integrators += [i for i in m if i not in integrators]
    best = {name: min(v[0] for v in m.values()) for name, m in data}
    lines = [
        "| integrator | " + " | ".join(name for name, _ in data) + " |",
        "|---|" + "---|" * len(data),
    ]
    for i in integrators:
        cells = []
        for name, m in data:
            if i not in m:
                cells.append("—")
                continue
            mse, speedup, n = m[i]
            cell = f"{mse:.2e} ({speedup:.2f}) [{passes(n)}]"
            cells.append(f"**{cell}**" if mse == best[name] else cell)
        lines.append(f"| {i} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


KINDS = {"grid": grid}


def parse_columns(args, where):
    columns = []
    for a in args:
        if "=" not in a:
            raise ResultsError(f"{where}: '{a}' is not COLUMN=DIR")
        name, d = a.split("=", 1)
        if name.isupper():
            continue  # a label such as T=60
        columns.append((name, d))
    if not columns:
        raise ResultsError(f"{where}: no COLUMN=DIR given")
    return columns


def update_text(text, filename, base):
    """`text` with every marked table regenerated; directories relative to `base`."""
    lines = text.split("\n")
    out = []
    i = 0
    while i < len(lines):
        m = MARKER.match(lines[i])
        out.append(lines[i])
        if not m:
            i += 1
            continue
        where = f"{filename}:{i + 1}"
        kind = m.group(1)
        if kind not in KINDS:
            raise ResultsError(f"{where}: unknown table kind '{kind}' (known: {', '.join(KINDS)})")
        columns = [(n, os.path.join(base, d)) for n, d in parse_columns(m.group(2).split(), where)]
        try:
            end = lines.index(END, i + 1)
        except ValueError:
            raise ResultsError(f"{where}: no '{END}' after the marker")
        try:
            table = KINDS[kind](columns)
        except ResultsError as e:
            raise ResultsError(f"{where}: {e}")
        out.append(table)
        out.append(END)
        i = end + 1
    return "\n".join(out)


def main(argv):
    if len(argv) >= 2 and argv[0] == "table":
        print(grid(parse_columns(argv[1:], "table")))
        return 0
    if len(argv) >= 2 and argv[0] == "update":
        new = {}
        for f in argv[1:]:
            with open(f) as fh:
                new[f] = update_text(fh.read(), f, os.getcwd())
        for f, text in new.items():
            tmp = f + ".tmp"
            with open(tmp, "w") as fh:
                fh.write(text)
            os.replace(tmp, f)
        return 0
    print(__doc__, file=sys.stderr)
    return 2


if __name__ == "__main__":
    try:
        sys.exit(main(sys.argv[1:]))
    except ResultsError as e:
        print(f"error: {e}", file=sys.stderr)
        sys.exit(1)
