"""Lowering of the pattern instructions (thesis ch. 4.2.2): T, M, the moves, the crosses, S,
the flat purl that stays on the back bed, and the instructions `patterning.instructions`
refuses. Each test reads the machine program the instruction turns into; the lowerings
also run clean on the independent machine (one batch, at the end)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from fabric import assert_knits_as_designed
from knitc.diagnostics import Diagnostics
from knitc.driver import compile_source
from knitc.patterning.instructions import check_instructions
from knitc.patterning.pattern import apply_patterns
from knitc.scheduling import schedule as sc
from knitc.shaping.shape import build_stitch_graph
from knitc.shaping.stitch_graph import INSTRUCTIONS
from test_props_shape import SETTINGS


def build(src: str):
    r = compile_source(src, "t.knit", until="machine")
    assert not r.diagnostics.has_errors, r.diagnostics.render()
    return r


def sheet(pattern: str, length: int = 8, width: int = 10) -> str:
    return f"sheet s {{ length: {length}  width: {width} }}\npattern s {{\n{pattern}\n}}\n"


def stitch(r, course: int, wale: int) -> int:
    """The stitch of a sheet at (course, wale): wale = needle order, left to right."""
    ids = r.graph.course_ids(course)
    return int(ids[np.argsort(r.graph.needle[ids])][wale])


def needle(r, s: int) -> tuple[str, int]:
    b, n = sc.knit_positions(r.schedule, r.graph.n_stitches)
    return "fb"[int(b[s])], int(n[s])


def ops_of(r, s: int, kind: str | None = None):
    return [o for o in r.program if o.stitch == s and (kind is None or o.kind == kind)]


def after(r, op):
    ops = list(r.program)
    return ops[ops.index(op) + 1 :]


def racked_xfers(ops):
    """(racking, from, to) of the transfers in `ops`."""
    rack, out = 0, []
    for o in ops:
        if o.kind == "rack":
            rack = o.value
        elif o.kind == "xfer":
            out.append(
                (rack, f"{o.needle.bed}{o.needle.index}", f"{o.needle2.bed}{o.needle2.index}")
            )
    return out


def before_cast_off(r, kind: str):
    """Ops of `kind` made for stitches below the last course (the cast-off transfers)."""
    last = r.graph.n_courses - 1
    return [
        o
        for o in r.program
        if o.kind == kind and o.stitch >= 0 and int(r.graph.course[o.stitch]) < last
    ]


def warnings(r, code: str):
    return [d for d in r.diagnostics if d.code == code]


# ---- T and M ------------------------------------------------------------------------------


def test_a_tuck_keeps_the_old_loop_and_the_next_knit_takes_both():
    r = build(sheet("  set T where select(3, 4)"))
    s = stitch(r, 3, 4)
    [tuck] = ops_of(r, s)
    assert tuck.kind == "tuck" and (tuck.needle.bed, tuck.needle.index) == needle(r, s)
    above = stitch(r, 4, 4)
    [knit] = ops_of(r, above, "knit")
    assert (knit.needle.bed, knit.needle.index) == needle(r, s)
    assert not before_cast_off(r, "xfer")  # a tuck needs no transfer


def test_a_miss_leaves_the_old_loop_and_floats_the_yarn():
    r = build(sheet("  set M where select(3, 4)"))
    s = stitch(r, 3, 4)
    assert [o.kind for o in ops_of(r, s)] == ["miss"]
    # the stitch above knits through the loop of course 2, still on the needle
    [knit] = ops_of(r, stitch(r, 4, 4), "knit")
    assert (knit.needle.bed, knit.needle.index) == needle(r, s)


# ---- moves ----------------------------------------------------------------------------------


@pytest.mark.parametrize("instr, shift", [("FR1", 1), ("FL1", -1), ("FR2", 2), ("FL2", -2)])
def test_a_front_move_carries_the_loop_and_leaves_an_eyelet(instr, shift):
    r = build(sheet(f"  set {instr} where select(3, 4)"))
    s = stitch(r, 3, 4)
    bed, n = needle(r, s)
    [knit] = ops_of(r, s, "knit")
    assert (knit.needle.bed, knit.needle.index) == (bed, n)
    moves = racked_xfers(after(r, knit))[:2]
    assert moves == [(0, f"f{n}", f"b{n}"), (shift, f"b{n}", f"f{n + shift}")]
    # the needle it left is empty when the next course comes: a yarn-over (a tuck)
    assert [o.kind for o in ops_of(r, stitch(r, 4, 4))] == ["tuck"]
    # and the neighbour's next stitch knits both loops together
    assert ops_of(r, stitch(r, 4, 4 + shift), "knit")
    # the yarn-over is made at the course's stitch number: the pass is not cut in two
    numbers = set()
    for op in r.program.ops:
        if op.kind == "stitch_number":
            number = op.value
        elif (
            op.kind in ("knit", "tuck")
            and op.phase == "action"
            and op.stitch >= 0
            and int(r.graph.course[op.stitch]) == 4
        ):
            numbers.add(number)
    assert len(numbers) == 1


def test_a_back_move_is_knitted_reversed_and_carried_from_the_back_bed():
    r = build(sheet("  set BR1 where select(3, 4)"))
    s = stitch(r, 3, 4)
    _, n = needle(r, s)
    [knit] = ops_of(r, s, "knit")
    assert (knit.needle.bed, knit.needle.index) == ("b", n)  # a reverse stitch
    assert racked_xfers(after(r, knit))[0] == (1, f"b{n}", f"f{n + 1}")


def test_right_is_read_from_each_beds_face_on_a_tube():
    src = (
        "tube t { length: 6  width: 8  gauge: half }\n"
        "pattern t { set FR1 where select(2, 2, front) or select(2, 2, back) }\n"
    )
    r = build(src)
    g = r.graph
    moved = np.nonzero(g.instr == INSTRUCTIONS.index("FR1"))[0]
    assert moved.size == 2
    for s in moved.tolist():
        bed, n = needle(r, s)
        [knit] = ops_of(r, s, "knit")
        come_back = [x for x in racked_xfers(after(r, knit)) if x[2][0] == bed][0]
        landed = int(come_back[2][1:])
        # seen from the back, right is towards lower needle numbers
        assert np.sign(landed - n) == (1 if bed == "f" else -1)


def test_a_move_off_the_edge_of_a_flat_piece_is_refused_where_it_was_written():
    r = build(sheet("  set FL1 where select(3, 0)\n  set FR1 where select(3, 9)"))
    ws = warnings(r, "W709")
    assert [w.span.line for w in ws] == [3, 4]
    assert not (r.graph.instr != 0).any()
    assert not before_cast_off(r, "xfer")


def test_a_third_loop_on_a_needle_is_refused():
    r = build(sheet("  set FR1 where select(3, 3)\n  set FL1 where select(3, 5)"))
    # 3 -> 4 and 5 -> 4 would make three loops on needle 4 (its own stays)
    assert len(warnings(r, "W709")) == 1
    assert int((r.graph.instr != 0).sum()) == 1


def test_stack_puts_its_loop_back_on_top_of_the_one_that_arrives():
    r = build(sheet("  set FR1 where select(3, 3)\n  set S where select(3, 4)"))
    s, t = stitch(r, 3, 3), stitch(r, 3, 4)
    _, n = needle(r, s)
    [knit] = ops_of(r, t, "knit")
    xs = racked_xfers(after(r, knit))[:4]
    assert xs == [
        (0, f"f{n}", f"b{n}"),
        (0, f"f{n + 1}", f"b{n + 1}"),
        (1, f"b{n}", f"f{n + 1}"),
        (0, f"b{n + 1}", f"f{n + 1}"),
    ]


# ---- crosses --------------------------------------------------------------------------------

CABLE = "  set XR+ where select(3, 2:3)\n  set XL- where select(3, 4:5)"


def test_a_cable_swaps_its_runs_upper_run_first():
    r = build(sheet(CABLE))
    first = [stitch(r, 3, w) for w in (2, 3)]
    n0 = needle(r, first[0])[1]
    [knit] = ops_of(r, stitch(r, 3, 5), "knit")
    xs = racked_xfers(after(r, knit))
    lift = {(0, f"f{n0 + i}", f"b{n0 + i}") for i in range(4)}
    assert set(xs[:4]) == lift
    # XR+ (upper) comes back first, two needles right; then XL-, two needles left
    assert xs[4:8] == [
        (2, f"b{n0}", f"f{n0 + 2}"),
        (2, f"b{n0 + 1}", f"f{n0 + 3}"),
        (-2, f"b{n0 + 2}", f"f{n0}"),
        (-2, f"b{n0 + 3}", f"f{n0 + 1}"),
    ]
    assert not warnings(r, "W709")


def test_a_lower_cable_brings_the_left_going_run_back_first():
    r = build(sheet("  set XR- where select(3, 2)\n  set XL+ where select(3, 3)"))
    n0 = needle(r, stitch(r, 3, 2))[1]
    [knit] = ops_of(r, stitch(r, 3, 3), "knit")
    xs = racked_xfers(after(r, knit))
    assert xs[2:4] == [(-1, f"b{n0 + 1}", f"f{n0}"), (1, f"b{n0}", f"f{n0 + 1}")]


def test_relief_stitches_stay_between_the_runs():
    r = build(
        sheet(
            "  set XR+ where select(3, 2)\n  set P where select(3, 3)\n  set XL- where select(3, 4)"
        )
    )
    n0 = needle(r, stitch(r, 3, 2))[1]
    [knit] = ops_of(r, stitch(r, 3, 4), "knit")
    moved = {(a, b) for _, a, b in racked_xfers(after(r, knit))}
    assert (f"b{n0}", f"f{n0 + 2}") in moved and (f"b{n0 + 2}", f"f{n0}") in moved
    assert not warnings(r, "W709")


@pytest.mark.parametrize(
    "pattern",
    [
        "  set XR+ where select(3, 2:3)",  # no complement
        "  set XR+ where select(3, 2)\n  set XR- where select(3, 3)",  # not a complement
        "  set XR+ where select(3, 2)\n  set K where select(3, 3)\n  set XL- where select(3, 4:5)",
    ],
)
def test_a_cross_without_its_complement_is_knitted_plain(pattern):
    r = build(sheet(pattern))
    assert warnings(r, "W709")
    assert not np.isin(r.graph.instr, [12, 13, 14, 15]).any()


def test_a_cable_on_a_full_gauge_tube_waits_on_the_sliders():
    r = build(
        "tube t { length: 6  width: 8 }\n"
        "pattern t { set XR+ where select(2, 2) and side(front)\n"
        "            set XL- where select(2, 3) and side(front) }\n"
    )
    assert any(o.kind == "xfer" and o.needle2.bed == "bs" for o in r.program)
    assert not warnings(r, "W709")


# ---- purls, refusals ----------------------------------------------------------------------


def test_a_flat_rib_keeps_its_purl_loops_on_the_back_bed_between_courses():
    r = build(
        "import std.stitches (rib)\nsheet s { length: 10  width: 8 }\n"
        "pattern s { apply rib(2, 2) }\n"
    )
    purls = int((r.graph.instr == INSTRUCTIONS.index("P")).sum())
    wales = 4  # purl wales of 8 stitches in rib(2, 2)
    xfers = [
        o for o in before_cast_off(r, "xfer") if r.graph.instr[o.stitch] == INSTRUCTIONS.index("P")
    ]
    # each purl wale goes to the back once, not twice per course (it comes home with the
    # last course, before the cast-off)
    assert purls == 10 * wales
    assert len(xfers) == wales


def test_instructions_on_shaping_are_ignored_and_point_at_the_designers_line():
    src = (
        "import std.stitches (tuck_stitch)\n"
        "sheet s { length: 10  width: [0: 12, 1: 6] }\n"
        "pattern s {\n  apply tuck_stitch()\n}\n"
    )
    r = build(src)
    [w] = [w for w in warnings(r, "W708") if "decrease" in w.message]
    assert w.span.line == 4 and w.span.file == "t.knit"
    assert w.notes and "stitches.knit" in str(w.notes[0].span.file)


def test_purls_on_a_full_gauge_tube_warn_at_the_pattern_line():
    r = build(
        "import std.stitches (rib)\ntube t { length: 3  width: 4 }\npattern t { apply rib(1, 1) }\n"
    )
    [w] = warnings(r, "W603")
    assert w.span.line == 3 and "half gauge" in (w.hint or "")


# ---- properties -----------------------------------------------------------------------------

CODES = ["K", "P", "T", "M", "FR1", "FR2", "FL1", "FL2", "BR1", "BL1", "XR+", "XL-", "S"]


@SETTINGS
@given(
    st.lists(
        st.tuples(st.sampled_from(CODES), st.integers(0, 7), st.integers(0, 9)),
        min_size=1,
        max_size=16,
    ),
    st.booleans(),
    st.booleans(),
)
def test_the_instruction_check_only_resets_to_knit_and_is_idempotent(writes, tube, shaped):
    """`check_instructions` never writes an instruction the pattern did not, never touches
    anything but `instr`, and a second run changes nothing (what it keeps is knittable)."""
    width = "[0: 5, 1: 8]" if shaped else "5"
    shape = (
        f"tube s {{ length: 8  width: {width}  gauge: half }}"
        if tube
        else f"sheet s {{ length: 8  width: {width} }}"
    )
    body = "\n".join(f"  set {c} where select({course}, {w})" for c, course, w in writes)
    r = compile_source(f"{shape}\npattern s {{\n{body}\n}}\n", "t.knit", until="skeleton")
    raw = apply_patterns(r.skeleton, build_stitch_graph(r.skeleton, Diagnostics()), Diagnostics())
    checked = check_instructions(raw, Diagnostics())
    changed = checked.instr != raw.instr
    assert (checked.instr[changed] == 0).all()
    for name in ("wale_prev", "wale_next", "cprev", "cnext", "course", "action", "origin"):
        assert np.array_equal(getattr(checked, name), getattr(raw, name)), name
    again = Diagnostics()
    assert np.array_equal(check_instructions(checked, again).instr, checked.instr)
    assert not list(again)


@SETTINGS
@given(
    st.lists(
        st.tuples(st.sampled_from(CODES), st.integers(1, 6), st.integers(0, 9)),
        min_size=1,
        max_size=12,
    ),
    st.booleans(),
)
def test_any_instructions_compile_and_keep_the_stitches(writes, tube):
    body = "\n".join(f"  set {c} where select({course}, {w})" for c, course, w in writes)
    src = (
        "tube s { length: 8  width: 5  gauge: half }\n"
        if tube
        else "sheet s { length: 8  width: 10 }\n"
    ) + f"pattern s {{\n{body}\n}}\n"
    plain = compile_source(src.split("pattern")[0], "t.knit", until="stitch-graph").graph
    r = compile_source(src, "t.knit", until="machine")
    assert not r.diagnostics.has_errors, r.diagnostics.render()
    g = r.graph
    for name in ("node", "course", "cprev", "cnext", "wale_prev", "wale_next", "needle"):
        assert np.array_equal(getattr(g, name), getattr(plain, name)), name
    # every stitch is made exactly once (a knit, tuck or miss of its own), except the
    # cast-on course's, which the cast-on makes
    made = {o.stitch for o in r.program if o.kind in ("knit", "tuck", "miss", "split")}
    later = set(np.nonzero(g.wale_prev[:, 0] >= 0)[0].tolist())
    assert later <= made


ORACLE_DESIGNS = [
    sheet("  set T where select(3, 4)"),
    sheet("  set M where select(3, 4)"),
    *[sheet(f"  set {m} where select(3, 4)") for m in ("FR1", "FL1", "FR2", "FL2", "BR1")],
    sheet("  set FR1 where select(3, 3)\n  set S where select(3, 4)"),
    sheet(CABLE),
    sheet("  set XR- where select(3, 2)\n  set XL+ where select(3, 3)"),
    sheet("  set XR+ where select(3, 2)\n  set P where select(3, 3)\n  set XL- where select(3, 4)"),
    "tube t { length: 6  width: 8  gauge: half }\n"
    "pattern t { set FR1 where select(2, 2, front) or select(2, 2, back) }\n",
    "tube t { length: 6  width: 8 }\n"
    "pattern t { set XR+ where select(2, 2) and side(front)\n"
    "            set XL- where select(2, 3) and side(front) }\n",
    "import std.stitches (rib)\nsheet s { length: 10  width: 8 }\npattern s { apply rib(2, 2) }\n",
    # refused instructions are knitted plain, and what remains must still knit
    sheet("  set FL1 where select(3, 0)\n  set FR1 where select(3, 9)"),
    sheet("  set FR1 where select(3, 3)\n  set FL1 where select(3, 5)"),
    "import std.stitches (tuck_stitch)\nsheet s { length: 10  width: [0: 12, 1: 6] }\n"
    "pattern s {\n  apply tuck_stitch()\n}\n",
    "import std.stitches (rib)\ntube t { length: 3  width: 4 }\npattern t { apply rib(1, 1) }\n",
]
"""The lowerings above, run through the independent machine in one batch (self-contained,
so the test does not depend on which other tests ran)."""


def test_every_lowering_knits_its_design_on_the_independent_machine():
    assert_knits_as_designed([build(src) for src in ORACLE_DESIGNS], names=ORACLE_DESIGNS)
