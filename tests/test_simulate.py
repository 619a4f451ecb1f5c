"""knitc's machine simulation (`knitc.codegen.simulate`): each rule on small programs, the
findings located at ops/stitches/spans and rendered as diagnostics, and agreement with the
independent oracle on valid and broken programs (the oracle stays the judge).
"""

from __future__ import annotations

from dataclasses import replace

import pytest

from knitc.backends.knitout import op_of_line, read_knitout, write_knitout
from knitc.codegen.machine import MachineProgram, Needle, Op
from knitc.codegen.simulate import CODES, Finding, Simulator, add_to_diagnostics, simulate
from knitc.diagnostics import Diagnostics
from knitc.source import SourceFile
from oracle import OracleReport, run_oracle_on_text
from test_knitout_backend import every_kind, tiny
from test_machine_ir import flat_swatch, half_gauge_tube, row_span
from test_oracle_harness import CAST_ON, FINISH  # one shared six-stitch swatch

# Thresholds of the oracle's own hazard warnings (4 loops on a needle, floats over 20).
ORACLE_LIMITS = {"max_loops": 3, "max_float": 20}


def sim(text: str, **kw) -> list[Finding]:
    return simulate(read_knitout(text), **kw)


def kinds(findings: list[Finding]) -> list[str]:
    return [f.kind for f in findings]


# ---- valid programs ---------------------------------------------------------------------------

SAMPLES = {
    "tiny": tiny,
    "swatch": flat_swatch,
    "tube": half_gauge_tube,
    "every_kind": every_kind,
    "cast_on": lambda: read_knitout(CAST_ON + FINISH),
}


@pytest.mark.parametrize("name", SAMPLES)
def test_valid_programs_have_no_findings(name):
    assert simulate(SAMPLES[name]()) == []
    assert simulate(SAMPLES[name](), **ORACLE_LIMITS) == []


def test_end_state():
    s = Simulator(flat_swatch(drops=False, outhook=False))
    s.run()
    assert s.loops == {Needle("f", k): 1 for k in range(1, 9)}
    assert s.active == (3,) and s.hook == () and s.racking == 0
    s = Simulator(half_gauge_tube())
    assert s.run() == [] and s.loops == {} and s.active == ()


# ---- rules ------------------------------------------------------------------------------------


def test_misaligned_xfer():
    [f] = sim(CAST_ON + "xfer f2 b2\nxfer b2 f1\nrack -1\n" + FINISH)
    assert f.kind == "misaligned_xfer" and f.code == "E801" and f.is_error
    assert f.message == (
        "b2 and f1 are not aligned at racking 0 in `xfer b2 f1` "
        "(they face each other at racking -1)"
    )
    assert sim(CAST_ON + "xfer f2 b2\nrack -1\nxfer b2 f1\nrack 0\n" + FINISH) == []


def test_no_transfer_at_quarter_pitch():
    assert kinds(sim(CAST_ON + "rack 0.25\nxfer f2 b2\nrack 0\nxfer b2 f2\n" + FINISH)) == [
        "misaligned_xfer"
    ]


def test_misaligned_split():
    assert kinds(sim(CAST_ON + "split + f2 b3 3\nxfer b3 f2\n" + FINISH)) == [
        "misaligned_xfer",
        "misaligned_xfer",
    ]


def test_loops_follow_transfers():
    s = Simulator(
        read_knitout(CAST_ON + "xfer f2 b2\nrack -1\nxfer b2 f1\nrack 0\nsplit + f1 b1 3\n")
    )
    s.run()
    assert s.loops[Needle("f", 1)] == 1 and s.loops[Needle("b", 1)] == 2
    assert Needle("f", 2) not in s.loops and Needle("b", 2) not in s.loops


def test_carrier_not_in():
    fs = sim(CAST_ON + "knit + f1 5\nknit + f2 5\n" + FINISH)
    assert kinds(fs) == ["carrier_not_in"]  # once, and no echo as a carrier left in
    assert fs[0].op == 14 and "carrier 5 is used by `knit + f1 5` but is not in" in fs[0].message
    assert kinds(sim(CAST_ON + "out 5\n" + FINISH)) == ["carrier_not_in"]
    # after the carrier goes out, using it again is reported again
    assert kinds(sim(CAST_ON + FINISH + "knit + f1 3\nknit + f2 3\n", check_end=False)) == [
        "carrier_not_in",
        "knit_on_empty",
        "knit_on_empty",
    ]


