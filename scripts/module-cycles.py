#!/usr/bin/env python3
"""Finds import cycles between the modules of one Rust crate.

Usage: scripts/module-cycles.py CRATE/src [--no-tests] [--graph]

Reads every module file under the folder (`lib.rs` or `main.rs` is the crate root, `a.rs` and
`a/mod.rs` are `a`, `a/b.rs` is `a::b`), strips comments and string literals, and collects the
module paths each file refers to: `use` trees (nested braces, `self`, renames), and paths in the
code that start at `crate::`, `super::`, `self::`, a child module or a name a `use` brought into
the file. Each reference is followed to the module that defines the item (through `use` and
`pub use` re-exports, so `crate::Result` counts as a use of `error` when the root re-exports it
from there). Modules declared inline in a file (`mod tests { ... }`) count as their file's.

Two graphs are checked, each by a depth-first search:
- top level: every module folded into its top-level module (`net::planes` is `net`);
- submodules: every file module on its own (`net` and `net::planes` are two nodes).

A module's reference to itself is no edge. Prints the cycles found (each once, by its strongly
connected component and one cycle through it) and exits 1 when there is one, 0 otherwise.
`--no-tests` leaves out `#[cfg(test)]` modules; `--graph` prints the edges too.
"""

import os
import re
import sys
from collections import defaultdict

ITEM_RE = re.compile(
    r"\b(?:fn|struct|enum|trait|type|const|static|union|mod)\s+([A-Za-z_][A-Za-z0-9_]*)"
)
MACRO_RE = re.compile(r"\bmacro_rules!\s*([A-Za-z_][A-Za-z0-9_]*)")
IDENT = r"[A-Za-z_][A-Za-z0-9_]*"
PATH_RE = re.compile(r"(?<![A-Za-z0-9_:$])((?:" + IDENT + r")(?:\s*::\s*" + IDENT + r")+)")
KEYWORDS = {
    "as", "break", "const", "continue", "crate", "else", "enum", "extern", "false", "fn", "for",
    "if", "impl", "in", "let", "loop", "match", "mod", "move", "mut", "pub", "ref", "return",
    "self", "Self", "static", "struct", "super", "trait", "true", "type", "unsafe", "use",
    "where", "while", "async", "await", "dyn",
}


def strip(src):
    """The source with comments, strings and char literals blanked (newlines kept)."""
    out = []
    i, n = 0, len(src)
    while i < n:
        c = src[i]
        if src.startswith("//", i):
            j = src.find("\n", i)
            j = n if j < 0 else j
            i = j
            continue
        if src.startswith("/*", i):
            depth, j = 1, i + 2
            while j < n and depth:
                if src.startswith("/*", j):
                    depth, j = depth + 1, j + 2
                elif src.startswith("*/", j):
                    depth, j = depth - 1, j + 2
                else:
                    j += 1
            out.append("\n" * src.count("\n", i, j))
            i = j
            continue
        m = re.match(r'b?r(#*)"', src[i:i + 300]) if c in "rb" and (
            i == 0 or not (src[i - 1].isalnum() or src[i - 1] == "_")) else None
        if m:
            end = '"' + m.group(1)
            j = src.find(end, i + m.end())
            j = n if j < 0 else j + len(end)
            out.append(' ""' + "\n" * src.count("\n", i, j))
            i = j
            continue
        if c == '"' or (c == "b" and src.startswith('b"', i)):
            j = i + (2 if c == "b" else 1)
            while j < n and src[j] != '"':
                j += 2 if src[j] == "\\" else 1
            j += 1
            out.append(' ""' + "\n" * src.count("\n", i, j))
            i = j
            continue
        if c == "'":
            if i + 1 < n and src[i + 1] == "\\":
                j = src.find("'", i + 2)
                i = (n if j < 0 else j + 1)
                out.append("' '")
                continue
            if i + 2 < n and src[i + 2] == "'":
                i += 3
                out.append("' '")
                continue
        out.append(c)
        i += 1
    return "".join(out)


