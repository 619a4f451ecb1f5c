"""The Knitout backend (`knitc.backends.knitout`): exact text, determinism, the format rules
of research §1.1/§4, reading back, and every program written here run through the
independent oracle (tests/oracle.py), valid ones clean and broken ones failing for their
own reason.
"""

from __future__ import annotations

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from knitc.backends.knitout import (
    knitout_lines,
    op_of_line,
    read_knitout,
    write_knitout,
)
from knitc.codegen.machine import Machine, MachineProgram, Needle, Op, verify
from knitc.source import Span
from oracle import assert_clean, run_oracle_on_text
from test_machine_ir import flat_swatch, half_gauge_tube

HEADER = (
    ";!knitout-2\n;;Machine: SWG091N2\n;;Gauge: 15\n;;Carriers: 1 2 3 4 5 6 7 8 9 10\n"
    ";;Position: Center\n"
)


def line(n: int, col: int = 1) -> Span:
    return Span("tiny.knit", n, col, n, col + 8)


def tiny() -> MachineProgram:
    """Four stitches, a row, a decrease at the right edge, a row, off the machine."""
    p = MachineProgram(Machine())
    p.comment("tiny: 4 stitches")
    p.stitch_number(61)
    with p.at(span=line(1)):
        p.inhook(3)
        p.tuck(-1, "f4", 3, stitch=3)
        p.tuck(-1, "f2", 3, stitch=1)
        p.tuck(+1, "f1", 3, stitch=0)
        p.tuck(+1, "f3", 3, stitch=2)
    with p.at(span=line(2, 3)):
        for k in (4, 3, 2, 1):
            p.knit(-1, Needle("f", k), 3, stitch=3 + k)
    p.releasehook(3, span=line(1))
    with p.at(stitch=7, span=line(3, 5)):
        p.xfer("f4", "b4")
        p.xfer("b4", "f3", auto_rack=True)
        p.rack(0)
    with p.at(span=line(4, 3)):
        for k in (1, 2, 3):
            p.knit(+1, Needle("f", k), 3, stitch=7 + k)
    p.outhook(3)
    for k in (1, 2, 3):
        p.drop(Needle("f", k))
    return p


TINY = (
    HEADER
    + """\
; tiny: 4 stitches
x-stitch-number 61
inhook 3 ;!source:tiny.knit:1:1
tuck - f4 3 ;!source:tiny.knit:1:1
tuck - f2 3 ;!source:tiny.knit:1:1
tuck + f1 3 ;!source:tiny.knit:1:1
tuck + f3 3 ;!source:tiny.knit:1:1
knit - f4 3 ;!source:tiny.knit:2:3
knit - f3 3 ;!source:tiny.knit:2:3
knit - f2 3 ;!source:tiny.knit:2:3
knit - f1 3 ;!source:tiny.knit:2:3
releasehook 3 ;!source:tiny.knit:1:1
xfer f4 b4 ;!source:tiny.knit:3:5
rack -1 ;!source:tiny.knit:3:5
xfer b4 f3 ;!source:tiny.knit:3:5
rack 0 ;!source:tiny.knit:3:5
knit + f1 3 ;!source:tiny.knit:4:3
knit + f2 3 ;!source:tiny.knit:4:3
knit + f3 3 ;!source:tiny.knit:4:3
outhook 3
drop f1
drop f2
drop f3
"""
)


def every_kind() -> MachineProgram:
    """A valid program that uses every op kind (and two carriers at once, a split, misses,
    quarter-pitch racking and the SWG extensions)."""
    p = MachineProgram()
    p.stitch_number(61)
    p.speed(3)
    p.presser("auto")
    p.inhook(3)
    for k in (6, 4, 2):
        p.tuck(-1, Needle("f", k), 3)
    for k in (1, 3, 5):
        p.tuck(+1, Needle("f", k), 3)
    for k in range(6, 0, -1):
        p.knit(-1, Needle("f", k), 3)
    p.releasehook(3)
    p.in_((4, 5))  # plating: two carriers brought in together
    for k in range(1, 7):
        p.knit(+1, Needle("f", k), (4, 5))
    p.out((4, 5))
    p.split(+1, "f2", "b2", 3)  # new loop on f2, the old one to b2
    p.xfer("b2", "f2")
    p.miss(+1, "f8", 3)
    p.miss(-1, "f7", 3)
    p.amiss("f3")
    p.rack(0.25)  # quarter pitch: f1 and b1 both knit in one pass
    p.knit(+1, "f1", 3)
    p.tuck(+1, "b1", 3)
    p.rack(0)
    p.pause("check the yarn")
    p.comment("casting off\nby dropping")
    p.outhook(3)
    for n in ("f1", "f2", "f3", "f4", "f5", "f6", "b1"):
        p.drop(n)
    return p