def test_carrier_state():
    assert kinds(sim(CAST_ON + "in 3\n" + FINISH)) == ["carrier_state"]
    assert kinds(sim(CAST_ON + "in 4\nout 4\n" + FINISH)) == ["carrier_state"]
    assert kinds(sim(CAST_ON + "in 4\nmiss + f9 4\nout 4\n" + FINISH)) == ["carrier_state"]
    assert sim(CAST_ON + "in 4\nknit + f1 4\nout 4\n" + FINISH) == []


@pytest.mark.parametrize(
    "text, message",
    [
        (CAST_ON.replace("releasehook 3\n", "") + FINISH, "still on the inserting hook"),
        (
            "inhook 3\nreleasehook 3\n" + CAST_ON.replace("inhook 3\n", "") + FINISH,
            "before any stitch",
        ),
        (CAST_ON + "releasehook 3\n" + FINISH, "holds nothing"),
        (CAST_ON.replace("releasehook 3", "releasehook 4") + FINISH, "holds carrier(s) 3"),
        (CAST_ON.replace("releasehook 3\n", "inhook 4\n") + FINISH, "still holds carrier(s) 3"),
        (
            CAST_ON.replace("tuck - f6 3\ntuck - f4 3\ntuck - f2 3\n", "")
            + "tuck - f6 3\ntuck - f4 3\ntuck - f2 3\n"
            + FINISH,
            "must go leftward",
        ),
    ],
)
def test_hook_rules(text, message):
    fs = sim(text)
    assert fs and fs[0].kind == "hook" and message in fs[0].message, fs


def test_hook_takes_one_carrier():
    p = MachineProgram()
    p.inhook((4, 5))
    for k in (6, 4, 2):
        p.tuck(-1, Needle("f", k), (4, 5))
    p.releasehook((4, 5))
    p.outhook((4, 5))
    for k in (6, 4, 2):
        p.drop(Needle("f", k))
    fs = simulate(p)
    assert kinds(fs) == ["hook"] * 3 and [f.op for f in fs] == [0, 4, 5]
    assert "takes one carrier at a time" in fs[0].message
    [r] = run_oracle_on_text([write_knitout(p)])  # written as `inhook 4` + `inhook 5`
    assert r.errors[0].type == "Inserting_Hook_In_Use_Error"
    assert op_of_line(p, r.errors[0].line) == 0


def test_hook_never_released():
    fs = sim(CAST_ON.replace("releasehook 3\n", "") + "".join(f"drop f{n}\n" for n in range(1, 7)))
    assert kinds(fs) == ["hook", "carriers_left"]
    assert fs[0].op == 0 and "at the end" in fs[0].message  # points at the inhook


def test_needle_range_and_sliders():
    assert kinds(sim(CAST_ON + "tuck + f541 3\n" + FINISH)) == ["needle_range"]
    assert kinds(sim(CAST_ON + "drop f-1\n" + FINISH)) == ["needle_range"]
    assert sim(CAST_ON + "miss + f540 3\n" + FINISH) == []
    assert kinds(sim(CAST_ON + "knit + fs3 3\n" + FINISH)) == ["needle_use"]
    assert kinds(sim(CAST_ON + "xfer f3 bs3\nxfer bs3 fs3\nxfer bs3 f3\n" + FINISH)) == [
        "needle_use"
    ]
    assert kinds(sim(CAST_ON + "xfer f3 bs3\nsplit + bs3 f3 3\nxfer bs3 f3\n" + FINISH)) == [
        "needle_use"
    ]
    assert sim(CAST_ON + "xfer f3 bs3\nknit + f4 3\nxfer bs3 f3\n" + FINISH) == []


@pytest.mark.parametrize(
    "r, ok",
    [
        (4, True),
        (-4, True),
        (5, False),
        (-4.75, False),
        (0.25, True),
        (-0.75, True),
        (0.5, False),
        (1.3, False),
    ],
)
def test_racking(r, ok):
    fs = sim(CAST_ON + f"rack {r}\nrack 0\n" + FINISH)
    assert (fs == []) == ok and all(f.kind == "racking" for f in fs)