def split_top(s, sep=","):
    parts, depth, cur = [], 0, []
    for ch in s:
        if ch == "{":
            depth += 1
        elif ch == "}":
            depth -= 1
        if ch == sep and depth == 0:
            parts.append("".join(cur))
            cur = []
        else:
            cur.append(ch)
    parts.append("".join(cur))
    return [p.strip() for p in parts if p.strip()]


def expand_use(tree, prefix=()):
    """(path segments, local name) for each leaf of a use tree; local name None for a glob."""
    tree = re.sub(r"\s+", " ", tree).strip()
    if "{" in tree and tree.endswith("}"):
        head, body = tree.split("{", 1)
        body = body[:-1]
        head_segs = [s.strip() for s in head.split("::") if s.strip()]
        out = []
        for part in split_top(body):
            out += expand_use(part, prefix + tuple(head_segs))
        return out
    alias = None
    m = re.match(r"(.*)\sas\s(" + IDENT + r")$", tree)
    if m:
        tree, alias = m.group(1).strip(), m.group(2)
    segs = [s.strip() for s in tree.split("::") if s.strip()]
    full = prefix + tuple(segs)
    if not full:
        return []
    if full[-1] == "*":
        return [(full[:-1], None)]
    if full[-1] == "self":
        full = full[:-1]
        if not full:
            return []
    return [(full, alias or full[-1])]


class Module:
    def __init__(self, path, file_mod):
        self.path = path  # tuple of segments, () is the crate root
        self.file_mod = file_mod  # the file module this (maybe inline) module belongs to
        self.children = set()
        self.defs = set()
        self.imports = {}  # local name -> absolute path segments (may end at an item)
        self.globs = []  # absolute module paths
        self.refs = []  # raw paths (segments) used in code
        self.is_test = False


def file_module_path(src_dir, f):
    rel = os.path.relpath(f, src_dir)[:-3].split(os.sep)
    if rel in (["lib"], ["main"]):
        return ()
    if rel[-1] == "mod":
        rel = rel[:-1]
    return tuple(rel)


def parse_crate(src_dir, no_tests):
    mods = {}
    for root, _, files in os.walk(src_dir):
        for name in sorted(files):
            if not name.endswith(".rs"):
                continue
            f = os.path.join(root, name)
            fpath = file_module_path(src_dir, f)
            with open(f, encoding="utf-8") as fh:
                text = strip(fh.read())
            parse_file(text, fpath, mods)
    # a file module declared `#[cfg(test)] mod x;` in its parent
    for m in list(mods.values()):
        parent = mods.get(m.path[:-1]) if m.path else None
        if parent is not None and m.path == m.file_mod and getattr(parent, "test_children", set()) \
                and m.path[-1] in parent.test_children:
            m.is_test = True
    # propagate test-ness downwards
    for p in sorted(mods, key=len):
        if p and mods.get(p[:-1]) is not None and mods[p[:-1]].is_test:
            mods[p].is_test = True
    if no_tests:
        mods = {p: m for p, m in mods.items() if not m.is_test}
    return mods


