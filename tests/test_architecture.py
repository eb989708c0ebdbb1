# Architecture rules of skillmimic-rs, checked on the source text (pure Python, no build needed).
#
# Rule (a) — file size: no source file has more than ``LINE_LIMIT`` lines of code.
#   * Files: every ``*.rs`` and ``*.py`` under ``SOURCE_DIRS`` (Rust sources, the crates' ``tests/``,
#     ``benches/``, build scripts, the Python package, ``tests/*.py``, scripts), skipping ``SKIP_DIRS``.
#   * A line of code is a non-blank line that is not only a comment: Rust lines whose stripped text
#     starts with ``//`` (so ``///`` and ``//!`` docs too) and Python lines whose stripped text starts
#     with ``#`` are skipped. Everything else counts, **including inline ``#[cfg(test)] mod tests``**
#     (tests are code the file's reader has to page through too) and Python docstrings.
#
# Rule (b) — no import cycle between the files (modules) of a Rust crate.
#   * One graph per compiled crate: ``src/lib.rs`` (or ``src/main.rs``), plus each of ``src/main.rs``
#     next to a lib, ``src/bin/*.rs``, ``tests/*.rs``, ``benches/*.rs``, ``examples/*.rs``. Its files
#     are found by following ``mod x;`` declarations (``#[path]`` honoured); ``*.rs`` files under
#     ``src/`` that no ``mod`` reaches yet are added at their conventional module path (so a crate
#     that is being restructured is still checked).
#   * Edge A → B when file A names a module path that lies in file B: in ``use`` trees and in
#     expressions/types, paths starting with ``crate::``, ``self::``, ``super::`` (``use super::*``
#     in a child module *file* is child → parent; in an inline ``mod tests`` it names the file
#     itself, no edge), with the name of a child module (``history::X`` in ``v2/mod.rs``), or with a
#     name the file bound by its own ``use`` (``use crate::tasks;`` then ``tasks::multi::f()``). The path
#     goes to the file of its longest module prefix; when the next segment is re-exported there by a
#     ``pub use`` (e.g. ``crate::Config`` re-exported by ``lib.rs`` from ``config.rs``), the edge goes
#     to the file the item really comes from, so a cycle cannot hide behind a re-export (glob
#     re-exports, ``pub use x::*``, are not followed).
#   * Not edges: ``mod`` declarations (a parent declaring its children), and ``pub use`` in a file of
#     items of its own descendant modules (``lib.rs``/``mod.rs``/``foo.rs`` re-exporting from its
#     children is the children's public face, not a dependency; otherwise every re-export would be a
#     cycle). Paths in comments and string literals are ignored. Code of inline test modules counts.
#     A path into a module that is declared but whose file is missing (a crate mid-edit) makes no edge.
#   * A strongly connected component of more than one file is a violation, reported as chains of
#     file paths with the line that makes each edge.
#
# Run ``python3 tests/test_architecture.py`` to print the full report.
"""Architecture rules of skillmimic-rs (file size, no import cycles); see the comment above."""

from __future__ import annotations

import bisect
import functools
import pathlib
import re
from collections import deque
from dataclasses import dataclass, field

REPO = pathlib.Path(__file__).resolve().parent.parent

LINE_LIMIT = 500
SOURCE_DIRS = ("crates", "tests", "python", "scripts")
SKIP_DIRS = {"target", "__pycache__", "node_modules"}  # and every hidden directory

# Explicit exceptions; keep them empty. A stale entry (no longer violating) fails the test.
# repo-relative path -> reason it may exceed LINE_LIMIT
LINE_LIMIT_EXCEPTIONS: dict[str, str] = {}
# frozenset of the repo-relative files of one cycle (strongly connected component) -> reason
CYCLE_EXCEPTIONS: dict[frozenset[str], str] = {}


# ---------------------------------------------------------------- rule (a): lines of code


