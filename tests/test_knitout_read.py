"""The Knitout reader (`knitc.backends.knitout_read`): every fixture and every shipped design
reads back to the ops that were written, the header lands in the program, each op keeps its
line, and each rule of the spec rejects a bad line with a located, coded error.

`machine_programs()` (also used by test_dat_read) draws random programs that a Shima machine
can run: carriers come in before they are used and go out at the end, the hook is released
after a stitch, transfers are aligned, racking is whole or quarter pitch.
"""

from __future__ import annotations

from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from knitc.backends.knitout import write_knitout
from knitc.backends.knitout_read import (
    KnitoutErrors,
    knitout_diagnostics,
    parse_knitout,
)
from knitc.codegen.machine import CARRIER_KINDS, Machine, MachineProgram, Needle, Op, verify
from knitc.driver import compile_source

ROOT = Path(__file__).resolve().parent.parent
FIXTURES = sorted((ROOT / "tests" / "fixtures" / "dat").glob("*.k"))
HEADER = ";!knitout-2\n;;Machine: SWG091N2\n;;Gauge: 15\n;;Carriers: 1 2 3 4 5 6 7 8 9 10\n"


def shape(prog: MachineProgram) -> list[tuple]:
    """The ops without provenance: what a round trip must keep."""
    return [(o.kind, o.dir, o.needle, o.needle2, o.carriers, o.value) for o in prog.ops]


def errors_of(text: str) -> list:
    with pytest.raises(KnitoutErrors) as exc:
        parse_knitout(text, "bad.k")
    return exc.value.errors


# ---- random machine programs ----------------------------------------------------------------

STITCH_PAIRS = ((10, 15), (-10, 10), (25, 65))
RACKINGS = (0, 1, -1, 2, -2, 0.25, -0.75)


@st.composite
def machine_programs(draw, max_steps: int = 40, width: int = 14) -> MachineProgram:
    """A random program a Shima machine (and its DAT) can take. Needles stay at index >= 3 so
    no slot is negative at racking >= -2 (the converter orders kicks to negative slots
    differently, research §2.6.4); at quarter pitch misses stay on the front bed (a front and
    a back miss in one column share the soft-miss colour, which reads back as nothing)."""
    ops: list[Op] = []
    active: dict[int, bool] = {}  # carrier in action -> has stitched
    hook: int | None = None
    hook_stitched = False
    racking: float = 0

    def pair(i: int) -> tuple[Needle, Needle]:
        r = int(racking)
        return (
            (Needle("f", i), Needle("b", i - r))
            if draw(st.booleans())
            else (Needle("b", i), Needle("f", i + r))
        )

    for _ in range(draw(st.integers(1, max_steps))):
        step = draw(
            st.sampled_from(
                (
                    "in",
                    "stitch",
                    "stitch",
                    "stitch",
                    "xfer",
                    "rack",
                    "setting",
                    "drop",
                    "split",
                    "release",
                    "out",
                    "pause",
                    "miss",
                    "comment",
                )
            )
        )
        quarter = racking != int(racking)
        if step == "in" and len(active) < 3:
            c = draw(st.sampled_from([c for c in range(1, 11) if c not in active]))
            kind = "inhook" if hook is None and draw(st.booleans()) else "in"
            ops.append(Op(kind, carriers=(c,)))
            active[c] = False
            if kind == "inhook":
                hook, hook_stitched = c, False
        elif step in ("stitch", "miss") and active:
            choices = [(c,) for c in active]
            stitched = [c for c, s in active.items() if s]
            if len(stitched) >= 2:
                choices.append(tuple(draw(st.permutations(stitched))[:2]))
            cs = draw(st.sampled_from(choices))
            d = draw(st.sampled_from((1, -1)))
            kind = "miss" if step == "miss" else draw(st.sampled_from(("knit", "tuck")))
            start = draw(st.integers(8, width + 8))
            for j in range(draw(st.integers(1, 6))):
                bed = "f" if kind == "miss" and quarter else draw(st.sampled_from("fb"))
                ops.append(Op(kind, d, Needle(bed, start + d * j), None, cs))
            for c in cs:
                active[c] = True
            hook_stitched = hook_stitched or hook in cs
        elif step == "xfer" and not quarter:
            for _ in range(draw(st.integers(1, 5))):
                a, b = pair(draw(st.integers(3, width)))
                slider = draw(st.sampled_from((None, None, "to", "from")))
                if slider == "to":
                    b = Needle(b.bed + "s", b.index)
                elif slider == "from":
                    a = Needle(a.bed + "s", a.index)
                ops.append(Op("xfer", needle=a, needle2=b))
        elif step == "split" and not quarter and any(active.values()):
            c = draw(st.sampled_from([c for c, s in active.items() if s]))
            a, b = pair(draw(st.integers(3, width)))
            ops.append(Op("split", draw(st.sampled_from((1, -1))), a, b, (c,)))
        elif step == "rack":
            r = draw(st.sampled_from(RACKINGS))
            if r != racking:
                ops.append(Op("rack", value=r))
                racking = r
        elif step == "setting":
            kind = draw(st.sampled_from(("stitch_number", "speed", "presser", "stitch")))
            value = {
                "stitch_number": st.integers(0, 100),
                "speed": st.integers(0, 15),
                "presser": st.sampled_from(("on", "off")),
                "stitch": st.sampled_from(STITCH_PAIRS),
            }[kind]
            ops.append(Op(kind, value=draw(value)))
        elif step == "drop":
            for _ in range(draw(st.integers(1, 4))):
                n = Needle(draw(st.sampled_from("fb")), draw(st.integers(3, width)))
                ops.append(Op(draw(st.sampled_from(("drop", "amiss"))), needle=n))
        elif step == "release" and hook is not None and hook_stitched:
            ops.append(Op("releasehook", carriers=(hook,)))
            hook = None
        elif step == "out":
            ready = [c for c, s in active.items() if s and c != hook]
            if ready:
                c = draw(st.sampled_from(ready))
                kind = draw(st.sampled_from(("out", "outhook"))) if hook is None else "out"
                ops.append(Op(kind, carriers=(c,)))
                del active[c]
        elif step == "pause":
            ops.append(Op("pause"))
        elif step == "comment":
            ops.append(Op("comment", value=draw(st.sampled_from(("row 1", "", "a; b")))))
    if hook is not None:
        if not hook_stitched:
            ops.append(Op("knit", -1, Needle("f", 3), None, (hook,)))
            active[hook] = True
        ops.append(Op("releasehook", carriers=(hook,)))
    for c, stitched in list(active.items()):
        if not stitched:
            ops.append(Op("knit", -1, Needle("f", 3), None, (c,)))
        ops.append(Op("out", carriers=(c,)))
    if not any(o.needle is not None for o in ops):
        ops.append(Op("drop", needle=Needle("f", 3)))
    return MachineProgram(Machine(), ops)


