"""KnitPaint pattern DATs (`knitc.backends.dat_codes`): hand-drawn courses of every code family
read into the Knitout they mean, unknown codes and options refused at their pixel, and the
seven DATs the original system (knitskel) writes for its designs
(tests/fixtures/knitskel_dat/) read into programs that run on knitc's machine model and on the
independent one (tests/oracle.py)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from knitc.backends.dat_codes import read_pattern
from knitc.backends.dat_format import SLOT_X, pack
from knitc.backends.dat_read import DatReadError, option_x, read_dat
from knitc.backends.knitout import write_knitout
from knitc.codegen.machine import Machine
from knitc.codegen.simulate import simulate
from oracle import run_oracle_on_text

ROOT = Path(__file__).resolve().parent.parent
KNITSKEL = sorted((ROOT / "tests" / "fixtures" / "knitskel_dat").glob("*.dat"))
R, L, X = 6, 7, 1  # direction codes: right, left, transfer


def raster(*courses: tuple[int, dict[int, int], dict[str, int]], used: int = 8) -> np.ndarray:
    """A KnitPaint raster of `courses` (direction, {column: code}, options), as knitskel
    lays it out: 5 blank rows, the courses, a blank row, the width row, the position code
    (0) and 5 blank rows; option bars with their markers."""
    height = 5 + len(courses) + 8
    img = np.zeros((height, used + 110), dtype=np.uint8)
    for i, (direction, codes, options) in enumerate(courses):
        y = 5 + i
        for k in range(2, 21):
            img[y, 51 - 2 * k] = k
            img[y, 58 + used + 2 * k] = k
        img[y, 49] = img[y, 60 + used] = direction
        for col, code in codes.items():
            img[y, SLOT_X + col] = code
        for name, value in options.items():
            img[y, option_x(name, used)] = value
    img[height - 7, SLOT_X - 5 : SLOT_X + used + 5] = 1
    return img


def ops(*courses: tuple[int, dict[int, int], dict[str, int]]) -> list[str]:
    prog, _ = read_pattern(raster(*courses), Machine())
    return [str(op) for op in prog.ops]


def knit(direction: int, cols, code: int = 51, **options: int):
    return (direction, {c: code for c in cols}, {"R3": 1, **options})


def test_links_and_carrier_marks_are_not_operations():
    assert ops((L, {0: 13, 1: 171, 2: 16, 3: 171, 4: 13, 5: 99}, {"R3": 1, "R10": 1})) == [
        "in 1",
        "tuck - f4 1",
        "miss - f3 1",
        "tuck - f2 1",
    ]


def test_a_knit_over_the_other_body_is_knitted_there_between_two_transfers():
    # front body (L13 = 31): 1 knits the front, 2 is a purl: to the back, knit, back again
    assert ops(knit(L, (1, 2), R10=1), (R, {1: 1, 2: 2}, {"R3": 1, "L13": 31})) == [
        "in 1",
        "knit - f3 1",
        "knit - f2 1",
        "xfer f3 b3",
        "knit + f2 1",
        "knit + b3 1",
        "xfer b3 f3",
    ]


def test_moves_shifted_transfers_and_restacks_rack_for_their_distance():
    moves = ops(
        knit(L, (2, 3, 4), R10=1),
        (X, {2: 61, 4: 71}, {"R3": 1, "R5": 1, "L13": 51}),  # front moves with sliders
        (X, {3: 24}, {"R3": 1, "R5": 1}),  # front -> back, one to the right
        (X, {4: 50}, {"R3": 1, "R5": 1}),  # restack on the back
    )
    assert moves[4:] == [
        "xfer f3 bs3",
        "xfer f5 bs5",
        "rack -1",
        "xfer bs3 f2",
        "rack 1",
        "xfer bs5 f6",
        "rack -1",
        "xfer f4 b5",
        "rack 0",
        "xfer b5 f5",
        "xfer f5 b5",
    ]


def test_a_cable_crosses_each_side_onto_the_other():
    # 5 99 4: the upper cell moves right 2, the lower one left 2 (the lower one first)
    crossed = ops(knit(L, (1, 2, 3), R10=1), (X, {1: 5, 2: 99, 3: 4}, {"R3": 1, "R5": 1}))
    assert crossed[4:] == [
        "xfer f2 b2",
        "xfer f4 b4",
        "rack -2",
        "xfer b4 f2",
        "rack 2",
        "xfer b2 f4",
    ]


def test_kickbacks_transfer_then_knit_and_splits():
    assert ops(
        knit(L, (1, 2), R10=1),
        (R, {1: 17, 2: 70}, {"R3": 1}),
        (L, {3: 107, 1: 101}, {"R3": 1}),
    )[3:] == [
        "xfer f3 b3",
        "knit + f2 1",
        "knit + b3 1",
        "split - f4 bs4 1",
        "split - f2 b2 1",
        "rack 1",
        "xfer bs4 f5",
    ]


def test_the_yarn_options_bring_in_release_and_take_out():
    assert ops(
        knit(L, (1, 2), R10=1, R15=10),
        knit(R, (1, 2), R15=90, R6=33),
        knit(L, (1, 2), R10=101, R15=20, R11=101),
        (R, {1: 52, 2: 51}, {"R3": 255}),
    ) == [
        "inhook 1",
        "knit - f3 1",
        "knit - f2 1",
        "x-stitch-number 33",
        "releasehook 1",
        "knit + f2 1",
        "knit + f3 1",
        "x-presser-mode on",
        "knit - f3 1",
        "knit - f2 1",
        "outhook 1",
        "drop f3",
    ]


def test_a_hook_never_released_means_the_yarn_was_inserted_by_hand():
    assert ops(knit(L, (1,), R10=1, R15=10), knit(R, (1,), R10=101, R15=20))[:1] == ["in 1"]


@pytest.mark.parametrize(
    ("course", "message", "x"),
    [
        ((R, {3: 199}, {"R3": 1}), "code 199 is not a knitting-course code", SLOT_X + 3),
        ((X, {2: 51}, {"R3": 1, "R5": 1}), "code 51 is not a transfer-course code", SLOT_X + 2),
        ((R, {3: 51}, {"R3": 1, "R20": 4}), "option R20 = 4 is not one knitc reads", None),
        ((X, {3: 5}, {"R3": 1, "R5": 1}), "cable code 5 has no other side", SLOT_X + 3),
        ((R, {3: 51}, {"R3": 1, "L2": 1}), "racking option L2 = 1", None),
    ],
)
def test_what_the_reader_does_not_know_is_refused_at_its_pixel(course, message, x):
    with pytest.raises(DatReadError, match=message) as info:
        read_pattern(raster(course), Machine())
    assert info.value.y == 5
    if x is not None:
        assert info.value.x == x


def test_a_pixel_outside_the_layout_is_refused():
    img = raster(knit(L, (1,), R10=1))
    img[2, 60] = 16
    _, diags = read_dat(pack(img), "p.dat")
    [d] = diags.sorted()
    assert d.span is not None and (d.span.line, d.span.column) == (3, 61)
    assert "outside the layout of a KnitPaint DAT" in d.message


@pytest.mark.parametrize("path", KNITSKEL, ids=lambda p: p.stem)
def test_knitskel_dats_read_to_programs_knitc_simulates_clean(path):
    prog, diags = read_dat(path.read_bytes(), str(path))
    assert prog is not None, diags.render()
    assert not [f for f in simulate(prog, placed=True) if f.is_error]


ORIGINAL_HAZARDS = {
    # the original's own cast-ons and gauge changes knit on needles no loop holds yet
    "Knit_on_Empty_Needle_Warning",
    "Long_Float_Warning",  # glove: one float of the original's layout
    "Needle_Holds_Too_Many_Loops",  # sock: one needle of the original's heel
}


def test_knitskel_dats_run_on_the_independent_machine():
    texts = [write_knitout(read_dat(p.read_bytes(), str(p))[0]) for p in KNITSKEL]  # type: ignore[arg-type]
    for path, report in zip(KNITSKEL, run_oracle_on_text(texts), strict=True):
        problems = report.problems()
        assert not [p for p in problems if p.kind != "hazard"], (path.name, report.describe())
        kinds = {p.text.split(": ")[1] for p in problems}
        assert kinds <= ORIGINAL_HAZARDS, (path.name, kinds)