def source_files(repo: pathlib.Path, dirs=SOURCE_DIRS, exts=(".rs", ".py")) -> list[pathlib.Path]:
    out = []
    for d in dirs:
        stack = [repo / d]
        while stack:
            p = stack.pop()
            if p.is_dir():
                if p.name.startswith(".") or p.name in SKIP_DIRS:
                    continue
                stack.extend(p.iterdir())
            elif p.suffix in exts and p.is_file():
                out.append(p)
    return sorted(out)


def code_lines(text: str, suffix: str) -> int:
    comment = "//" if suffix == ".rs" else "#"
    return sum(1 for ln in text.splitlines() if ln.strip() and not ln.strip().startswith(comment))


def oversized_files(repo: pathlib.Path, limit: int = LINE_LIMIT) -> list[tuple[str, int]]:
    out = []
    for p in source_files(repo):
        n = code_lines(p.read_text(encoding="utf-8", errors="replace"), p.suffix)
        if n > limit:
            out.append((p.relative_to(repo).as_posix(), n))
    return out


# ---------------------------------------------------------------- rule (b): Rust lexing and parsing

_TOKEN = re.compile(
    r"""(?P<ws>\s+)|(?P<lc>//[^\n]*)|(?P<bc>/\*)|(?P<raw>(?:br|cr|r)(?P<h>\#*)")
    |(?P<str>[bc]?"(?:[^"\\]|\\.)*")
    |(?P<chr>b?'(?:[^'\\\n]|\\(?:x[0-9a-fA-F]{2}|u\{[0-9a-fA-F_]*\}|.))')
    |(?P<life>'[A-Za-z_][A-Za-z0-9_]*)|(?P<id>(?:r\#)?[A-Za-z_][A-Za-z0-9_]*)
    |(?P<num>[0-9][0-9A-Za-z_]*)|(?P<dc>::)|(?P<p>.)""",
    re.VERBOSE | re.DOTALL,
)


@dataclass
class Tok:
    kind: str  # "id", "str", "p" (punctuation, "::" included), "eof"
    val: str
    line: int


def lex_rust(text: str) -> list[Tok]:
    """Tokens of Rust source without comments; string literals kept as "str" tokens."""
    nl = [i for i, c in enumerate(text) if c == "\n"]
    toks, i, n = [], 0, len(text)
    while i < n:
        m = _TOKEN.match(text, i)
        kind, j = m.lastgroup, m.end()
        if kind == "bc":  # nested block comment
            depth = 1
            while j < n and depth:
                if text.startswith("/*", j):
                    depth, j = depth + 1, j + 2
                elif text.startswith("*/", j):
                    depth, j = depth - 1, j + 2
                else:
                    j += 1
        elif kind == "h" or kind == "raw":
            end = '"' + m.group("h")
            k = text.find(end, j)
            toks.append(Tok("str", text[j : n if k < 0 else k], bisect.bisect(nl, i) + 1))
            j = n if k < 0 else k + len(end)
        elif kind == "str":
            toks.append(Tok("str", m.group()[m.group().index('"') + 1 : -1], bisect.bisect(nl, i) + 1))
        elif kind == "id":
            toks.append(Tok("id", m.group().removeprefix("r#"), bisect.bisect(nl, i) + 1))
        elif kind in ("dc", "p"):
            toks.append(Tok("p", m.group(), bisect.bisect(nl, i) + 1))
        i = j
    last = toks[-1].line if toks else 1
    return toks + [Tok("eof", "", last)] * 4


@dataclass
class UseItem:
    segs: tuple[str, ...]  # path as written, trailing `self` removed; glob: the module's path
    glob: bool
    name: str | None  # the name it binds (alias or last segment); None for globs


@dataclass
class Parsed:
    mods: list = field(default_factory=list)  # (inline scope, name, #[path] or None)
    inline_mods: set = field(default_factory=set)  # inline scopes, e.g. ("tests",)
    uses: list = field(default_factory=list)  # (inline scope, is_pub, [UseItem], line)
    paths: list = field(default_factory=list)  # (inline scope, segs, line)