def test_too_many_loops():
    two = CAST_ON + "tuck + f3 3\n"
    assert sim(two + FINISH) == []
    fs = sim(two + "tuck - f3 3\n" + FINISH)
    assert kinds(fs) == ["too_many_loops"] and not fs[0].is_error and fs[0].code == "W801"
    assert fs[0].message == "f3 holds 3 loops (more than 2) after `tuck - f3 3`"
    assert sim(two + "tuck - f3 3\n" + FINISH, max_loops=3) == []
    # reported when the count rises, not again while it stays or falls
    fs = sim(two + "tuck - f3 3\nxfer f3 b3\nxfer b3 f3\ntuck + f3 3\n" + FINISH)
    assert [f.message.split(" after")[0] for f in fs] == [
        "f3 holds 3 loops (more than 2)",
        "b3 holds 3 loops (more than 2)",
        "f3 holds 3 loops (more than 2)",
        "f3 holds 4 loops (more than 2)",
    ]


def test_knit_on_empty():
    fs = sim(CAST_ON + "knit + f7 3\n" + FINISH + "drop f7\n")
    assert kinds(fs) == ["knit_on_empty"] and "empty needle f7" in fs[0].message
    assert sim(CAST_ON + "tuck + f7 3\n" + FINISH + "drop f7\n") == []  # a cast-on tuck


def test_long_float():
    fs = sim(CAST_ON + "tuck + f14 3\n" + FINISH + "drop f14\n")
    assert kinds(fs) == ["long_float"]
    assert fs[0].message == "carrier 3 floats 13 needles from f1 to f14 (more than 12)"
    assert sim(CAST_ON + "tuck + f13 3\n" + FINISH + "drop f13\n") == []
    # misses do not end a float; racking counts (b18 at rack 4 faces f22)
    assert kinds(sim(CAST_ON + "miss + f9 3\ntuck + f14 3\n" + FINISH + "drop f14\n")) == [
        "long_float"
    ]
    fs = sim(CAST_ON + "rack 4\ntuck + b18 3\nrack 0\n" + FINISH + "drop b18\n", max_float=20)
    assert kinds(fs) == ["long_float"] and "floats 21 needles" in fs[0].message


def test_float_follows_a_transferred_loop():
    # the carrier's last loop moves f1 -> b1 -> f5, so the float to f25 is 20 needles, not 24
    text = (
        CAST_ON + "xfer f1 b1\nrack 4\nxfer b1 f5\nrack 0\ntuck + f25 3\n" + FINISH + "drop f25\n"
    )
    assert sim(text, max_float=20) == []
    assert "floats 20 needles from f5" in sim(text)[0].message


# ---- the hazards a technician checks for --------------------------------------------------


def row(d: int, needles, carrier: int = 3) -> str:
    """One row of knits in direction `d` over `needles` (taken in that direction)."""
    ks = sorted(needles, reverse=d < 0)
    return "".join(f"knit {'+' if d > 0 else '-'} f{k} {carrier}\n" for k in ks)


def with_profile(text: str, **limits: int) -> MachineProgram:
    p = read_knitout(text)
    return MachineProgram(replace(p.machine, **limits), list(p.ops))


def test_thresholds_come_from_the_machine_profile():
    text = CAST_ON + "tuck + f3 3\ntuck - f3 3\n" + FINISH
    assert kinds(simulate(read_knitout(text))) == ["too_many_loops"]
    assert simulate(with_profile(text, max_loops=3)) == []
    assert simulate(with_profile(text, max_loops=3), max_loops=2) != []  # a caller's wins
    far = CAST_ON + "tuck + f14 3\n" + FINISH + "drop f14\n"
    assert simulate(with_profile(far, max_float=13)) == []


