"""Stripes: `yarn` declarations and `knit YARN where Q`, through every stage.

Properties on random striped sheets and tubes (derandomized, as every property test here):

- the stripes pass (`shaping.stripes.orient_stripes`) only renumbers: the graph verifies,
  every course keeps its stitches (needle, side, yarn, instruction) and its wales, and a
  flat course of a yarn that knitted before in its node starts at the end nearest to where
  that yarn stopped;
- tracing gives each course one strand of its own yarn; a strand that rested is carried
  (CARRY) no more than its yarn's `carry_up` courses, and the trace verifies.

Then a set of designs, compiled to the end, runs clean on the independent machine and
knits the designed fabric, each loop on its yarn's carrier (`fabric.check_fabric`), and
round-trips through DAT.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, note, settings
from hypothesis import strategies as st

from design_helpers import assert_round_trips_through_dat, compiled
from fabric import assert_knits_as_designed
from knitc.diagnostics import Diagnostics
from knitc.driver import compile_source
from knitc.patterning.pattern import apply_patterns
from knitc.scheduling import trace as tr
from knitc.shaping import stitch_graph as sg
from knitc.shaping.shape import build_stitch_graph
from knitc.shaping.stripes import orient_stripes

# ---- random striped designs -------------------------------------------------------------------

YARNS = ("red", "blue", "gold")


@st.composite
def striped(draw, fair_isle: bool = False) -> str:
    """A sheet or tube (maybe widening) and stripes of 1 to 3 yarns in random runs; with
    `fair_isle`, some runs are bands of two or more yarns per course."""
    kind = draw(st.sampled_from(["sheet", "tube"]))
    length = draw(st.integers(3, 24))
    w0 = draw(st.integers(3, 10))
    w1 = draw(st.sampled_from([w0, w0, w0 + 2, max(w0 - 2, 3)]))
    width = f"{w0}" if w0 == w1 else f"[0: {w0}, 1: {w1}]"
    n_yarns = draw(st.integers(1, 3))
    carry = [draw(st.integers(0, 6)) for _ in range(n_yarns)]
    lines = [
        f"yarn {YARNS[i]} {{ carrier: {5 + i}, carry_up: {carry[i]} }}" for i in range(n_yarns)
    ]
    lines.append(f"{kind} p {{ length: {length}, width: {width} }}")
    lines.append("pattern p {")
    c = 0
    while c < length:
        run = draw(st.integers(1, 5))
        yarn = draw(st.sampled_from(("main",) + YARNS[:n_yarns]))
        where = f"courses({c}:{min(c + run, length) - 1})"
        if yarn != "main":
            # a band of two (or more) yarns; not over increases (E711), decreases are fine
            if fair_isle and w1 <= w0 and draw(st.booleans()):
                k, r = draw(st.integers(2, 5)), draw(st.integers(0, 4))
                where += f" and filter(wale % {k} == {r % k})"
                if kind == "tube" and draw(st.booleans()):  # a band on one face only
                    where += f" and side({draw(st.sampled_from(['front', 'back']))})"
            lines.append(f"  knit {yarn} where {where}")
        c += run
    lines.append("}")
    return "\n".join(lines) + "\n"


def _unoriented(text: str) -> tuple[sg.StitchGraph, sg.StitchGraph, object]:
    """(the patterned graph before the stripes pass, after it, the result)."""
    r = compile_source(text, "stripes.knit", until="trace")
    assert r.graph is not None and r.skeleton is not None, r.diagnostics.render()
    diags = Diagnostics()
    built = build_stitch_graph(r.skeleton, diags)
    assert built is not None
    return apply_patterns(r.skeleton, built, diags), r.graph, r


@settings(max_examples=60, deadline=None)
@given(text=striped())
def test_the_stripes_pass_only_renumbers_and_starts_each_course_at_its_carrier(text):
    note(text)
    before, after, _ = _unoriented(text)
    assert orient_stripes(before).n_stitches == after.n_stitches
    assert sg.verify(after) == []
    assert before.yarn is not None and after.yarn is not None
    # each course keeps its stitches and the same wales between them, by (needle, side)
    for c in range(after.n_courses):
        a, b = before.course_ids(c), after.course_ids(c)
        key = lambda g, ids: sorted(  # noqa: E731
            zip(
                g.needle[ids].tolist(),
                g.side[ids].tolist(),
                g.yarn[ids].tolist(),
                g.instr[ids].tolist(),
                strict=True,
            )
        )
        assert key(before, a) == key(after, b)
    where_b = {
        s: (int(before.course[s]), int(before.needle[s]), int(before.side[s]))
        for s in range(before.n_stitches)
    }
    where_a = {
        s: (int(after.course[s]), int(after.needle[s]), int(after.side[s]))
        for s in range(after.n_stitches)
    }
    wales = lambda g, where: sorted(  # noqa: E731
        (where[s], where[int(p)]) for s in range(g.n_stitches) for p in g.wale_prev[s] if p >= 0
    )
    assert wales(before, where_b) == wales(after, where_a)
    # a flat course starts at the end nearest to where its yarn stopped in the node
    rest: dict[tuple[int, int], int] = {}  # (yarn, node) -> needle where it stopped
    for c in range(after.n_courses):
        ids = after.course_ids(c)
        y, node = int(after.yarn[ids[0]]), int(after.course_node[c])
        at = rest.get((y, node))
        if at is not None and ids.size > 1 and not after.course_circular[c]:
            first, last = int(after.needle[ids[0]]), int(after.needle[ids[-1]])
            assert abs(first - at) <= abs(last - at), f"course {c} starts away from its yarn"
        rest[(y, node)] = int(after.needle[ids[-1]])


@settings(max_examples=60, deadline=None)
@given(text=striped())
def test_each_course_is_one_strand_of_its_yarn_carried_at_most_carry_up(text):
    note(text)
    _, g, r = _unoriented(text)
    t = r.trace
    assert t is not None and g.yarn is not None
    assert tr.verify(g, t) == []
    carry_up = {y.name: y.carry_up for y in r.skeleton.yarn_list}
    strand_yarn: dict[int, int] = {}
    for c in range(g.n_courses):
        ids = g.course_ids(c)
        strands = set(t.yarn[ids].tolist())
        assert len(strands) == 1, f"course {c} is knitted by strands {strands}"
        (s,) = strands
        assert strand_yarn.setdefault(s, int(g.yarn[ids[0]])) == int(g.yarn[ids[0]])
    order = np.lexsort((np.arange(t.n_visits), t.yarn))
    for i, j in zip(order[:-1], order[1:], strict=True):
        if t.yarn[i] == t.yarn[j] and t.flags[j] & tr.CARRY:
            rested = tr.carried(g, int(t.stitch[i]), int(t.stitch[j]))
            name = g.yarn_names[int(g.yarn[t.stitch[j]])]
            assert 0 <= rested <= carry_up[name]


@settings(max_examples=40, deadline=None)
@given(text=striped(fair_isle=True))
def test_random_stripes_and_fair_isle_compile_clean_through_every_verifier(text):
    """Through code generation and knitc's own machine simulation, with every IR's
    verifier run after its stage: no error, and only the float hazard a chart can make."""
    note(text)
    r = compile_source(text, "fair.knit", until="machine", verify=True)
    assert r.program is not None, r.diagnostics.render()
    codes = {d.code for d in r.diagnostics}
    assert not r.diagnostics.has_errors and codes <= {"W803"}, r.diagnostics.render()


@settings(max_examples=3, deadline=None)
@given(texts=st.lists(striped(fair_isle=True), min_size=8, max_size=8))
def test_random_stripes_and_fair_isle_knit_as_designed(texts):
    """Eight random designs at a time (one oracle process for all): each runs clean on the
    independent machine and knits its design, every loop on its yarn's carrier."""
    results = []
    for text in texts:
        note(text)
        r = compile_source(text, "fair.knit", until="machine")
        assert r.program is not None, r.diagnostics.render()
        results.append(r)
    assert_knits_as_designed(results, names=[f"design {i}" for i in range(len(results))])


