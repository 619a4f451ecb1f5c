"""Plating: `yarn red { carrier: 5, plating: 6 }` knits a second yarn together with red in
every stitch, both carriers in one carrier set (thesis ch. 3.1.6).

Designs on a sheet and a tube (with stripes and a fair isle band of plated and unplated
yarns) run clean on the independent machine, which makes a loop per yarn of a plated
stitch; the fabric check holds each stitch's loops, the face yarn's first, to the design;
and the DAT writer takes them (a carrier brought in is first used in the set it came in
with).
"""

from __future__ import annotations

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from design_helpers import assert_random_designs_knit, assert_round_trips_through_dat, compiled
from fabric import assert_knits_as_designed
from knitc.driver import compile_source
from knitc.summary import summary_line
from test_stripes import striped

DESIGNS = {
    "sheet": """
yarn main { carrier: 3, plating: 4 }
yarn red { carrier: 5, plating: 6 }
sheet s { length: 10, width: 8 }
pattern s {
  knit red where courses(3:5)
}
""",
    "tube": """
// stripes of a plated yarn and a fair isle band of an unplated one
yarn main { carrier: 3, plating: 4 }
yarn red { carrier: 5, plating: 6 }
yarn navy { carrier: 7 }
tube t { length: 16, width: 8 }
pattern t {
  knit red where courses(3:5)
  knit navy where courses(8:10) and filter(wale % 3 == 0)
}
""",
}


def _compiled(name: str):
    return compiled(DESIGNS[name], name, clean=True)


def test_plated_designs_knit_as_designed_on_the_independent_machine():
    assert_knits_as_designed([_compiled(n) for n in DESIGNS], names=list(DESIGNS))


@pytest.mark.parametrize("name", sorted(DESIGNS))
def test_plated_designs_round_trip_through_dat(name):
    assert_round_trips_through_dat(_compiled(name))


def test_every_stitch_of_a_plated_yarn_is_knitted_with_both_carriers():
    r = _compiled("tube")
    g = r.graph
    assert g is not None and g.yarn is not None
    plating = {0: 4, 1: 6}  # main, red (navy, 2, is not plated)
    for op in r.program.ops:
        if op.phase != "action" or op.stitch < 0 or op.kind != "knit":
            continue
        y = int(g.yarn[op.stitch])
        if y in plating and op.carriers[0] in (3, 5):  # (navy's own passes are its own)
            assert op.carriers == (op.carriers[0], plating[y]), op
    ins = [op.carriers for op in r.program.ops if op.kind == "in"]
    assert (5, 6) in ins  # a yarn brought in with `in` comes in with its plating


def test_the_summary_counts_both_yarns_of_a_plated_pair():
    # main on the hook (3), its plating at its first knit (4), red with its plating (5 6):
    # four lengths of yarn, eight ends
    assert "8 ends to weave in" in summary_line(_compiled("sheet"), "s.k")


def test_a_decrease_stacks_a_plated_stitch_on_the_face_yarn_alone():
    """The stitches a decrease stacks are knitted without the plating yarn: the
    independent machine, which counts a plated stitch as two loops, sees at most three on
    a needle (its hazard is four)."""
    text = "yarn main { carrier: 3, plating: 4 }\nsheet s { length: 12, width: [0: 10, 1: 7] }\n"
    r = compile_source(text, "p.knit", until="machine")
    assert r.program is not None and not r.diagnostics.warning_count, r.diagnostics.render()
    g = r.graph
    assert g is not None
    parents = set(g.wale_prev[(g.wale_prev >= 0).sum(axis=1) == 2].ravel().tolist())
    knits = [o for o in r.program.ops if o.phase == "action" and o.kind == "knit"]
    assert {o.carriers for o in knits if o.stitch in parents} == {(3,)}
    assert (3, 4) in {o.carriers for o in knits if o.stitch not in parents}
    assert_knits_as_designed([r], names=["plated decreases"])


# ---- inlay ------------------------------------------------------------------------------------

INLAYS = {
    "sheet-inlay": """
// an elastic laid into a band of a sheet, held every third needle
yarn elastic { carrier: 7, inlay: 3 }
sheet s { length: 12, width: 10 }
pattern s {
  knit elastic where courses(2:6)
}
""",
    "tube-inlay": """
// an inlay in two bands of a striped tube, resting at the side between them
yarn elastic { carrier: 7, inlay: 2 }
yarn red { carrier: 5 }
tube t { length: 12, width: 8 }
pattern t {
  knit red where courses(4:5)
  knit elastic where courses(1:3) or courses(8:9)
}
""",
}


def _inlaid(name: str):
    return compiled(INLAYS[name], name, clean=True)


def test_inlaid_designs_knit_as_designed_on_the_independent_machine():
    assert_knits_as_designed([_inlaid(n) for n in INLAYS], names=list(INLAYS))


@pytest.mark.parametrize("name", sorted(INLAYS))
def test_inlaid_designs_round_trip_through_dat(name):
    assert_round_trips_through_dat(_inlaid(name))


