"""The DAT reader (`knitc.backends.dat_read`): pass rows -> ops, on hand-built images (every
colour, option and carrier action), on the CMU converter's fixture DATs (decoded, read, written
again: the same bytes; and as Knitout text the reader's program converts to the same bytes),
and on random programs (write, decode, read, write: the same bytes)."""

from __future__ import annotations

from collections import Counter
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings

from knitc.backends.dat import DatImage, DatPass
from knitc.backends.dat_format import decode, encode, rows
from knitc.backends.dat_read import (
    DatReadError,
    carriers_of_code,
    dat_to_program,
    racking_of,
)
from knitc.backends.dat_write import carrier_code, to_dat
from knitc.backends.knitout import write_knitout
from knitc.backends.knitout_read import parse_knitout
from knitc.codegen.machine import verify
from test_knitout_read import machine_programs

ROOT = Path(__file__).resolve().parent.parent
FIXTURES = sorted((ROOT / "tests" / "fixtures" / "dat").glob("*.dat"))

R, L, N = 6, 7, 1  # direction codes


def row(direction: int, slots: dict[int, int], **options: int) -> DatPass:
    """A pass row as the converter writes it: R9 = 1 and L4 = 10 unless given."""
    p = DatPass(direction=direction, slots=dict(slots))
    for name, value in {"R9": 1, "L4": 10, **options}.items():
        p.set(name, value)
    return p


def image(*passes: DatPass, position: int = 0) -> DatImage:
    slots = [s for p in passes for s in p.slots]
    return DatImage(
        passes=list(passes), min_slot=min(slots), max_slot=max(slots), position=position
    )


def knitout(img: DatImage, **kw) -> list[str]:
    return [str(op) for op in dat_to_program(img, **kw).ops]


def knit_row(direction: int, slots, code: int = 51, **options: int) -> DatPass:
    return row(direction, {s: code for s in slots}, **{"R3": 3, "R6": 5, **options})


# The research's hand-made test (knitout-and-dat.md §3.3): the JS converter's rows 8..20.
HAND_MADE = image(
    row(L, {1: 16, **{s: 11 for s in (2, 4, 6, 8, 10)}}, R3=3, R6=5, R10=3, R15=10),
    row(R, {s: 11 for s in (1, 3, 5, 7, 9)}, R3=3, R6=5),
    row(L, {9: 16}, R3=255, R6=5, R15=90),  # hook release
    row(L, {9: 16}, R3=3, R5=2, R6=5),  # kick
    row(R, {10: 16}, R3=3, R6=5),  # kick
    knit_row(L, range(1, 11)),
    knit_row(R, range(1, 11)),
    knit_row(L, range(1, 11)),
    knit_row(R, range(1, 11)),
    row(N, {10: 20}, R5=1),
    row(N, {9: 30}, L2=1, R5=1),
    knit_row(L, range(1, 10)),
    knit_row(R, range(1, 10), R10=103, R15=20),
)


def test_the_research_hand_made_rows_read_as_the_knitout_that_made_them():
    ops = knitout(HAND_MADE)
    stst = [
        f"knit {d} f{n} 3"
        for _ in range(2)
        for d, ns in (("-", range(10, 0, -1)), ("+", range(1, 11)))
        for n in ns
    ]
    assert ops == (
        ["inhook 3"]
        + [f"tuck - f{n} 3" for n in (10, 8, 6, 4, 2)]
        + [f"tuck + f{n} 3" for n in (1, 3, 5, 7, 9)]
        + ["releasehook 3"]
        + stst
        + ["xfer f10 b10", "rack -1", "xfer b10 f9", "rack 0"]
        + [f"knit - f{n} 3" for n in range(9, 0, -1)]
        + [f"knit + f{n} 3" for n in range(1, 10)]
        + ["outhook 3"]
    )
    prog = dat_to_program(HAND_MADE)
    assert verify(prog) == [] and prog.position == "Right"
    # the converter's kick, release and dummy rows come back from the writer
    again = to_dat(prog)
    assert again.passes == HAND_MADE.passes and again.position == 0


def test_explicit_kicks_show_the_carrier_motion_as_misses():
    ops = knitout(HAND_MADE, explicit_kicks=True)
    assert ops[:7] == [
        "inhook 3",
        "tuck - f10 3",
        "tuck - f8 3",
        "tuck - f6 3",
        "tuck - f4 3",
        "tuck - f2 3",
        "miss - f1 3",
    ]
    release = ops.index("releasehook 3")
    assert ops[release + 1 : release + 3] == ["miss - f9 3", "miss + f10 3"]
    assert len(ops) == len(knitout(HAND_MADE)) + 3


