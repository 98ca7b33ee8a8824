#!/usr/bin/env python3
"""Report import cycles between sibling and parent modules of Rust crates.

Usage: modcycles.py [--count-facades] [--siblings] SRC_DIR [SRC_DIR ...]

Each SRC_DIR is a crate's `src/`. Crate roots found there (lib.rs, main.rs,
bin/*.rs, bin/*/main.rs) are walked through their `mod x;` declarations. For every
module file, paths that start with `crate::`, `super::`, `self::` or a child module's
name (in `use` declarations and in code) become edges "module -> module that defines
the item"; a `pub use` re-export is followed to where the item really lives, so
`use crate::flow::FlowVector` counts as a dependency on `flow::vector`. Items under
`#[cfg(test)]` are ignored.

Then, for every module P, the edges among P and its direct children (a grandchild
counts as its child's) are checked for strongly connected components: each is a cycle
such as "dbscan -> dense_grid -> dbscan", reported with the items that make each edge.
A module's `pub use` of its own descendants (the re-export facade of a `mod.rs`) is
not counted as the parent using them, unless --count-facades is given: then a parent
that defines an item its children use and re-exports them shows as a cycle too.
Exit status is 1 when a cycle was found.
"""
import os
import re
import sys
from collections import defaultdict

IDENT = r"[A-Za-z_][A-Za-z0-9_]*"
# A module's `pub use` of its own descendants is the facade that gives them their
# public path, not a use of them; --count-facades counts it as an edge as well.
COUNT_FACADES = False
# --siblings: only modules that share a parent importing each other count; a child's
# use of its parent's items (and the parent's of its children's) is how a module is
# made of files, not a circle.
SIBLINGS_ONLY = False


def strip_comments_and_strings(src):
    """Blank out comments, string and char literals, keeping everything else."""
    out = []
    i, n = 0, len(src)
    while i < n:
        c = src[i]
        if src.startswith("//", i):
            j = src.find("\n", i)
            i = n if j < 0 else j
        elif src.startswith("/*", i):
            depth, i = 1, i + 2
            while i < n and depth:
                if src.startswith("/*", i):
                    depth, i = depth + 1, i + 2
                elif src.startswith("*/", i):
                    depth, i = depth - 1, i + 2
                else:
                    i += 1
            out.append(" ")
        elif (m := re.match(r'b?r(#*)"', src[i:])) and (i == 0 or not re.match(r"\w", src[i - 1])):
            end = '"' + m.group(1)
            j = src.find(end, i + m.end())
            i = n if j < 0 else j + len(end)
            out.append('""')
        elif c == '"' or (c == "b" and src.startswith('b"', i) and (i == 0 or not re.match(r"\w", src[i - 1]))):
            i += 2 if c == "b" else 1
            while i < n and src[i] != '"':
                i += 2 if src[i] == "\\" else 1
            i += 1
            out.append('""')
        elif c == "'" and (m := re.match(r"'(\\u\{[0-9a-fA-F]+\}|\\.|[^\\'])'", src[i:])):
            i += m.end()
            out.append("' '")
        else:
            out.append(c)
            i += 1
    return "".join(out)


def matching_brace(text, open_at):
    depth = 0
    for k in range(open_at, len(text)):
        if text[k] == "{":
            depth += 1
        elif text[k] == "}":
            depth -= 1
            if depth == 0:
                return k
    return len(text) - 1


def drop_cfg_test(text):
    """Remove every item under `#[cfg(test)]` (a `mod tests { .. }`, a `use`, a fn)."""
    while (m := re.search(r"#\s*\[\s*cfg\s*\(\s*test\s*\)\s*\]", text)):
        k = m.end()
        semi, brace = text.find(";", k), text.find("{", k)
        if brace < 0 or (0 <= semi < brace):
            end = semi
        else:
            end = matching_brace(text, brace)
        text = text[: m.start()] + " " + text[end + 1 :]
    return text


