"""The machine-program IR (`knitc.codegen.machine`): needles, ops, the builder, stats, the
verifier and the JSON dump.

`flat_swatch` and `half_gauge_tube` are hand-built valid programs shared with
tests/test_knitout_backend.py and tests/test_simulate.py, which run them through the
independent oracle.
"""

from __future__ import annotations

import json

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from knitc.codegen.machine import (
    KINDS,
    Machine,
    MachineProgram,
    Needle,
    Op,
    aligned,
    estimate_passes,
    format_number,
    op_problems,
    racking_for,
    to_json,
    verify,
)
from knitc.source import Span


def row_span(file: str, line: int) -> Span:
    return Span(file, line, 3, line, 20)


# ---- sample programs ------------------------------------------------------------------------


def flat_swatch(
    n: int = 8,
    rows: int = 6,
    carrier: int = 3,
    *,
    drops: bool = True,
    outhook: bool = True,
    release: bool = True,
) -> MachineProgram:
    """A stockinette swatch on f1..fn: inhook, alternating tuck cast-on (leftward first),
    knit rows, releasehook after two rows, drops, outhook. Row r has span line r + 2 of
    swatch.knit; the stitch of needle k in row r is r * n + k - 1."""
    p = MachineProgram(Machine())
    with p.at(span=row_span("swatch.knit", 1)):
        p.stitch_number(61)
        p.inhook(carrier)
        for k in range(n if n % 2 == 0 else n - 1, 0, -2):
            p.tuck(-1, Needle("f", k), carrier, stitch=k - 1)
        for k in range(1 if n % 2 == 0 else 2, n + 1, 2):
            p.tuck(+1, Needle("f", k), carrier, stitch=k - 1)
    for r in range(rows):
        d = -1 if r % 2 == 0 else +1
        needles = range(n, 0, -1) if d < 0 else range(1, n + 1)
        with p.at(span=row_span("swatch.knit", r + 2)):
            for k in needles:
                p.knit(d, Needle("f", k), carrier, stitch=r * n + k - 1)
        if r == 1 and release:
            p.releasehook(carrier, span=row_span("swatch.knit", 1))
    end = row_span("swatch.knit", rows + 2)
    with p.at(span=end):
        if drops:
            for k in range(1, n + 1):
                p.drop(Needle("f", k))
        if outhook:
            p.outhook(carrier)
    return p


def tube_round(p: MachineProgram, w: int, carrier: int, line: int) -> None:
    """One round of a half-gauge tube of width `w`: back b(2w+1)..b3 leftward, then front
    f2..f(2w) rightward."""
    with p.at(span=row_span("tube.knit", line)):
        for i in range(w, 0, -1):
            p.knit(-1, Needle("b", 2 * i + 1), carrier)
        for i in range(1, w + 1):
            p.knit(+1, Needle("f", 2 * i), carrier)


def half_gauge_tube(w: int = 6, carrier: int = 5, *, shaping_rack: bool = True) -> MachineProgram:
    """A half-gauge tube: front stitches on even needles f2..f(2w), back stitches on odd
    needles b3..b(2w+1), so no two face each other at racking 0. Cast on in four passes,
    two rounds, releasehook, two rounds, then a shaping step that narrows both beds by one
    stitch at the right edge through the empty needles of the other bed (collapse-shift):
    f(2w) -> b(2w) -> f(2w-2) at racking -2 and b(2w+1) -> f(2w+1) -> b(2w-1) at racking 2.
    Two more rounds at width w - 1, outhook, drops. `shaping_rack=False` leaves the racks
    out (a broken program)."""
    p = MachineProgram(Machine())
    with p.at(span=row_span("tube.knit", 1)):
        p.inhook(carrier)
        backs = [2 * i + 1 for i in range(w, 0, -1)]
        fronts = [2 * i for i in range(1, w + 1)]
        for k in backs[0::2]:
            p.tuck(-1, Needle("b", k), carrier)
        for k in fronts[0::2]:
            p.tuck(+1, Needle("f", k), carrier)
        for k in backs[1::2]:
            p.tuck(-1, Needle("b", k), carrier)
        for k in fronts[1::2]:
            p.tuck(+1, Needle("f", k), carrier)
    line = 2
    for _ in range(2):
        tube_round(p, w, carrier, line)
        line += 1
    p.releasehook(carrier, span=row_span("tube.knit", 1))
    for _ in range(2):
        tube_round(p, w, carrier, line)
        line += 1
    with p.at(span=row_span("tube.knit", line)):  # the shaping step
        right_f, right_b = 2 * w, 2 * w + 1
        p.xfer(Needle("f", right_f), Needle("b", right_f))
        if shaping_rack:
            p.rack(-2)
        p.xfer(Needle("b", right_f), Needle("f", right_f - 2))
        if shaping_rack:
            p.rack(0)
        p.xfer(Needle("b", right_b), Needle("f", right_b))
        if shaping_rack:
            p.rack(2)
        p.xfer(Needle("f", right_b), Needle("b", right_b - 2))
        p.rack(0)
    line += 1
    for _ in range(2):
        tube_round(p, w - 1, carrier, line)
        line += 1
    with p.at(span=row_span("tube.knit", line)):
        p.outhook(carrier)
        for i in range(1, w):
            p.drop(Needle("f", 2 * i))
        for i in range(1, w):
            p.drop(Needle("b", 2 * i + 1))
    return p


