"""Every stitch pattern of `std.stitches` and every motif of `std.motifs`, applied to a flat
sheet and to a half-gauge tube (and, when it needs no purl, to a full-gauge tube), compiles
to Knitout that runs clean on the independent machine. The lists of patterns are read from
the stdlib itself, so a new pattern is covered the day it is added."""

from __future__ import annotations

import functools

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from fabric import assert_knits_as_designed
from knitc.driver import compile_source
from knitc.patterning.query import coords
from knitc.shaping.stitch_graph import INSTRUCTIONS

SHAPES = {
    "sheet": "sheet s {{ length: 26  width: 24 }}",
    "half-gauge tube": "tube s {{ length: 26  width: 24  gauge: half }}",
    "full-gauge tube": "tube s {{ length: 26  width: 24 }}",
}
MODULES = ("std.stitches", "std.motifs")
NO_PURL = {
    "std.stitches": {
        "tuck_stitch": "tuck_stitch()",
        "eyelets": "eyelets()",
        "cable": "cable(2, 6, 0)",
    },
    "std.motifs": {
        "mesh": "mesh()",
        "short_holes": "short_holes()",
        "pointelle": "pointelle()",
        "leaf": "leaf()",
        "zigzag_holes": "zigzag_holes()",
        "chevron_lace": "chevron_lace()",
        "lacy_noise": "lacy_noise(purl = 0)",
    },
}
"""Per module, the patterns (with arguments) that write no purl, so they work on full-gauge
tubes too."""
MOVES = {"FR1", "FL1", "FR2", "FL2", "BR1", "BL1", "BR2", "BL2"}
P = INSTRUCTIONS.index("P")


@functools.cache
def stdlib_patterns(module: str) -> tuple[str, ...]:
    r = compile_source(f"import {module}\n", "t.knit", until="skeleton")
    assert not r.diagnostics.has_errors, r.diagnostics.render()
    return tuple(sorted(r.skeleton.patterns))


CASES = [
    (module, name, shape)
    for module in MODULES
    for name in stdlib_patterns(module)
    for shape in ("sheet", "half-gauge tube")
]
CASES += [(module, name, "full-gauge tube") for module in MODULES for name in NO_PURL[module]]


@functools.cache
def compile_case(module: str, name: str, shape: str):
    """The pattern applied on its own (imported alone: it must not need another definition
    of its module) to the whole of an unshaped piece, compiled to a machine program."""
    call = NO_PURL[module][name] if shape == "full-gauge tube" else f"{name}()"
    src = (
        f"import {module} ({name})\n" + SHAPES[shape].format() + f"\npattern s {{ apply {call} }}\n"
    )
    r = compile_source(src, "t.knit", until="machine")
    assert not r.diagnostics.has_errors, r.diagnostics.render()
    return r


def written(r) -> set[str]:
    return {INSTRUCTIONS[i] for i in np.unique(r.graph.instr)}


def refused(r) -> list[str]:
    """W708/W709 messages other than those about a piece's last course."""
    return [
        d.message
        for d in r.diagnostics
        if d.code in ("W708", "W709") and "last course" not in d.message
    ]


def test_the_stdlib_has_the_common_patterns():
    assert {"rib", "seed", "garter", "basket", "eyelets", "cable", "tuck_stitch"} <= set(
        stdlib_patterns("std.stitches")
    )


def test_the_stdlib_has_the_original_systems_motifs():
    assert {
        "crosses",
        "seed_margin",
        "holy_margin",
        "short_holes",
        "pointelle",
        "leaf",
        "zigzag_holes",
        "chevron_lace",
        "purl_noise",
        "lacy_noise",
        "cat",
    } <= set(stdlib_patterns("std.motifs"))


@pytest.mark.parametrize("module, name, shape", CASES)
def test_each_pattern_keeps_its_instructions(module, name, shape):
    """Nothing the pattern writes is refused on an unshaped piece, except on its last
    course (where moves, crosses and tucks have no next course)."""
    r = compile_case(module, name, shape)
    g = r.graph
    assert (g.instr != 0).any(), "the pattern wrote nothing"
    assert not refused(r)
    assert not [d for d in r.diagnostics if d.code in ("W603", "W710")]
    ops = {o.kind for o in r.program}
    if written(r) & (MOVES | {"XR+", "XL-"}):
        assert "xfer" in ops and "rack" in ops  # carried with racking


@pytest.mark.parametrize("module", MODULES)
def test_patterns_without_purls_are_also_tried_on_full_gauge_tubes(module):
    """A pattern whose default call writes no purl must be listed in NO_PURL, else nobody
    checks that it knits on a full-gauge tube."""
    for name in stdlib_patterns(module):
        if "P" not in written(compile_case(module, name, "sheet")):
            assert name in NO_PURL[module]


def test_every_pattern_knits_its_design_on_the_independent_machine():
    # clean, and the fabric the pattern says: every purl a purl, every lace move's loop
    # carried where it was sent, every cable's runs crossed (tests/fabric.py)
    assert_knits_as_designed(
        [compile_case(*case) for case in CASES],
        names=[f"{m}.{n} on a {shape}" for m, n, shape in CASES],
    )


# ---- std.motifs: what the motifs knit --------------------------------------------------------