def _use_tree(toks: list[Tok], i: int, prefix: tuple[str, ...]) -> tuple[list[UseItem], int]:
    out, segs = [], prefix
    if toks[i].val == "::":
        segs, i = segs + ("::",), i + 1
    while True:
        t = toks[i]
        if t.val == "*":
            return out + [UseItem(segs, True, None)], i + 1
        if t.val == "{":
            i += 1
            while toks[i].val not in ("}", ";", ""):
                sub, i = _use_tree(toks, i, segs)
                out += sub
                if toks[i].val == ",":
                    i += 1
                elif toks[i].val != "}":
                    break
            return out, i + 1
        if t.kind != "id":
            return out, i
        segs, i = segs + (t.val,), i + 1
        if toks[i].val == "::":
            i += 1
            continue
        alias = None
        if toks[i].val == "as":
            alias, i = toks[i + 1].val, i + 2
        if segs[-1] == "self":
            segs = segs[:-1]
        name = alias or (segs[-1] if segs else None)
        return out + [UseItem(segs, False, name)], i


def _is_pub(toks: list[Tok], i: int) -> bool:
    """Whether the item starting at token i has a `pub` / `pub(...)` visibility."""
    j = i - 1
    if toks[j].val == ")" and j >= 0:
        depth = 0
        while j >= 0:
            depth += {")": 1, "(": -1}.get(toks[j].val, 0)
            if depth == 0:
                break
            j -= 1
        j -= 1
    return j >= 0 and toks[j].val == "pub"


def parse_rust(text: str) -> Parsed:
    toks, res = lex_rust(text), Parsed()
    stack: list[str | None] = []  # open braces: inline module name, or None
    attr_path = None
    i = 0
    while toks[i].kind != "eof":
        t = toks[i]
        scope = tuple(s for s in stack if s is not None)
        if t.val == "#" and toks[i + 1].val == "[" and toks[i + 2].val == "path" and toks[i + 4].kind == "str":
            attr_path, i = toks[i + 4].val, i + 5
            continue
        if t.kind == "id" and t.val == "mod" and toks[i + 1].kind == "id":
            name, nxt = toks[i + 1].val, toks[i + 2].val
            if nxt == ";":
                res.mods.append((scope, name, attr_path))
                attr_path, i = None, i + 3
                continue
            if nxt == "{":
                stack.append(name)
                res.inline_mods.add(scope + (name,))
                attr_path, i = None, i + 3
                continue
        if t.kind == "id" and t.val == "use":
            items, j = _use_tree(toks, i + 1, ())
            res.uses.append((scope, _is_pub(toks, i), items, t.line))
            i = j
            continue
        if t.val == "{":
            stack.append(None)
        elif t.val == "}":
            if stack:
                stack.pop()
        elif t.val == ";":
            attr_path = None
        elif t.kind == "id" and toks[i + 1].val == "::" and toks[i - 1].val != "::":
            segs, j = [t.val], i + 1
            while toks[j].val == "::" and toks[j + 1].kind == "id":
                segs.append(toks[j + 1].val)
                j += 2
            in_vis = toks[i - 1].val == "in" and toks[i - 2].val == "("  # pub(in crate::x)
            if not in_vis:
                res.paths.append((scope, tuple(segs), t.line))
            i = j
            continue
        i += 1
    return res


# ---------------------------------------------------------------- rule (b): module graph