def test_the_hook_blocks_the_bed_right_of_the_first_loop():
    # CAST_ON's first tuck is on f6 (leftward): the hook is parked in the slot of f7
    early = CAST_ON.replace("releasehook 3\n", "tuck + f7 3\nreleasehook 3\n")
    [f] = sim(early + FINISH + "drop f7\n")
    assert f.kind == "hook" and f.is_error and f.op == 13
    assert f.message.startswith("`tuck + f7 3` uses f7, at or right of the inserting hook")
    assert sim(CAST_ON + "tuck + f7 3\n" + FINISH + "drop f7\n") == []  # once released
    # any carrier, and a miss too; once per hook (the first offending op)
    other = CAST_ON.replace(
        "releasehook 3\n", "in 4\nknit + f5 4\nmiss + f8 4\ntuck + f9 4\nreleasehook 3\n"
    )
    fs = sim(other + "out 4\n" + FINISH + "drop f9\n")
    assert kinds(fs) == ["hook"] and "`miss + f8 4` uses f8" in fs[0].message
    # a back needle is where the racking puts it: b9 at racking -3 sits in slot 6
    racked = CAST_ON.replace("releasehook 3\n", "rack -3\ntuck + b9 3\nrack 0\nreleasehook 3\n")
    assert sim(racked + FINISH + "drop b9\n") == []
    racked = racked.replace("rack -3", "rack -2")
    assert kinds(sim(racked + FINISH + "drop b9\n")) == ["hook"]


def test_carriers_per_op():
    text = CAST_ON + "in 4\nin 5\n" + row(1, range(1, 7), 0).replace(" 0\n", " 3 4 5\n")
    fs = sim(text + "out 4\nout 5\n" + FINISH)
    # once per carrier set, and the op still counts: carriers 4 and 5 did stitch
    assert kinds(fs) == ["carriers_per_op"] and fs[0].is_error and fs[0].code == "E811"
    assert fs[0].message == (
        "`knit + f1 3 4 5` uses 3 carriers in one op; the machine takes at most 2 in a pass"
    )


def slipped(passes: int) -> str:
    """f3 slipped (its neighbours knitted, it not) in `passes` rows, then knitted."""
    rows = [row(1 if r % 2 == 0 else -1, [1, 2, 4, 5, 6]) for r in range(passes)]
    return CAST_ON + "".join(rows) + row(1 if passes % 2 == 0 else -1, range(1, 7)) + FINISH


def test_long_miss():
    assert sim(slipped(6)) == []
    [f] = sim(slipped(7))
    assert f.kind == "long_miss" and f.code == "W804" and not f.is_error
    assert f.message.startswith("`knit - f3 3` knits through the loop on f3, which the yarn")
    assert "in 7 passes in a row (more than 6)" in f.message
    assert simulate(with_profile(slipped(7), max_misses=7)) == []
    # short rows hold their loops outside the rows: the yarn never passes them
    short = "".join(row(1 if r % 2 == 0 else -1, [1, 2, 3, 4]) for r in range(10))
    assert sim(CAST_ON + short + row(1, range(1, 7)) + FINISH) == []


def lace_move(by: int) -> str:
    """The loop of f2 moved `by` needles right (onto f(2+by)), then a yarn-over on f2."""
    xfer = f"xfer f2 b2\nrack {by}\nxfer b2 f{2 + by}\nrack 0\n"
    back = row(-1, range(1, 7)).replace("knit - f2", "tuck - f2")
    return CAST_ON + row(1, range(1, 7)) + xfer + back + FINISH


def test_stretch():
    assert sim(lace_move(3)) == []  # f1's neighbour ends 4 needles away, 3 more than knitted
    [f] = sim(lace_move(4))
    assert f.kind == "stretch" and f.code == "W805" and str(f.op) and not f.is_error
    assert f.message.startswith("`xfer b2 f6` leaves the loop on f6 5 needles from its yarn")
    assert simulate(with_profile(lace_move(4), max_stretch=4)) == []
    # a block moved together keeps its yarn: the whole swatch shifted by 4 is not stretched
    shift = "".join(f"xfer f{k} b{k}\n" for k in range(1, 7)) + "rack 4\n"
    shift += "".join(f"xfer b{k} f{k + 4}\n" for k in range(1, 7)) + "rack 0\n"
    end = "outhook 3\n" + "".join(f"drop f{k}\n" for k in range(5, 11))
    assert sim(CAST_ON + shift + end) == []