def test_an_inlay_yarn_only_tucks_every_n_needles_of_its_courses():
    r = _inlaid("sheet-inlay")
    g = r.graph
    assert g is not None and g.inlay is not None
    ops = [op for op in r.program.ops if 7 in op.carriers]
    assert {op.kind for op in ops} <= {"in", "tuck", "miss", "outhook"}  # never a knit
    tucks = [op for op in ops if op.kind == "tuck"]
    assert tucks and all(op.phase == "float_catch" for op in tucks)
    by_course: dict[int, list[int]] = {}
    for op in tucks:
        c = int(g.course[op.stitch]) if op.stitch >= 0 else -1
        by_course.setdefault(c, []).append(op.needle.index)
    assert sorted(by_course) == [2, 3, 4, 5, 6]
    for needles in by_course.values():
        gaps = {abs(b - a) for a, b in zip(needles, needles[1:], strict=False)}
        assert gaps == {3}
    # the stitches keep their own yarn: an inlay does not knit them
    assert not g.yarn.any()
    assert "2 yarns (elastic, main), 4 ends to weave in" in summary_line(r, "s.k")


# ---- the plating pass on random designs -------------------------------------------------------


@st.composite
def plated(draw) -> str:
    """A random striped or fair isle design (`test_stripes.striped`) whose yarns, `main`
    included, are plated on carriers 8 to 10, some of them."""
    text = draw(striped(fair_isle=True))
    lines = text.splitlines()
    plates = iter((8, 9, 10))
    out = []
    for line in lines:
        if line.startswith("yarn ") and draw(st.booleans()):
            line = line.replace(" }", f", plating: {next(plates)} }}", 1)
        out.append(line)
    rest = list(plates)
    if rest and draw(st.booleans()):
        out.insert(0, f"yarn main {{ carrier: 3, plating: {rest[0]} }}")
    return "\n".join(out) + "\n"


@settings(max_examples=40, derandomize=True, deadline=None)
@given(plated())
def test_the_plating_pass_keeps_each_plated_yarn_with_its_partner(text):
    """Every set holds a plating carrier right after its yarn's own, never alone but for
    the parking miss after its `in`; each plating carrier comes in before it knits and
    goes out with its yarn; the program verifies (the verifier of every stage runs)."""
    r = compile_source(text, "plated.knit", until="machine", verify=True)
    assert r.program is not None, text + r.diagnostics.render()
    partner = {}
    for line in text.splitlines():
        if line.startswith("yarn ") and "plating" in line:
            c = int(line.split("carrier: ")[1].split(",")[0].split(" ")[0])
            partner[int(line.split("plating: ")[1].split(" ")[0].rstrip(",}"))] = c
    inside: set[int] = set()
    for op in r.program.ops:
        cs = op.carriers
        assert len(cs) <= 2, op
        if op.kind == "in":
            inside.update(cs)
        elif op.kind in ("out", "outhook"):
            inside.difference_update(cs)
        for i, c in enumerate(cs):
            if (
                c in partner
                and op.kind not in ("in", "out")
                and not (op.kind == "miss" and cs == (c,))
            ):
                assert c in inside, (op, text)
                assert i > 0 and cs[i - 1] == partner[c], (op, text)
    assert not inside & set(partner), text


@st.composite
def inlaid(draw) -> tuple[str, int]:
    """A random striped or fair isle design with an inlay yarn laid over random courses."""
    text = draw(striped(fair_isle=True))
    n = draw(st.integers(1, 5))
    lines = text.splitlines()
    length = int(next(ln for ln in lines if "length:" in ln).split("length: ")[1].split(",")[0])
    a = draw(st.integers(0, length - 1))
    b = draw(st.integers(a, length - 1))
    lines.insert(0, f"yarn elastic {{ carrier: 9, inlay: {n} }}")
    lines.insert(-1, f"  knit elastic where courses({a}:{b})")
    return "\n".join(lines) + "\n", n


@settings(max_examples=40, derandomize=True, deadline=None)
@given(inlaid())
def test_an_inlay_only_tucks_on_its_courses_n_needles_apart(case):
    """The inlay carrier never knits; each tuck rides on a stitch of its courses that has a
    stitch above (which knits it in), at least N needles from the one before in its pass;
    the stitches keep their yarns; every stage verifies."""
    text, n = case
    r = compile_source(text, "inlaid.knit", until="machine", verify=True)
    assert r.program is not None, text + r.diagnostics.render()
    g = r.graph
    assert g is not None and g.inlay is not None
    last: dict[int, tuple[str, int]] = {}  # course -> the bed and needle of its last tuck
    for op in r.program.ops:
        if 9 not in op.carriers:
            continue
        assert op.kind in ("in", "tuck", "miss", "out", "outhook"), (op, text)
        if op.kind == "tuck" and op.phase == "float_catch" and op.stitch >= 0:
            # (a tuck of no stitch is the resting yarn's catch into the edge)
            s = op.stitch
            assert g.inlay[s] > 0 and g.wale_next[s, 0] >= 0, (op, text)
            c = int(g.course[s])
            if c in last and last[c][0] == op.needle.bed:  # (a tube's fold turns the pass)
                assert abs(op.needle.index - last[c][1]) >= n, (op, text)
            last[c] = (op.needle.bed, op.needle.index)


@settings(max_examples=3, derandomize=True, deadline=None)
@given(st.lists(plated(), min_size=3, max_size=3), st.lists(inlaid(), min_size=3, max_size=3))
def test_random_plated_and_inlaid_designs_knit_as_designed(plated_texts, inlaid_cases):
    """Six random designs at a time (one oracle process for all) on the independent
    machine, held to the design by the fabric check."""
    texts = [*plated_texts, *(t for t, _ in inlaid_cases)]
    assert_random_designs_knit(texts, "p")