class CrateModel:
    """Files of one compiled crate, their module paths, and the dependency edges between them."""

    def __init__(self, root: pathlib.Path | None, src_dir: pathlib.Path | None, repo: pathlib.Path):
        self.repo = repo
        self.file_of: dict[tuple, pathlib.Path] = {}  # module path of a file -> file
        self.mod_of: dict[pathlib.Path, tuple] = {}
        self.parsed: dict[pathlib.Path, Parsed] = {}
        queue = deque([(root, (), True)] if root else [])
        self._walk(queue)
        if src_dir is not None and src_dir.is_dir():  # files no `mod` reaches (yet)
            orphans = []
            for p in source_files(src_dir.parent, (src_dir.name,), (".rs",)):
                rel = p.relative_to(src_dir).parts
                if p in self.mod_of or rel[0] == "bin" or rel in (("main.rs",), ("lib.rs",), ("build.rs",)):
                    continue
                mp = tuple(rel[:-1]) + (() if rel[-1] == "mod.rs" else (rel[-1][:-3],))
                orphans.append((len(mp), mp, p))
            for _, mp, p in sorted(orphans):
                if p not in self.mod_of and mp not in self.file_of:
                    self._walk(deque([(p, mp, p.name == "mod.rs")]))
        self.inline = {self.mod_of[p] + s for p, parsed in self.parsed.items() for s in parsed.inline_mods}
        self.modules = set(self.file_of) | self.inline
        self.modules |= {mp[:k] for mp in self.file_of for k in range(1, len(mp))}  # dirs of unreached files
        for p, parsed in self.parsed.items():
            self.modules |= {self.mod_of[p] + s + (name,) for s, name, _ in parsed.mods}
        self.pub_bindings: dict[tuple, dict[str, tuple]] = {}  # module -> name -> (path, scope)
        for p, parsed in self.parsed.items():
            for scope, is_pub, items, _ in parsed.uses:
                mod = self.mod_of[p] + scope
                for it in items:
                    if is_pub and it.name and not it.glob:
                        self.pub_bindings.setdefault(mod, {})[it.name] = (it.segs, mod)

    def _walk(self, queue):
        while queue:
            path, mp, mod_rs = queue.popleft()
            if path in self.mod_of or not path.is_file():
                continue
            self.file_of[mp], self.mod_of[path] = path, mp
            self.parsed[path] = parsed = parse_rust(path.read_text(encoding="utf-8", errors="replace"))
            base = path.parent if mod_rs else path.parent / path.stem
            for scope, name, attr in parsed.mods:
                if attr:
                    cands = [(path.parent if not scope else base.joinpath(*scope)) / attr]
                else:
                    d = base.joinpath(*scope)
                    cands = [d / f"{name}.rs", d / name / "mod.rs"]
                for c in cands:
                    if c.is_file():
                        queue.append((c.resolve(), mp + scope + (name,), bool(attr) or c.name == "mod.rs"))
                        break

    def absolute(self, segs: tuple, cur: tuple) -> tuple | None:
        """Module-absolute form of a path written in module `cur`; None if it leaves the crate."""
        if not segs:
            return None
        first, rest = segs[0], segs[1:]
        if first == "crate":
            base = ()
        elif first == "self":
            base = cur
        elif first == "super":
            base = cur[:-1] if cur else None
            while rest and rest[0] == "super" and base:
                base, rest = base[:-1], rest[1:]
            if base is None or (rest and rest[0] == "super"):
                return None
        elif cur + (first,) in self.modules:
            base, rest = cur, segs
        else:
            return None
        return base + tuple(s for s in rest if s != "self")

    def locate(self, abs_path: tuple, follow: bool = True, depth: int = 0) -> pathlib.Path | None:
        """File that holds the item/module at `abs_path` (following `pub use` re-exports)."""
        k = max((k for k in range(len(abs_path) + 1) if abs_path[:k] in self.file_of), default=None)
        if k is None:
            return None
        file = self.file_of[abs_path[:k]]
        if k < len(abs_path) and abs_path[: k + 1] in self.modules and abs_path[: k + 1] not in self.inline:
            return None  # a declared module whose file is missing (crate being edited): no edge
        if follow and depth < 8:
            q = k  # innermost module on the path: the file's, or an inline (or missing) one below it
            while q < len(abs_path) and abs_path[: q + 1] in self.modules:
                q += 1
            mod, rest = abs_path[:q], abs_path[q:]
            binding = self.pub_bindings.get(mod, {}).get(rest[0]) if rest else None
            target = self.absolute(*binding) if binding else None
            if target is not None:
                return self.locate(target + rest[1:], True, depth + 1) or file
        return file

    @staticmethod
    def _bindings(parsed: Parsed) -> dict[tuple, dict[str, tuple]]:
        """Names bound by the file's own `use` items, per inline scope (`use crate::tasks;` binds
        `tasks` to `crate::tasks`), so that `tasks::x::f()` later in the file is followed too."""
        out: dict[tuple, dict[str, tuple]] = {}
        for scope, _, items, _ in parsed.uses:
            for it in items:
                if it.name and not it.glob and it.segs and it.segs[0] in ("crate", "self", "super"):
                    out.setdefault(scope, {})[it.name] = it.segs
        return out

    @staticmethod
    def _expand(segs: tuple, scope: tuple, bound: dict[tuple, dict[str, tuple]]) -> tuple[tuple, tuple]:
        """`segs` with a first segment bound by a `use` replaced by the bound path, and the scope
        that path was written in (the innermost enclosing scope that binds the name)."""
        if not segs or segs[0] in ("crate", "self", "super"):
            return segs, scope
        for k in range(len(scope), -1, -1):
            hit = bound.get(scope[:k], {}).get(segs[0])
            if hit is not None:
                return hit + segs[1:], scope[:k]
        return segs, scope

    def edges(self) -> dict[pathlib.Path, dict[pathlib.Path, list[tuple[int, str]]]]:
        out: dict = {p: {} for p in self.parsed}
        for p, parsed in self.parsed.items():
            mp = self.mod_of[p]
            bound = self._bindings(parsed)
            refs = []
            for scope, is_pub, items, line in parsed.uses:
                for it in items:
                    refs.append((scope, it.segs, line, is_pub, "use " + "::".join(it.segs) + ("::*" if it.glob else "")))
            refs += [(scope, segs, line, False, "::".join(segs)) for scope, segs, line in parsed.paths]
            for scope, segs, line, is_pub, text in refs:
                segs, scope = self._expand(segs, scope, bound)
                target_path = self.absolute(segs, mp + scope)
                if target_path is None:
                    continue
                if is_pub and target_path[: len(mp)] == mp:
                    continue  # a parent re-exporting its descendants
                target = self.locate(target_path)
                if target is not None and target != p:
                    out[p].setdefault(target, []).append((line, text))
        return out