# ---- needles ----------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "text, bed, index",
    [("f12", "f", 12), ("b0", "b", 0), ("fs3", "fs", 3), ("bs40", "bs", 40), ("f-2", "f", -2)],
)
def test_needle_parse_and_str(text, bed, index):
    n = Needle.parse(text)
    assert n == Needle(bed, index) and str(n) == text


@pytest.mark.parametrize("text", ["x3", "f", "fb3", "F3", "f3.5", ""])
def test_needle_parse_rejects(text):
    with pytest.raises(ValueError, match="not a needle"):
        Needle.parse(text)


def test_needle_helpers():
    f3, b3 = Needle("f", 3), Needle("b", 3)
    assert f3.is_front and not f3.is_back and not f3.is_slider
    assert Needle("bs", 1).is_back and Needle("bs", 1).is_slider
    assert f3.shifted(-2) == Needle("f", 1)
    assert f3.opposite() == b3 and b3.opposite(5) == Needle("f", 5)
    assert f3.opposite(slider=True) == Needle("bs", 3)
    assert b3.position(2) == 5 and f3.position(2) == 3
    assert sorted([Needle("f", 2), Needle("b", 9), Needle("f", 1)])[0] == Needle("b", 9)


def test_racking_convention():
    # research §1.3: at racking R, b(k) faces f(k + R); at R=2, `xfer f3 b1` is legal.
    assert racking_for("f3", "b1") == 2 and racking_for("b1", "f3") == 2
    assert aligned("f3", "b1", 2) and aligned("b1", "f3", 2)
    assert not aligned("f3", "b1", 0) and not aligned("f3", "b1", -2)
    assert aligned("f5", "bs5", 0) and not aligned("f5", "fs5", 0)
    assert not aligned("f1", "b1", 0.25)
    with pytest.raises(ValueError, match="same bed"):
        racking_for("f1", "f2")


def test_format_number():
    assert [format_number(v) for v in (2, -1, 0, 2.0, 0.25, -0.75)] == [
        "2",
        "-1",
        "0",
        "2",
        "0.25",
        "-0.75",
    ]


# ---- ops and the builder --------------------------------------------------------------------


def test_op_text_for_every_kind():
    p = MachineProgram()
    p.in_((4, 5))
    p.inhook(3)
    p.knit(+1, "f3", 3)
    p.tuck(-1, "b4", (3, 4))
    p.split(+1, "f3", "b3", 3)
    p.xfer("f3", "b3")
    p.drop("f3")
    p.miss(-1, "f0", 3)
    p.amiss("b7")
    p.rack(0.25)
    p.stitch_number(61)
    p.emit(Op("stitch", value=(10, 15)))
    p.speed(3)
    p.presser("auto")
    p.pause("check the yarn")
    p.comment("hello")
    p.releasehook(3)
    p.out(4)
    p.outhook((3, 5))
    assert [str(op) for op in p] == [
        "in 4 5",
        "inhook 3",
        "knit + f3 3",
        "tuck - b4 3 4",
        "split + f3 b3 3",
        "xfer f3 b3",
        "drop f3",
        "miss - f0 3",
        "amiss b7",
        "rack 0.25",
        "x-stitch-number 61",
        "stitch 10 15",
        "x-speed-number 3",
        "x-presser-mode auto",
        "pause",
        "; hello",
        "releasehook 3",
        "out 4",
        "outhook 3 5",
    ]
    assert {op.kind for op in p} == set(KINDS)
    assert verify(p) == []