# ---- designs through the whole pipeline ---------------------------------------------------------

DESIGNS = {
    # a sheet whose stripes leave each yarn at the far side: courses are turned
    "sheet-odd": """
yarn red { carrier: 5 }
sheet s { length: 24, width: 12 }
pattern s {
  knit red where courses(3:5)
  knit red where courses(9)
  knit red where courses(15:19)
}
""",
    # a tube: three yarns, one resting past its carry_up (ended and brought in again)
    "tube-three": """
yarn red { carrier: 5 }
yarn blue { carrier: 6, carry_up: 2 }
tube t { length: 30, width: 10 }
pattern t {
  knit red where courses(4:7)
  knit blue where courses(8:9)
  knit red where courses(10:11)
  knit blue where courses(18:22)
}
""",
    # a widening sheet, stripes over its increases
    "sheet-shaped": """
yarn red { carrier: 5 }
sheet s { length: 30, width: [0: 10, 1: 16] }
pattern s {
  knit red where courses(0.2:0.3)
  knit red where courses(0.5:0.55)
}
""",
    # a ribbed brim into a body: `main` rests across the connection
    "brim-body": """
import std.stitches (rib)
yarn coral { carrier: 5 }
tube brim { length: 6, width: 10, gauge: half }
tube body { length: 16, width: 10 }
brim.top -> body.bottom
pattern brim {
  apply rib(1, 1)
}
pattern body {
  knit coral where courses(0:3)
  knit coral where courses(8:11)
}
""",
    # fair isle on a sheet: a checked band of two yarns per course
    "fair-sheet": """
yarn red { carrier: 5 }
sheet s { length: 20, width: 16 }
pattern s {
  knit red where courses(4:9) and filter((wale + course) % 4 == 0)
}
""",
    # fair isle on a tube, two bands of different yarns, then a stripe of one of them
    "fair-tube": """
yarn red { carrier: 5 }
yarn blue { carrier: 6 }
tube t { length: 24, width: 12 }
pattern t {
  knit red where courses(4:9) and filter(wale % 3 == 0)
  knit blue where courses(12:15) and filter(wale % 4 == 1)
  knit red where courses(16:19)
}
""",
    # fair isle over a narrowing tube (the decreases are transfers between courses), three
    # yarns in some courses, and a stripe of a yarn while it also floats in fair isle
    "fair-narrowing": """
yarn red { carrier: 5 }
yarn gold { carrier: 7 }
tube t { length: 30, width: [0: 16, 1: 10] }
pattern t {
  knit red where courses(3:12) and filter(wale % 4 == 0)
  knit gold where courses(6:9) and filter(wale % 4 == 2)
  knit red where courses(14:15)
  knit red where courses(17:20) and filter(wale % 2 == 0)
}
""",
    # a colour chart of three yarns as one drawn layer
    "colour-chart": '''
yarn red { carrier: 5 }
yarn navy { carrier: 6 }
tube t { length: 24, width: 16 }
pattern t {
  tile """
    red  .    .    navy
    .    red  navy .
    .    navy red  .
    navy .    .    red
  """ where courses(6:13)
}
''',
    # long floats caught by tucks, on a sheet and on a tube
    "fair-tucked": """
yarn red { carrier: 5, tuck_every: 6 }
sheet s { length: 12, width: 60 }
pattern s {
  knit red where courses(4:7) and filter(wale % 30 == 5)
}
""",
    "fair-tucked-tube": """
yarn red { carrier: 5, tuck_every: 5 }
tube t { length: 14, width: 30 }
pattern t {
  knit red where courses(3:8) and filter(wale % 15 == 2)
}
""",
    # `main` on a carrier of its own, another yarn on the next free one (the machine's)
    "declared-main": """
machine { carriers: [3] }
yarn main { carrier: 4 }
yarn red {}
sheet s { length: 12, width: 8 }
pattern s {
  knit red where courses(4:7)
}
""",
}


