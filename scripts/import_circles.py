#!/usr/bin/env python3
"""Import circles between lodestar's modules: two or more files of `src/` and `integrators/`
that reach each other through `use crate::...` / `use super::...` paths (and such paths written
in code). A module's own `mod.rs` declaring its children is not an import; comments and test
modules are ignored. Each circle is printed as its files' module paths.

    scripts/import_circles.py            # prints the circles, exits 1 if there is one

`scripts/test_import_circles.py` keeps the crate free of them.
"""

import os
import re
import sys

ROOTS = ("src", "integrators")


def module_path(root, path):
    """`crate::a::b` of a source file, as a tuple, or None outside the crate's trees."""
    rel = os.path.relpath(path, root).replace(os.sep, "/")
    top = rel.split("/")[0]
    if top not in ROOTS or not rel.endswith(".rs"):
        return None
    parts = rel[:-3].split("/")
    if top == "src":
        parts = parts[1:]
    if parts and parts[-1] in ("mod", "lib", "main"):
        parts = parts[:-1]
    return ("crate",) + tuple(parts)


def modules(root):
    out = {}
    for top in ROOTS:
        for dirpath, _, files in os.walk(os.path.join(root, top)):
            for name in files:
                m = module_path(root, os.path.join(dirpath, name))
                if m is not None:
                    out[m] = os.path.join(dirpath, name)
    return out


def code_of(path):
    text = open(path, encoding="utf-8").read()
    text = re.sub(r"#\[cfg\(test\)\]\s*mod tests\s*\{.*", "", text, flags=re.S)
    return "\n".join(l for l in text.split("\n") if not l.strip().startswith("//"))


def resolve(mods, here, path):
    """The module a `crate::`/`super::`/`self::` path names (its longest module prefix)."""
    base = list(here)
    i = 0
    if path[0] == "crate":
        base, i = ["crate"], 1
    elif path[0] == "super":
        while i < len(path) and path[i] == "super":
            base, i = base[:-1], i + 1
    elif path[0] == "self":
        i = 1
    else:
        return None
    rest = path[i:]
    for k in range(len(rest), -1, -1):
        cand = tuple(base + rest[:k])
        if cand in mods:
            return cand
    return None


def edges(mods):
    out = {}
    for m, path in mods.items():
        src = code_of(path)
        deps = set()
        for base, group in re.findall(r"\buse\s+((?:crate|super|self)(?:::\w+)*)(?:::\{([^;]*)\})?", src):
            items = [x.strip().split("::")[0] for x in group.replace("\n", " ").split(",")] if group else [""]
            for item in items:
                p = base.split("::") + ([item] if item and item != "self" else [])
                r = resolve(mods, m, p)
                if r and r != m:
                    deps.add(r)
        for p in re.findall(r"\b((?:crate|super)(?:::\w+)+)", src):
            r = resolve(mods, m, p.split("::"))
            if r and r != m:
                deps.add(r)
        out[m] = deps
    return out


def circles(root):
    """The strongly connected groups of two or more modules, each sorted."""
    mods = modules(root)
    graph = edges(mods)
    index, low, stack, on, found = {}, {}, [], set(), []
    counter = [0]

    def strong(v):
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in graph.get(v, ()):
            if w not in index:
                strong(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            group = []
            while True:
                w = stack.pop()
                on.discard(w)
                group.append(w)
                if w == v:
                    break
            if len(group) > 1:
                found.append(sorted("::".join(x) for x in group))

    sys.setrecursionlimit(10000)
    for v in sorted(graph):
        if v not in index:
            strong(v)
    return sorted(found)


def main():
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    found = circles(root)
    for group in found:
        print(" <-> ".join(group))
    return 1 if found else 0


if __name__ == "__main__":
    sys.exit(main())
