"""Intarsia: `intarsia where Q`, each region of one yarn on a carrier of its own (thesis ch.
6.9.6).

Properties of the regions (`shaping.intarsia.regions`) on random designs: every stitch of
an intarsia course has a region and no other stitch has one; a region is of one yarn; two
neighbours in a course share a region exactly when they share a yarn (a round's first and
last stitch too); a wale between two intarsia stitches of one yarn stays in a region.

Tracing gives each region a local yarn of its own (rule R7), and slicing splits where the
yarn changes.

Then designs on sheets and tubes, compiled to the end, run clean on the independent
machine and knit the designed fabric: each stitch on its region's yarn, and every wall
between two regions joined at every course (`fabric._walls`: no slit); and round-trip
through DAT.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from design_helpers import assert_random_designs_knit, assert_round_trips_through_dat, compiled
from fabric import assert_knits_as_designed
from knitc.driver import compile_source
from knitc.scheduling import trace as tr
from knitc.shaping.intarsia import regions
from knitc.shaping.stitch_graph import INTARSIA

TWO = "yarn red { carrier: 5 }\n"
THREE = TWO + "yarn navy { carrier: 6 }\n"


@st.composite
def intarsia(draw) -> str:
    """A sheet or tube, maybe narrowing, with one or two motifs (rectangles of red and
    navy, maybe on one face of a tube) in an intarsia band between plain courses."""
    kind = draw(st.sampled_from(["sheet", "tube"]))
    length = draw(st.integers(6, 18))
    w0 = draw(st.integers(6, 14))
    w1 = draw(st.sampled_from([w0, w0, max(w0 - 2, 5)]))
    width = f"{w0}" if w0 == w1 else f"[0: {w0}, 1: {w1}]"
    a = draw(st.integers(1, length - 3))
    b = draw(st.integers(a, length - 2))
    lines = [THREE, f"{kind} p {{ length: {length}, width: {width} }}", "pattern p {"]
    for yarn in draw(st.sampled_from([("red",), ("red", "navy")])):
        c0 = draw(st.integers(a, b))
        c1 = draw(st.integers(c0, b))
        lo = draw(st.sampled_from([0.0, 0.2, 0.4, 0.6]))
        hi = min(lo + draw(st.sampled_from([0.2, 0.3, 0.5])), 1.0)
        where = f"courses({c0}:{c1}) and wales({lo}:{hi})"
        if kind == "tube" and draw(st.booleans()):
            where += f" and side({draw(st.sampled_from(['front', 'back']))})"
        lines.append(f"  knit {yarn} where {where}")
    lines.append(f"  intarsia where courses({a}:{b})")
    lines.append("}")
    return "\n".join(lines) + "\n"


@settings(max_examples=60, derandomize=True, deadline=None)
@given(intarsia())
def test_regions_follow_the_yarns(text):
    r = compile_source(text, "i.knit", until="stitch-graph")
    g = r.graph
    assert g is not None and g.backing is not None and g.yarn is not None, text
    reg = regions(g)
    band = g.intarsia_courses()  # (the selected courses of more than one yarn)
    selected = np.zeros(g.n_courses, bool)
    selected[g.course[g.backing == INTARSIA]] = True
    first = np.repeat(g.yarn[g.course_start], g.course_len)
    several = np.zeros(g.n_courses, bool)
    several[g.course[g.yarn != first]] = True
    assert (band == (selected & several)).all()
    on = band[g.course]
    assert ((reg >= 0) == on).all()
    for k in np.unique(reg[on]).tolist():  # a region is of one yarn
        assert len(set(g.yarn[reg == k].tolist())) == 1
    ids = np.nonzero(on)[0]
    nxt = g.cnext[ids]
    has = nxt >= 0
    a, b = ids[has], nxt[has]
    assert ((reg[a] == reg[b]) == (g.yarn[a] == g.yarn[b])).all()
    child = g.wale_next[ids, 0]
    ok = (child >= 0) & on[np.maximum(child, 0)]
    a, b = ids[ok], child[ok]
    same = g.yarn[a] == g.yarn[b]
    assert (reg[a][same] == reg[b][same]).all()


def assert_one_local_yarn_per_region(r) -> None:
    """Each region is visited by one strand, which visits nothing else, starting on the
    region's first course and ending on its last."""
    g, t = r.graph, r.trace
    reg = regions(g)
    strand_of = np.full(g.n_stitches, -1, np.int64)
    strand_of[t.stitch] = t.yarn
    for k in np.unique(reg[reg >= 0]).tolist():
        mine = reg == k
        strands = set(strand_of[mine].tolist())
        assert len(strands) == 1, (k, strands)
        (strand,) = strands
        assert (mine == (strand_of == strand)).all()  # its stitches and no others
        visits = np.nonzero(t.yarn == strand)[0]
        assert t.flags[visits[0]] & tr.START and t.flags[visits[-1]] & tr.END
        courses = g.course[mine]
        assert g.course[t.stitch[visits[0]]] == courses.min()
        assert g.course[t.stitch[visits[-1]]] == courses.max()