def strongly_connected(graph: dict) -> list[list]:
    """Tarjan's algorithm (iterative); components in discovery order."""
    index, low, on, stack, comps, counter = {}, {}, set(), [], [], [0]
    for v0 in sorted(graph):
        if v0 in index:
            continue
        work = [(v0, iter(sorted(graph[v0])))]
        index[v0] = low[v0] = counter[0]
        counter[0] += 1
        stack.append(v0)
        on.add(v0)
        while work:
            v, it = work[-1]
            w = next(it, None)
            if w is not None:
                if w not in index:
                    index[w] = low[w] = counter[0]
                    counter[0] += 1
                    stack.append(w)
                    on.add(w)
                    work.append((w, iter(sorted(graph.get(w, ())))))
                elif w in on:
                    low[v] = min(low[v], index[w])
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[v])
            if low[v] == index[v]:
                comp = []
                while True:
                    w = stack.pop()
                    on.discard(w)
                    comp.append(w)
                    if w == v:
                        break
                comps.append(sorted(comp))
    return comps


def _shortest_cycle(graph: dict, start, members: set) -> list:
    prev, queue = {}, deque([start])
    while queue:
        v = queue.popleft()
        for w in sorted(graph[v]):
            if w not in members:
                continue
            if w == start:
                chain = [v]
                while chain[-1] != start:
                    chain.append(prev[chain[-1]])
                return chain[::-1] + [start]
            if w not in prev:
                prev[w] = v
                queue.append(w)
    return [start]


@dataclass
class Cycle:
    crate: str
    files: frozenset  # repo-relative paths
    report: str