def test_builder_normalises_arguments():
    p = MachineProgram()
    a = p.knit(-1, Needle("f", 3), 3)
    b = p.knit(-1, "f3", [3])
    assert a == b == Op("knit", -1, Needle("f", 3), None, (3,))
    assert a.stitch == -1 and a.span is None


def test_rack_and_settings_are_elided():
    p = MachineProgram()
    assert p.rack(0) is None  # the machine starts at racking 0
    assert p.rack(1) is not None and p.rack(1.0) is None and p.racking == 1
    assert p.rack(1, force=True) is not None
    assert p.stitch_number(61) is not None and p.stitch_number(61) is None
    assert p.stitch_number(62) is not None
    assert p.speed(0) is not None and p.speed(0) is None
    assert p.presser("on") is not None and p.presser("on") is None
    assert [str(op) for op in p] == [
        "rack 1",
        "rack 1",
        "x-stitch-number 61",
        "x-stitch-number 62",
        "x-speed-number 0",
        "x-presser-mode on",
    ]
    assert isinstance(p.ops[0].value, int)  # whole racks print without ".0"


def test_emit_tracks_state():
    p = MachineProgram(ops=[Op("rack", value=-1), Op("knit", 1, Needle("f", 1), None, (3,))])
    assert p.racking == -1 and p.rack(-1) is None
    p.emit(Op("stitch_number", value=5))
    assert p.stitch_number(5) is None


def test_xfer_auto_rack():
    p = MachineProgram()
    p.xfer("f3", "b3", auto_rack=True)
    p.xfer("b3", "f2", auto_rack=True)
    p.xfer("f2", "b3", auto_rack=True)  # still -1: no second rack
    p.xfer("f2", "b2", auto_rack=True)
    assert [str(op) for op in p] == [
        "xfer f3 b3",
        "rack -1",
        "xfer b3 f2",
        "xfer f2 b3",
        "rack 0",
        "xfer f2 b2",
    ]


def test_provenance_context():
    s1, s2, s3 = (row_span("a.knit", i) for i in (1, 2, 3))
    p = MachineProgram()
    with p.at(stitch=7, span=s1):
        k1 = p.knit(+1, "f1", 3)
        with p.at(stitch=8, span=s2):
            k2 = p.knit(+1, "f2", 3)
            k3 = p.knit(+1, "f3", 3, stitch=9)  # explicit wins
            k4 = p.knit(+1, "f4", 3, span=None)  # explicitly none
        r = p.rack(1)
        x = p.xfer("f1", "b0", span=s3)
    k5 = p.knit(+1, "f5", 3)
    assert (k1.stitch, k1.span) == (7, s1)
    assert (k2.stitch, k2.span) == (8, s2)
    assert (k3.stitch, k3.span) == (9, s2)
    assert (k4.stitch, k4.span) == (8, None)
    assert (r.stitch, r.span) == (7, s1) and (x.stitch, x.span) == (7, s3)
    assert (k5.stitch, k5.span) == (-1, None)


def test_ops_are_frozen_and_hashable():
    op = Op("knit", 1, Needle("f", 1), None, (3,), stitch=2, span=row_span("a.knit", 1))
    with pytest.raises(AttributeError):
        op.kind = "tuck"  # type: ignore[misc]
    assert (
        len({op, Op("knit", 1, Needle("f", 1), None, (3,), stitch=2, span=row_span("a.knit", 1))})
        == 1
    )


# ---- stats and JSON ---------------------------------------------------------------------------


def test_stats_of_the_swatch():
    p = flat_swatch()
    s = p.stats()
    assert list(s) == [
        "ops",
        "kinds",
        "passes",
        "carriers",
        "needles",
        "needle_range",
        "racking",
        "stitches",
    ]
    assert s["ops"] == len(p) == 1 + 1 + 8 + 48 + 1 + 8 + 1
    assert s["kinds"] == {
        "inhook": 1,
        "releasehook": 1,
        "outhook": 1,
        "knit": 48,
        "tuck": 8,
        "drop": 8,
        "stitch_number": 1,
    }
    # 2 cast-on passes, 6 rows, 1 drop pass (the oracle agrees: test_knitout_backend)
    assert s["passes"] == 9
    assert s["carriers"] == [3]
    assert s["needles"] == {"f": [1, 8]} and s["needle_range"] == [1, 8]
    assert s["racking"] == [0, 0]
    assert s["stitches"] == 48  # ids 0..47 (the cast-on tucks reuse 0..7)