# ---- reading what was written ----------------------------------------------------------------


@pytest.mark.parametrize("path", FIXTURES, ids=lambda p: p.stem)
def test_every_fixture_reads_and_writes_back_to_the_same_ops(path):
    text = path.read_text(encoding="utf-8")
    warnings: list = []
    prog = parse_knitout(text, str(path), warnings=warnings)
    assert warnings == [] and verify(prog) == []
    lines = text.splitlines()
    instructions = [n for n, line in enumerate(lines, 1) if line.split(";")[0].strip()]
    ops = [o for o in prog.ops if o.kind != "comment"]
    assert [o.span.line for o in ops] == instructions  # one op per instruction line, in order
    for op in ops:
        assert text[op.span.start : op.span.end] == lines[op.span.line - 1].split(";")[0].strip()
    again = parse_knitout(write_knitout(prog, one_carrier_per_line=False), "again.k")
    assert shape(again) == shape(prog)
    assert (again.position, again.width) == (prog.position, prog.width)


def test_headers_land_in_the_program():
    prog = parse_knitout((ROOT / "tests/fixtures/dat/pos_center.k").read_text(), "c.k")
    assert (prog.position, prog.width) == ("Center", 250)
    assert (
        parse_knitout((ROOT / "tests/fixtures/dat/pos_keep.k").read_text(), "k.k").position
        == "Keep"
    )
    prog = parse_knitout(
        ";!knitout-2\n;;Machine: SWG061N2\n;;Gauge: 7\n;;Carriers: 1 2 3\n"
        ";;Yarn-1: 50-50 Rust\n;;X-Note: ignored\n",
        "h.k",
    )
    assert prog.machine.name == "SWG061N2" and prog.machine.gauge == 7
    assert prog.machine.carriers == 3 and prog.position == "Center" and prog.width is None
    assert ";;Width: 250" in write_knitout(MachineProgram(Machine(), width=250))


