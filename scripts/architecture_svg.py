"""Draw the guide's architecture picture (docs/concepts/architecture.svg): the workspace's crates
as boxes in dependency layers, an arrow per direct dependency that no path through other crates
implies (the transitive reduction of the graph `cargo metadata` reports, so the picture cannot
drift from the Cargo.toml files), and under each crate the seams it offers: the traits and
registries that new tasks, characters, policy families and learners plug into.

Usage: python scripts/architecture_svg.py [--check]
       (--check: exit 1 when the committed SVG differs from what this draws; tests/test_docs.py)
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
OUT = ROOT / "docs" / "concepts" / "architecture.svg"

# the seams each crate offers (trait or registry: what plugs in), listed under its box
SEAMS = {
    "skillmimic-core": ["CharacterSpec, REGISTERED: characters as data", "safetensors I/O, rotations"],
    "skillmimic-sim": ["Scene (MJCF from a spec)", "MjBatch: batched, allocation-free step"],
    "skillmimic-motion": ["clip readers, validate", "Generator: new clips for active learning"],
    "skillmimic-nn": ["Network: state_dict names", "PolicyNet: actor/critic networks"],
    "skillmimic-env": ["Task + TaskEntry in TASKS", "Env: the one batched driver"],
    "skillmimic-learn": ["PolicyFamily in FAMILIES", "Collective, IterationHook, Extension"],
    "skillmimic-cli": ["the skillmimic command (run)"],
    "skillmimic-py": ["skillmimic_rs._core", "(the Python package's extension)"],
    "skillmimic-fuzz": ["mutation fuzzer of every reader"],
}
W, H, GAP_X, GAP_Y, MARGIN = 250, 92, 28, 60, 20


def workspace_graph() -> dict[str, list[str]]:
    """Crate → its normal (non-dev) dependencies inside the workspace."""
    meta = json.loads(
        subprocess.run(
            ["cargo", "metadata", "--format-version", "1", "--no-deps"], cwd=ROOT, check=True, capture_output=True, text=True
        ).stdout
    )
    names = {p["name"] for p in meta["packages"]}
    return {
        p["name"]: sorted(d["name"] for d in p["dependencies"] if d["name"] in names and d["kind"] is None)
        for p in meta["packages"]
    }


def reduced(graph: dict[str, list[str]]) -> dict[str, list[str]]:
    """The transitive reduction: an edge n → m only when no other path leads from n to m."""

    def reach(n: str) -> set[str]:
        seen: set[str] = set()
        todo = list(graph[n])
        while todo:
            m = todo.pop()
            if m not in seen:
                seen.add(m)
                todo.extend(graph[m])
        return seen

    return {n: [m for m in deps if not any(m in reach(k) for k in deps if k != m)] for n, deps in graph.items()}


def layers(graph: dict[str, list[str]]) -> list[list[str]]:
    """Longest-path layering: a crate sits one layer above its highest dependency."""
    depth: dict[str, int] = {}

    def d(n: str) -> int:
        if n not in depth:
            depth[n] = 1 + max((d(m) for m in graph[n]), default=-1)
        return depth[n]

    for n in graph:
        d(n)
    out: list[list[str]] = [[] for _ in range(max(depth.values()) + 1)]
    for n in sorted(graph):
        out[depth[n]].append(n)
    return out[::-1]  # the crates users call on top


def esc(s: str) -> str:
    return s.replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;")


def draw(graph: dict[str, list[str]]) -> str:
    rows = layers(graph)
    width = max(len(r) for r in rows) * (W + GAP_X) - GAP_X + 2 * MARGIN
    height = len(rows) * (H + GAP_Y) - GAP_Y + 2 * MARGIN
    pos: dict[str, tuple[float, float]] = {}
    for i, row in enumerate(rows):
        row_w = len(row) * (W + GAP_X) - GAP_X
        x0 = (width - row_w) / 2
        for j, n in enumerate(row):
            pos[n] = (x0 + j * (W + GAP_X), MARGIN + i * (H + GAP_Y))
    out = [
        f'<svg xmlns="http://www.w3.org/2000/svg" width="{width:.0f}" height="{height:.0f}" '
        f'viewBox="0 0 {width:.0f} {height:.0f}" font-family="sans-serif">',
        "<title>skillmimic-rs: crates, their dependencies and seams</title>",
        '<defs><marker id="arrow" viewBox="0 0 10 10" refX="10" refY="5" markerWidth="7" markerHeight="7" '
        'orient="auto-start-reverse"><path d="M 0 0 L 10 5 L 0 10 z" fill="#667"/></marker></defs>',
        f'<rect width="{width:.0f}" height="{height:.0f}" fill="white"/>',
    ]
    arrows = reduced(graph)
    for n in sorted(graph):
        x, y = pos[n]
        for m in arrows[n]:
            mx, my = pos[m]
            out.append(
                f'<line x1="{x + W / 2:.1f}" y1="{y + H:.1f}" x2="{mx + W / 2:.1f}" y2="{my:.1f}" '
                'stroke="#99a" stroke-width="1.2" marker-end="url(#arrow)"/>'
            )
    for n in sorted(graph):
        x, y = pos[n]
        out.append(f'<rect x="{x:.1f}" y="{y:.1f}" width="{W}" height="{H}" rx="8" fill="#eef3fb" stroke="#357"/>')
        out.append(f'<text x="{x + W / 2:.1f}" y="{y + 24:.1f}" text-anchor="middle" font-size="16" font-weight="bold">{esc(n)}</text>')
        for k, line in enumerate(SEAMS.get(n, [])):
            out.append(f'<text x="{x + W / 2:.1f}" y="{y + 48 + 18 * k:.1f}" text-anchor="middle" font-size="12">{esc(line)}</text>')
    out.append("</svg>")
    return "\n".join(out) + "\n"


def main(argv: list[str]) -> int:
    svg = draw(workspace_graph())
    if "--check" in argv:
        if not OUT.is_file() or OUT.read_text() != svg:
            print(f"{OUT} is out of date: run python scripts/architecture_svg.py", file=sys.stderr)
            return 1
        return 0
    OUT.write_text(svg)
    print(f"wrote {OUT}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