def test_stretch_is_counted_in_stitch_widths():
    # half gauge: loops two needles apart, as long as two needles' worth of yarn; a move of
    # f4 by 8 needles (two transfers at racking 4) is 4 stitch widths, by 4 only 2
    evens = range(2, 13, 2)
    start = "inhook 3\n" + "".join(f"tuck - f{k} 3\n" for k in evens[::-1])
    start += row(1, evens) + "releasehook 3\n"
    step = "xfer f{a} b{a}\nrack 4\nxfer b{a} f{b}\nrack 0\n"
    end = row(-1, evens).replace("knit - f4", "tuck - f4") + "outhook 3\n"
    end += "".join(f"drop f{k}\n" for k in evens)
    assert sim(start + step.format(a=4, b=8) + end) == []
    fs = sim(start + step.format(a=4, b=8) + step.format(a=8, b=12) + end)
    [f] = [f for f in fs if f.kind == "stretch"]  # (f8's own loop goes along: W801, W802)
    assert "`xfer b8 f12` leaves the loop on f12 10 needles from its yarn neighbour on f2" in (
        f.message
    )
    assert f.message.endswith(
        "8 more than they were knitted apart (more than 3 stitch widths of 2 needles): "
        "the yarn between them is stretched"
    )


def test_reverse_stitch_with_the_facing_needle_occupied():
    purl = "xfer f3 b3\nknit - b3 3\nxfer b3 f3\n"
    assert sim(CAST_ON + purl + FINISH) == []  # b3 was empty: a plain reverse stitch
    occupied = CAST_ON + "tuck + b3 3\n" + purl + FINISH
    [f] = sim(occupied)
    assert f.kind == "reverse_occupied" and f.code == "W806" and not f.is_error
    assert str(read_knitout(occupied).ops[f.op]) == "xfer b3 f3"
    assert "`knit - b3 3` knitted b3's own loop together with the one moved from f3" in (f.message)
    # a decrease onto the facing needle that stays there is no reverse stitch
    assert sim(CAST_ON + "tuck + b3 3\nxfer f3 b3\nknit - b3 3\n" + FINISH + "drop b3\n") == []
    # nor a lace move through the other bed, moved on after the knit: the loop that came
    # from b2 was knitted on the front (f2), so b2 had no loop of its own to lose
    lace = "xfer f2 b2\nrack -1\nxfer b2 f1\nknit - f1 3\nxfer f1 b2\nrack 0\nxfer b2 f2\n"
    assert kinds(sim(CAST_ON + lace + FINISH)) == []


def test_loose_yarn():
    loose = CAST_ON.replace("inhook 3", "in 3").replace("releasehook 3\n", "")
    [f] = sim(loose + FINISH)
    assert f.kind == "loose_yarn" and f.code == "W807" and f.op == 1
    assert f.message.startswith("carrier 3 came in with `in`, not `inhook`")
    # a yarn that starts on loops may come in loose
    assert sim(CAST_ON + "in 4\n" + row(1, range(1, 7), 4) + "out 4\n" + FINISH) == []


def test_cast_on_knitted_before_the_carrier_turns():
    tucks = "".join(f"tuck - f{k} 3\n" for k in range(6, 0, -1))
    same_way = "inhook 3\n" + tucks + row(-1, range(1, 7)) + "releasehook 3\n" + FINISH
    [f] = sim(same_way)  # once for the pass
    assert f.kind == "cast_on_knit" and f.code == "W808" and f.op == 7
    assert f.message.startswith("`knit - f6 3` knits the cast-on loop on f6 before carrier 3")
    back = "inhook 3\n" + tucks + row(1, range(1, 7)) + "releasehook 3\n" + FINISH
    assert sim(back) == []  # knitted back the other way
    assert sim(CAST_ON + FINISH) == []  # the interlock


def test_loops_and_carriers_left():
    p = flat_swatch(drops=False, outhook=False)
    fs = simulate(p)
    assert kinds(fs) == ["loops_left", "carriers_left"]
    assert fs[0].message == (
        "8 loop(s) left on 8 needle(s) at the end: f1 f2 f3 f4 f5 f6 f7 f8 (drop or bind off)"
    )
    # both point at the last op that touched them: the last knit of the last row
    assert fs[0].op == fs[1].op == len(p) - 1
    assert fs[0].span == row_span("swatch.knit", 7) and fs[0].stitch == 47
    assert simulate(p, check_end=False) == []


def test_malformed_ops_are_reported_and_skipped():
    p = MachineProgram(
        ops=[Op("knit", 1, Needle("f", 1)), Op("xfer", 0, Needle("f", 1)), Op("rack", value="x")]
    )
    assert kinds(simulate(p)) == ["malformed"] * 3
    assert simulate(p)[0].message == "`knit` op: carriers missing"