@pytest.mark.parametrize(
    "r,l2,l3,l4",
    [
        (0, 0, 0, 10),
        (2, 1, 0, 11),
        (-1, 1, 0, 10),
        (0.25, 0, 1, 10),
        (-0.75, 1, 1, 10),
        (1.25, 0, 1, 11),
        (1, 0, 0, 11),
        (-8, 8, 0, 10),
    ],
)
def test_racking_from_the_option_lines(r, l2, l3, l4):
    assert racking_of(row(N, {1: 20}, L2=l2, L3=l3, L4=l4)) == r


def test_carrier_codes_invert_the_writers():
    for a in range(1, 11):
        assert carriers_of_code(carrier_code((a,))) == (a,)
        for b in range(1, 11):
            if a != b:
                assert carriers_of_code(carrier_code((a, b))) == (a, b)
    assert carriers_of_code(36) == (3, 6) and carriers_of_code(30) == (3, 10)
    assert carriers_of_code(110) == (1, 10) and carriers_of_code(103) == (10, 3)
    assert carriers_of_code(13) == (1, 3)  # the converter's (10, 3) too: it cannot be told
    assert carriers_of_code(11) == (10, 1)
    assert carriers_of_code(0) == carriers_of_code(255) == ()
    for bad in (100, 111, 120, 254):
        with pytest.raises(ValueError):
            carriers_of_code(bad)


def test_quarter_pitch_pairs_go_in_carriage_order():
    img = image(
        row(R, {1: 3, 2: 41, 3: 42, 4: 88, 5: 51, 6: 12}, R3=5, R6=5, R10=5, L3=1),
        row(L, {6: 3, 5: 41}, R3=5, R6=5, L2=1, L3=1),
    )
    assert knitout(img) == [
        "rack 0.25",
        "in 5",
        "knit + f1 5",
        "knit + b1 5",
        "knit + f2 5",
        "tuck + b2 5",
        "tuck + f3 5",
        "knit + b3 5",
        "tuck + f4 5",
        "tuck + b4 5",
        "knit + f5 5",
        "tuck + b6 5",
        "rack -0.75",  # back needle b(s - floor(R)) = b(s + 1)
        "knit - b7 5",
        "knit - f6 5",
        "tuck - b6 5",
        "knit - f5 5",
    ]


def test_transfers_splits_and_sliders():
    img = image(
        row(N, {3: 20, 4: 30}, R5=1),
        row(N, {3: 20, 4: 30}, R5=1, L13=1),  # to sliders
        row(N, {3: 20, 4: 30}, R5=1, L13=3),  # from sliders
        row(N, {5: 30, 6: 20}, R5=1, L2=1),  # racking -1
        row(L, {6: 101, 5: 102}, R3=2, R6=5, R10=2, L12=10, L2=1),
    )
    assert knitout(img) == [
        "xfer f3 b3",
        "xfer b4 f4",
        "xfer f3 bs3",
        "xfer b4 fs4",
        "xfer fs3 b3",
        "xfer bs4 f4",
        "rack -1",
        "xfer b6 f5",
        "xfer f6 b7",
        "in 2",
        "split - f6 b7 2",
        "split - b6 f5 2",
    ]


def test_splits_via_sliders_come_with_their_return_transfers():
    img = image(row(R, {5: 107, 8: 108}, R3=4, R6=5, R10=4, R11=0))
    ops = knitout(img)
    assert ops == [
        "in 4",
        "split + f5 bs5 4",
        "split + b8 fs8 4",
        "rack 1",
        "xfer bs5 f6",
        "xfer fs8 b7",
    ]
    prog = dat_to_program(img)
    prog.rack(0)
    prog.knit(+1, "f9", 4)
    prog.out(4)
    assert to_dat(prog).passes[0].slots == {5: 107, 8: 108}


def test_drops_and_amiss_have_no_carriers():
    img = image(
        row(R, {1: 51, 2: 52}, R3=255, R6=5),
        row(L, {3: 11, 1: 12}, R3=0, R6=5, L12=20),
        row(R, {4: 3}, R3=255, R6=5, L3=1),
    )
    assert knitout(img) == [
        "drop f1",
        "drop b2",
        "amiss f3",
        "amiss b1",
        "rack 0.25",
        "drop f4",
        "drop b4",
    ]


