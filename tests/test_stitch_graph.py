"""The shape pass (skeleton → stitch graph) and the stitch-graph IR, primitive by primitive.

Each test compiles a small design to a stitch graph and checks what the thesis (ch. 5.2,
5.4.1) and `knitc.shaping.shape` say about it: stitch counts, course lengths and layout,
course and wale links, course kinds and names. Every graph also goes through
`stitch_graph.verify`, and a few hand-corrupted graphs check that the verifier can fail.

Also here: the exact `--emit stitch-graph` JSON of a few tiny designs
(`tests/golden/stitch_graph/NAME.{knit,json}`; `KNITC_UPDATE_GOLDEN=1` rewrites the JSON),
and the fidelity test against the seven knitskel ports in `examples/knitskel/`
(reference numbers in `tests/fixtures/knitskel/*.json`).

Designs that crash the shape pass today are pinned as strict xfails (`KNOWN BUG`): when the
bug is fixed they XPASS and fail loudly; then drop the marker.
"""

from __future__ import annotations

import copy
import json
import os
import re
import subprocess
import sys
from collections import Counter
from pathlib import Path

import numpy as np
import pytest

from golden import assert_golden
from knitc.cli import main
from knitc.driver import compile_file, compile_source, emit_json
from knitc.shaping import stitch_graph as sg
from knitc.shaping.shapers import shape as shaper_map
from knitc.shaping.sheet import GOLDEN as GOLDEN_STEP

ROOT = Path(__file__).resolve().parent.parent
KNITSKEL = ROOT / "examples" / "knitskel"
FIXTURES = Path(__file__).resolve().parent / "fixtures" / "knitskel"
GOLDEN = Path(__file__).resolve().parent / "golden" / "stitch_graph"
FRONT, BACK = 0, 1


# ---- helpers -----------------------------------------------------------------------------------


def build(text: str) -> sg.StitchGraph:
    """Compile `text` to a stitch graph; it must succeed and verify."""
    r = compile_source(text, "t.knit", until="stitch-graph")
    assert r.ok, r.diagnostics.render()
    assert r.graph is not None
    assert sg.verify(r.graph) == [], sg.verify(r.graph)
    return r.graph


def node_courses(g: sg.StitchGraph, name: str) -> list[int]:
    """Courses owned by node `name`, in knitting order."""
    n = g.node_names.index(name)
    return [int(c) for c in np.nonzero(g.course_node == n)[0]]


def lens(g: sg.StitchGraph, courses) -> list[int]:
    return [int(g.course_len[c]) for c in courses]


def named(g: sg.StitchGraph, itf: str) -> int:
    """The course carrying interface name `itf` (e.g. "a.top")."""
    hits = [c for c, names in g.course_names.items() if itf in names]
    assert len(hits) == 1, (itf, g.course_names)
    return hits[0]


def pos(g: sg.StitchGraph, s: int) -> tuple[int, int]:
    return int(g.side[s]), int(g.needle[s])


def wale_edges(g: sg.StitchGraph) -> set[tuple[int, int]]:
    src, slot = np.nonzero(g.wale_next >= 0)
    return {(int(a), int(b)) for a, b in zip(src, g.wale_next[src, slot])}


def prevs(g: sg.StitchGraph, s: int) -> list[int]:
    return sorted(int(x) for x in g.wale_prev[s] if x >= 0)


def nexts(g: sg.StitchGraph, s: int) -> list[int]:
    return sorted(int(x) for x in g.wale_next[s] if x >= 0)


def half_src(g: sg.StitchGraph, small: int, large: int, bed: int) -> list[int]:
    """The shaper mapping between two consecutive courses read off the graph, for one bed:
    for each stitch of the larger course in needle order, the index (in needle order) of
    the smaller-course stitch it is linked to by a wale."""

    def half(c):
        ids = g.course_ids(c)
        ids = ids[g.side[ids] == bed]
        return ids[np.argsort(g.needle[ids], kind="stable")]

    hs, hl = half(small), half(large)
    index = {int(s): i for i, s in enumerate(hs)}
    out = []
    for s in hl:
        linked = [index[int(x)] for x in (*g.wale_prev[s], *g.wale_next[s]) if int(x) in index]
        assert len(linked) == 1, (int(s), linked)
        out.append(linked[0])
    return out


def assert_path(g: sg.StitchGraph, c: int) -> None:
    """A flat course: a path through its ids in order."""
    ids = g.course_ids(c)
    assert not g.course_circular[c]
    assert g.cprev[ids[0]] == -1 and g.cnext[ids[-1]] == -1
    assert list(g.cnext[ids[:-1]]) == list(ids[1:])
    assert list(g.cprev[ids[1:]]) == list(ids[:-1])


def assert_cycle(g: sg.StitchGraph, c: int) -> None:
    """A circular course: a cycle through its ids in order."""
    ids = g.course_ids(c)
    assert g.course_circular[c]
    assert list(g.cnext[ids]) == list(np.roll(ids, -1))
    assert list(g.cprev[ids]) == list(np.roll(ids, 1))


# ---- flat sheets ------------------------------------------------------------------------------


def test_flat_sheet_counts_courses_and_paths():
    # widths at t = 0, .25, .5, .75, 1: 3, 3.75, 4.5, 5.25, 6 -> rounded half up 3 4 5 5 6
    g = build("sheet s { type: flat  length: 5  width: [0: 3, 1: 6] }\n")
    assert g.n_courses == 5
    assert lens(g, range(5)) == [3, 4, 5, 5, 6]
    assert g.n_stitches == 23 == int(g.course_len.sum())
    for c in range(5):
        assert_path(g, c)
        ids = g.course_ids(c)
        assert set(g.side[ids]) == {FRONT}
        # flat courses alternate direction: even courses left to right, odd right to left
        step = np.diff(g.needle[ids])
        assert np.all(step == (1 if c % 2 == 0 else -1))
    assert [sg.COURSE_KINDS[k] for k in g.course_kind] == [
        "interface",
        "regular",
        "regular",
        "regular",
        "interface",
    ]
    assert g.course_names == {0: ("s.bottom",), 4: ("s.top",)}
    assert set(g.node) == {0} and g.node_names == ["s"]