def parse_file(text, fpath, mods):
    def get(path, file_mod):
        if path not in mods:
            mods[path] = Module(path, file_mod)
        return mods[path]

    get(fpath, fpath)
    # Walk the text, tracking inline `mod x {` blocks by brace depth.
    stack = [(fpath, -1)]  # (module path, depth at which it closes)
    depth = 0
    pending_test = False
    i, n = 0, len(text)
    tok = re.compile(
        r"#\s*\[\s*cfg\s*\(\s*test\s*\)\s*\]"
        r"|\b(?:pub(?:\s*\([^)]*\))?\s+)?mod\s+(" + IDENT + r")\s*([;{])"
        r"|\b(?:pub(?:\s*\([^)]*\))?\s+)?use\s+([^;]*);"
        r"|[{}]"
    )
    segments = []  # (start, end, module path) of code belonging to each module
    last = 0
    for m in tok.finditer(text):
        cur = stack[-1][0]
        segments.append((last, m.start(), cur))
        last = m.end()
        s = m.group(0)
        if s.startswith("#"):
            pending_test = True
            continue
        if s == "{":
            depth += 1
            pending_test = False
            continue
        if s == "}":
            depth -= 1
            if len(stack) > 1 and depth == stack[-1][1]:
                stack.pop()
            continue
        if m.group(1):
            name, kind = m.group(1), m.group(2)
            mod = get(cur, fpath)
            mod.children.add(name)
            child = cur + (name,)
            if kind == ";":
                if pending_test:
                    mod.__dict__.setdefault("test_children", set()).add(name)
            else:
                c = get(child, fpath)
                c.is_test = c.is_test or pending_test or mods[cur].is_test
                depth += 1
                stack.append((child, depth - 1))
            pending_test = False
            continue
        if m.group(3) is not None:
            mod = get(cur, fpath)
            for segs, local in expand_use(m.group(3)):
                segs = tuple(s.replace(" ", "") for s in segs)
                mod.refs.append(("use", segs))
                if local is None:
                    mod.globs.append(segs)
                else:
                    mod.imports[local] = segs
            pending_test = False
    segments.append((last, n, stack[-1][0]))
    for a, b, path in segments:
        chunk = text[a:b]
        mod = get(path, fpath)
        for dm in ITEM_RE.finditer(chunk):
            mod.defs.add(dm.group(1))
        for dm in MACRO_RE.finditer(chunk):
            mod.defs.add(dm.group(1))
        for pm in PATH_RE.finditer(chunk):
            segs = tuple(s.strip() for s in pm.group(1).split("::"))
            mod.refs.append(("code", segs))


def absolute(mods, at, segs):
    """Absolute segments of a path written in module `at`, or None for an outside path."""
    if not segs:
        return None
    first = segs[0]
    if first == "crate":
        return tuple(segs[1:])
    if first in ("super", "self"):
        base = at
        rest = list(segs)
        while rest and rest[0] in ("super", "self"):
            if rest[0] == "super":
                base = base[:-1]
            rest.pop(0)
        return base + tuple(rest)
    mod = mods.get(at)
    if mod is None:
        return None
    if first in mod.children:
        return at + tuple(segs)
    if first in mod.imports:
        target = mod.imports[first]
        if target and target[0] == first:
            # `use map::{self, ...}` of an extern crate that shares its name with a module of
            # this crate (lab's `map` command and the `map` crate): an outside path.
            return None
        resolved = absolute(mods, at, target)
        if resolved is None:
            return None
        return resolved + tuple(segs[1:])
    # 2018 paths: a use tree starting with a name declared at the crate root is not allowed
    # without `crate::`, so anything else is an extern crate, a std path or a type's item.
    return None


def resolve(mods, at, segs, seen=None):
    """The module that defines what `segs` (absolute) names."""
    seen = seen or set()
    if (at, segs) in seen:
        return None
    seen.add((at, segs))
    cur = ()
    i = 0
    while i < len(segs) and (cur + (segs[i],)) in mods:
        cur = cur + (segs[i],)
        i += 1
    if i == len(segs):
        return cur
    name = segs[i]
    mod = mods.get(cur)
    if mod is None:
        return cur
    if name in mod.defs:
        return cur
    if name in mod.imports:
        target = absolute(mods, cur, mod.imports[name])
        if target is not None:
            r = resolve(mods, cur, target + tuple(segs[i + 1:]), seen)
            if r is not None:
                return r
        return cur
    for g in mod.globs:
        target = absolute(mods, cur, g)
        if target is None:
            continue
        r = resolve(mods, cur, target + tuple(segs[i:]), seen)
        if r is not None and name in mods.get(r, Module((), ())).defs:
            return r
    return cur


def edges(mods):
    out = defaultdict(set)
    for path, mod in mods.items():
        src = mod.file_mod
        if src not in mods:
            continue
        for kind, segs in mod.refs:
            if segs[0] not in ("crate", "super", "self") and kind == "code":
                if segs[0] in KEYWORDS or (segs[0] not in mod.children and segs[0] not in mod.imports):
                    continue
            absu = absolute(mods, path, segs)
            if absu is None:
                continue
            target = resolve(mods, path, absu)
            if target is None or target not in mods:
                continue
            dst = mods[target].file_mod
            if dst != src:
                out[src].add(dst)
    return out


