#!/usr/bin/env python3
"""Checks the library's include graph against vdbscatter/LAYERS: no include from a lower
layer to a higher one, and no include circle among the library's modules.

usage: scripts/check_layers.py [ROOT]   (ROOT: the repository; default this script's)
       scripts/check_layers.py --self-test
A module is a source file's name without its extension; its public header
include/vdbscatter/NAME.h and any private header NAME.h belong to it. Prints every arrow
back up and every circle, one line each, and exits 1 if there is any."""
import os
import re
import sys
import tempfile

INCLUDE = re.compile(r'^\s*#\s*include\s+"([^"]+)"', re.M)


def read_layers(lib):
    order, placed = [], {}
    with open(os.path.join(lib, "LAYERS")) as f:
        for line in f:
            line = line.split("#", 1)[0].strip()
            if not line:
                continue
            name, _, modules = line.partition(":")
            order.append(name.strip())
            for m in modules.split():
                placed[m] = name.strip()
    return order, placed


def scan(root):
    """(module -> layer, module -> set of included modules, errors)."""
    lib = os.path.join(root, "vdbscatter")
    order, layer_of = read_layers(lib)
    files = {}  # module -> list of paths
    for dirpath, dirs, names in os.walk(lib):
        rel = os.path.relpath(dirpath, lib)
        if rel == "include" or rel.startswith("include" + os.sep):
            continue
        layer = "top" if rel == "." else rel.split(os.sep)[0]
        for n in names:
            stem, ext = os.path.splitext(n)
            if ext not in (".c", ".cpp", ".h"):
                continue
            if ext != ".h" or stem not in layer_of:
                layer_of.setdefault(stem, layer)
            files.setdefault(stem, []).append(os.path.join(dirpath, n))
    errors = [f"{m}: layer '{l}' is not in vdbscatter/LAYERS"
              for m, l in sorted(layer_of.items()) if l not in order]
    public = os.path.join(lib, "include", "vdbscatter")
    for n in sorted(os.listdir(public)):
        stem = os.path.splitext(n)[0]
        files.setdefault(stem, []).append(os.path.join(public, n))
        if stem not in layer_of:
            errors.append(f"include/vdbscatter/{n}: no source and no place in vdbscatter/LAYERS")
    deps = {m: set() for m in files}
    for m, paths in files.items():
        for p in paths:
            with open(p, encoding="utf-8") as f:
                for inc in INCLUDE.findall(f.read()):
                    stem = os.path.splitext(os.path.basename(inc))[0]
                    if stem in files and stem != m:
                        deps[m].add(stem)
    return order, layer_of, deps, errors


def check(root):
    order, layer_of, deps, errors = scan(root)
    rank = {l: i for i, l in enumerate(order)}
    for m in sorted(deps):
        for d in sorted(deps[m]):
            lm, ld = layer_of.get(m), layer_of.get(d)
            if lm in rank and ld in rank and rank[ld] > rank[lm]:
                errors.append(f"arrow back up: {m} ({lm}) includes {d} ({ld})")
    # circles: strongly connected components of more than one module (Tarjan)
    index, low, stack, on, comps = {}, {}, [], set(), []

    def visit(v):
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in sorted(deps[v]):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                comps.append(sorted(comp))

    sys.setrecursionlimit(10000)
    for v in sorted(deps):
        if v not in index:
            visit(v)
    for c in comps:
        errors.append(f"include circle of {len(c)} modules: {' '.join(c)}")
    return errors, len(deps), sum(len(d) for d in deps.values())


def self_test():
    """A tree with one arrow back up and one circle must fail; without them it must pass."""
    def tree(files):
        root = tempfile.mkdtemp(prefix="layers-")
        for path, text in files.items():
            full = os.path.join(root, "vdbscatter", path)
            os.makedirs(os.path.dirname(full), exist_ok=True)
            with open(full, "w") as f:
                f.write(text)
        return root
    good = {"LAYERS": "low\nhigh\n", "low/a.c": '#include "vdbscatter/a.h"\n',
            "include/vdbscatter/a.h": "", "high/b.c": '#include "vdbscatter/a.h"\n',
            "include/vdbscatter/b.h": '#include "vdbscatter/a.h"\n'}
    errors, _, _ = check(tree(good))
    assert errors == [], errors
    bad = dict(good)
    bad["low/a.c"] = '#include "vdbscatter/b.h"\n'
    errors, _, _ = check(tree(bad))
    assert any(e.startswith("arrow back up: a (low) includes b (high)") for e in errors), errors
    assert any(e.startswith("include circle of 2 modules: a b") for e in errors), errors
    print("check_layers self-test: an arrow back up and a circle are found; a clean tree passes")


def main():
    if sys.argv[1:] == ["--self-test"]:
        self_test()
        return 0
    root = sys.argv[1] if len(sys.argv) > 1 else os.path.dirname(os.path.dirname(
        os.path.abspath(__file__)))
    errors, modules, arrows = check(root)
    for e in errors:
        print(e)
    if errors:
        print(f"check_layers: {len(errors)} problem(s) in {modules} modules, {arrows} include arrows")
        return 1
    print(f"check_layers: {modules} modules, {arrows} include arrows, no arrow back up, no circle")
    return 0


if __name__ == "__main__":
    sys.exit(main())