def test_flat_sheet_constant_width_has_one_to_one_wales():
    g = build("sheet s { type: flat  length: 4  width: 5 }\n")
    assert g.n_stitches == 20
    for c in range(3):
        for s in g.course_ids(c):
            (t,) = nexts(g, s)
            assert g.course[t] == c + 1 and pos(g, t) == pos(g, s)
            assert prevs(g, t) == [int(s)]
    assert all(nexts(g, s) == [] for s in g.course_ids(3))
    assert all(prevs(g, s) == [] for s in g.course_ids(0))
    assert len(wale_edges(g)) == 15


# ---- tubes --------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "decl", ["tube t { length: 3  width: 3 }", "sheet t { type: cylinder  length: 3  width: 3 }"]
)
def test_tube_courses_are_cycles_of_two_beds(decl):
    g = build(decl + "\n")
    assert lens(g, range(3)) == [6, 6, 6] and g.n_stitches == 18
    for c in range(3):
        assert_cycle(g, c)
        ids = g.course_ids(c)
        # counter-clockwise from above: front left to right, then back right to left
        assert [pos(g, s) for s in ids] == [(0, 0), (0, 1), (0, 2), (1, 2), (1, 1), (1, 0)]
    for s in range(12):
        (t,) = nexts(g, s)
        assert pos(g, t) == pos(g, s) and g.course[t] == g.course[s] + 1


# ---- width profiles: increases and decreases -----------------------------------------------


def test_tube_increases_and_decreases_per_bed():
    # 4 -> 6 -> 4 per bed: each bed gets 2 increases, then 2 decreases, separately
    g = build("tube t { length: 3  width: [0: 4, 0.5: 6, 1: 4]  shaper: uniform }\n")
    assert lens(g, range(3)) == [8, 12, 8]
    inc = [s for s in g.course_ids(0) if len(nexts(g, s)) == 2]
    dec = [s for s in g.course_ids(2) if len(prevs(g, s)) == 2]
    assert len(inc) == 4 and len(dec) == 4
    for bed in (FRONT, BACK):
        assert sum(g.side[s] == bed for s in inc) == 2
        assert sum(g.side[s] == bed for s in dec) == 2
    # every wale stays on its bed (halves are shaped apart), links are 1->2 or 2->1 only
    for a, b in wale_edges(g):
        assert g.side[a] == g.side[b]
    for s in inc:
        assert all(len(prevs(g, t)) == 1 for t in nexts(g, s))
    for s in dec:
        assert all(len(nexts(g, p)) == 1 for p in prevs(g, s))
    # each bed follows the uniform mapping 4 -> 6, and reads it backwards for 6 -> 4; the
    # spacing's phase moves on by the golden ratio at each change
    for bed in (FRONT, BACK):
        assert half_src(g, 0, 1, bed) == list(shaper_map("uniform", 4, 6))
        assert half_src(g, 2, 1, bed) == list(shaper_map("uniform", 4, 6, phase=GOLDEN_STEP))


def test_flat_increase_links():
    g = build("sheet s { type: flat  length: 2  width: [0: 3, 1: 6] }\n")
    # doubling: every stitch splits in two
    assert all(len(nexts(g, s)) == 2 for s in g.course_ids(0))
    assert all(len(prevs(g, s)) == 1 for s in g.course_ids(1))


# Each shaper on 4 -> 6 stitches, as `src` in needle order (larger-course stitch j continues
# smaller-course stitch src[j]), computed by hand from the formulas (seed-systems §1.6)
# and from the programs in stdlib/std/shapers.knit.
SHAPERS = {
    "uniform": [0, 0, 1, 2, 2, 3],  # r = 1.5: i -> round(1.5 i), split where the gap is 2
    "center": [0, 1, 1, 2, 2, 3],  # splits the middle two
    "left": [0, 0, 1, 1, 2, 3],
    "right": [0, 1, 2, 2, 3, 3],
    "sides": [0, 0, 1, 2, 3, 3],  # one at each edge
    "zigzag": [0, 0, 1, 1, 2, 3],  # M = 4 even: increases at the left edge
    "edges": [0, 1, 1, 2, 2, 3],  # one stitch in from each edge
}


@pytest.mark.parametrize("shaper", list(SHAPERS))
def test_shapers_on_a_sheet(shaper):
    g = build(
        "import std.shapers (zigzag, edges)\n"
        f"sheet s {{ type: flat  length: 3  width: [0: 4, 0.5: 6, 1: 4]  shaper: {shaper} }}\n"
    )
    assert lens(g, range(3)) == [4, 6, 4]
    assert half_src(g, 0, 1, FRONT) == SHAPERS[shaper]
    # the decrease reads it backwards (uniform's spacing with the second change's phase)
    second = (
        list(shaper_map("uniform", 4, 6, phase=GOLDEN_STEP))
        if shaper == "uniform"
        else SHAPERS[shaper]
    )
    assert half_src(g, 2, 1, FRONT) == second


@pytest.mark.parametrize("shaper", list(SHAPERS))
def test_shapers_agree_with_the_mapping_module_on_a_tube(shaper):
    text = (
        "import std.shapers (zigzag, edges)\n"
        f"tube t {{ length: 2  width: [0: 7, 1: 12]  shaper: {shaper} }}\n"
    )
    r = compile_source(text, "t.knit", until="stitch-graph")
    assert r.ok, r.diagnostics.render()
    g = r.graph
    program = r.skeleton.shapers.get(shaper, shaper)
    expect = list(shaper_map(program, 7, 12))  # the first change: turn 0, phase 0
    for bed in (FRONT, BACK):
        assert half_src(g, 0, 1, bed) == expect


