#!/usr/bin/env python3
"""Import cycles between sibling modules of the library.

Every path a source file names (`crate::a::b`, `super::c`, `self::d`, a `use` group) is resolved
to the module it points into; each reference becomes an edge between the two modules' children
of their nearest common ancestor (so `fit::lsq` naming `fit::argmin_peer::solve` is the edge
lsq -> argmin_peer, and `render::scene` naming `fit::pick` is render -> fit). A parent naming its
own child, or a child its parent, is how Rust modules are built and is not counted. A name a
module re-exports (`pub use child::Item;` in `model/mod.rs`) is followed to the module that
defines it, so `super::Item` in a sibling of `child` is the edge to `child`. Unit tests
(from `#[cfg(test)]` to the end of a file) are left out. Prints every cycle; exits 1 if any.
`--edges` also prints every edge between siblings, one `parent: from -> to` a line.
"""
import os
import re
import sys

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "src")


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


def reexports_of(text):
    """Names a module re-exports (`pub use`, `pub(crate) use`...) -> the path each names."""
    out = {}
    for m in re.finditer(r"\bpub(?:\([^)]*\))?\s+use\s+([^;]+);", text):
        for p in expand_use(m.group(1)):
            alias = re.search(r"\bas\s+(\w+)\s*$", p)
            p = p.split(" as ")[0].strip()
            name = alias.group(1) if alias else p.split("::")[-1].strip()
            if name not in ("*", "self"):
                out[name] = p
    return out


def resolve(mod, p, modules, reexports, depth=0):
    """The module a path named in module `mod` points into, or None if outside the crate."""
    segs = [s.strip() for s in p.split("::") if s.strip()]
    if not segs or segs[0] not in ("crate", "super", "self"):
        if segs and mod + (segs[0],) in modules:
            segs = ["self"] + segs  # a child named without `self::`
        else:
            return None
    base = list(mod)
    if segs[0] == "crate":
        base, segs = [], segs[1:]
    else:
        while segs and segs[0] in ("super", "self"):
            if segs[0] == "super":
                base = base[:-1]
            segs = segs[1:]
    target = tuple(base)
    rest = segs
    for s in segs:
        if target + (s,) in modules:
            target = target + (s,)
            rest = rest[1:]
        else:
            break
    if rest and depth < 8 and rest[0] in reexports.get(target, {}):
        followed = resolve(target, reexports[target][rest[0]], modules, reexports, depth + 1)
        if followed is not None:
            return followed
    return target


def main():
    files = {}
    for d, _, fs in os.walk(ROOT):
        for f in fs:
            if f.endswith(".rs"):
                files[module_of(os.path.join(d, f))] = os.path.join(d, f)
    modules = set(files)
    texts = {mod: strip(open(path, encoding="utf-8").read()) for mod, path in files.items()}
    reexports = {mod: reexports_of(text) for mod, text in texts.items()}
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
            target = resolve(mod, p, modules, reexports)
            if target is None or target == mod:
                continue
            k = 0
            while k < min(len(mod), len(target)) and mod[k] == target[k]:
                k += 1
            if k == len(mod) or k == len(target):
                continue  # parent and child
            parent = mod[:k]
            edges.setdefault(parent, {}).setdefault(mod[k], set()).add(target[k])
    if "--edges" in sys.argv[1:]:
        for parent, graph in sorted(edges.items()):
            for v in sorted(graph):
                for w in sorted(graph[v]):
                    print(f"{'::'.join(parent) or 'crate'}: {v} -> {w}")
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
    for c in cycles:
        print(f"import cycle in {c}", file=sys.stderr)
    return 1 if cycles else 0


if __name__ == "__main__":
    sys.exit(main())