def expand_use_tree(tree):
    """`a::{b, c::{d as e, self}}` -> [["a","b"], ["a","c","d"], ["a","c"]] with aliases."""
    tree = re.sub(r"\s+", "", tree)
    results = []

    def walk(prefix, s):
        # split top-level commas
        parts, depth, cur = [], 0, ""
        for ch in s:
            if ch == "{":
                depth += 1
            elif ch == "}":
                depth -= 1
            if ch == "," and depth == 0:
                parts.append(cur)
                cur = ""
            else:
                cur += ch
        if cur:
            parts.append(cur)
        for p in parts:
            if not p:
                continue
            if "{" in p:
                head = p[: p.index("{")]
                inner = p[p.index("{") + 1 : p.rindex("}")]
                segs = [x for x in head.split("::") if x]
                walk(prefix + segs, inner)
            else:
                alias = None
                if "as" in p and re.search(r"(?<=\w)as(?=\w)", p):
                    p, alias = re.split(r"(?<=\w)as(?=[A-Za-z_])", p, maxsplit=1)
                segs = [x for x in p.split("::") if x]
                if segs == ["self"]:
                    segs = []
                full = prefix + segs
                results.append((full, alias or (full[-1] if full else None)))

    walk([], tree)
    return results


class Crate:
    def __init__(self, name, root_file):
        self.name = name
        self.files = {}  # module path tuple -> file
        self.children = defaultdict(set)
        self.walk((), root_file, is_dir_owner=True)

    def walk(self, mod, path, is_dir_owner):
        self.files[mod] = path
        text = drop_cfg_test(strip_comments_and_strings(open(path, encoding="utf-8").read()))
        base = os.path.dirname(path) if is_dir_owner else os.path.splitext(path)[0]
        for m in re.finditer(r"(?:^|[;}\s])(?:pub(?:\s*\([^)]*\))?\s+)?mod\s+(" + IDENT + r")\s*;", text):
            child = m.group(1)
            for cand, owner in ((os.path.join(base, child + ".rs"), False), (os.path.join(base, child, "mod.rs"), True)):
                if os.path.exists(cand):
                    self.children[mod].add(child)
                    self.walk(mod + (child,), cand, owner)
                    break

    def texts(self):
        for mod, path in self.files.items():
            yield mod, drop_cfg_test(strip_comments_and_strings(open(path, encoding="utf-8").read()))


def absolute(crate, mod, segs):
    """Absolute segments of a path written in `mod`, or None if it leaves the crate."""
    if not segs:
        return None
    cur, k = None, 0
    if segs[0] == "crate":
        cur, k = (), 1
    elif segs[0] in ("super", "self"):
        cur = mod
        while k < len(segs) and segs[k] in ("super", "self"):
            if segs[k] == "super":
                if not cur:
                    return None
                cur = cur[:-1]
            k += 1
    elif segs[0] in crate.children[mod]:
        cur = mod
    else:
        return None
    return list(cur) + segs[k:]


def collect(crate):
    """Per module: re-exports (name -> absolute path) and raw references."""
    reexports = defaultdict(dict)
    refs = []  # (module, absolute segments)
    for mod, text in crate.texts():
        for m in re.finditer(r"(?:^|[;{}\s])(pub(?:\s*\([^)]*\))?\s+)?use\s+([^;]+);", text):
            public = m.group(1) is not None
            for segs, alias in expand_use_tree(m.group(2)):
                full = absolute(crate, mod, segs)
                if full is None:
                    continue
                facade = public and full[: len(mod)] == list(mod) and len(full) > len(mod)
                if not facade or COUNT_FACADES:
                    refs.append((mod, full))
                if public and alias and alias != "*" and alias != "_":
                    reexports[mod][alias] = full
        code = re.sub(r"(?:^|[;{}\s])(?:pub(?:\s*\([^)]*\))?\s+)?use\s+[^;]+;", " ", text)
        heads = ["crate", "super", "self"] + sorted(crate.children[mod])
        for m in re.finditer(r"(?<![\w:])((?:" + "|".join(heads) + r")(?:\s*::\s*" + IDENT + r")+)", code):
            segs = re.sub(r"\s+", "", m.group(1)).split("::")
            if segs[0] == "self" and len(segs) > 1 and segs[1][:1].isupper() is False and segs[1] not in crate.children[mod]:
                continue
            full = absolute(crate, mod, segs)
            if full is not None:
                refs.append((mod, full))
    return reexports, refs


