"""Jacquard: `backing KIND where Q`, the yarns of a course knitting a back layer on the other
bed (thesis ch. 6.9.5, Fig. 6-44).

Properties of the backing rule (`codegen.backing.back_knits`) on random rows: every stitch
of a two-bed backing has its back needle knitted, by the yarns its kind says (the other
yarns for tubular, one per needle for birdseye / pique / vertical, all for horizontal), so
no yarn floats more than the region's yarn count of needles behind the front.

Then random jacquard sheets and half-gauge tubes and every backing for 2 and 3 yarns,
compiled to the end, run clean on the independent machine and knit the designed fabric with the back layer the
check expects (`fabric._backing`: a backing loop behind each stitch of a straight course,
back loops pulled through back loops only and closed onto the front where the region ends
or the sheet is shaped), and round-trip through DAT.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from design_helpers import assert_random_designs_knit, assert_round_trips_through_dat, compiled
from fabric import assert_knits_as_designed
from knitc.codegen.backing import back_knits
from knitc.driver import compile_source
from knitc.shaping.stitch_graph import BACKINGS, JACQUARD, two_bed

# ---- the backing rule -------------------------------------------------------------------------


@st.composite
def rows_of_stitches(draw):
    """A region of 1 to 4 yarns and one course of it: kind, front yarn, needle per stitch."""
    yarns = sorted(draw(st.sets(st.integers(0, 6), min_size=1, max_size=4)))
    n = draw(st.integers(1, 30))
    kind = draw(st.sampled_from(range(len(BACKINGS))))
    front = np.array([draw(st.sampled_from(yarns)) for _ in range(n)], np.int8)
    x0 = draw(st.integers(0, 50))
    x = np.arange(x0, x0 + n)
    y = draw(st.integers(0, 40))
    return yarns, np.full(n, kind, np.int8), front, x, y


@settings(max_examples=300, derandomize=True, deadline=None)
@given(rows_of_stitches())
def test_every_back_needle_is_knitted_by_the_yarns_its_backing_says(case):
    yarns, kind, front, x, y = case
    out = back_knits(kind, front, x, np.full(x.shape, y), yarns)
    n = len(yarns)
    per_needle = out.sum(axis=0)
    k = BACKINGS[int(kind[0])]
    if not two_bed(kind)[0]:
        assert not out.any()
        return
    expect = n if k == "horizontal" else 1
    assert (per_needle == expect).all(), (k, per_needle)
    knitter = out.argmax(axis=0)
    f = np.searchsorted(yarns, front)
    if k == "tubular" and n > 1:  # the back shows the yarns the front does not
        assert (knitter != f).all()
    if k == "birdseye":
        assert (knitter == (x + y) % n).all()
    if k == "vertical":  # the same yarn up each back wale, whatever the course
        assert (knitter == x % n).all()
    if k == "pique":
        even = (x + y) % 2 == 0
        assert (knitter[even] == f[even]).all()
        if n > 1:
            assert (knitter[~even] != f[~even]).all()
    # no yarn floats far behind a row: each one that knits the back of a long enough row
    # comes back within n needles (2n - 2 for tubular / pique, whose turns skip the front)
    if k in ("birdseye", "vertical", "horizontal") and len(x) > 2 * n:
        for i in range(n):
            at = np.nonzero(out[i])[0]
            assert at.size and np.diff(at, prepend=-1, append=len(x)).max() <= n


# ---- designs on the independent machine -------------------------------------------------------

TWO = 'yarn red { carrier: 5, colour: "#c0392b" }\n'
THREE = TWO + 'yarn navy { carrier: 6, colour: "#1f3a60" }\n'


def _design(kind: str, yarns: int) -> str:
    chart = (
        '  tile """\n    red  .    .\n    .    red  .\n  """ where courses(2:11)\n'
        if yarns == 2
        else '  tile """\n    red  .    navy\n    navy red  .\n  """ where courses(2:11)\n'
    )
    return (
        (TWO if yarns == 2 else THREE)
        + "sheet s { length: 14, width: [0: 14, 1: 10] }\n"
        + "pattern s {\n"
        + chart
        + f"  backing {kind} where courses(2:11)\n"
        + "}\n"
    )


DESIGNS = {f"{kind}-{n}": _design(kind, n) for kind in ("float", *JACQUARD) for n in (2, 3)} | {
    # the region runs to the bind-off, and starts at the cast-on
    "whole-sheet": TWO
    + "sheet s { length: 8, width: 9 }\n"
    + 'pattern s {\n  tile """\n    red .\n    .   red\n  """\n  backing birdseye\n}\n',
    # one yarn knitting its own back: a double knit
    "one-yarn": "sheet s { length: 8, width: 6 }\npattern s {\n  backing pique\n}\n",
    # half gauge: the backing's checkerboard counts the sheet's columns, not needles
    "half-gauge": TWO
    + "sheet s { length: 10, width: 8, gauge: half }\n"
    + "pattern s {\n  knit red where courses(2:7) and filter(wale % 2 == 0)\n"
    + "  backing birdseye where courses(2:7)\n}\n",
    # a half-gauge tube has the needles behind both sides free: the back of its back side
    # is knitted on the front bed; the band is unshaped, the tube narrows above it
    **{
        f"half-tube-{kind}": TWO
        + "tube t { length: 16, width: [0: 10, 0.6: 10, 1: 7], gauge: half }\n"
        + "pattern t {\n  knit red where courses(2:7) and filter(wale % 3 == 0)\n"
        + f"  backing {kind} where courses(1:7)\n}}\n"
        for kind in ("tubular", "birdseye", "vertical")
    },
    # a full-gauge tube's colourwork floats: `backing float` is fair isle
    "tube-float": TWO
    + "tube t { length: 10, width: 8 }\n"
    + "pattern t {\n  knit red where courses(2:5) and filter(wale % 2 == 0)\n"
    + "  backing float where courses(2:5)\n}\n",
}


def _compiled(name: str):
    return compiled(DESIGNS[name], name, clean=True)


def test_jacquard_designs_knit_as_designed_on_the_independent_machine():
    assert_knits_as_designed([_compiled(n) for n in DESIGNS], names=list(DESIGNS))


@pytest.mark.parametrize(
    "name", ["birdseye-2", "horizontal-3", "whole-sheet", "half-tube-birdseye"]
)
def test_jacquard_designs_round_trip_through_dat(name):
    assert_round_trips_through_dat(_compiled(name))


def _back_ops(r):
    return [op for op in r.program.ops if op.phase == "backing" and op.kind != "xfer"]


def test_a_backing_knits_behind_the_front_and_binds_the_floats():
    """A sparse chart on a wide sheet floats 14 needles in fair isle (W803 past 12); with
    a backing every yarn comes back to the back bed every few needles."""
    chart = (
        "pattern s {\n  knit red where courses(2:9) and filter(wale % 15 == 0)\n"
        "  backing BACKING where courses(2:9)\n}\n"
    )
    base = TWO + "sheet s { length: 12, width: 30 }\n" + chart
    fair = compile_source(base.replace("BACKING", "float"), "f.knit", until="machine")
    assert "W803" in {d.code for d in fair.diagnostics}
    jac = compile_source(base.replace("BACKING", "birdseye"), "j.knit", until="machine")
    assert not jac.diagnostics.warning_count, jac.diagnostics.render()
    backs = _back_ops(jac)
    assert {op.needle.bed for op in backs} == {"b"}
    assert {op.carriers[0] for op in backs} == {3, 5}  # both yarns knit the back


def test_the_back_layer_is_closed_onto_the_front_where_the_region_ends():
    r = _compiled("birdseye-2")
    ops = r.program.ops
    closing = [op for op in ops if op.phase == "backing" and op.kind == "xfer"]
    assert closing and all(op.needle.bed == "b" and op.needle2.bed == "f" for op in closing)
    # nothing is left on the back bed: every back needle's last backing op moves its loop
    # onto the front
    last: dict[int, str] = {}
    for op in ops:
        if op.phase == "backing" and op.needle is not None and op.needle.bed == "b":
            last[op.needle.index] = op.kind
    assert last and set(last.values()) == {"xfer"}


def test_birdseye_gives_the_back_needles_to_the_yarns_in_turn():
    """The back knits of the birdseye design, against the rule written out here: the
    region's yarns (main, red: carriers 3 and 5) take the back needles in turn along the
    course, one needle further each course of the node."""
    r = _compiled("birdseye-2")
    g = r.graph
    assert g is not None
    carriers = (3, 5)
    first = int(np.argmax(g.course_node == g.course_node[0]))
    seen = 0
    for op in r.program.ops:
        if op.phase != "backing" or op.kind not in ("knit", "tuck"):
            continue
        y = int(g.course[op.stitch]) - first
        assert op.carriers[0] == carriers[(op.needle.index + y) % 2], op
        seen += 1
    assert seen > 50


def test_the_stitch_graph_dump_names_the_backing():
    from knitc.shaping.stitch_graph import to_json

    r = compile_source(DESIGNS["pique-2"], "p.knit", until="stitch-graph")
    assert r.graph is not None
    kinds = {s.get("backing") for s in to_json(r.graph)["stitches"]}
    assert kinds == {None, "pique"}


def test_a_shaped_band_on_a_half_gauge_tube_is_e719():
    text = (
        TWO + "tube t { length: 14, width: [0: 10, 1: 7], gauge: half }\npattern t {\n"
        "  knit red where courses(2:11) and filter(wale % 2 == 0)\n"
        "  backing birdseye where courses(2:11)\n}\n"
    )
    r = compile_source(text, "t.knit", until="machine")
    errors = [d for d in r.diagnostics if d.is_error]
    assert [d.code for d in errors] == ["E719"] and "shaped" in errors[0].message


def test_a_jacquard_course_with_a_purl_is_e711():
    text = (
        TWO + "sheet s { length: 10, width: 8 }\npattern s {\n"
        "  backing birdseye where courses(2:5)\n  set P where courses(3:3) and wales(2:2)\n}\n"
    )
    r = compile_source(text, "p.knit", until="machine")
    assert [d.code for d in r.diagnostics if d.is_error] == ["E711"]


# ---- random jacquard sheets -------------------------------------------------------------------


@st.composite
def jacquard(draw) -> str:
    """A sheet, maybe narrowing, or an unshaped half-gauge tube, with a random chart of 2
    or 3 yarns over a random band of courses and a random backing over a band that
    overlaps it."""
    tube = draw(st.booleans())
    length = draw(st.integers(4, 16))
    w0 = draw(st.integers(4, 12))
    w1 = w0 if tube else draw(st.sampled_from([w0, w0, max(w0 - 3, 3)]))
    width = f"{w0}" if w0 == w1 else f"[0: {w0}, 1: {w1}]"
    n = draw(st.integers(2, 3))
    node = (
        f"tube s {{ length: {length}, width: {width}, gauge: half }}"
        if tube
        else (f"sheet s {{ length: {length}, width: {width} }}")
    )
    lines = [TWO if n == 2 else THREE, node]
    lines.append("pattern s {")
    a = draw(st.integers(0, length - 1))
    b = draw(st.integers(a, length - 1))
    for yarn in ("red", "navy")[: n - 1]:
        k, r = draw(st.integers(2, 4)), draw(st.integers(0, 3))
        lines.append(f"  knit {yarn} where courses({a}:{b}) and filter(wale % {k} == {r % k})")
    c = draw(st.integers(0, length - 1))
    d = draw(st.integers(c, length - 1))
    kind = draw(st.sampled_from(JACQUARD))
    lines.append(f"  backing {kind} where courses({c}:{d})")
    lines.append("}")
    return "\n".join(lines) + "\n"


@settings(max_examples=4, derandomize=True, deadline=None)
@given(st.lists(jacquard(), min_size=6, max_size=6))
def test_random_jacquard_sheets_knit_as_designed(texts):
    """Six random designs at a time (one oracle process for all)."""
    assert_random_designs_knit(texts, "j")