def test_stats_of_the_tube():
    s = half_gauge_tube().stats()
    assert s["needles"] == {"f": [2, 13], "b": [3, 13]} and s["needle_range"] == [2, 13]
    assert s["racking"] == [-2, 2]
    assert s["kinds"]["xfer"] == 4 and s["kinds"]["rack"] == 4
    # 4 cast-on passes, 2 passes per round for 6 rounds, 4 xfer passes, 1 drop pass
    assert s["passes"] == 4 + 12 + 4 + 1


def test_pass_estimate_rules():
    def passes(*lines: str) -> int:
        from knitc.backends.knitout import read_knitout

        return estimate_passes(read_knitout("\n".join(lines)).ops)

    assert passes("knit + f1 3", "knit + f2 3", "knit + f3 3") == 1
    assert passes("knit + f1 3", "knit + f2 3", "knit - f1 3") == 2  # direction
    assert passes("knit + f1 3", "knit + f2 4") == 2  # carriers
    assert passes("knit + f2 3", "knit + f1 3") == 2  # needle order against direction
    assert passes("knit + f1 3", "rack 1", "knit + f2 3") == 2  # racking
    assert passes("knit + f1 3", "knit + b1 3") == 1  # both beds in one pass
    assert passes("xfer f1 b1", "xfer f2 b2", "xfer b3 f3") == 1
    assert passes("xfer f1 b1", "xfer b1 f1") == 2  # a needle twice
    assert passes("knit + f1 3", "in 4", "knit + f2 3") == 1  # carrier ops do not move
    assert passes("knit + f1 3", "pause", "knit + f2 3") == 2
    assert passes() == 0


def test_to_json_stats_first_and_stable():
    p = half_gauge_tube()
    d = to_json(p)
    assert list(d) == ["stats", "machine", "position", "ops"]
    assert d["machine"] == {
        "name": "SWG091N2",
        "needles": 541,
        "gauge": 15,
        "racking_limit": 4,
        "carriers": 10,
        "max_carriers_per_op": 2,
    }
    assert d["ops"][0] == {"op": "inhook", "carriers": [5], "span": ["tube.knit", 1, 3, 1, 20]}
    knit = next(o for o in d["ops"] if o["op"] == "knit")
    assert knit == {
        "op": "knit",
        "dir": "-",
        "needle": "b13",
        "carriers": [5],
        "span": ["tube.knit", 2, 3, 2, 20],
    }
    assert {"op": "rack", "value": -2, "span": ["tube.knit", 6, 3, 6, 20]} in d["ops"]
    text = json.dumps(d, indent=1, allow_nan=False)
    assert text == json.dumps(to_json(half_gauge_tube()), indent=1, allow_nan=False)


def test_swatch_ops_carry_provenance():
    p = flat_swatch()
    knits = [op for op in p if op.kind == "knit"]
    assert knits[0].stitch == 7 and str(knits[0].needle) == "f8" and knits[0].span.line == 2
    assert knits[-1].stitch == 47 and knits[-1].span.line == 7
    assert all(op.span is not None for op in p)


# ---- verifier ---------------------------------------------------------------------------------


def test_sample_programs_verify():
    assert verify(flat_swatch()) == [] and verify(half_gauge_tube()) == []
    assert verify(flat_swatch()) == []