def test_shaper_none_gives_grid_wales():
    # centred: the 4-stitch course sits on needles 1..4 under the 6-stitch course on 0..5
    g = build("sheet s { type: flat  length: 3  width: [0: 4, 0.5: 6, 1: 4]  shaper: none }\n")
    edges = wale_edges(g)
    assert edges and all(pos(g, a) == pos(g, b) for a, b in edges)
    assert all(len(nexts(g, s)) <= 1 and len(prevs(g, s)) <= 1 for s in range(g.n_stitches))
    assert sorted(g.needle[g.course_ids(0)]) == [1, 2, 3, 4]
    # needles 0 and 5 of the wide course start new wales and end them
    wide = g.course_ids(1)
    orphans = sorted(int(g.needle[s]) for s in wide if not prevs(g, s))
    assert orphans == [0, 5]
    assert len(edges) == 8


def test_alignment_left_puts_courses_on_needle_zero():
    g = build(
        "sheet s { type: flat  length: 2  width: [0: 3, 1: 5]  alignment: left  shaper: none }\n"
    )
    assert min(g.needle[g.course_ids(0)]) == 0 and min(g.needle[g.course_ids(1)]) == 0
    assert len(wale_edges(g)) == 3


# ---- closed tube ends ----------------------------------------------------------------------


def test_closed_top_collapses_the_last_course():
    g = build("tube t { length: 4  width: 3 }\nstart t.bottom\nt.top closed\n")
    assert lens(g, range(4)) == [6, 6, 6, 3]
    last = 3
    assert not g.course_circular[last] and g.course_names[last] == ("t.top",)
    assert_path(g, last)
    for s in g.course_ids(last):
        p = prevs(g, s)
        assert len(p) == 2
        # front needle k and back needle k join on stitch k
        assert sorted(pos(g, x) for x in p) == [(0, int(g.needle[s])), (1, int(g.needle[s]))]


def test_closed_bottom_collapses_the_first_course():
    g = build("tube t { length: 3  width: 4 }\nstart t.bottom\nt.bottom closed\n")
    assert lens(g, range(3)) == [4, 8, 8]
    for s in g.course_ids(0):
        n = nexts(g, s)
        assert len(n) == 2
        assert sorted(pos(g, x) for x in n) == [(0, int(g.needle[s])), (1, int(g.needle[s]))]


def test_closed_end_keeps_the_width_of_its_neighbour():
    # widths 4, 3, 2 per bed; the closed top keeps 3 (collapsing already halves the course)
    g = build("tube t { length: 3  width: [0: 4, 1: 2] }\nstart t.bottom\nt.top closed\n")
    assert lens(g, range(3)) == [8, 6, 3]
    assert g.n_stitches == 17


def test_closed_flat_end_is_not_collapsed():
    r = compile_source(
        "sheet s { type: flat  length: 3  width: 4 }\ns.top closed\n",
        "t.knit",
        until="stitch-graph",
    )
    assert r.ok and [d.code for d in r.diagnostics] == ["W503"]
    assert lens(r.graph, range(3)) == [4, 4, 4]


# ---- joints (short rows) ----------------------------------------------------------------------

SOCK = KNITSKEL / "sock.knit"


def _load(name: str) -> dict:
    return json.loads((FIXTURES / f"{name}.json").read_text(encoding="utf-8"))


def _needle_names(g: sg.StitchGraph, c: int) -> list[str]:
    return [f"{'fb'[int(g.side[s])]}{int(g.needle[s])}" for s in g.course_ids(c)]


def test_sock_heel_short_rows_match_the_original():
    g = compile_file(str(SOCK), until="stitch-graph").graph
    fx = _load("sock")
    heel = node_courses(g, "heel")
    kinds = [sg.COURSE_KINDS[int(g.course_kind[c])] for c in heel]
    assert kinds == ["short_row"] * 16 + ["continuity", "interface"]
    rows = heel[:16]
    built = fx["nodes"]["heel"]["short_row_widths_as_built"]
    assert built == [10, 9, 8, 7, 6, 6, 5, 4, 4, 5, 6, 6, 7, 8, 9, 10]
    ext = [0] * 16
    for e in fx["short_row_extensions"]:
        ext[e["row"]] += e["stitches"]
    assert ext == [5, 0, 0, 0, 0, 0, 1, 1, 1, 1, 0, 0, 0, 0, 0, 0]
    assert lens(g, rows) == [b + x for b, x in zip(built, ext)]
    # the first short row reaches back to front needle 0, where the leg's yarn is
    assert _needle_names(g, rows[0]) == [f"f{k}" for k in range(15)]
    # every short row is on the front bed, around the layout column 10 (0.25 of 40)
    for c in rows:
        assert set(g.side[g.course_ids(c)]) == {FRONT}
    # continuity: 35 stitches, exactly the original's walk f5 -> f19, b19 -> b0
    cont = heel[16]
    (orig,) = fx["continuity"]
    assert orig["stitches"] == 35 == int(g.course_len[cont])
    assert _needle_names(g, cont) == orig["needles"]
    # the heel's rows sit between the leg's top and the heel's top, which the foot shares
    assert g.course_names[heel[0] - 1] == ("main.top", "heel.bottom")
    assert g.course_names[heel[-1]] == ("heel.top", "bottom.bottom")
    assert int(g.course_len[heel[-1]]) == 40 and g.course_circular[heel[-1]]
    # the heel's own stitches: 110 + 5 + 4 + 35 short-row and continuity stitches + top 40
    assert sum(lens(g, heel)) == 110 + 5 + 4 + 35 + 40


def test_sock_heel_wales_follow_columns():
    g = compile_file(str(SOCK), until="stitch-graph").graph
    heel = node_courses(g, "heel")
    ids = np.concatenate([g.course_ids(c) for c in heel])
    for s in ids:
        for p in prevs(g, s):
            assert pos(g, p) == pos(g, int(s))  # grid wales: same bed, same needle
        assert len(prevs(g, s)) <= 1
    # each column runs through the rows in knitting order, so every short-row stitch
    # has a previous wale, and the 40 columns end in the top course
    for c in heel[:-1]:
        assert all(len(prevs(g, s)) == 1 for s in g.course_ids(c))
    assert all(len(prevs(g, s)) == 1 for s in g.course_ids(heel[-1]))