def cycles(graph):
    """Strongly connected components with more than one node, each with one cycle in it."""
    index, low, on, stack, comps = {}, {}, set(), [], []
    counter = [0]
    nodes = set(graph) | {d for ds in graph.values() for d in ds}

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
                comps.append(sorted(comp))

    sys.setrecursionlimit(10000)
    for v in sorted(nodes):
        if v not in index:
            visit(v)
    result = []
    for comp in comps:
        members = set(comp)
        start = comp[0]
        # shortest cycle through `start` inside the component (BFS back to start)
        prev = {start: None}
        queue = [start]
        found = None
        while queue and found is None:
            nxt = []
            for v in queue:
                for w in sorted(graph.get(v, ())):
                    if w not in members:
                        continue
                    if w == start:
                        found = v
                        break
                    if w not in prev:
                        prev[w] = v
                        nxt.append(w)
                if found is not None:
                    break
            queue = nxt
        path = [start]
        v = found
        while v is not None and v != start:
            path.append(v)
            v = prev[v]
        cyc = [start] + list(reversed(path[1:])) + [start]
        result.append((comp, cyc))
    return result


def name(p):
    return "::".join(p) if p else "crate"


def main():
    args = [a for a in sys.argv[1:] if not a.startswith("--")]
    flags = {a for a in sys.argv[1:] if a.startswith("--")}
    if len(args) != 1 or not os.path.isdir(args[0]) or flags - {"--no-tests", "--graph"}:
        print(__doc__.strip().splitlines()[2], file=sys.stderr)
        return 2
    src = os.path.normpath(args[0])
    mods = parse_crate(src, "--no-tests" in flags)
    sub = edges(mods)
    top = defaultdict(set)
    for a, ds in sub.items():
        for b in ds:
            ta, tb = a[:1], b[:1]
            if ta != tb:
                top[ta].add(tb)
    found = False
    nfiles = len({m.file_mod for m in mods.values()})
    print(f"{src}: {nfiles} module files")
    for label, graph in (("top-level modules", top), ("submodules", sub)):
        if "--graph" in flags:
            print(f"  {label} edges:")
            for a in sorted(graph):
                print(f"    {name(a)} -> {', '.join(name(b) for b in sorted(graph[a]))}")
        cs = cycles(graph)
        if not cs:
            print(f"  {label}: no cycle")
            continue
        found = True
        print(f"  {label}: {len(cs)} cycle(s)")
        for comp, cyc in cs:
            print(f"    cycle: {' -> '.join(name(p) for p in cyc)}")
            if len(comp) > len(cyc) - 1:
                print(f"      (all tangled: {', '.join(name(p) for p in comp)})")
            for a, b in zip(cyc, cyc[1:]):
                fold = (lambda p: p[:1]) if graph is top else (lambda p: p)
                print(f"      {name(a)} -> {name(b)}: {why(mods, a, b, fold)}")
    return 1 if found else 0


def why(mods, a, b, fold):
    """The references in module `a` that lead to `b` (for the report)."""
    hits = []
    for path, mod in mods.items():
        if fold(mod.file_mod) != a:
            continue
        for kind, segs in mod.refs:
            if segs[0] not in ("crate", "super", "self") and kind == "code":
                if segs[0] in KEYWORDS or (segs[0] not in mod.children and segs[0] not in mod.imports):
                    continue
            absu = absolute(mods, path, segs)
            if absu is None:
                continue
            t = resolve(mods, path, absu)
            if t in mods and fold(mods[t].file_mod) == b:
                s = "::".join(segs)
                if mod.file_mod != a:
                    s = f"{s} (in {name(mod.file_mod)})"
                if s not in hits:
                    hits.append(s)
    return ", ".join(hits[:4]) + (f" (+{len(hits) - 4})" if len(hits) > 4 else "")


if __name__ == "__main__":
    sys.exit(main())
