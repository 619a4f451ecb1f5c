"""The pattern pass (`patterning/pattern.py`) and the lowering of P in code generation: which
instruction each stitch gets, that nothing but instructions changes, the purl's transfers,
and the warnings for what cannot be knitted. Every program here also runs clean on the
independent machine."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import given

from fabric import assert_knits_as_designed
from knitc.diagnostics import Diagnostics
from knitc.driver import compile_source
from knitc.patterning.instructions import check_instructions
from knitc.patterning.pattern import apply_patterns
from knitc.patterning.query import coords
from knitc.shaping.shape import build_stitch_graph
from knitc.shaping.stitch_graph import INSTRUCTIONS
from test_props_resolve import programs
from test_props_shape import SETTINGS, compile_graph

P = INSTRUCTIONS.index("P")
RIB = "import std.stitches (rib)\n"


def build(src: str, until: str = "machine"):
    r = compile_source(src, "t.knit", until=until)
    assert not r.diagnostics.has_errors, r.diagnostics.render()
    return r


@pytest.mark.parametrize(
    "src",
    [
        RIB + "tube t { length: 4  width: 6  gauge: half }\npattern t { apply rib(1, 1) }\n",
        RIB + "sheet s { length: 4  width: 8 }\npattern s { apply rib(2, 1) }\n",
    ],
)
def test_rib_purls_every_wale_the_definition_says(src):
    r = build(src, "stitch-graph")
    k, p = (1, 1) if "rib(1, 1)" in src else (2, 1)
    wale = coords(r.graph).wale
    assert np.array_equal(r.graph.instr == P, wale % (k + p) >= k)


def test_later_layers_win_and_global_layers_wrap_node_layers():
    src = (
        "sheet s { length: 3  width: 6 }\n"
        "pattern before { set P }\n"
        "pattern s { set K where courses(0) }\n"
        "pattern after { set T where wales(0) and courses(0:1) }\n"
    )
    g = build(src, "stitch-graph").graph
    c = coords(g)
    want = np.where(
        (c.wale == 0) & (c.course < 2), INSTRUCTIONS.index("T"), np.where(c.course == 0, 0, P)
    )
    assert np.array_equal(g.instr, want)


def test_a_purl_is_knitted_from_the_other_bed_and_put_back():
    r = build(RIB + "tube t { length: 3  width: 4  gauge: half }\npattern t { apply rib(1, 1) }\n")
    ops = list(r.program)
    # (stitches of the cast-on course are made by the cast-on; look at the later ones)
    purled = {int(s) for s in np.nonzero((r.graph.instr == P) & (r.graph.wale_prev[:, 0] >= 0))[0]}
    assert purled
    side = "fb"
    for s in purled:
        at = next(i for i, o in enumerate(ops) if o.stitch == s and o.kind in ("knit", "tuck"))
        made = ops[at]
        assert made.needle.bed != side[int(r.graph.side[s])]  # knitted from the other bed
        back = next(o for o in ops[at:] if o.stitch == s and o.kind == "xfer")
        assert back.needle == made.needle  # and its new loop returned to its own bed
        assert back.needle2.bed == side[int(r.graph.side[s])]
        assert back.needle2.index == made.needle.index
    assert not [d for d in r.diagnostics if d.code in ("W603", "W604")]


FULL_GAUGE_RIB = RIB + "tube t { length: 3  width: 4 }\npattern t { apply rib(1, 1) }\n"


def test_purls_on_a_full_gauge_tube_are_knitted_plain():
    r = build(FULL_GAUGE_RIB)
    assert [d.code for d in r.diagnostics if d.code == "W603"] == ["W603"]
    purled = set(np.nonzero(r.graph.instr == P)[0].tolist())
    made = [o for o in r.program if o.stitch in purled and o.kind == "knit"]
    assert made and all(o.needle.bed == "fb"[int(r.graph.side[o.stitch])] for o in made)


def test_patterned_programs_knit_their_design_on_the_independent_machine():
    results = [
        build(RIB + src)
        for src in (
            "tube t { length: 4  width: 6  gauge: half }\npattern t { apply rib(1, 1) }\n",
            "sheet s { length: 4  width: 8 }\npattern s { apply rib(2, 2) }\n",
            "sheet s { length: 5  width: [0: 8, 1: 6] }\npattern s { apply rib(1, 1) }\n",
            "tube t { length: 3  width: 4  gauge: half }\npattern t { apply rib(1, 1) }\n",
        )
    ]
    results.append(build(FULL_GAUGE_RIB))
    sweater = build(
        Path(__file__).resolve().parent.parent.joinpath("examples", "sweater.knit").read_text()
    )
    # its ribs are half-gauge tubes: every purl finds its facing needle free (the new
    # yarns' catching tucks keep off those needles)
    assert not [d for d in sweater.diagnostics if d.code == "W603"]
    assert (sweater.graph.instr == P).sum() > 100
    results.append(sweater)
    assert_knits_as_designed(results)


@SETTINGS
@given(programs())
def test_patterns_never_create_or_delete_stitches(prog):
    r, patterned = compile_graph(prog)
    raw = build_stitch_graph(r.skeleton, Diagnostics())
    again = check_instructions(
        apply_patterns(r.skeleton, raw, Diagnostics()),
        Diagnostics(),
        racking=r.skeleton.machine.racking,
    )
    for name in (
        "node",
        "course",
        "side",
        "needle",
        "cprev",
        "cnext",
        "wale_prev",
        "wale_next",
        "course_start",
        "course_len",
    ):
        assert np.array_equal(getattr(again, name), getattr(raw, name)), name
    assert np.array_equal(again.instr, patterned.instr)  # the driver runs the same pass
    assert again.instr.max(initial=0) < len(INSTRUCTIONS)


def test_an_applied_pattern_counts_from_the_corner_of_its_selection():
    """rib(1, 1) on wales 3..8 starts with a knit wale at wale 3 (not where the node's own
    wale parity would put it), and garter's first purl course is the selection's second."""
    src = (
        "import std.stitches (rib, garter)\nsheet s { length: 8  width: 12 }\n"
        "pattern s {\n  apply rib(1, 1) where wales(3:8) and courses(0:3)\n"
        "  apply garter() where courses(5:7)\n}\n"
    )
    g = build(src, "stitch-graph").graph
    c = coords(g)
    rib = (c.wale >= 3) & (c.wale <= 8) & (c.course <= 3)
    assert np.array_equal((g.instr == P) & rib, rib & ((c.wale - 3) % 2 == 1))
    assert np.array_equal((g.instr == P) & (c.course >= 5), c.course == 6)


def test_a_warning_inside_nested_definitions_points_at_the_designers_line_with_each_step():
    from knitc.driver import compile_source

    src = (
        "pattern inner() { set T where courses(end) }\n"
        "pattern outer() { apply inner() }\n"
        "sheet s { length: 3  width: 4 }\n"
        "pattern s { apply outer() }\n"
    )
    r = compile_source(src, "n.knit", until="stitch-graph")
    (w,) = [d for d in r.diagnostics if d.code == "W708"]
    assert (w.span.line, w.span.parent) == (4, None)  # the designer's `apply outer()`
    assert [(n.span.line, n.message) for n in w.notes] == [
        (2, "written here, in the applied pattern"),
        (1, "written here, in the applied pattern"),
    ]
    g = r.graph
    chained = g.spans[int(g.origin[g.course_ids(2)[0]])]
    assert [s.line for s in chained.chain()] == [4, 2, 1]  # one mechanism: Span.parent


def test_a_definition_passes_its_own_arguments_on():
    from knitc.driver import compile_source

    src = (
        "pattern p(n = 1) { set P where wales(0:n) }\n"
        "pattern q(n = 2) { apply p(n + 1) }\n"
        "sheet s { length: 4  width: 6 }\n"
        "pattern s { apply q(2) }\n"
    )
    r = compile_source(src, "n.knit", until="stitch-graph")
    assert r.ok, [str(d) for d in r.diagnostics]
    g = r.graph
    assert sorted({int(x) for x in g.needle[g.instr == 1]}) == [0, 1, 2, 3]  # wales 0..3


def test_a_word_where_a_range_needs_a_number_is_located():
    from knitc.driver import compile_source

    src = (
        "pattern p(n = 1) { set P where wales(0:n) }\n"
        "sheet s { length: 4  width: 6 }\n"
        "pattern s { apply p(front) }\n"
    )
    r = compile_source(src, "n.knit", until="stitch-graph")
    assert [d.code for d in r.diagnostics] == ["E702"]
