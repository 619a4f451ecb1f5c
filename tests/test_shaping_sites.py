"""Where the shipped designs increase and decrease: symmetric where their shapers say so.

A shaper's intent is a promise about the garment: `sides` and `std.shapers.edges` shape a
tube at both folds (two lines up the sides of a sleeve), `uniform` spreads its changes over
the whole course (a round yoke). These tests read each shipped design's stitch graph and
count the shaping sites of every node on each half of the course: the left half of each bed
is the left fold of a tube (or the left edge of a sheet), the right half the right one.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from knitc.driver import compile_file
from knitc.shaping.stitch_graph import StitchGraph

REPO = Path(__file__).resolve().parent.parent
DESIGNS = sorted((REPO / "examples").glob("*.knit")) + sorted(
    (REPO / "examples" / "knitskel").glob("*.knit")
)
TWO_EDGES = {"sides", "edges"}
"""Shapers that promise the same shaping at both edges (both folds of a tube)."""


def sites(g: StitchGraph, node: str) -> list[tuple[int, int, str]]:
    """(course, bed, 'L' or 'R') of every increase (a stitch with two next wales) and
    decrease (two previous wales) within one bed of `node`."""
    k = g.node_names.index(node)
    out = []
    for c in np.flatnonzero(g.course_node == k).tolist():
        ids = g.course_ids(c)
        for bed in (0, 1):
            half = ids[g.side[ids] == bed]
            half = half[np.argsort(g.needle[half], kind="stable")]
            for i, s in enumerate(half.tolist()):
                kids = [int(x) for x in g.wale_next[s] if x >= 0]
                parents = [int(x) for x in g.wale_prev[s] if x >= 0]
                # a closed end joins the beds (two parents, one on each): not shaping
                inc = len(kids) == 2 and all(g.node[x] == k and g.side[x] == bed for x in kids)
                dec = len(parents) == 2 and all(
                    g.node[x] == k and g.side[x] == bed for x in parents
                )
                if inc or dec:
                    out.append((c, bed, "L" if 2 * i < half.size else "R"))
    return out


def shaped_nodes(path: Path) -> list[tuple[str, str, StitchGraph]]:
    r = compile_file(str(path), until="stitch-graph")
    assert r.graph is not None, r.diagnostics.render()
    out = []
    for name, node in r.skeleton.nodes.items():
        shaper = str(node.props.get("shaper", ""))
        if node.kind in ("sheet", "tube") and shaper in TWO_EDGES | {"uniform"}:
            out.append((name, shaper, r.graph))
    return out


CASES = [(path, name, shaper, g) for path in DESIGNS for name, shaper, g in shaped_nodes(path)]


def _id(case) -> str:
    path, name, shaper, _ = case
    return f"{path.parent.name}/{path.stem}:{name}:{shaper}"


@pytest.mark.parametrize("case", [c for c in CASES if c[2] in TWO_EDGES], ids=_id)
def test_two_edge_shapers_shape_both_edges_alike_course_by_course(case):
    _, name, _, g = case
    found = sites(g, name)
    assert found, f"`{name}` has no shaping to check"
    # per course and edge (a tube's fold is shaped on both beds in the same course)
    edges = sorted({(c, side) for c, _, side in found})
    left = right = 0
    for _, side in edges:
        left += side == "L"
        right += side == "R"
        # evenly over the courses: one edge is never more than one course of changes ahead
        assert abs(left - right) <= 1, f"`{name}`: {left} left, {right} right so far"
    # and each course changes both beds alike
    per_course = {}
    for c, bed, side in found:
        per_course.setdefault((c, side), set()).add(bed)
    beds = {len(b) for b in per_course.values()}
    assert beds == {1} or beds == {2}, f"`{name}`: its beds are shaped unlike"


@pytest.mark.parametrize(
    "case", [c for c in CASES if c[2] == "uniform" and len(sites(c[3], c[1])) >= 8], ids=_id
)
def test_uniform_spreads_its_changes_over_the_course(case):
    _, name, _, g = case  # nodes with fewer changes are too little to judge
    found = sites(g, name)
    left = sum(side == "L" for _, _, side in found)
    assert abs(2 * left - len(found)) <= max(2, len(found) // 5), (
        f"`{name}`: {left} of {len(found)} changes on the left half"
    )


def test_the_shipped_designs_have_two_edge_shaping_to_check():
    names = {(p.stem, n) for p, n, s, _ in CASES if s in TWO_EDGES}
    assert {
        ("tube", "sleeve"),
        ("sweater", "sleeve_l"),
        ("sweater", "sleeve_r"),
        ("glove", "hand"),
        ("sock", "toe"),
    } <= names