def test_joint_flat_sock_heel():
    g = compile_file(str(KNITSKEL / "sock_flat.knit"), until="stitch-graph").graph
    heel = node_courses(g, "heel")
    kinds = [sg.COURSE_KINDS[int(g.course_kind[c])] for c in heel]
    assert kinds == ["short_row"] * 16 + ["continuity", "interface"]
    # today knitc extends rows 0 and 6-9 as on the tube; the original extends rows 1-4 and
    # 11-14 on the flat heel (README, sock_flat), which is why sock_flat counts 794, not 798
    assert lens(g, heel[:16]) == [15, 9, 8, 7, 6, 6, 6, 5, 5, 6, 6, 6, 7, 8, 9, 10]
    assert _needle_names(g, heel[16]) == ["f5", "f4", "f3", "f2", "f1"]
    assert not g.course_circular[heel[-1]] and int(g.course_len[heel[-1]]) == 20


# ---- splits and merges ------------------------------------------------------------------------

SPLIT = """\
tube trunk { length: 2  width: 4 }
split fork { degree: 2 }
tube left { length: 2  width: 2 }
tube right { length: 2  width: 2 }
trunk.top -> fork.base
fork.branches[0] -> left.bottom
fork.branches[1] -> right.bottom
"""

MERGE = """\
tube left { length: 2  width: 2 }
tube right { length: 2  width: 2 }
split fork { degree: 2 }
tube trunk { length: 2  width: 4 }
left.top -> fork.branches[0]
right.top -> fork.branches[1]
fork.base -> trunk.bottom
start left.bottom
"""


def test_split_from_the_base():
    g = build(SPLIT)
    base = named(g, "fork.base")
    assert g.course_names[base] == ("trunk.top", "fork.base")  # shared with the trunk
    b0, b1 = named(g, "fork.branches[0]"), named(g, "fork.branches[1]")
    assert g.course_names[b0] == ("fork.branches[0]", "left.bottom")
    assert g.course_names[b1] == ("fork.branches[1]", "right.bottom")
    assert node_courses(g, "fork") == [b0, b1]
    assert base < b0 < b1
    # the branches lie side by side on the base ring: front 0-1 / back 0-1 and 2-3 / 2-3
    assert sorted(pos(g, s) for s in g.course_ids(b0)) == [(0, 0), (0, 1), (1, 0), (1, 1)]
    assert sorted(pos(g, s) for s in g.course_ids(b1)) == [(0, 2), (0, 3), (1, 2), (1, 3)]
    for c in (b0, b1):
        assert_cycle(g, c)
        for s in g.course_ids(c):
            (p,) = prevs(g, s)
            assert g.course[p] == base and pos(g, p) == pos(g, s)
    # the base's stitches each continue into exactly one branch
    assert all(len(nexts(g, s)) == 1 for s in g.course_ids(base))
    assert g.n_stitches == 8 + 8 + 4 + 4 + 4 + 4


def test_merge_into_the_base():
    g = build(MERGE)
    order = [g.node_names[int(g.course_node[c])] for c in range(g.n_courses)]
    assert order == ["left", "left", "right", "right", "fork", "fork", "trunk"]
    cont, base = node_courses(g, "fork")
    assert sg.COURSE_KINDS[int(g.course_kind[cont])] == "continuity"
    assert g.course_names[base] == ("fork.base", "trunk.bottom")
    assert_cycle(g, base)
    # `right` is knitted last; its yarn ends at its back needle 0, which is back needle 2 of
    # the base ring; the continuity course walks on around the ring to the base's end,
    # over the back stitches of `left`
    assert _needle_names(g, cont) == ["b1", "b0"]
    # every base stitch has exactly one previous wale at its ring position: `left` sits at
    # needles 0-1 of the base, `right` at 2-3 (its own needles are 0-1)
    offset = {named(g, "left.top"): 0, named(g, "right.top"): 2, cont: 0}
    for s in g.course_ids(base):
        (p,) = prevs(g, s)
        c = int(g.course[p])
        assert c in offset
        assert (int(g.side[p]), int(g.needle[p]) + offset[c]) == pos(g, s)
    assert {int(g.course[p]) for s in g.course_ids(base) for p in prevs(g, s)} == set(offset)
    # the continuity stitches continue `left`'s back stitches
    assert [pos(g, prevs(g, s)[0]) for s in g.course_ids(cont)] == [(1, 1), (1, 0)]
    assert g.n_stitches == 4 * 4 + 2 + 8 + 8


@pytest.mark.parametrize(
    "folded,expect",
    [
        ("true", {0: [(0, 0), (0, 1), (1, 0), (1, 1)], 1: [(0, 2), (0, 3), (1, 2), (1, 3)]}),
        # unfolded: two flat strips on the base ring, the second one on the back bed
        ("false", {0: [(0, 0), (0, 1), (0, 2), (0, 3)], 1: [(1, 0), (1, 1), (1, 2), (1, 3)]}),
    ],
)
def test_split_layouts(folded, expect):
    kind = "tube" if folded == "true" else "sheet"
    extra = "" if folded == "true" else "type: flat "
    width = 2 if folded == "true" else 4
    g = build(f"""\
tube trunk {{ length: 1  width: 4 }}
split fork {{ degree: 2  folded: {folded} }}
{kind} a {{ {extra}length: 1  width: {width} }}
{kind} b {{ {extra}length: 1  width: {width} }}
trunk.top -> fork.base
fork.branches[0] -> a.bottom
fork.branches[1] -> b.bottom
""")
    for i in (0, 1):
        c = named(g, f"fork.branches[{i}]")
        assert sorted(pos(g, s) for s in g.course_ids(c)) == expect[i]


LAYOUT_PAST_THE_BASE = """\
split s { degree: 1  folded: true  layout: [0.14] }
tube base { length: 1  width: [0: 8, 1: 14] }
s.base -> base.bottom
tube b0 { length: 5  width: [0: 7, 1: 8]  shaper: left }
b0.top -> s.branches[0]
start b0.bottom
"""
LAYOUT_OVERLAP = """\
machine { gauge: half }
split s { degree: 3  folded: false  alignment: right  layout: [0.62, 0.69, 0.32] }
tube base { length: 2  width: 16  gauge: half }
base.top -> s.base
sheet b0 { type: cylinder  length: 4  width: 7 }
s.branches[0] -> b0.bottom
sheet b1 { type: flat  length: 5  width: 1 }
s.branches[1] -> b1.bottom
tube b2 { length: 1  width: 7 }
s.branches[2] -> b2.bottom
"""