def _compiled(name: str):
    return compiled(DESIGNS[name], name)


def test_striped_designs_knit_as_designed_on_the_independent_machine():
    results = [_compiled(n) for n in DESIGNS]
    assert_knits_as_designed(results, names=list(DESIGNS))


@pytest.mark.parametrize("name", sorted(DESIGNS))
def test_striped_designs_round_trip_through_dat(name):
    assert_round_trips_through_dat(_compiled(name))


def test_yarns_are_brought_in_once_and_carried_between_their_stripes():
    from knitc.backends.knitout import write_knitout

    text = write_knitout(_compiled("brim-body").program)
    ins = [
        line.split(";")[0].strip()
        for line in text.splitlines()
        if line.split(" ")[0] in ("in", "inhook", "out", "outhook")
    ]
    assert ins == ["inhook 3", "in 5", "outhook 5", "outhook 3"]


def test_a_yarn_resting_longer_than_carry_up_is_ended_and_brought_in_again():
    r = _compiled("tube-three")
    assert r.trace is not None and r.graph is not None
    blue = r.graph.yarn_names.index("blue")
    strands = {int(s) for s in r.trace.yarn[r.graph.yarn[r.trace.stitch] == blue].tolist()}
    assert len(strands) == 2  # rested 8 courses, carry_up 2