def test_limit_per_kind():
    text = CAST_ON + "".join(f"knit + f{k} 3\n" for k in range(7, 17)) + FINISH
    fs = sim(text, limit_per_kind=3, check_end=False)
    assert kinds(fs) == ["knit_on_empty"] * 4
    assert fs[-1].op == -1 and fs[-1].message == "... and 7 more `knit_on_empty` finding(s)"


def test_findings_are_located():
    p = half_gauge_tube(shaping_rack=False)
    fs = simulate(p)
    assert kinds(fs) == ["misaligned_xfer", "misaligned_xfer"]
    f = fs[0]
    assert str(p.ops[f.op]) == "xfer b12 f10"
    assert f.span == row_span("tube.knit", 6) and f.stitch == -1
    assert str(f).startswith("error[E801] op ")
    assert f.to_json()["span"] == ["tube.knit", 6, 3, 6, 20]
    assert f.to_json()["code"] == "E801"


def test_as_diagnostics():
    p = MachineProgram()
    src = SourceFile("a.knit", "tube t { length: 10 }\nstart t.bottom\n")
    span = src.span(0, 4)
    p.knit(+1, "f1", 3, stitch=4, span=span)
    diags = Diagnostics()
    diags.add_source(src)
    add_to_diagnostics(simulate(p, check_end=False), p, diags)
    assert diags.render() == (
        "a.knit:1:1: error[E802]: carrier 3 is used by `knit + f1 3` but is not in "
        "(bring it in with `in` or `inhook` first)\n"
        " 1 | tube t { length: 10 }\n"
        "   | ^^^^\n"
        "   = note: machine op 0: `knit + f1 3`, stitch 4\n"
        "a.knit:1:1: warning[W802]: `knit + f1 3` knits on empty needle f1 (nothing holds "
        "the new loop; tuck to cast on)\n"
        " 1 | tube t { length: 10 }\n"
        "   | ^^^^\n"
        "   = note: machine op 0: `knit + f1 3`, stitch 4\n"
    )
    assert diags.error_count == 1 and diags.warning_count == 1


def test_every_code_is_distinct():
    assert len(set(CODES.values())) == len(CODES)
    assert all(c[0] in "EW" and c[1] == "8" for c in CODES.values())


def test_a_long_plain_program_is_clean():
    # 100,000 knits; how fast this is belongs to `make bench` (the tube series), not here.
    p = MachineProgram()
    p.inhook(3)
    for k in range(500, 0, -2):
        p.tuck(-1, Needle("f", k), 3)
    for k in range(1, 501, 2):
        p.tuck(+1, Needle("f", k), 3)
    for r in range(200):  # 100,000 knits
        for k in range(500, 0, -1) if r % 2 == 0 else range(1, 501):
            p.knit(-1 if r % 2 == 0 else 1, Needle("f", k), 3)
        if r == 1:
            p.releasehook(3)
    p.outhook(3)
    for k in range(1, 501):
        p.drop(Needle("f", k))
    assert simulate(p) == []


# ---- agreement with the oracle ------------------------------------------------------------------

# The oracle's findings, in the simulator's words.
ORACLE_ERRORS = {
    "Use_Inactive_Carrier_Error": "carrier_not_in",
    "Misaligned_Xfer": "misaligned_xfer",
    "Hooked_Carrier_Error": "hook",
}
ORACLE_HAZARDS = {
    "Needle_Holds_Too_Many_Loops": "too_many_loops",
    "Long_Float_Warning": "long_float",
    "Knit_on_Empty_Needle_Warning": "knit_on_empty",
}
ORACLE_END = {"loops_left": "loops_left", "carriers_in": "carriers_left", "hook": "hook"}


def oracle_error_kind(r: OracleReport) -> str:
    e = r.errors[0]
    if e.type in ORACLE_ERRORS:
        return ORACLE_ERRORS[e.type]
    if "Cannot Xfer" in e.message:  # the oracle's own alignment check (a ValueError)
        return "misaligned_xfer"
    if "Inserting Hook must start in a leftward direction" in e.message:
        return "hook"
    return f"unmapped {e.type}: {e.message}"


def with_carrier_5(p: MachineProgram, row_line: int) -> MachineProgram:
    """`p` with the knits of one row made by carrier 5, never brought in."""
    q = MachineProgram(p.machine)
    for op in p:
        if op.kind == "knit" and op.span is not None and op.span.line == row_line:
            op = Op(op.kind, op.dir, op.needle, op.needle2, (5,), op.value, op.stitch, op.span)
        q.emit(op)
    return q