def graph_of(body: str, shape: str = "sheet s { length: 20  width: 16 }"):
    r = compile_source(
        f"import std.motifs\n{shape}\npattern s {{ {body} }}\n", "t.knit", until="stitch-graph"
    )
    assert not r.diagnostics.has_errors, r.diagnostics.render()
    return r


def chart(r) -> np.ndarray:
    """The instructions as a (course, wale) array of mnemonics (unshaped pieces only)."""
    c = coords(r.graph)
    out = np.full((c.course.max() + 1, c.wale.max() + 1), "", dtype=object)
    out[c.course, c.wale] = np.array(INSTRUCTIONS, dtype=object)[r.graph.instr]
    return out


def test_seed_margin_borders_the_callers_selection_and_leaves_its_inside():
    r = graph_of("set T\n apply seed_margin(2) where select(4:15, 3:12)")
    a = chart(r)
    rows, cols = np.mgrid[0 : a.shape[0], 0 : a.shape[1]]
    inside = (rows >= 4) & (rows <= 15) & (cols >= 3) & (cols <= 12)
    ring = inside & ~((rows >= 6) & (rows <= 13) & (cols >= 5) & (cols <= 10))
    kept = ~ring & (rows < 19)  # (a tuck on the last course is refused, W708)
    assert (a[kept] == "T").all()  # outside the selection, and its middle, untouched
    seed = np.where((rows - 4 + cols - 3) % 2 == 1, "P", "K")  # from the selection's corner
    assert (a[ring] == seed[ring]).all()


def test_seed_margin_on_a_tube_is_a_band_at_each_end():
    a = chart(graph_of("apply seed_margin(3)", "tube s { length: 12  width: 6  gauge: half }"))
    assert (a[3:9] == "K").all()
    for band in (a[:3], a[9:]):
        assert set(np.unique(band)) == {"K", "P"}


def test_lace_stays_inside_each_bed_and_off_the_first_and_last_course():
    """The tiled lace keeps its moves one stitch away from a flat piece's edges and from a
    tube's folds (the drawn leaf only moves towards its middle, see below)."""
    for shape in (
        "sheet s { length: 20  width: 17 }",
        "tube s { length: 20  width: 9  gauge: half }",
    ):
        for name in set(NO_PURL["std.motifs"]) - {"leaf"}:
            r = graph_of(f"apply {name}()", shape)
            g = r.graph
            moved = np.isin(g.instr, [INSTRUCTIONS.index(m) for m in MOVES])
            assert moved.any(), name
            c = coords(g)
            assert not (moved & ((c.course == 0) | (c.course == c.course_end))).any(), name
            assert not (moved & ((c.swale == 0) | (c.swale == c.swale_end))).any(), name


def test_leaf_and_cat_are_drawn_once_in_the_middle():
    a = chart(graph_of("apply leaf()", "sheet s { length: 30  width: 31 }"))
    moves = np.argwhere(np.isin(a, list(MOVES)))
    assert len(moves) == 16  # two eyelets on seven courses, the stem and the tip
    assert moves[:, 1].min() == 10 and moves[:, 1].max() == 20  # centred: 31 = 10 + 11 + 10
    assert abs(moves[:, 0].min() + moves[:, 0].max() - 29) <= 1
    kinds = a[moves[:, 0], moves[:, 1]]
    assert (moves[kinds == "FR1", 1] <= 15).all() and (moves[kinds == "FL1", 1] >= 15).all()
    a = chart(graph_of("apply cat()", "sheet s { length: 30  width: 31 }"))
    purl = np.argwhere(a == "P")
    assert (abs(purl.min(0) + purl.max(0) - [29, 30]) <= 1).all()
    assert (purl.max(0) - purl.min(0) == [10, 10]).all()  # 11 x 11, once


def test_noise_motifs_follow_their_seed():
    one = graph_of("apply purl_noise(4, 0.5, 1)").graph.instr
    again = graph_of("apply purl_noise(4, 0.5, 1)").graph.instr
    other = graph_of("apply purl_noise(4, 0.5, 2)").graph.instr
    assert (one == again).all() and (one != other).any()
    assert 0.2 < (one == P).mean() < 0.8


def test_lacy_noise_rings_its_lace_with_knit_then_purl():
    r = graph_of("apply lacy_noise(6, 0.5)", "sheet s { length: 30  width: 30 }")
    a = chart(r)
    lace = np.argwhere(np.isin(a, list(MOVES)))
    purl = np.argwhere(a == "P")
    assert len(lace) and len(purl)
    # the purl ring is at least three stitches from every lace stitch (course + wale hops)
    gap = np.abs(lace[:, None, :] - purl[None, :, :]).sum(-1).min()
    assert gap >= 3


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    name=st.sampled_from(stdlib_patterns("std.motifs")),
    tube=st.booleans(),
    width=st.integers(3, 26),
    length=st.integers(3, 30),
    panel=st.booleans(),
)
def test_motifs_are_never_refused_on_unshaped_pieces(name, tube, width, length, panel):
    """Whatever the size of the piece, and on the whole of it or on a panel, a motif's
    instructions are knitted as written except on the piece's last course; too small a
    piece only clips the drawn motifs (W710)."""
    shape = (
        f"tube s {{ length: {length}  width: {width}  gauge: half }}"
        if tube
        else f"sheet s {{ length: {length}  width: {width} }}"
    )
    where = "where select(0.2:0.8, 0.25:0.75)" if panel else ""
    r = graph_of(f"apply {name}() {where}", shape)
    assert not refused(r)