def test_settings_pause_and_carriers_from_the_option_bars():
    img = image(
        knit_row(L, (3, 2), R10=3, R11=101),
        knit_row(R, (2, 3), L5=13, L6=13, L7=20, R6=85),
        row(N, {3: 20}, R5=1, L5=13, L6=13),  # transfer rows carry stitch 0: no change
        knit_row(L, (3, 2), R3=36, R6=85, R10=136),  # carriers 3 and 6 together, out
    )
    assert knitout(img) == [
        "x-presser-mode on",
        "in 3",
        "knit - f3 3",
        "knit - f2 3",
        "pause",
        "x-stitch-number 85",
        "x-speed-number 3",
        "x-presser-mode off",
        "knit + f2 3",
        "knit + f3 3",
        "xfer f3 b3",
        "x-speed-number 0",
        "knit - f3 3 6",
        "knit - f2 3 6",
        "out 3 6",
    ]


def test_dat_read_errors_name_the_row_and_slot():
    with pytest.raises(DatReadError, match="pass 1, slot 4: colour 99"):
        dat_to_program(image(knit_row(L, (3,), R10=3), row(R, {4: 99}, R3=3)))
    with pytest.raises(DatReadError, match="pass 0: hook release"):
        dat_to_program(image(row(L, {2: 16}, R3=255, R15=90)))
    with pytest.raises(DatReadError, match="carrier code 111"):
        dat_to_program(image(knit_row(L, (3,), R3=111)))
    with pytest.raises(DatReadError, match="L5 = 5"):
        dat_to_program(image(knit_row(L, (3,), L5=5)))
    with pytest.raises(DatReadError, match="miss colour 216 in a row without carriers"):
        dat_to_program(image(row(R, {2: 216}, R3=255)))
    with pytest.raises(DatReadError, match="quarter-pitch"):
        dat_to_program(image(row(N, {2: 20}, L3=1, R5=1)))


@pytest.mark.parametrize(
    "position,min_slot,expected",
    [
        (0, 1, ("Right", None)),
        (1, 1, ("Left", None)),
        (21, 21, ("Keep", None)),
        (65, 1, ("Center", 140)),
        (265, 1, ("Center", None)),
        (600, 600, ("Keep", 609)),
    ],
)
def test_placement_from_the_position_code(position, min_slot, expected):
    needles = range(min_slot, min_slot + 10)
    img = DatImage(
        passes=[
            knit_row(R, needles, R10=3),
            knit_row(L, needles[::-1]),
            knit_row(R, needles, R10=103),
        ],
        min_slot=min_slot,
        max_slot=min_slot + 9,
        position=position,
    )
    prog = dat_to_program(img)
    assert (prog.position, prog.width) == expected
    assert to_dat(prog).position == position


@pytest.mark.parametrize("path", FIXTURES, ids=lambda p: p.stem)
def test_every_fixture_reads_back_to_a_program_that_writes_it_again(path):
    data = path.read_bytes()
    prog = dat_to_program(decode(data))
    assert verify(prog) == []
    assert encode(to_dat(prog)) == data
    # as Knitout text (one `in` per carrier set, as the converter wants), read by knitout_read
    text = write_knitout(prog, one_carrier_per_line=False)
    assert rows(to_dat(parse_knitout(text, path.stem + ".k"))) == rows(data)


def test_the_fixture_knitout_and_its_dat_read_to_the_same_needle_work():
    source = parse_knitout((ROOT / "tests/fixtures/dat/rib_2x2.k").read_text(), "rib.k")
    read = dat_to_program(decode((ROOT / "tests/fixtures/dat/rib_2x2.dat").read_bytes()))
    work = ("knit", "tuck", "xfer", "split", "drop", "amiss")

    def needle_ops(prog):
        ops = [o for o in prog.ops if o.kind in work]
        low = min(o.needle.index for o in ops)  # the DAT places the design on the bed
        return Counter(
            (o.kind, o.needle.shifted(-low), o.needle2 and o.needle2.shifted(-low), o.carriers)
            for o in ops
        )

    assert needle_ops(read) == needle_ops(source)


@settings(max_examples=120, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(machine_programs())
def test_random_programs_survive_write_decode_read_write(prog):
    data = encode(to_dat(prog))
    read = dat_to_program(decode(data))
    assert encode(to_dat(read)) == data
    text = write_knitout(read, one_carrier_per_line=False)
    assert encode(to_dat(parse_knitout(text, "read.k"))) == data
