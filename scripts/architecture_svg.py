#!/usr/bin/env python3
"""Draws docs/architecture.svg, the workspace's crates as the data flows through them, from the crates'
own manifests (`cargo metadata`): one row per layer (a crate sits one row below the lowest of the crates
it depends on), arrows from a crate to the crates that use it, drawn only where no longer path already
implies them (the transitive reduction), the faces (CLI, Python) shaded.

    python3 scripts/architecture_svg.py            # writes docs/architecture.svg
    python3 scripts/architecture_svg.py --check    # exit 1 if docs/architecture.svg is not current
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
OUT = ROOT / "docs" / "architecture.svg"
PREFIX = "unicac-"
FACES = {"unicac-cli", "unicac-py"}
BOX_W, BOX_H, GAP_X, GAP_Y, MARGIN = 118, 30, 22, 58, 24


def dependencies() -> dict[str, set[str]]:
    """Each workspace crate and the workspace crates it depends on (normal dependencies only)."""
    text = subprocess.run(
        ["cargo", "metadata", "--format-version", "1", "--no-deps", "--offline"],
        cwd=ROOT, check=True, capture_output=True, text=True,
    ).stdout
    packages = json.loads(text)["packages"]
    names = {p["name"] for p in packages}
    return {
        p["name"]: {d["name"] for d in p["dependencies"] if d["name"] in names and d["kind"] is None}
        for p in packages
    }


def layers(deps: dict[str, set[str]]) -> dict[str, int]:
    layer: dict[str, int] = {}

    def of(name: str, path: tuple[str, ...] = ()) -> int:
        if name in path:
            raise SystemExit(f"dependency circle: {' -> '.join(path + (name,))}")
        if name not in layer:
            layer[name] = 1 + max((of(d, path + (name,)) for d in deps[name]), default=-1)
        return layer[name]

    for name in deps:
        of(name)
    return layer


def reduction(deps: dict[str, set[str]]) -> set[tuple[str, str]]:
    """(dependency, user) pairs no longer path implies."""

    def reaches(start: str, goal: str, skip: tuple[str, str]) -> bool:
        stack, seen = [start], set()
        while stack:
            node = stack.pop()
            for d in deps[node]:
                if (node, d) == skip or d in seen:
                    continue
                if d == goal:
                    return True
                seen.add(d)
                stack.append(d)
        return False

    return {(d, user) for user in deps for d in deps[user] if not reaches(user, d, (user, d))}


def draw(deps: dict[str, set[str]]) -> str:
    layer = layers(deps)
    edges = sorted(reduction(deps))
    # An edge that skips rows passes through one waypoint per row between its ends (Sugiyama's dummy
    # nodes), which take a place in their row: no line runs behind another crate's box.
    rows: dict[int, list[str]] = {}
    for name in sorted(deps):
        rows.setdefault(layer[name], []).append(name)
    above: dict[str, list[str]] = {name: [] for name in deps}
    paths = []
    for dep, user in edges:
        path = [dep]
        for level in range(layer[dep] + 1, layer[user]):
            waypoint = f"{dep}>{user}@{level}"
            rows[level].append(waypoint)
            above[waypoint] = [path[-1]]
            path.append(waypoint)
        above[user].append(path[-1])
        paths.append(path + [user])
    # Order each row by the mean position of what it hangs from (fewer crossings), ties by name.
    position: dict[str, float] = {}
    for level in sorted(rows):
        row = rows[level]
        row.sort(key=lambda n: (sum(position[a] for a in above[n]) / len(above[n]) if above[n] else 0.0, n))
        for i, name in enumerate(row):
            position[name] = i - (len(row) - 1) / 2
    widest = max(len(r) for r in rows.values())
    width = 2 * MARGIN + widest * BOX_W + (widest - 1) * GAP_X
    height = 2 * MARGIN + len(rows) * BOX_H + (len(rows) - 1) * GAP_Y + 20
    centre = {}
    for level, row in rows.items():
        y = MARGIN + level * (BOX_H + GAP_Y)
        for name in row:
            centre[name] = (width / 2 + position[name] * (BOX_W + GAP_X), y)
    out = [
        f'<svg xmlns="http://www.w3.org/2000/svg" width="{width:.0f}" height="{height:.0f}" '
        f'viewBox="0 0 {width:.0f} {height:.0f}" font-family="sans-serif" font-size="13">',
        '<defs><marker id="a" viewBox="0 0 10 10" refX="10" refY="5" markerWidth="7" markerHeight="7" '
        'orient="auto"><path d="M0,0 L10,5 L0,10 z" fill="#555"/></marker></defs>',
        f'<rect width="{width:.0f}" height="{height:.0f}" fill="white"/>',
    ]
    for path in paths:
        # From the bottom of the first box, through each waypoint's row, to the top of the last box.
        points = [(centre[path[0]][0], centre[path[0]][1] + BOX_H)]
        for waypoint in path[1:-1]:
            x, y = centre[waypoint]
            points += [(x, y), (x, y + BOX_H)]
        points.append(centre[path[-1]])
        text = " ".join(f"{x:.1f},{y:.1f}" for x, y in points)
        out.append(
            f'<polyline points="{text}" fill="none" stroke="#555" stroke-width="1.2" marker-end="url(#a)"/>'
        )
    for name in sorted(deps):
        x, y = centre[name]
        fill = "#f3d9b1" if name in FACES else "#dbe8f6"
        out.append(
            f'<rect x="{x - BOX_W / 2:.1f}" y="{y:.1f}" width="{BOX_W}" height="{BOX_H}" rx="5" '
            f'fill="{fill}" stroke="#345"/>'
        )
        label = name[len(PREFIX):] if name.startswith(PREFIX) else name
        out.append(f'<text x="{x:.1f}" y="{y + BOX_H / 2 + 4.5:.1f}" text-anchor="middle">{label}</text>')
    out.append(
        f'<text x="{MARGIN}" y="{height - 12:.0f}" font-size="11" fill="#444">unicac-* crates; an arrow: '
        'used by (data flows down; arrows implied by longer paths left out); shaded: the faces.</text>'
    )
    out.append("</svg>")
    return "\n".join(out) + "\n"


def main() -> int:
    svg = draw(dependencies())
    if "--check" in sys.argv[1:]:
        if not OUT.exists() or OUT.read_text() != svg:
            print(f"{OUT.relative_to(ROOT)} is not current: run python3 scripts/architecture_svg.py")
            return 1
        return 0
    tmp = OUT.with_suffix(".svg.tmp")
    tmp.write_text(svg)
    tmp.replace(OUT)
    print(f"wrote {OUT.relative_to(ROOT)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