@settings(max_examples=40, derandomize=True, deadline=None)
@given(intarsia())
def test_tracing_starts_a_local_yarn_for_each_region_and_slicing_splits_where_it_changes(text):
    """Tracing's rule R7: each region is knitted by one strand of its own, which starts on
    the region's first course and ends after its last (the strand of the course below is
    pending meanwhile: it knits no stitch of the band); every run but a flat course's last
    ends in a JOIN; and no slice holds visits of two strands (the thesis' slicing split
    where the yarn changes). Every stage's verifier runs too."""
    r = compile_source(text, "i.knit", until="schedule", verify=True)
    g, t, sl = r.graph, r.trace, r.slices
    assert g is not None and t is not None and sl is not None, text + r.diagnostics.render()
    assert_one_local_yarn_per_region(r)
    band = g.intarsia_courses()
    visit_course = g.course[t.stitch]
    for c in range(g.n_courses):
        vs = np.nonzero(visit_course == c)[0]
        runs = 1 + int(np.count_nonzero(np.diff(t.yarn[vs]) != 0))
        joins = int(np.count_nonzero(t.flags[vs] & tr.JOIN))
        if not band[c]:
            assert joins == 0
        else:
            assert joins == (runs if g.course_circular[c] else runs - 1), (c, text)
    bounds = np.r_[sl.visit, t.n_visits]
    for a, b in zip(bounds[:-1], bounds[1:], strict=True):
        assert len(set(t.yarn[a:b].tolist())) == 1, text


DESIGNS = {
    "sheet-block": TWO
    + "sheet s { length: 16, width: 14 }\n"
    + "pattern s {\n  knit red where courses(4:11) and wales(4:9)\n"
    + "  intarsia where courses(4:11)\n}\n",
    # regions that change width every course, two yarns, a narrowing sheet, an odd band
    "sheet-diamond": THREE
    + "sheet s { length: 24, width: [0: 20, 1: 16] }\n"
    + 'pattern s {\n  draw """\n'
    + "    .   .   red .   .   .   .   .   .   .   navy navy\n"
    + "    .   red red red .   .   .   .   .   .   navy navy\n"
    + "    red red red red red .   .   .   .   .   navy navy\n"
    + "    .   red red red .   .   .   .   .   .   navy navy\n"
    + "    .   .   red .   .   .   .   .   .   .   navy navy\n"
    + '  """ where courses(5:9)\n  intarsia where courses(5:9)\n}\n',
    # a U of red around a navy block: red's one carrier knits both arms
    "sheet-u": THREE
    + "sheet s { length: 14, width: 12 }\n"
    + 'pattern s {\n  tile """\n    red  navy navy red\n    red  navy navy red\n'
    + '    red  red  red  red\n  """ where courses(3:8) and wales(4:7)\n'
    + "  intarsia where courses(3:8)\n}\n",
    # a band longer than main's carry_up: main is ended and brought back in above it
    "sheet-long": TWO
    + "sheet s { length: 30, width: 10 }\n"
    + "pattern s {\n  knit red where courses(3:24) and wales(3:6)\n"
    + "  intarsia where courses(3:24)\n}\n",
    "tube-front": TWO
    + "tube t { length: 16, width: 12 }\n"
    + "pattern t {\n  knit red where courses(4:10) and wales(0.3:0.7) and side(front)\n"
    + "  intarsia where courses(4:10)\n}\n",
    # a band going on from one tube into the next, whose course count starts again: each
    # region keeps its yarn (the round that continues it goes the other way round)
    "tube-into-tube": TWO
    + "tube a { length: 7, width: 10 }\ntube b { length: 8, width: 10 }\na.top -> b.bottom\n"
    + "pattern a {\n  knit red where courses(2:6) and wales(0.3:0.6) and side(front)\n"
    + "  intarsia where courses(2:6)\n}\n"
    + "pattern b {\n  knit red where courses(0:4) and wales(0.3:0.6) and side(front)\n"
    + "  intarsia where courses(0:4)\n}\n",
    # an inlay over an intarsia round: laid once the round is knitted, onto its new loops
    "tube-inlay": TWO
    + "yarn elastic { carrier: 7, inlay: 2 }\ntube s { length: 12, width: 10 }\n"
    + "pattern s {\n  knit red where courses(3:7) and wales(0.3:0.6) and side(front)\n"
    + "  knit elastic where courses(4:5)\n  intarsia where courses(3:7)\n}\n",
    "tube-two-faces": THREE
    + "tube t { length: 16, width: 10, gauge: half }\n"
    + "pattern t {\n  knit red where courses(3:10) and wales(0.2:0.5) and side(front)\n"
    + "  knit navy where courses(5:8) and wales(0.4:0.8) and side(back)\n"
    + "  intarsia where courses(3:10)\n}\n",
}