# ---- exact text -------------------------------------------------------------------------------


def test_golden_tiny():
    assert write_knitout(tiny()) == TINY


def test_golden_without_source_comments():
    text = write_knitout(tiny(), source_comments=False)
    assert text == "".join(l.split(" ;!source:")[0] + "\n" for l in TINY.splitlines())
    assert ";!source" not in text


def test_carrier_sets_one_per_line():
    p = MachineProgram()
    p.in_((4, 5), span=line(9))
    p.knit(-1, "f2", (4, 5))
    p.out((4, 5))
    body = write_knitout(p)[len(HEADER) :]
    assert body == (
        "in 4 ;!source:tiny.knit:9:1\nin 5 ;!source:tiny.knit:9:1\nknit - f2 4 5\nout 4\nout 5\n"
    )
    joined = write_knitout(p, one_carrier_per_line=False)[len(HEADER) :]
    assert joined == "in 4 5 ;!source:tiny.knit:9:1\nknit - f2 4 5\nout 4 5\n"


def test_pause_and_comments():
    p = MachineProgram()
    p.comment("two\nlines")
    p.comment("")
    p.pause("change  the\nyarn", span=line(5))
    p.pause()
    assert (
        write_knitout(p)[len(HEADER) :]
        == "; two\n; lines\n;\n; change the yarn\npause ;!source:tiny.knit:5:1\npause\n"
    )


def test_header_follows_the_machine_and_position():
    p = MachineProgram(Machine(name="SWG061N2", gauge=12, carriers=8), position="Keep")
    assert write_knitout(p) == (
        ";!knitout-2\n;;Machine: SWG061N2\n;;Gauge: 12\n"
        ";;Carriers: 1 2 3 4 5 6 7 8\n;;Position: Keep\n"
    )


def test_source_comment_stays_on_one_line():
    p = MachineProgram()
    p.knit(+1, "f1", 3, span=Span("odd\nname.knit", 2, 1, 2, 2))
    assert write_knitout(p).endswith("knit + f1 3 ;!source:odd name.knit:2:1\n")


SAMPLES = {"tiny": tiny, "swatch": flat_swatch, "tube": half_gauge_tube, "every_kind": every_kind}


@pytest.mark.parametrize("name", SAMPLES)
def test_format_rules(name):
    """research §1.1/§4: single spaces, LF, no tabs, no trailing spaces, no blank lines."""
    text = write_knitout(SAMPLES[name]())
    assert text.startswith(HEADER) and text.endswith("\n")
    assert "\t" not in text and "\r" not in text and "  " not in text
    assert all(l and l == l.strip() for l in text.splitlines())
    assert text.isascii()


@pytest.mark.parametrize("name", SAMPLES)
def test_deterministic(name):
    a = write_knitout(SAMPLES[name]()).encode()
    b = write_knitout(SAMPLES[name]()).encode()
    assert a == b


def test_line_map():
    p = tiny()
    lines = knitout_lines(p)
    assert [i for _, i in lines[:5]] == [-1] * 5
    assert lines[5] == ("; tiny: 4 stitches", 0)
    assert [l for l, _ in lines] == write_knitout(p).splitlines()
    n = write_knitout(p).splitlines().index("rack -1 ;!source:tiny.knit:3:5") + 1
    assert str(p.ops[op_of_line(p, n)]) == "rack -1"
    assert op_of_line(p, 1) == -1 and op_of_line(p, 10_000) == -1
    q = MachineProgram()
    q.in_((4, 5))
    assert [i for _, i in knitout_lines(q)][-2:] == [0, 0]