@pytest.mark.parametrize(
    "op, message",
    [
        (Op("knit", 1, Needle("f", 1)), "carriers missing"),
        (Op("knit", 0, Needle("f", 1), None, (3,)), "direction 0 is not"),
        (Op("knit", 1, None, None, (3,)), "needle missing"),
        (Op("drop", 0, Needle("f", 1), None, (3,)), "carriers not allowed"),
        (Op("drop", 1, Needle("f", 1)), "direction not allowed"),
        (Op("xfer", 0, Needle("f", 1), Needle("fs", 1)), "on the same bed"),
        (Op("xfer", 0, Needle("f", 1)), "second needle missing"),
        (Op("split", 1, Needle("f", 1), Needle("b", 1)), "carriers missing"),
        (Op("knit", 1, Needle("f", 1), None, (1, 2, 3)), "3 carriers in one op"),
        (Op("knit", 1, Needle("f", 1), None, (11,)), "outside 1..10"),
        (Op("knit", 1, Needle("f", 1), None, (3, 3)), "listed twice"),
        (Op("in", 0, None, None, ()), "carriers missing"),
        (Op("in", 0, Needle("f", 1), None, (3,)), "needle not allowed"),
        (Op("rack", value="2"), "is not a number"),
        (Op("rack", value=float("nan")), "is not a number"),
        (Op("stitch_number", value=-1), "non-negative integer"),
        (Op("presser", value="sometimes"), "not on, off or auto"),
        (Op("comment"), "comment text missing"),
        (Op("drop", 0, Needle("f", 1), value=3), "value not allowed"),
        (Op("knit", 1, Needle("x", 1), None, (3,)), "bad needle"),
        (Op("knot", 1, Needle("f", 1), None, (3,)), "unknown kind"),
        (Op("knit", 1, Needle("f", 1), None, (3,), stitch=-5), "not an id"),
    ],
)
def test_verifier_rejects(op, message):
    p = MachineProgram(ops=[op])
    problems = verify(p)
    assert problems and message in problems[0], problems


def test_verifier_rejects_position():
    p = flat_swatch()
    p.position = "Middle"
    assert "position 'Middle'" in verify(p)[0]


# ---- properties -------------------------------------------------------------------------------

needles = st.builds(Needle, st.sampled_from(["f", "b"]), st.integers(0, 40))


@settings(max_examples=60, deadline=None)
@given(
    st.lists(
        st.tuples(
            st.sampled_from(["knit", "tuck", "xfer", "drop", "rack"]),
            needles,
            st.sampled_from([1, -1]),
            st.integers(-4, 4),
        ),
        max_size=40,
    )
)
def test_builder_output_is_well_formed_and_rack_never_redundant(steps):
    p = MachineProgram()
    for kind, n, d, r in steps:
        if kind == "xfer":
            p.xfer(n, n.opposite(n.index + (r if n.is_back else -r)), auto_rack=True)
        elif kind == "rack":
            p.rack(r)
        elif kind == "drop":
            p.drop(n)
        else:
            getattr(p, kind)(d, n, 3)
    assert verify(p) == []
    racks = [op.value for op in p if op.kind == "rack"]
    assert all(a != b for a, b in zip([0] + racks, racks))  # no rack repeats the racking
    assert p.stats()["passes"] <= sum(op.kind != "rack" for op in p)


# ---- op_problems' fast paths against its full check ---------------------------------------

_NEEDLE_VALUES = [
    None,
    Needle("f", 3),
    Needle("bs", 2),
    Needle("b", 540),
    Needle("x", 1),
    Needle("f", True),
    Needle("f", 2.0),
    Needle(["f"], 1),  # type: ignore[arg-type]
    ("f", 3),
    "f3",
]


@settings(max_examples=600, deadline=None)
@given(
    kind=st.sampled_from(["knit", "tuck", "miss", "split", "xfer", "drop", "in", "rack", "bad"]),
    dir=st.sampled_from([-1, 0, 1, 2, True, 1.0]),
    needle=st.sampled_from(_NEEDLE_VALUES),
    needle2=st.sampled_from(_NEEDLE_VALUES),
    carriers=st.sampled_from([(), (1,), (10,), (0,), (11,), (True,), (1, 1), (1, 2), (1, 2, 3)]),
    value=st.sampled_from([None, 1, "x"]),
    stitch=st.sampled_from([-2, -1, 0, 7, True, 1.5]),
    phase=st.sampled_from(["", "action", "bogus", ["action"]]),
    per_op=st.sampled_from([0, 1, 2]),
    carrier_limit=st.booleans(),
)
def test_op_problems_fast_paths_agree_with_the_full_check(
    kind, dir, needle, needle2, carriers, value, stitch, phase, per_op, carrier_limit
):
    from knitc.codegen.machine import _full_problems

    op = Op(kind, dir, needle, needle2, carriers, value, stitch, None, phase)
    m = Machine(max_carriers_per_op=per_op)
    got = op_problems(op, m, carrier_limit=carrier_limit)
    assert got == _full_problems(op, m, carrier_limit)