def _compiled(name: str):
    return compiled(DESIGNS[name], name, clean=True)


def test_intarsia_designs_knit_as_designed_on_the_independent_machine():
    assert_knits_as_designed([_compiled(n) for n in DESIGNS], names=list(DESIGNS))


@pytest.mark.parametrize("name", ["sheet-diamond", "tube-front"])
def test_intarsia_designs_round_trip_through_dat(name):
    assert_round_trips_through_dat(_compiled(name))


def test_each_region_has_its_own_carrier_in_once_and_out_once():
    r = _compiled("sheet-block")
    ops = r.program.ops
    ins = [op.carriers[0] for op in ops if op.kind == "in"]
    outs = [op.carriers[0] for op in ops if op.kind == "outhook"]
    # main's background left and right of the block, and the block: three regions, three
    # carriers, none of them main's own (it rests at the side over the band)
    assert len(ins) == 3 and len(set(ins)) == 3 and 3 not in ins
    assert sorted(ins) == sorted(o for o in outs if o in ins)
    joins = [
        op for op in ops if op.phase == "float_catch" and op.kind == "tuck" and op.carriers[0] != 3
    ]  # (main's own are its catches into the edge while it rests)
    assert len(joins) == 2 * 8  # two walls, one tuck join each, eight courses


def test_a_band_into_the_next_tube_keeps_each_regions_yarn():
    r = _compiled("tube-into-tube")
    assert_one_local_yarn_per_region(r)


def test_an_inlay_over_an_intarsia_round_tucks_on_the_rounds_new_loops():
    r = _compiled("tube-inlay")
    knitted: set[int] = set()
    for op in r.program.ops:
        if op.kind == "knit" and op.stitch >= 0:
            knitted.add(op.stitch)
        elif op.kind == "tuck" and 7 in op.carriers and op.stitch >= 0:
            assert op.stitch in knitted, op  # (its stitch is knitted first)


def test_each_region_carrier_knits_only_its_own_region():
    """Every knit of an intarsia course's region carrier is on its own region's needles
    (that no yarn floats far is the designs' test: they compile without W803)."""
    r = _compiled("sheet-diamond")
    g = r.graph
    reg = regions(g)
    by_carrier: dict[int, set[int]] = {}
    for op in r.program.ops:
        if op.kind == "knit" and op.stitch >= 0 and reg[op.stitch] >= 0:
            by_carrier.setdefault(op.carriers[0], set()).add(int(reg[op.stitch]))
    assert all(len(v) == 1 for v in by_carrier.values()), by_carrier


def test_an_intarsia_course_of_one_yarn_is_knitted_as_any_course():
    text = "sheet s { length: 10, width: 8 }\npattern s {\n  intarsia where courses(2:5)\n}\n"
    r = compile_source(text, "one.knit", until="machine")
    assert r.program is not None and not r.diagnostics.warning_count, r.diagnostics.render()
    assert r.graph is not None and not r.graph.intarsia_courses().any()
    assert sum(op.kind in ("in", "inhook") for op in r.program.ops) == 1


def test_a_plated_yarn_in_two_regions_at_once_is_an_error_at_the_yarn():
    text = (
        "yarn red { carrier: 5, plating: 6 }\nsheet s { length: 10, width: 12 }\n"
        "pattern s {\n  knit red where courses(2:5) and (wales(1:2) or wales(7:8))\n"
        "  intarsia where courses(2:5)\n}\n"
    )
    r = compile_source(text, "p.knit", until="machine")
    errors = [d for d in r.diagnostics if d.is_error]
    assert [d.code for d in errors] == ["E602"] and "plated" in errors[0].message
    assert errors[0].span is not None and errors[0].span.line == 1


@settings(max_examples=4, derandomize=True, deadline=None)
@given(st.lists(intarsia(), min_size=6, max_size=6))
def test_random_intarsia_designs_knit_as_designed(texts):
    """Six random designs at a time (one oracle process for all)."""
    assert_random_designs_knit(texts, "i")