def crate_roots(repo: pathlib.Path) -> list[tuple[str, pathlib.Path | None, pathlib.Path | None]]:
    """(label, root file, src dir for unreached files) of every compiled crate of every package."""
    out = []
    for manifest in sorted(source_files(repo, ("crates",), (".toml",)) + [repo / "Cargo.toml"]):
        if manifest.name != "Cargo.toml" or not manifest.is_file() or "[package]" not in manifest.read_text(encoding="utf-8"):
            continue
        pkg, src = manifest.parent, manifest.parent / "src"
        lib, main = src / "lib.rs", src / "main.rs"
        primary = lib if lib.is_file() else main if main.is_file() else None
        out.append((f"{pkg.name} ({primary.relative_to(pkg).as_posix() if primary else 'src/'})", primary, src))
        extra = [main] if primary == lib and main.is_file() else []
        for d in ("src/bin", "tests", "benches", "examples"):
            if (pkg / d).is_dir():
                extra += sorted(p for p in (pkg / d).iterdir() if p.suffix == ".rs" and p.is_file())
                extra += sorted(p / "main.rs" for p in (pkg / d).iterdir() if (p / "main.rs").is_file())
        out += [(f"{pkg.name} ({p.relative_to(pkg).as_posix()})", p, None) for p in extra]
    return out


@functools.lru_cache(maxsize=None)
def find_cycles(repo: pathlib.Path) -> list[Cycle]:
    found, seen = [], set()
    for label, root, src in crate_roots(repo):
        model = CrateModel(root.resolve() if root else None, src.resolve() if src else None, repo)
        edges = model.edges()
        graph = {v: set(ws) for v, ws in edges.items()}
        rel = lambda p: p.relative_to(repo.resolve()).as_posix()  # noqa: E731
        for comp in strongly_connected(graph):
            files = frozenset(rel(p) for p in comp)
            if len(comp) < 2 or files in seen:
                continue
            seen.add(files)
            members, covered, lines = set(comp), set(), [f"cycle in crate {label} between {len(comp)} files:"]
            for start in comp:
                if start in covered:
                    continue
                chain = _shortest_cycle(graph, start, members)
                covered |= set(chain)
                lines.append("  " + " -> ".join(rel(p) for p in chain))
                for a, b in zip(chain, chain[1:]):
                    ev = edges[a][b]
                    more = f" (+{len(ev) - 1} more)" if len(ev) > 1 else ""
                    lines.append(f"      {rel(a)}:{ev[0][0]} `{ev[0][1]}`{more}")
            found.append(Cycle(label, files, "\n".join(lines)))
    return found


# ---------------------------------------------------------------- the rules on this repository


def test_sources_are_found():
    files = source_files(REPO)
    assert len([p for p in files if p.suffix == ".rs"]) > 20 and len([p for p in files if p.suffix == ".py"]) > 5
    labels = [label for label, _, _ in crate_roots(REPO)]
    assert any(label.startswith("skillmimic-motion (src/lib.rs)") for label in labels), labels


def test_no_source_file_over_line_limit():
    over = [(f, n) for f, n in oversized_files(REPO) if f not in LINE_LIMIT_EXCEPTIONS]
    msg = "\n".join(f"  {f}: {n} lines of code (limit {LINE_LIMIT})" for f, n in over)
    print(msg)
    assert not over, f"{len(over)} source file(s) over {LINE_LIMIT} lines of code; split them:\n{msg}"


def test_no_import_cycle_between_files_of_a_crate():
    cycles = [c for c in find_cycles(REPO) if c.files not in CYCLE_EXCEPTIONS]
    msg = "\n".join(c.report for c in cycles)
    print(msg)
    assert not cycles, f"{len(cycles)} import cycle(s) between files; make the dependency go one way:\n{msg}"


def test_exceptions_are_still_needed():
    over = {f for f, _ in oversized_files(REPO)}
    stale = [f for f in LINE_LIMIT_EXCEPTIONS if f not in over]
    cycles = {c.files for c in find_cycles(REPO)}
    stale += [" <-> ".join(sorted(c)) for c in CYCLE_EXCEPTIONS if c not in cycles]
    assert not stale, f"exceptions that no longer apply; remove them from test_architecture.py: {stale}"


if __name__ == "__main__":
    for f, n in oversized_files(REPO):
        print(f"over {LINE_LIMIT} lines of code: {f}: {n}")
    for c in find_cycles(REPO):
        print(c.report)