@pytest.mark.parametrize("name", ["sheet", "tube", "sock"])
def test_compiled_designs_read_back_to_the_ops_knitc_wrote(name):
    path = ROOT / "examples" / f"{name}.knit"
    prog = compile_source(path.read_text(encoding="utf-8"), str(path), until="machine").program
    assert prog is not None
    for one_per_line in (False, True):
        text = write_knitout(prog, one_carrier_per_line=one_per_line)
        back = parse_knitout(text, f"{name}.k")
        expected = []
        for k, d, n, n2, cs, v in shape(prog):  # `in 3 4` is written `in 3` + `in 4`
            split = one_per_line and k in CARRIER_KINDS
            expected += [(k, d, n, n2, (c,), v) for c in cs] if split else [(k, d, n, n2, cs, v)]
        assert shape(back) == expected


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(machine_programs())
def test_random_programs_print_and_read_back_equal(prog):
    text = write_knitout(prog, one_carrier_per_line=False)
    back = parse_knitout(text, "random.k")
    assert shape(back) == shape(prog)
    lines = text.split("\n")
    assert all(
        lines[o.span.line - 1].startswith(str(o).split(" ;")[0])
        for o in back.ops
        if o.kind != "comment"
    )


def test_synonyms_and_extensions_map_onto_the_ir():
    text = (
        HEADER
        + """\
in 3
knit - f2 3
knit + f1
tuck - b4
split + f1 b1
split - f2 b2 3
rack -0.75
stitch 10 15
x-stitch-number 61
x-speed-number 3
x-presser-mode auto
pause ; before the next pass
tuck + fs-2 3
out 3
"""
    )
    prog = parse_knitout(text, "s.k")
    assert [str(o) for o in prog.ops] == [
        "in 3",
        "knit - f2 3",
        "drop f1",
        "amiss b4",
        "xfer f1 b1",
        "split - f2 b2 3",
        "rack -0.75",
        "stitch 10 15",
        "x-stitch-number 61",
        "x-speed-number 3",
        "x-presser-mode auto",
        "pause",
        "tuck + fs-2 3",
        "out 3",
    ]
    assert prog.ops[6].value == -0.75 and prog.ops[7].value == (10, 15)
    assert verify(prog) == []


def test_comments_are_kept_as_ops_or_dropped():
    text = HEADER + "; a note\n;;not a header\nin 3 ; trailing\n;\nout 3\n"
    with_comments = parse_knitout(text, "c.k")
    assert [(o.kind, o.value) for o in with_comments.ops] == [
        ("comment", "a note"),
        ("comment", ";not a header"),
        ("in", None),
        ("comment", ""),
        ("out", None),
    ]
    assert [o.kind for o in parse_knitout(text, "c.k", comments=False).ops] == ["in", "out"]


def test_carrier_names_are_numbered_by_their_place_in_the_header():
    warnings: list = []
    prog = parse_knitout(
        ";!knitout-2\n;;Carriers: A B C\nin C\nknit + f1 C\nout C\n", "n.k", warnings=warnings
    )
    assert [o.carriers for o in prog.ops] == [(3,), (3,), (3,)]
    assert prog.machine.carriers == 3
    assert [w.code for w in warnings] == ["W910"] and "C -> 3" in warnings[0].message
    multi = parse_knitout(";!knitout-2\n;;Carriers: 1,2;3,4 5\nin 5\n", "m.k", warnings=[])
    assert multi.machine.carriers == 5 and multi.ops[0].carriers == (5,)


def test_warnings_for_what_the_spec_says_to_warn_about():
    warnings: list = []
    text = ";!knitout-9\r\n;;Foo: 1\r\nin 1\r\nx-vis-color #ff0000 1\r\nknit + f1 1\r\nout 1\r\n"
    prog = parse_knitout(text, "w.k", warnings=warnings)
    assert [str(o) for o in prog.ops] == ["in 1", "knit + f1 1", "out 1"]
    assert prog.ops[1].span.line == 5 and text[prog.ops[1].span.start :][:11] == "knit + f1 1"
    messages = " | ".join(w.message for w in warnings)
    assert all(w.code == "W910" and w.warning for w in warnings)
    for part in ("CRLF", "version 9", "`;;Foo:`", "Carriers", "x-vis-color"):
        assert part in messages


# ---- located errors, one per rule -------------------------------------------------------------