@pytest.mark.parametrize(
    "text,message",
    [
        # the branch ran one needle past the base: a wale went back in time
        (LAYOUT_PAST_THE_BASE, "branch 0 of split `s` (8 stitches per bed from stitch 1)"),
        # branches on one base stitch: a stitch with more than two wales
        (LAYOUT_OVERLAP, "branches 0 and 1 of split `s` both lie on stitch 22"),
    ],
)
def test_a_layout_that_does_not_fit_the_base_is_E534(text, message):
    r = compile_source(text, "t.knit", until="stitch-graph")
    assert [d.code for d in r.diagnostics] == ["E534"]
    assert message in r.diagnostics.items[0].message
    span = r.diagnostics.items[0].span
    assert text[span.start : span.end].startswith("layout: [")  # at the property


def test_an_unfolded_branch_may_wrap_around_the_base():
    # from the middle of the back, round the left fold and along the front: a ring
    g = build(
        "tube base { length: 3  width: 4 }\nsplit s { degree: 1  folded: false  layout: [0.5] }\n"
        "sheet f { type: flat  length: 3  width: 8 }\nbase.top -> s.base\ns.branches[0] -> f.bottom\n"
    )
    c = named(g, "s.branches[0]")
    assert [pos(g, s) for s in g.course_ids(c)][:5] == [(1, 3), (1, 2), (1, 1), (1, 0), (0, 0)]


# ---- connections --------------------------------------------------------------------------------


def test_equal_sizes_share_one_course():
    g = build("tube a { length: 3  width: 4 }\ntube b { length: 2  width: 4 }\na.top -> b.bottom\n")
    assert g.n_courses == 4 and g.n_stitches == 32
    shared = named(g, "b.bottom")
    assert g.course_names[shared] == ("a.top", "b.bottom")
    assert g.node_names[int(g.course_node[shared])] == "a"


def test_different_sizes_are_spread():
    # flat 4 -> flat 6 (W502): no shared course; a size ratio under 2 spreads with factor
    # 1, so the first 4 stitches continue 1:1 and the extra 2 start without wales
    text = (
        "sheet a { type: flat  length: 1  width: 4 }\n"
        "sheet b { type: flat  length: 1  width: 6 }\na.top -> b.bottom\n"
    )
    r = compile_source(text, "t.knit", until="stitch-graph")
    assert [d.code for d in r.diagnostics] == ["W502"]
    g = r.graph
    assert sg.verify(g) == []
    a, b = named(g, "a.top"), named(g, "b.bottom")
    assert a != b and lens(g, [a, b]) == [4, 6]
    assert [prevs(g, s) for s in g.course_ids(b)] == [[0], [1], [2], [3], [], []]


@pytest.mark.parametrize("shaper", ["uniform", "none"])
def test_flat_branches_of_an_unfolded_split_continue_into_their_sheets(shaper):
    # a tube opened into two flat strips: the second lies on the back bed, and its strip
    # continues there, every stitch in a wale (it was cast on anew as a separate piece)
    g = build(
        "tube t { length: 2  width: 4 }\nsplit s { degree: 2  folded: false }\n"
        f"sheet a {{ type: flat  length: 3  width: 4  shaper: {shaper} }}\n"
        f"sheet b {{ type: flat  length: 3  width: 4  shaper: {shaper} }}\n"
        "t.top -> s.base\ns.branches[0] -> a.bottom\ns.branches[1] -> b.bottom\n"
    )
    for branch, sheet, bed in (("s.branches[0]", "a", 0), ("s.branches[1]", "b", 1)):
        c = named(g, branch)
        assert {int(g.side[x]) for x in g.course_ids(c)} == {bed}
        node = g.node_names.index(sheet)
        ids = np.flatnonzero(g.node == node)
        assert {int(g.side[x]) for x in ids} == {bed}  # the strip stays on its branch's bed
        for course in [c] + sorted(set(g.course[ids].tolist()))[:-1]:
            for x in g.course_ids(course):
                assert len(nexts(g, int(x))) == 1, (sheet, course, int(x))


def test_an_unfolded_split_lays_every_branch_flat():
    # a tube joined to a branch of an unfolded split does not make that branch a tube (it
    # used to be laid as a ring beyond the base, with no wale to it): the branch lies flat
    # along the base ring and the tube is spread from it
    g = build(
        "tube t { length: 2  width: 8 }\nsplit s { degree: 2  folded: false }\n"
        "sheet a { type: flat  length: 2  width: 4 }\ntube b { length: 3  width: 6 }\n"
        "t.top -> s.base\ns.branches[0] -> a.bottom\ns.branches[1] -> b.bottom\n"
    )
    for branch in ("s.branches[0]", "s.branches[1]"):
        c = named(g, branch)
        assert not g.course_circular[c]
        assert all(prevs(g, int(x)) for x in g.course_ids(c))  # each from a base stitch
    b = g.node_names.index("b")
    first = int(np.flatnonzero(g.course_node == b)[0])
    assert all(prevs(g, int(x)) for x in g.course_ids(first))


def test_gauge_change_spreads_full_onto_half():
    # 6 per bed at full gauge span the needles of 3 per bed at half gauge: the courses stay
    # apart and each half-gauge stitch i takes full-gauge stitches 2i and 2i + 1, the loops
    # of its own bed (the original took 2i - 1 and 2i, so the pairs at the folds straddled
    # them and the rings had to be laid out rotated against each other)
    g = build(
        "tube a { length: 2  width: 6 }\ntube b { length: 2  width: 3  gauge: half }\n"
        "a.top -> b.bottom\n"
    )
    top, bottom = named(g, "a.top"), named(g, "b.bottom")
    assert top != bottom and lens(g, [top, bottom]) == [12, 6]
    assert int(g.course_gauge[top]) == 1 and int(g.course_gauge[bottom]) == 2
    big = g.course_ids(top)
    for i, s in enumerate(g.course_ids(bottom)):
        assert prevs(g, s) == [int(big[2 * i]), int(big[2 * i + 1])]
        assert {int(g.side[p]) for p in prevs(g, s)} == {int(g.side[s])}
    assert g.n_stitches == 12 * 2 + 6 * 2