_OP_VALUES = st.builds(
    Op,
    kind=st.sampled_from(["knit", "tuck", "miss", "split", "xfer", "in", "bad"]),
    dir=st.sampled_from([-1, 0, 1, True]),
    needle=st.sampled_from(_NEEDLE_VALUES),
    needle2=st.sampled_from(_NEEDLE_VALUES[:3]),
    carriers=st.sampled_from([(1,), (1,), (11,), (True,), [1], (1, 2)]),
    value=st.sampled_from([None, None, 1]),
    stitch=st.sampled_from([-2, -1, 0, 7, True]),
    phase=st.sampled_from(["action", "action", "bogus"]),
)


@settings(max_examples=300, deadline=None)
@given(ops=st.lists(_OP_VALUES, max_size=12), per_op=st.sampled_from([0, 1, 2]))
def test_verify_says_what_op_problems_says_of_each_op(ops, per_op):
    """verify remembers the needles and carrier tuples it has checked (by identity, as code
    generation shares them): its report is still op_problems' of every op, in order."""
    m = Machine(max_carriers_per_op=per_op)
    want = [f"op {i} ({op.kind}): {p}" for i, op in enumerate(ops) for p in op_problems(op, m)]
    assert verify(MachineProgram(ops=ops, machine=m)) == want


_PASS_OPS = st.one_of(
    st.tuples(
        st.sampled_from(["knit", "tuck", "miss", "split", "xfer", "drop", "amiss"]),
        st.sampled_from([-1, 1]),
        st.sampled_from(["f", "b", "fs", "bs"]),
        st.integers(0, 6),
        st.sampled_from([(1,), (2,), (1, 2)]),
    ),
    st.tuples(st.just("rack"), st.sampled_from([-1, 0, 1, 0.5])),
    st.tuples(st.sampled_from(["pause", "in", "stitch_number", "comment"])),
)


def _pass_op(t: tuple) -> Op:
    kind = t[0]
    if kind == "rack":
        return Op("rack", value=t[1])
    if len(t) == 1:
        return Op(kind)
    _, d, bed, i, cs = t
    n = Needle(bed, i)
    if kind == "xfer":
        return Op(kind, needle=n, needle2=Needle("b" if bed in ("f", "fs") else "f", i))
    if kind in ("drop", "amiss"):
        return Op(kind, needle=n)
    n2 = Needle("b" if bed in ("f", "fs") else "f", i) if kind == "split" else None
    return Op(kind, d, n, n2, cs)


@settings(max_examples=400, deadline=None)
@given(st.lists(_PASS_OPS, max_size=40))
def test_pass_index_cuts_the_program_into_maximal_carriage_passes(raw):
    """Each pass is a run of ops the carriage makes in one sweep (one class, direction,
    carriers and racking; no needle twice; knits in the order of their direction), and a
    pass ends only where the next op could not join it (or at a pause)."""
    from knitc.codegen.machine import DIRECTED_KINDS, pass_index

    ops = [_pass_op(t) for t in raw]
    index = pass_index(ops)
    assert len(index) == len(ops)
    racking: float = 0
    cur: dict | None = None  # the pass in progress
    paused = False
    last = -1
    for op, p in zip(ops, index, strict=True):
        if op.kind == "rack":
            racking = op.value  # type: ignore[assignment]
        carriage = op.kind in DIRECTED_KINDS or op.kind in ("xfer", "drop", "amiss")
        if not carriage:
            assert p == -1
            paused |= op.kind == "pause"
            continue
        cls = "knit" if op.kind in DIRECTED_KINDS else "xfer" if op.kind == "xfer" else "drop"
        key = (cls, op.dir if cls == "knit" else 0, op.carriers if cls == "knit" else (), racking)
        needles = {op.needle, op.needle2} - {None}
        pos = op.needle.position(racking)
        fits = (
            cur is not None
            and not paused
            and cur["key"] == key
            and not (needles & cur["used"])
            and (cls != "knit" or (pos - cur["pos"]) * op.dir >= 0)
        )
        assert p == (last if fits else last + 1)  # joins the pass exactly when it can
        if not fits:
            cur = {"key": key, "used": set()}
        assert cur is not None
        cur["used"] |= needles
        cur["pos"] = pos
        last, paused = p, False
