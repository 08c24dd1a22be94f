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
of each column in bold; integrator names after the benches keep only those rows, in that
order. `ratios` makes one row per bench and one column per pair `A/B` given
after the benches (integrator names as the bench spells them), each cell "median MSE of A /
median MSE of B (the seeds in which A's MSE is lower, of those both ran)", below 1 where A is
better:

    <!-- results: ratios pool=out/pool-60 dining=out/dining-60 guided-pt/pt guided-bdpt/vcm -->

`stat` makes one row per integrator and one column per bench, each cell the median over the
runs of a statistic the renders report (the bench's `stats.csv`), named by the one word given
after the benches; integrators that do not report it are left out:

    <!-- results: stat pool=out/pool-60 dining=out/dining-60 failed_guided_share -->

Keys in capitals (such as `T=60`) are labels for the reader and are ignored. The reports behind the tables of docs/results.md are kept in docs/results-data/
(`report.csv` of each bench, a few kilobytes), so `update` reproduces the file as committed;
`scripts/test_results.py` checks that it does.

    scripts/results.py table pool=out/pool-60 dining=out/dining-60   # print one table
    scripts/results.py ratios pool=out/pool-60 guided-pt/pt          # print a ratios table
    scripts/results.py stat pool=out/pool-60 failed_guided_share     # print a statistic's table
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


def report_rows(directory):
    path = os.path.join(directory, "report.csv")
    try:
        with open(path, newline="") as f:
            return path, list(csv.DictReader(f))
    except OSError as e:
        raise ResultsError(f"{path}: cannot read the bench report ({e.strerror})")


def medians(directory):
    """{integrator: (mse, speedup, passes)} of the median rows of DIR/report.csv, in order."""
    path, rows = report_rows(directory)
    out = {}
    for r in rows:
        if r.get("run") == "median":
            out[r["integrator"]] = (float(r["mse"]), float(r["speedup"]), float(r["passes"]))
    if not out:
        raise ResultsError(f"{path}: no median rows (is it a `lodestar bench` report?)")
    return out


def passes(p):
    return f"{p:.0f}" if p == int(p) else f"{p:.1f}"


def per_seed(directory):
    """{integrator: {seed: mse}} of the per-run rows of DIR/report.csv."""
    _, rows = report_rows(directory)
    out = {}
    for r in rows:
        if r.get("run") != "median":
            out.setdefault(r["integrator"], {})[r["seed"]] = float(r["mse"])
    return out


def ratios(columns, pairs):
    """The ratios table: one row per (name, directory) of `columns`, a column per "A/B"."""
    if not pairs:
        raise ResultsError("no pair A/B given")
    split = []
    for p in pairs:
        a, sep, b = p.partition("/")
        if not sep or not a or not b:
            raise ResultsError(f"'{p}' is not a pair A/B")
        split.append((a, b))
    lines = [
        "| bench | " + " | ".join(f"{a} / {b}" for a, b in split) + " |",
        "|---|" + "---|" * len(split),
    ]
    for name, d in columns:
        m, seeds = medians(d), per_seed(d)
        cells = []
        for a, b in split:
            if a not in m or b not in m:
                cells.append("—")
                continue
            both = sorted(set(seeds[a]) & set(seeds[b]))
            lower = sum(seeds[a][s] < seeds[b][s] for s in both)
            cells.append(f"{m[a][0] / m[b][0]:.3f}x ({lower}/{len(both)})")
        lines.append(f"| {name} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def grid(columns, only=()):
    """The grid table of `columns`, a list of (name, directory); with `only`, just those
    integrators, in that order."""
    data = [(name, medians(d)) for name, d in columns]
    integrators = []
    for _, m in data:
        integrators += [i for i in m if i not in integrators]
    missing = [i for i in only if i not in integrators]
    if missing:
        raise ResultsError(f"no bench ran '{missing[0]}'")
    if only:
        integrators = list(only)
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


def median(xs):
    xs = sorted(xs)
    n = len(xs)
    return xs[n // 2] if n % 2 else 0.5 * (xs[n // 2 - 1] + xs[n // 2])


def stat(columns, words):
    """The stat table: the median of statistic `words[0]` per integrator and bench."""
    if len(words) != 1:
        raise ResultsError("a stat table takes one statistic's name")
    key = words[0]
    data = []
    for name, d in columns:
        path = os.path.join(d, "stats.csv")
        try:
            with open(path, newline="") as f:
                rows = [r for r in csv.DictReader(f) if r["key"] == key]
        except OSError as e:
            raise ResultsError(f"{path}: cannot read the bench statistics ({e.strerror})")
        values = {}
        for r in rows:
            try:
                values.setdefault(r["integrator"], []).append(float(r["value"]))
            except ValueError:
                raise ResultsError(f"{path}: {key} of {r['integrator']} is not a number")
        data.append((name, {i: median(v) for i, v in values.items()}))
    integrators = []
    for _, m in data:
        integrators += [i for i in m if i not in integrators]
    if not integrators:
        raise ResultsError(f"no run reports '{key}'")
    lines = [
        "| integrator | " + " | ".join(name for name, _ in data) + " |",
        "|---|" + "---|" * len(data),
    ]
    for i in integrators:
        cells = [f"{m[i]:.3g}" if i in m else "—" for _, m in data]
        lines.append(f"| {i} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


KINDS = {"grid": grid, "ratios": ratios, "stat": stat}


def parse_columns(args, where, extra=None):
    """(name, dir) of every COLUMN=DIR in `args`; other words go to `extra` if given."""
    columns = []
    for a in args:
        name, _, d = a.partition("=")
        # A column's name is a plain word; anything else (`A/B`, an integrator with options
        # such as `guided-pt:manifold=0.5/guided-pt`) is one of the kind's own words.
        if not d or not re.fullmatch(r"[\w.-]+", name):
            if extra is None:
                raise ResultsError(f"{where}: '{a}' is not COLUMN=DIR")
            extra.append(a)
            continue
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
        extra = []
        named = parse_columns(m.group(2).split(), where, extra)
        columns = [(n, os.path.join(base, d)) for n, d in named]
        try:
            end = lines.index(END, i + 1)
        except ValueError:
            raise ResultsError(f"{where}: no '{END}' after the marker")
        try:
            table = KINDS[kind](columns, extra)
        except ResultsError as e:
            raise ResultsError(f"{where}: {e}")
        out.append(table)
        out.append(END)
        i = end + 1
    return "\n".join(out)


def main(argv):
    if len(argv) >= 2 and argv[0] in ("table", "ratios", "stat"):
        extra = []
        columns = parse_columns(argv[1:], argv[0], extra)
        kind = {"table": grid, "ratios": ratios, "stat": stat}[argv[0]]
        print(kind(columns, extra))
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