# ---- errors -------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "decl",
    [
        "sheet a { type: flat  length: 2  width: [0: 2, 1: 5] }",
        "tube a { length: 2  width: [0: 5, 1: 2] }",
        "tube a { length: 3  width: [0: 3, 0.5: 7, 1: 3] }",
    ],
)
def test_more_than_doubling_is_E530(decl):
    r = compile_source(decl + "\n", "t.knit", until="stitch-graph")
    assert [d.code for d in r.diagnostics] == ["E530"]
    assert r.graph is None


def test_exactly_doubling_is_fine():
    g = build("tube a { length: 2  width: [0: 3, 1: 6] }\n")
    assert lens(g, range(2)) == [6, 12]


# ---- stats and the JSON dump -------------------------------------------------------------------


def test_stats():
    g = build(SPLIT)
    st = g.stats()
    assert list(st) == ["stitches", "courses", "nodes", "instructions"]
    assert st["stitches"] == g.n_stitches == 32 and st["courses"] == g.n_courses
    assert st["nodes"] == 4
    assert st["instructions"] == {"K": 32}
    assert sum(st["instructions"].values()) == st["stitches"]


def test_json_dump_is_deterministic(tmp_path, monkeypatch, capsys):
    design = KNITSKEL / "wristband.knit"
    r1 = compile_file(str(design), until="stitch-graph")
    r2 = compile_file(str(design), until="stitch-graph")
    text = emit_json(r1, "stitch-graph")
    assert text == emit_json(r2, "stitch-graph")
    obj = json.loads(text)
    assert list(obj) == ["stats", "nodes", "courses", "stitches"]
    assert obj["stats"] == r1.graph.stats()
    assert len(obj["stitches"]) == obj["stats"]["stitches"]
    # the CLI prints the same text
    monkeypatch.chdir(tmp_path)
    assert main(["--emit", "stitch-graph", str(design)]) == 0
    assert capsys.readouterr().out == text


def test_json_dump_is_identical_across_processes(tmp_path):
    """Another interpreter with another hash seed prints the same bytes."""
    design = str(KNITSKEL / "split_unfolded_4x.knit")
    outs = []
    for seed in ("1", "2"):
        env = dict(os.environ, PYTHONHASHSEED=seed)
        p = subprocess.run(
            [sys.executable, "-m", "knitc", "--emit", "stitch-graph", design],
            capture_output=True,
            text=True,
            env=env,
            cwd=tmp_path,
            check=True,
        )
        outs.append(p.stdout)
    assert outs[0] == outs[1] and outs[0].startswith('{\n "stats": {\n  "stitches": 400,')


# ---- golden dumps -------------------------------------------------------------------------------

GOLDEN_CASES = sorted(p.stem for p in GOLDEN.glob("*.knit"))


def test_golden_cases_exist():
    assert {"flat_3x2", "tube_w3_2courses", "joint_tiny", "split_tiny"} <= set(GOLDEN_CASES)


@pytest.mark.parametrize("name", GOLDEN_CASES)
def test_golden_stitch_graph(name, monkeypatch, capsys):
    monkeypatch.chdir(GOLDEN)  # spans name the bare file
    capsys.readouterr()
    assert main(["--emit", "stitch-graph", f"{name}.knit"]) == 0
    out = capsys.readouterr().out
    expected = GOLDEN / f"{name}.json"
    assert_golden(expected, out, f"stitch graph of {name}.knit")
    g = compile_file(f"{name}.knit", until="stitch-graph").graph
    assert sg.verify(g) == []


def test_golden_flat_3x2_content():
    obj = json.loads((GOLDEN / "flat_3x2.json").read_text(encoding="utf-8"))
    assert obj["stats"] == {"stitches": 6, "courses": 2, "nodes": 1, "instructions": {"K": 6}}
    assert [(s["needle"], s["prev"], s["next"], s["wale_prev"]) for s in obj["stitches"]] == [
        (0, -1, 1, []),
        (1, 0, 2, []),
        (2, 1, -1, []),
        (2, -1, 4, [2]),
        (1, 3, 5, [1]),
        (0, 4, -1, [0]),
    ]


# ---- the verifier can fail ----------------------------------------------------------------------


def _corrupt(g: sg.StitchGraph) -> sg.StitchGraph:
    return copy.deepcopy(g)


def test_verifier_catches_corruption():
    g = build("tube t { length: 3  width: [0: 2, 1: 4] }\n")
    assert sg.verify(g) == []

    h = _corrupt(g)
    h.cnext[0] = 2  # not mutual
    assert any("not mutual" in p for p in sg.verify(h))

    h = _corrupt(g)
    s = int(g.course_ids(1)[0])
    (t,) = nexts(g, s)
    h.wale_next[s] = [-1, -1]  # one-sided wale
    assert any("wale_prev of stitch" in p and "not mutual" in p for p in sg.verify(h))

    h = _corrupt(g)
    a, b = 0, int(g.course_ids(1)[0])  # a wale running backwards in time
    h.wale_next[b, 1], h.wale_prev[a, 0] = a, b
    assert any("does not go forward" in p for p in sg.verify(h))

    h = _corrupt(g)
    h.course_start[1] += 1  # courses no longer tile the ids
    assert any("tile" in p for p in sg.verify(h))

    h = _corrupt(g)
    h.course[0] = 1  # the per-stitch course disagrees with the table
    assert any("disagree" in p for p in sg.verify(h))

    h = _corrupt(g)
    s = int(g.course_ids(0)[0])
    h.wale_next[s, 1] = h.wale_next[s, 0]  # the same wale twice
    assert any("same wale twice" in p for p in sg.verify(h))

    h = _corrupt(g)
    h.cnext[0] = g.course_ids(1)[1]  # a course link into another course
    h.cprev[g.course_ids(1)[1]] = 0
    assert any("different courses" in p for p in sg.verify(h))