def test_declared_carriers_are_used_and_main_may_declare_its_own():
    from knitc.backends.knitout import write_knitout

    text = write_knitout(_compiled("declared-main").program)
    assert "inhook 4" in text and "\nin 3 " in text


def test_a_one_yarn_design_dumps_no_yarns():
    from knitc.driver import emit_json

    r = compile_source("sheet s { length: 3, width: 3 }\n", "one.knit", until="stitch-graph")
    assert "yarn" not in str(emit_json(r, "stitch-graph"))
    assert "yarns" not in str(emit_json(r, "skeleton"))


def test_the_summary_counts_the_ends_to_weave_in():
    from knitc.summary import summary_line

    line = summary_line(_compiled("tube-three"), "t.k")
    assert "3 yarns (blue, main, red), 8 ends to weave in" in line  # blue brought in twice


def test_a_fair_isle_yarn_knits_its_stitches_and_floats_behind_the_others():
    from knitc.codegen.machine import Needle

    r = _compiled("fair-sheet")
    g, prog = r.graph, r.program
    assert g is not None and g.yarn is not None and prog is not None
    red = set(np.nonzero(g.yarn == g.yarn_names.index("red"))[0].tolist())
    knits = [op for op in prog.ops if op.kind == "knit" and op.phase == "action"]
    by_stitch = {op.stitch: op for op in knits}
    for s in range(g.n_stitches):
        assert by_stitch[s].carriers == ((5,) if s in red else (3,))
    # each red pass knits only red stitches, in the course's direction, skipping the others
    course = g.course[min(red)]
    passes = [op for op in knits if g.course[op.stitch] == course]
    red_pass = [op for op in passes if op.carriers == (5,)]
    assert {op.dir for op in red_pass} == {by_stitch[int(g.course_start[course])].dir}
    assert all(isinstance(op.needle, Needle) for op in red_pass)
    assert passes.index(red_pass[0]) > passes.index(
        next(op for op in passes if op.carriers == (3,))
    )


def test_a_long_fair_isle_float_is_a_warning_at_the_knit_statement():
    text = """
yarn red { carrier: 5 }
sheet s { length: 12, width: 60 }
pattern s {
  knit red where courses(4:7) and filter(wale % 30 == 5)
}
"""
    r = compile_source(text, "long.knit", until="machine")
    floats = [d for d in r.diagnostics if d.code == "W803"]
    assert floats and all(d.span is not None and d.span.line == 5 for d in floats)