def extra(p: MachineProgram, text: str, at: int) -> MachineProgram:
    """`p` with the ops of `text` inserted before op `at` (negative: from the end)."""
    ops = list(p.ops)
    ops[at:at] = read_knitout(text).ops
    return MachineProgram(p.machine, ops)


def swatch_inhook_rightward() -> MachineProgram:
    p = flat_swatch()
    ops = list(p.ops)
    tucks = [i for i, op in enumerate(ops) if op.kind == "tuck"]
    first, second = tucks[:4], tucks[4:]
    ops[tucks[0] : tucks[-1] + 1] = [ops[i] for i in second + first]
    return MachineProgram(p.machine, ops)


BROKEN = {
    # errors: the oracle stops at the first one
    "misaligned_xfer": lambda: half_gauge_tube(shaping_rack=False),
    "carrier_not_in": lambda: with_carrier_5(flat_swatch(), 5),
    "hook_not_released": lambda: flat_swatch(release=False),
    "inhook_rightward": swatch_inhook_rightward,
    # end state
    "loops_left": lambda: flat_swatch(drops=False),
    "carriers_left": lambda: flat_swatch(outhook=False),
    "both_left": lambda: flat_swatch(drops=False, outhook=False),
    # hazards
    "too_many_loops": lambda: extra(flat_swatch(), "tuck - f3 3\ntuck + f3 3\ntuck - f3 3\n", -9),
    "long_float": lambda: extra(flat_swatch(), "tuck - f30 3\ndrop f30\n", -9),
    "knit_on_empty": lambda: extra(flat_swatch(), "knit - f9 3\ndrop f9\n", -9),
}
VALID = {"tiny": tiny, "swatch": flat_swatch, "tube": half_gauge_tube, "every_kind": every_kind}


@pytest.fixture(scope="module")
def agreement():
    programs = {name: make() for name, make in {**VALID, **BROKEN}.items()}
    names = list(programs)
    reports = run_oracle_on_text([write_knitout(programs[n]) for n in names])
    return {n: (programs[n], r) for n, r in zip(names, reports)}


@pytest.mark.parametrize("name", VALID)
def test_agrees_on_valid_programs(agreement, name):
    p, r = agreement[name]
    assert r.problems() == [] and simulate(p, **ORACLE_LIMITS) == [] and simulate(p) == []


@pytest.mark.parametrize(
    "name", ["misaligned_xfer", "carrier_not_in", "hook_not_released", "inhook_rightward"]
)
def test_agrees_on_the_first_error(agreement, name):
    """Same kind of error, at the same op (the oracle's line mapped back to its op)."""
    p, r = agreement[name]
    assert not r.ok and r.errors, r.describe()
    first = next(f for f in simulate(p, **ORACLE_LIMITS) if f.is_error)
    assert first.kind == oracle_error_kind(r)
    assert first.op == op_of_line(p, r.errors[0].line)
    assert first.span is not None  # ... and so at a DSL line


@pytest.mark.parametrize(
    "name",
    ["loops_left", "carriers_left", "both_left", "too_many_loops", "long_float", "knit_on_empty"],
)
def test_agrees_on_end_state_and_hazards(agreement, name):
    p, r = agreement[name]
    assert r.ok and not r.errors
    oracle = {ORACLE_END[k] for k in r.problem_kinds() if k in ORACLE_END}
    oracle |= {ORACLE_HAZARDS[w.type] for w in r.warnings if w.type in ORACLE_HAZARDS}
    found = simulate(p, **ORACLE_LIMITS)
    assert {f.kind for f in found} == oracle != set()
    for f in found:  # hazards at the same op as the oracle's warning
        ws = [w for w in r.warnings if ORACLE_HAZARDS.get(w.type) == f.kind]
        if ws:
            assert f.op == op_of_line(p, ws[0].line)
        if f.kind == "loops_left":
            assert r.loops_left == 8
            assert r.needles_with_loops == tuple(f"f{k}" for k in range(1, 9))
            assert f.message.startswith(f"{r.loops_left} loop(s) left on 8 needle(s)")
        if f.kind == "carriers_left":
            assert r.carriers_active == (3,) and f.message.startswith("carrier 3 ")
