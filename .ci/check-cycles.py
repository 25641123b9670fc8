#!/usr/bin/env python3
"""Import cycles between sibling modules of the library.

Every path a source file names (`crate::a::b`, `super::c`, `self::d`, a `use` group) is resolved
to the module it points into; each reference becomes an edge between the two modules' children
of their nearest common ancestor (so `fit::lsq` naming `fit::argmin_peer::solve` is the edge
lsq -> argmin_peer, and `render::scene` naming `fit::pick` is render -> fit). A parent naming its
own child, or a child its parent, is how Rust modules are built and is not counted; a name a
module re-exports (`pub use`) is followed to the module that defines it. Unit tests
(from `#[cfg(test)]` to the end of a file) are left out. The library's top-level modules also
keep the data's path (LAYERS): none names a module of a later layer. Prints every cycle and
every such edge; exits 1 if any.
"""
import os
import re
import sys

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "src")


# The data's path, lowest first: a top-level module may name modules of its own or an earlier
# layer only.
LAYERS = [
    {"support"},
    {"data"},
    {"model"},
    {"simulate", "fit", "prior"},
    {"export", "plot", "render"},
    {"scene"},
    {"choose", "study", "inverse", "plan"},
    {"report"},
]


def module_of(path):
    rel = os.path.relpath(path, ROOT)[:-3].split(os.sep)
    if rel[-1] in ("mod", "lib", "main"):
        rel = rel[:-1]
    return tuple(rel)


def strip(text):
    text = re.split(r"\n\s*#\[cfg\(test\)\]", text)[0]
    text = re.sub(r"//[^\n]*", "", text)
    text = re.sub(r'"(\\.|[^"\\])*"', '""', text)
    return text


def expand_use(body):
    """`a::{b, c::{d, e}}` -> [a::b, a::c::d, a::c::e]."""
    body = body.strip()
    i = body.find("{")
    if i < 0:
        return [body.split(" as ")[0].strip()]
    prefix, inner = body[:i], body[i + 1 : body.rfind("}")]
    parts, depth, cur = [], 0, ""
    for ch in inner:
        if ch == "," and depth == 0:
            parts.append(cur)
            cur = ""
            continue
        depth += ch == "{"
        depth -= ch == "}"
        cur += ch
    parts.append(cur)
    return [p for part in parts if part.strip() for p in expand_use(prefix + part.strip())]


def main():
    files = {}
    for d, _, fs in os.walk(ROOT):
        for f in fs:
            if f.endswith(".rs"):
                files[module_of(os.path.join(d, f))] = os.path.join(d, f)
    modules = set(files)
    texts = {m: strip(open(p, encoding="utf-8").read()) for m, p in files.items()}

    def absolute(mod, segs):
        """A path as written in `mod`, made absolute: (base module, remaining segments)."""
        base = list(mod)
        if segs[0] == "crate":
            return [], segs[1:]
        while segs and segs[0] in ("super", "self"):
            if segs[0] == "super":
                base = base[:-1]
            segs = segs[1:]
        if segs and tuple(base) + (segs[0],) not in modules and mod + (segs[0],) in modules:
            base = list(mod)
        return base, segs

    # Names each module re-exports: name -> absolute path of what it names.
    reexports = {}
    for mod, text in texts.items():
        for m in re.finditer(r"\bpub(?:\([^)]*\))?\s+use\s+([^;]+);", text):
            for p in expand_use(m.group(1)):
                segs = [x.strip() for x in p.split("::") if x.strip()]
                if len(segs) < 2 or segs[-1] == "*":
                    continue
                if segs[0] not in ("crate", "super", "self") and mod + (segs[0],) not in modules:
                    continue  # another crate's item
                if segs[0] not in ("crate", "super", "self"):
                    segs = ["self"] + segs
                base, rest = absolute(mod, segs)
                reexports.setdefault(mod, {})[segs[-1]] = (tuple(base), rest)

    def resolve(base, segs, depth=0):
        target = tuple(base)
        for i, s in enumerate(segs):
            if target + (s,) in modules:
                target = target + (s,)
            elif depth < 8 and s in reexports.get(target, {}):
                b, rest = reexports[target][s]
                return resolve(b, rest, depth + 1)
            else:
                break
        return target

    edges = {}
    for mod, path in files.items():
        if mod and mod[0] == "cli" or path.endswith("main.rs"):
            continue  # the binary's own modules
        text = texts[mod]
        paths = []
        for m in re.finditer(r"\buse\s+([^;]+);", text):
            paths += expand_use(m.group(1))
        paths += re.findall(r"\b((?:crate|super|self)(?:::\w+)+)", text)
        for p in paths:
            segs = [s.strip() for s in p.split("::") if s.strip()]
            if not segs or segs[0] not in ("crate", "super", "self"):
                continue
            target = resolve(*absolute(mod, segs))
            if target == mod:
                continue
            k = 0
            while k < min(len(mod), len(target)) and mod[k] == target[k]:
                k += 1
            if k == len(mod) or k == len(target):
                continue  # parent and child
            parent = mod[:k]
            edges.setdefault(parent, {}).setdefault(mod[k], set()).add(target[k])
    if "--edges" in sys.argv:
        for parent, graph in sorted(edges.items()):
            for a, bs in sorted(graph.items()):
                print("::".join(parent) or "crate", a, "->", ", ".join(sorted(bs)))
    cycles = []
    for parent, graph in sorted(edges.items()):
        # Tarjan's strongly connected components.
        index, low, stack, on, out, counter = {}, {}, [], set(), [], [0]

        def visit(v):
            index[v] = low[v] = counter[0]
            counter[0] += 1
            stack.append(v)
            on.add(v)
            for w in sorted(graph.get(v, ())):
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
                    out.append(sorted(comp))

        for v in sorted(graph):
            if v not in index:
                visit(v)
        for comp in out:
            where = "::".join(parent) or "crate"
            cycles.append(f"{where}: {' <-> '.join(comp)}")
    layer = {m: i for i, ms in enumerate(LAYERS) for m in ms}
    for a, bs in sorted(edges.get((), {}).items()):
        for b in sorted(bs):
            if a not in layer or b not in layer:
                cycles.append(f"crate: {a} or {b} is in no layer of .ci/check-cycles.py's LAYERS")
            elif layer[b] > layer[a]:
                cycles.append(f"crate: {a} names {b}, a later stage of the data's path")
    for c in cycles:
        print(f"import cycle or layering in {c}", file=sys.stderr)
    return 1 if cycles else 0


if __name__ == "__main__":
    sys.exit(main())