# ---- reading back -----------------------------------------------------------------------------


def strip_spans(p: MachineProgram) -> list[Op]:
    """The ops without provenance (and pause messages, which are written as comments)."""
    return [
        Op(o.kind, o.dir, o.needle, o.needle2, o.carriers, None if o.kind == "pause" else o.value)
        for o in p
    ]


@pytest.mark.parametrize("name", SAMPLES)
@pytest.mark.parametrize("source_comments", [True, False])
def test_read_back(name, source_comments):
    p = SAMPLES[name]()
    q = read_knitout(write_knitout(p, source_comments=source_comments, one_carrier_per_line=False))
    assert q.position == p.position
    want = strip_spans(p)
    if name == "every_kind":  # the two-line comment reads back as two comments; pause's
        want = [o for o in want if o.kind != "comment"]  # message as a comment
    got = [o for o in q if o.kind != "comment"] if name == "every_kind" else list(q)
    assert got == want


def test_read_rejects():
    with pytest.raises(ValueError, match="line 1: cannot read 'knot \\+ f1 3'"):
        read_knitout("knot + f1 3")
    with pytest.raises(ValueError, match="line 2"):
        read_knitout("knit + f1 3\nknit * f1 3")


ops = st.one_of(
    st.builds(
        lambda d, n, c: Op("knit", d, n, None, c),
        st.sampled_from([1, -1]),
        st.builds(Needle, st.sampled_from(["f", "b"]), st.integers(0, 540)),
        st.lists(st.integers(1, 10), min_size=1, max_size=2, unique=True).map(tuple),
    ),
    st.builds(
        lambda a, b: Op("xfer", 0, Needle("f", a), Needle("bs", b)),
        st.integers(0, 540),
        st.integers(0, 540),
    ),
    st.builds(lambda r: Op("rack", value=r), st.sampled_from([0, 1, -4, 0.25, -0.75, 2])),
    st.builds(lambda k: Op("stitch_number", value=k), st.integers(0, 99)),
    st.builds(
        lambda c: Op("outhook", carriers=c),
        st.lists(st.integers(1, 10), min_size=1, max_size=3, unique=True).map(tuple),
    ),
)


@settings(max_examples=80, deadline=None)
@given(st.lists(ops, max_size=30))
def test_write_read_round_trip(op_list):
    p = MachineProgram(ops=op_list)
    assert verify(p) == []
    text = write_knitout(p, one_carrier_per_line=False)
    assert read_knitout(text).ops == op_list
    assert write_knitout(read_knitout(text), one_carrier_per_line=False) == text


spans = st.sampled_from([None, Span("a.knit", 3, 5, 3, 12), Span("b c.knit", 1, 1, 2, 4)])


@settings(max_examples=80, deadline=None)
@given(st.lists(st.tuples(ops, spans), max_size=30), st.booleans(), st.booleans())
def test_the_fast_writer_writes_the_line_map(op_spans, sc, one):
    # write_knitout formats each distinct op and span once; its text must stay the lines
    # knitout_lines (the line map tools use) gives, for every kind and option
    p = MachineProgram(ops=[op._replace(span=sp, stitch=3) for op, sp in op_spans])
    p.emit(Op("comment", value="two\nlines"))
    p.emit(Op("pause", value="check the yarn"))
    lines = knitout_lines(p, source_comments=sc, one_carrier_per_line=one)
    assert write_knitout(p, source_comments=sc, one_carrier_per_line=one) == (
        "\n".join(line for line, _ in lines) + "\n"
    )


def test_equal_ops_of_other_number_types_print_as_they_are():
    # 1, 1.0 and True are one dict key: an unverified program's odd op must not lend its
    # text to a later well-formed one (nor borrow it)
    p = MachineProgram()
    for n in (Needle("f", True), Needle("f", 1), Needle("f", 2.0), Needle("f", 2)):
        p.emit(Op("knit", 1, n, None, (1,)))
    p.emit(Op("knit", True, Needle("f", 3), None, (1,)))
    p.emit(Op("knit", 1, Needle("f", 3), None, (1.0,)))
    p.emit(Op("knit", 1, Needle("f", 3), None, (1,)))
    body = write_knitout(p).splitlines()[-7:]
    assert body == [str(op) for op in p.ops]