def test_verifier_reports_course_lengths_that_do_not_add_up():
    g = build("tube t { length: 3  width: 2 }\n")
    h = _corrupt(g)
    h.course_len[0] += 1
    assert any("tile" in p for p in sg.verify(h))


def test_verifier_catches_two_to_two_links():
    g = build("sheet s { type: flat  length: 3  width: [0: 2, 0.5: 4, 1: 2]  shaper: left }\n")
    h = _corrupt(g)
    # give an increase child a second parent: 2 -> 2
    inc = next(s for s in g.course_ids(0) if len(nexts(g, s)) == 2)
    other = next(s for s in g.course_ids(0) if s != inc)
    child = nexts(g, inc)[0]
    old = int(h.wale_next[other, 0])
    h.wale_next[other, 1] = child
    h.wale_prev[child, 1] = other
    assert old >= 0
    assert any("2->2" in p for p in sg.verify(h))


# ---- fidelity against the original knitskel -----------------------------------------------------

DESIGNS = (
    "glove",
    "sock",
    "sock_flat",
    "sweatpants",
    "wristband",
    "wristband2",
    "split_unfolded_4x",
)
KNITC_TODAY = {
    "sweatpants": 8304,
    "split_unfolded_4x": 400,
    "wristband": 520,
    "wristband2": 2550,
    "glove": 5100,
    "sock": 1490,
    "sock_flat": 794,
}
"""Stitch counts knitc gives today, pinned while `examples/knitskel/README.md` has no
"knitc" column. Four equal the original. The others differ:
- glove 5100 vs 5140: the two merge continuity courses are 30 and 40 stitches, the
  original's 50 and 60 (it walks around the base from the branch's other end);
- sock 1490 vs 1489: the closed toe keeps the previous course's width (6 per bed collapsed
  to 6), where the original collapses the last course of 5 per bed to 5;
- sock_flat 794 vs 798: the flat heel's short rows are extended on rows 0 and 6-9 (as on
  the tube), the original's on rows 0, 1-4 and 11-14."""
EQUAL_TO_ORIGINAL = ("sweatpants", "split_unfolded_4x", "wristband", "wristband2")
WIDTH_DIFFERENCES = {("sock", "bottom"), ("sock_flat", "heel")}


def _readme_column(header: str) -> dict[str, int] | None:
    """The integer column `header` of the README's design table, if it has one."""
    text = (KNITSKEL / "README.md").read_text(encoding="utf-8")
    lines = text.splitlines()
    first = next(i for i, line in enumerate(lines) if line.startswith("| design"))
    rows = []
    for line in lines[first:]:
        if not line.startswith("|"):
            break
        rows.append(line)
    head = [c.strip().strip("*`").strip().lower() for c in rows[0].strip("|").split("|")]
    if header not in head:
        return None
    k = head.index(header)
    out = {}
    for line in rows[2:]:
        cells = [c.strip() for c in line.strip("|").split("|")]
        num = re.sub(r"[^0-9]", "", cells[k])
        if num:
            out[cells[0]] = int(num)
    return out


def _graph(name: str) -> sg.StitchGraph:
    r = compile_file(str(KNITSKEL / f"{name}.knit"), until="stitch-graph")
    assert r.ok, r.diagnostics.render()
    assert sg.verify(r.graph) == []
    return r.graph


def test_readme_table_lists_the_originals():
    orig = _readme_column("original stitches")
    assert orig == {d: _load(d)["total_stitches"] for d in DESIGNS}


@pytest.mark.parametrize("name", DESIGNS)
def test_knitskel_stitch_counts(name):
    g = _graph(name)
    pinned = _readme_column("knitc") or _readme_column("knitc stitches") or KNITC_TODAY
    assert g.n_stitches == pinned[name]
    if name in EQUAL_TO_ORIGINAL:
        assert g.n_stitches == _load(name)["total_stitches"]


@pytest.mark.parametrize("name", DESIGNS)
def test_knitskel_course_widths_per_node(name):
    """Each node's courses (shared interface courses included, as in the fixtures) have
    the original's widths, up to order, except the two documented differences."""
    g = _graph(name)
    fx = _load(name)
    diffs = []
    for n, node in enumerate(g.node_names):
        want = fx["nodes"].get(node, {}).get("course_widths")
        if want is None:
            continue
        mine = {int(c) for c in np.nonzero(g.course_node == n)[0]}
        mine |= {
            c for c, names in g.course_names.items() if any(x.split(".")[0] == node for x in names)
        }
        got = [int(g.course_len[c]) for c in sorted(mine)]
        if Counter(got) != Counter(want):
            diffs.append(node)
    assert {(name, d) for d in diffs} == {k for k in WIDTH_DIFFERENCES if k[0] == name}


def test_glove_continuity_differs_from_the_original():
    g = _graph("glove")
    cont = [
        (g.node_names[int(g.course_node[c])], int(g.course_len[c]))
        for c in range(g.n_courses)
        if sg.COURSE_KINDS[int(g.course_kind[c])] == "continuity"
    ]
    assert cont == [("split_15", 30), ("split_24", 40)]
    assert [(c["node"], c["stitches"]) for c in _load("glove")["continuity"]] == [
        ("split_15", 50),
        ("split_24", 60),
    ]
    assert 5140 - 5100 == (50 - 30) + (60 - 40)


# ---- crashes these tests found: regressions (fixed in bfe996e) and known bugs ----------------