BAD = [
    # (instruction line, code, column, end column, part of the message)
    ("knot + f1 3", "E911", 1, 5, "unknown operation `knot`"),
    ("knit * f1 3", "E912", 6, 7, "direction must be `+` or `-`"),
    ("knit + f1 x", "E914", 11, 12, "carrier `x` is not declared"),
    ("knit +", "E912", 1, 7, "a needle is missing"),
    ("knit", "E912", 1, 5, "needs a direction"),
    ("knit + g1 3", "E913", 8, 10, "`g1` is not a needle"),
    ("knit + f1.5 3", "E913", 8, 12, "is not a needle"),
    ("knit + f1 11", "E914", 11, 13, "carrier `11` is not declared"),
    ("knit + f1 3 3", "E914", 13, 14, "listed twice"),
    ("knit + f1 4", "E915", 11, 12, "carrier 4 is used but is not in"),
    ("miss + f1", "E914", 1, 10, "`miss` needs carriers"),
    ("xfer f1 b1 3", "E912", 12, 13, "`xfer` takes 2 arguments"),
    ("xfer f1 f2", "E916", 9, 11, "on the same bed"),
    ("xfer fs1 bs1", "E916", 10, 13, "a slider to a slider"),
    ("xfer f1 b2", "E916", 9, 11, "not aligned at racking 0"),
    ("split + f1 b3 3", "E916", 12, 14, "not aligned"),
    ("drop f1 3", "E912", 9, 10, "`drop` takes 1 argument"),
    ("amiss", "E912", 1, 6, "`amiss` takes 1 argument"),
    ("rack", "E912", 1, 5, "`rack` takes 1 argument"),
    ("rack 1 2", "E912", 8, 9, "`rack` takes 1 argument"),
    ("rack one", "E912", 6, 9, "racking must be a number"),
    ("rack 1e3", "E912", 6, 9, "racking must be a number"),
    ("stitch 10", "E912", 1, 10, "`stitch` takes 2 arguments"),
    ("stitch a 10", "E912", 8, 9, "stitch values must be numbers"),
    ("x-stitch-number -1", "E912", 17, 19, "non-negative integer"),
    ("x-speed-number 1.5", "E912", 16, 19, "non-negative integer"),
    ("x-presser-mode maybe", "E912", 16, 21, "on, off or auto"),
    ("pause now", "E912", 7, 10, "`pause` takes 0 arguments"),
    ("in", "E914", 1, 3, "needs at least one carrier"),
    ("in 3", "E915", 4, 5, "carrier 3 is already in"),
    ("out 4", "E915", 5, 6, "`out` of carrier 4, which is not in"),
    ("releasehook 3", "E915", 13, 14, "does not hold"),
    # numbers beyond their limits
    ("knit + f10001 3", "E913", 8, 14, "`f10001` is beyond any bed"),
    ("knit + b-10001 3", "E913", 8, 15, "`b-10001` is beyond any bed"),
    ("rack 20001", "E912", 6, 11, "racking 20001 is beyond any machine"),
    ("rack -20000.5", "E912", 6, 14, "beyond any machine"),
    ("stitch 10 1001", "E912", 11, 15, "stitch value 1001 is beyond"),
    ("stitch -1000.5 10", "E912", 8, 15, "stitch value -1000.5 is beyond"),
    ("x-stitch-number 256", "E912", 17, 20, "`x-stitch-number` 256 is beyond the machine's"),
    ("x-speed-number 246", "E912", 16, 19, "`x-speed-number` 246 is beyond the machine's"),
]


@pytest.mark.parametrize("line,code,col,end,message", BAD, ids=[b[0] for b in BAD])
def test_each_rule_rejects_a_bad_line_at_its_token(line, code, col, end, message):
    errors = errors_of(HEADER + "in 3\n" + line + "\n")
    assert len(errors) == 1
    e = errors[0]
    assert (e.code, e.line, e.col, e.end_col) == (code, 6, col, end)
    assert message in e.message


@pytest.mark.parametrize(
    "text,line,message",
    [
        ("", 1, "magic"),
        (";!knitout-two\n;;Carriers: 1\n", 1, "magic"),
        (";!knitout-2\n;;Gauge: 0\n", 2, "`;;Gauge:` must be a number greater than zero"),
        (";!knitout-2\n;;Width: -5\n", 2, "`;;Width:` must be a positive integer"),
        (";!knitout-2\n;;Position: Middle\n", 2, "Left, Center, Right or Keep"),
        (";!knitout-2\n;;Carriers: 1 1\n", 2, "names a carrier twice"),
        # beyond the limits (the hint says them)
        (";!knitout-2\n;;Width: 542\n", 2, "the width is 1..541"),
        (";!knitout-2\n;;Width: " + "9" * 5000 + "\n", 2, "the width is 1..541"),
        (";!knitout-2\n;;Gauge: 100.5\n", 2, "at most 100"),
        (";!knitout-2\n;;Gauge: " + "9" * 5000 + "\n", 2, "at most 100"),
        (";!knitout-2\n;;Carriers: " + " ".join(map(str, range(65))) + "\n", 2, "at most 64"),
        (";!knitout-2\n;;Carriers: 1 " + "c" * 33 + "\n", 2, "at most 32 characters"),
    ],
)
def test_header_errors(text, line, message):
    errors = errors_of(text)
    e = errors[0]
    assert e.code == "E910" and e.line == line and message in e.message + (e.hint or "")
    assert len(e.message) < 200