# ---- the independent oracle ------------------------------------------------------------------


def broken_programs() -> dict[str, tuple[MachineProgram, set[str]]]:
    """Each sample program with one defect, and the problem kinds the oracle must find."""
    return {
        "swatch_no_drops": (flat_swatch(drops=False), {"loops_left"}),
        "swatch_no_outhook": (flat_swatch(outhook=False), {"carriers_in"}),
        # the drops come before the outhook, which fails: no loops are left
        "swatch_hook_kept": (flat_swatch(release=False), {"error", "hook", "carriers_in"}),
        "tube_no_rack": (
            half_gauge_tube(shaping_rack=False),
            {"error", "loops_left", "carriers_in"},
        ),
    }


@pytest.fixture(scope="module")
def reports():
    texts = {
        f"{name}{'' if sc else '/plain'}": write_knitout(make(), source_comments=sc)
        for name, make in SAMPLES.items()
        for sc in (True, False)
    }
    texts |= {name: write_knitout(p) for name, (p, _) in broken_programs().items()}
    texts["tiny/joined"] = write_knitout(tiny(), one_carrier_per_line=False)
    names = list(texts)
    return dict(zip(names, run_oracle_on_text([texts[n] for n in names])))


@pytest.mark.parametrize("name", SAMPLES)
def test_samples_are_clean_on_the_oracle(reports, name):
    r = reports[name]
    assert_clean(r)
    assert r.errors == () and r.no_ops == 0
    # the only warning allowed: `in` of carriers that are not hooked (every_kind's plating)
    assert {w.type for w in r.warnings} <= {"In_Loose_Carrier_Warning"}
    # the trailing source comments are read as comments, not stripped
    assert "source_comment" not in r.stripped


@pytest.mark.parametrize("name", SAMPLES)
def test_source_comments_change_nothing(reports, name):
    a, b = reports[name], reports[name + "/plain"]
    assert_clean(b)
    assert (a.carriage_passes, a.knit_graph, a.lines) == (b.carriage_passes, b.knit_graph, b.lines)


@pytest.mark.parametrize("name", ["tiny", "swatch", "tube"])
def test_pass_estimate_matches_the_oracle(reports, name):
    assert SAMPLES[name]().stats()["passes"] == reports[name].carriage_passes


def test_oracle_counts(reports):
    # swatch: 8 cast-on tucks + 6 rows of 8 loops; each knit is one stitch
    assert reports["swatch"].knit_graph == {"loops": 8 + 48, "stitches": 48}
    # tube: 12 tucks + 4 rounds of 12 + 2 rounds of 10; the two decreases knit through 2
    assert reports["tube"].knit_graph == {"loops": 12 + 48 + 20, "stitches": 48 + 20 + 2}


@pytest.mark.parametrize("name", list(broken_programs()))
def test_broken_programs_fail_on_the_oracle(reports, name):
    """The clean verdicts above can fail: one defect each makes the oracle object."""
    _, kinds = broken_programs()[name]
    r = reports[name]
    assert r.problem_kinds() == kinds, r.describe()
    with pytest.raises(AssertionError, match="is not clean"):
        assert_clean(r)


def test_oracle_error_maps_back_to_the_dsl(reports):
    """The oracle's line number -> op -> stitch and DSL span."""
    p, _ = broken_programs()["tube_no_rack"]
    [err] = reports["tube_no_rack"].errors
    op = p.ops[op_of_line(p, err.line)]
    assert str(op) == "xfer b12 f10" and err.source == "xfer b12 f10 ;!source:tube.knit:6:3"
    assert op.span is not None and (op.span.file, op.span.line) == ("tube.knit", 6)


def test_joined_carrier_sets_are_refused_by_the_oracle(reports):
    """Why carrier sets are split by default: the oracle parses one carrier per in/out line
    (here the sets have one carrier, so joined and split text are the same and it passes)."""
    assert_clean(reports["tiny/joined"])
    [r] = run_oracle_on_text([write_knitout(every_kind(), one_carrier_per_line=False)])
    assert [e.source for e in r.errors] == ["in 4 5", "out 4 5"]