KNOWN_CRASHES = {  # inputs that once crashed the shape pass; now a graph or a diagnostic
    # A joint whose first short row contains the column the yarn arrives at (or spans the
    # whole width) walks all the way round and re-knits the row: a course visits a column
    # twice and a wale links two stitches of one course.
    "joint-first-row-at-yarn": """\
sheet a { type: flat  length: 2  width: 3 }
joint j { rows: 3  width: 3 }
sheet b { type: flat  length: 2  width: 3 }
a.top -> j.bottom
j.top -> b.bottom
""",
    "joint-full-width-tube": """\
sheet a { type: cylinder  length: 2  width: 4 }
joint j { rows: 3  layout: 0 }
sheet b { type: cylinder  length: 2  width: 4 }
a.top -> j.bottom
j.top -> b.bottom
""",
    # A flat joint laid out at the right edge wraps its short rows around (needle 7 -> 0).
    "joint-flat-wraps-around": """\
sheet a { type: flat  length: 2  width: 8 }
joint j { rows: 3  width: 3  layout: 1 }
sheet b { type: flat  length: 2  width: 8 }
a.top -> j.bottom
j.top -> b.bottom
""",
    # The yarn cannot reach the first short row on a flat joint: a bare `assert best`.
    "joint-flat-unreachable-row": """\
sheet a { type: flat  length: 2  width: 4 }
joint j { rows: 3  width: 1  layout: 0 }
sheet b { type: flat  length: 2  width: 4 }
a.top -> j.bottom
j.top -> b.bottom
""",
    # A one-course sheet with different end widths: the skeleton gives its ends w(0) and
    # w(1), the shape pass builds one course (of w(1) when knitted downwards); a split
    # that trusts the interface size crashes (numpy lexsort shape mismatch).
    "length-1-sheet-into-split": """\
sheet n1 { length: 1  type: flat  width: 2 }
sheet n2 { length: 1  type: flat  width: [0: 4, 1: 2] }
split n3 { degree: 1 }
n2.bottom -> n3.branches[0]
sheet n4 { length: 1  type: flat  width: [0: 4, 1: 2] }
n3.base -> n4.bottom
""",
    # A folded split of a tube with flat branches: the resolver accepts it, the layout puts
    # all branches on needle 0 ("a stitch would get more than two wales").
    "folded-split-flat-branches": """\
tube n3 { length: 1  width: 4 }
split n4 { degree: 3 }
n3.top -> n4.base
sheet n5 { length: 1  type: flat  width: 2 }
n4.branches[0] -> n5.bottom
sheet n6 { length: 1  type: flat  width: 2 }
n4.branches[1] -> n6.bottom
sheet n7 { length: 1  type: flat  width: 4 }
n4.branches[2] -> n7.bottom
""",
    # A tubular producer merging into a (flat) branch of an unfolded split.
    "tube-into-unfolded-branch": """\
sheet n1 { length: 1  type: cylinder  width: 1 }
joint n2 { rows: 1 }
n1.top -> n2.bottom
split n3 { degree: 1  folded: false }
n2.top -> n3.branches[0]
""",
}


@pytest.mark.parametrize("name", list(KNOWN_CRASHES))
def test_known_shape_crashes(name):
    r = compile_source(KNOWN_CRASHES[name], "t.knit", until="stitch-graph")
    # fixed = either a valid graph or a diagnostic, never an exception
    if r.graph is not None:
        assert sg.verify(r.graph) == []
    else:
        assert r.diagnostics.has_errors


def test_closed_end_of_a_shared_one_course_tube():
    r = compile_source(
        "tube a { length: 2  width: 3 }\ntube b { length: 1  width: 3 }\n"
        "a.top -> b.bottom\nb.top closed\n",
        "t.knit",
        until="stitch-graph",
    )
    if r.diagnostics.items:
        return  # a diagnostic explaining it is a fix too
    g = r.graph
    top = named(g, "b.top")
    assert not g.course_circular[top] and int(g.course_len[top]) == 3
    assert all(len(prevs(g, s)) == 2 for s in g.course_ids(top))


MIXED_SIDES = {
    # A folded split whose branches are one flat, one tubular (both knitted into it).
    "folded-merge-flat-and-tube": """\
sheet n4 { length: 1  type: flat  width: 2 }
split n5 { degree: 2 }
n4.top -> n5.branches[0]
sheet n6 { length: 1  type: cylinder  width: 1 }
n5.branches[1] -> n6.bottom
""",
    "folded-merge-flat-and-shaped-tube": """\
sheet n4 { length: 1  type: flat  width: 2 }
split n5 { degree: 2 }
n4.top -> n5.branches[0]
sheet n6 { length: 3  type: cylinder  width: [0: 2, 0.5: 3, 1: 2] }
n5.branches[1] -> n6.bottom
""",
    # A flat branch makes the folded base flat, while a tubular joint meets the base.
    "tube-joint-into-flat-folded-base": """\
tube n2 { length: 1  width: 1 }
joint n5 { rows: 1 }
n2.top -> n5.bottom
split n6 { degree: 1 }
n5.top -> n6.base
sheet n7 { length: 1  type: flat  width: 2 }
n6.branches[0] -> n7.bottom
""",
}


@pytest.mark.parametrize("name", list(MIXED_SIDES))
def test_mixed_split_sides_do_not_crash(name):
    r = compile_source(MIXED_SIDES[name], "t.knit", until="stitch-graph")
    if r.graph is not None:
        assert sg.verify(r.graph) == []
    else:
        assert r.diagnostics.has_errors


@pytest.mark.parametrize("closing", ["zigzag", "zigzagreturn"])
def test_zigzag_course_into_joint(closing):
    r = compile_source(
        "tube a { length: 1  width: 2 }\njoint j { rows: 1 }\na.top -> j.bottom\n"
        f"tube b {{ length: 2  width: 2 }}\nj.top -> b.bottom\n"
        f"a.bottom closed({closing})\n",
        "t.knit",
        until="stitch-graph",
    )
    if r.graph is not None:
        assert sg.verify(r.graph) == []
    else:
        assert r.diagnostics.has_errors


def test_a_full_round_short_row_ending_inside_the_next_is_an_error_not_a_backward_wale():
    from knitc.driver import compile_source

    src = "tube a { length: 2  width: 3 }\njoint k { rows: 3  width: [0: 6, 1: 1] }\n"
    r = compile_source(src + "a.top -> k.bottom\n", "j.knit", until="stitch-graph")
    assert [d.code for d in r.diagnostics] == ["E532"]