def test_a_magic_line_with_thousands_of_digits_is_a_newer_version():
    warnings: list = []
    parse_knitout(";!knitout-" + "9" * 5000 + "\n;;Carriers: 1\n", "v.k", warnings=warnings)
    assert [w.code for w in warnings] == ["W910"]
    assert "newer" in warnings[0].message and len(warnings[0].message) < 120
    parse_knitout(";!knitout-0\n;;Carriers: 1\n", "v.k", warnings=(none := []))
    assert none == []


HUGE = "9" * 5000


@pytest.mark.parametrize(
    "line,token,hint",
    [
        (f"knit + f{HUGE} 3", 3, "needle numbers are read from -10000 to 10000"),
        (f"xfer f1 b-{HUGE}", 3, "needle numbers are read from -10000 to 10000"),
        (f"rack {HUGE}", 2, "racking is read up to 20000 either way"),
        (f"rack -{HUGE}.5", 2, "racking is read up to 20000 either way"),
        (f"stitch {HUGE} 10", 2, "stitch values are read from -1000 to 1000"),
        (f"x-stitch-number {HUGE}", 2, "it takes 0..255"),
        (f"x-speed-number +{HUGE}", 2, "it takes 0..245"),
    ],
)
def test_a_number_of_thousands_of_digits_is_refused_at_its_token(line, token, hint):
    """Python refuses to convert more than 4,300 digits (a ValueError, once a crash of
    `knitc k2dat`); the reader judges the token by its length first. The message quotes
    the number shortened, and the hint says the limit."""
    errors = errors_of(HEADER + "in 3\n" + line + "\n")
    assert len(errors) == 1
    e = errors[0]
    col = len(" ".join(line.split()[: token - 1])) + 2
    assert (e.line, e.col, e.end_col) == (6, col, col + len(line.split()[token - 1]))
    assert f"({len(line.split()[token - 1])} characters)" in e.message
    assert len(e.message) < 120 and hint in e.hint


def test_limits_are_inclusive():
    prog = parse_knitout(
        ";!knitout-2\n;;Width: 541\n;;Gauge: 100\n;;Carriers: 1 2 3\nin 3\n"
        "knit + f10000 3\nknit + f-10000 3\nrack -20000\nrack 20000\nstitch -1000 1000\n"
        "x-stitch-number 255\nx-speed-number 245\n",
        "limits.k",
        warnings=[],
    )
    assert prog.width == 541
    assert [o.value for o in prog.ops[3:]] == [-20000, 20000, (-1000, 1000), 255, 245]
    assert prog.ops[2].needle == Needle("f", -10000)


def test_state_rules_follow_the_carriers():
    # releasehook before a stitch, then a carrier used after it went out, reported once
    errors = errors_of(
        HEADER + "inhook 3\nreleasehook 3\nknit + f1 3\nout 3\nknit + f1 3\nknit + f2 3\n"
    )
    assert [(e.code, e.line) for e in errors] == [("E915", 6), ("E915", 9)]
    assert "before it made a stitch" in errors[0].message
    # racking is tracked: aligned at rack 2, not after rack 0
    assert parse_knitout(HEADER + "rack 2\nxfer f3 b1\n", "r.k").ops[-1].needle2 == Needle("b", 1)
    assert errors_of(HEADER + "rack 2\nrack 0\nxfer f3 b1\n")[0].code == "E916"


def test_errors_are_collected_and_rendered_with_the_line_and_a_caret():
    text = HEADER + "in 3\nknit + f2 11\nknit + f1 3\nxfer f1 b3\nfrob\n"
    errors = errors_of(text)
    assert [(e.line, e.code) for e in errors] == [(6, "E914"), (8, "E916"), (9, "E911")]
    out = knitout_diagnostics("bad.k", text, errors).render()
    assert "bad.k:6:11: error[E914]: carrier `11` is not declared" in out
    assert " 6 | knit + f2 11\n   |           ^^\n" in out
    assert "bad.k:8:9: error[E916]" in out and "^^" in out


def test_error_count_is_bounded():
    errors = errors_of(HEADER + "frob\n" * 500)
    assert len(errors) == 101 and "too many errors" in errors[-1].message