def resolve(crate, reexports, full, seen=None):
    """(module that defines the item, item name) for absolute path segments."""
    seen = seen or set()
    mod = ()
    k = 0
    while k < len(full) and full[k] in crate.children[mod]:
        mod = mod + (full[k],)
        k += 1
    item = full[k] if k < len(full) else None
    if item and item != "*" and item in reexports[mod] and (mod, item) not in seen:
        seen.add((mod, item))
        return resolve(crate, reexports, reexports[mod][item], seen)
    return mod, item


def sccs(nodes, edges):
    index, low, stack, on, out, counter = {}, {}, [], set(), [], [0]

    def strong(v):
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in edges.get(v, ()):
            if w not in index:
                strong(w)
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

    for v in nodes:
        if v not in index:
            strong(v)
    return out


def name(mod):
    return "::".join(mod) if mod else "crate"


def check(crate):
    reexports, refs = collect(crate)
    raw = defaultdict(set)  # (from module, to module) -> items
    for mod, full in refs:
        target, item = resolve(crate, reexports, full)
        if target != mod:
            raw[(mod, target)].add(item or f"{target[-1]}::")
    found = []
    for parent in sorted(crate.files):
        kids = sorted(crate.children[parent])
        if not kids:
            continue

        def lift(m):
            if m == parent:
                return "(mod)"
            if m[: len(parent)] == parent and len(m) > len(parent):
                return m[len(parent)]
            return None

        edges, why = defaultdict(set), defaultdict(set)
        for (a, b), items in raw.items():
            la, lb = lift(a), lift(b)
            if la is None or lb is None or la == lb:
                continue
            if SIBLINGS_ONLY and "(mod)" in (la, lb):
                continue
            edges[la].add(lb)
            why[(la, lb)] |= items
        for comp in sccs(["(mod)"] + kids, edges):
            inside = [(a, b) for a in comp for b in sorted(edges[a]) if b in comp]
            desc = ", ".join(f"{a} -> {b} ({', '.join(sorted(why[(a, b)]))})" for a, b in inside)
            items = sorted({i for a, b in inside for i in why[(a, b)]})
            found.append(f"{crate.name} `{name(parent)}`: cycle among {{{', '.join(comp)}}} through "
                         f"{', '.join('`' + i + '`' for i in items)}\n    {desc}")
    return found


def crate_roots(src):
    label = os.path.basename(os.path.dirname(os.path.abspath(src))) or src
    roots = []
    for f in ("lib.rs", "main.rs"):
        if os.path.exists(os.path.join(src, f)):
            roots.append((f"{label}[{f[:-3]}]", os.path.join(src, f)))
    bindir = os.path.join(src, "bin")
    if os.path.isdir(bindir):
        for e in sorted(os.listdir(bindir)):
            p = os.path.join(bindir, e)
            if e.endswith(".rs"):
                roots.append((f"{label}[bin {e[:-3]}]", p))
            elif os.path.exists(os.path.join(p, "main.rs")):
                roots.append((f"{label}[bin {e}]", os.path.join(p, "main.rs")))
    return roots


def main(argv):
    global COUNT_FACADES, SIBLINGS_ONLY
    if "--count-facades" in argv:
        COUNT_FACADES = True
        argv = [a for a in argv if a != "--count-facades"]
    if "--siblings" in argv:
        SIBLINGS_ONLY = True
        argv = [a for a in argv if a != "--siblings"]
    status = 0
    for src in argv:
        for label, root in crate_roots(src):
            crate = Crate(label, root)
            found = check(crate)
            print(f"{label}: {len(crate.files)} modules, {len(found)} cycle(s)")
            for f in found:
                print("  " + f)
            status |= bool(found)
    return status


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]) if len(sys.argv) > 1 else (print(__doc__) or 2))