def test_tuck_every_catches_long_floats_and_silences_the_warning():
    r = _compiled("fair-tucked")
    assert not [d for d in r.diagnostics if d.code == "W803"]
    assert r.program is not None
    catches = [op for op in r.program.ops if op.phase == "float_catch"]
    assert catches and all(op.kind == "tuck" and op.carriers == (5,) for op in catches)
    # a float of 30 needles caught every 6: four tucks per course of the band
    assert len(catches) == 4 * 4


def test_a_colour_chart_gives_each_cell_its_yarn():
    r = _compiled("colour-chart")
    g = r.graph
    assert g is not None and g.yarn is not None
    names = [g.yarn_names[y] for y in g.yarn.tolist()]
    first = g.course_ids(6)
    assert [names[s] for s in first[:4]] == ["navy", "main", "main", "red"]  # the last row
    assert {names[s] for s in g.course_ids(5)} == {"main"}


def test_a_colour_image_knits_each_pixel_with_the_nearest_yarn(tmp_path):
    """`stretch img(...)`: each pixel's yarn is the one whose colour is nearest (main
    white); on one face of a tube, where a bed's part of a course is all another yarn."""
    from PIL import Image

    im = Image.new("RGBA", (8, 6), (250, 250, 250, 255))
    for x in range(8):
        im.putpixel((x, 0), (200, 30, 30, 255))  # the top row: red
        im.putpixel((x, 5), (20, 20, 120, 255))  # the bottom row: navy
    im.putpixel((3, 5), (0, 0, 0, 0))  # transparent: the stitch keeps its yarn
    im.save(tmp_path / "motif.png")
    text = """
yarn red { carrier: 5, colour: "#c0392b" }
yarn navy { carrier: 6, colour: "#000080" }
tube t { length: 20, width: 8 }
pattern t {
  stretch img("motif.png") where courses(5:10) and side(front)
}
"""
    path = tmp_path / "img.knit"
    path.write_text(text)
    r = compile_source(text, str(path), until="machine")
    assert r.program is not None and not r.diagnostics.has_errors, r.diagnostics.render()
    g = r.graph
    assert g is not None and g.yarn is not None
    names = g.yarn_names
    front = lambda c: [names[y] for y in g.yarn[g.course_ids(c)][:8].tolist()]  # noqa: E731
    assert front(10) == ["red"] * 8
    assert front(5) == ["navy"] * 3 + ["main"] + ["navy"] * 4
    assert set(front(7)) == {"main"}
    assert_knits_as_designed([r], names=["img"])


def test_a_yarn_resting_at_the_side_is_caught_into_the_edge_every_few_courses():
    """`main` rests 8 courses in tube-three while red and blue knit: after 4 it tucks on
    the edge stitch beside it and goes back out (a miss), and again after 4 more; a yarn
    resting fewer courses is not caught."""
    from knitc.codegen.generate import CATCH_RESTING_EVERY

    r = _compiled("tube-three")
    assert r.program is not None and r.graph is not None
    ops = r.program.ops
    catches = [i for i, op in enumerate(ops) if op.phase == "float_catch" and op.kind == "tuck"]
    by_carrier: dict[int, int] = {}
    for i in catches:
        (c,) = ops[i].carriers
        by_carrier[c] = by_carrier.get(c, 0) + 1
        after = ops[i + 1]
        assert after.kind == "miss" and after.carriers == (c,) and after.dir == -ops[i].dir
    assert by_carrier.get(3, 0) == 8 // CATCH_RESTING_EVERY  # main, 8 courses of rest
    assert 5 not in by_carrier  # red rests 2 courses between its stripes


def test_the_tracers_default_carry_is_the_yarn_propertys():
    from knitc.frontend.skeleton import YARN_PROPS
    from knitc.scheduling.tracing import DEFAULT_CARRY_UP

    assert DEFAULT_CARRY_UP == YARN_PROPS["carry_up"].default
