"""Hostile DAT files through `knitc dat2k` (`knitc.backends.dat_read.read_dat`): every input
ends in a located E902 (exit 1) or in Knitout that knitc's own Knitout reader and machine
simulation accept (exit 0), never an internal error, a hang or an allocation beyond the bed.

Work is bounded by construction, not by a clock: the header's size is checked against the bed
before the raster exists, the run-length data must cover exactly W x H pixels, and the decoded
program is simulated once, linear in its ops.
"""

from __future__ import annotations

import random
from pathlib import Path

import pytest

from knitc.backends.dat import DatImage, DatPass
from knitc.backends.dat_format import HEADER_SIZE, PASS_Y, SLOT_X, encode, pack, read_raster
from knitc.backends.dat_read import read_dat, width_limit
from knitc.backends.knitout import write_knitout
from knitc.cli import main
from knitc.codegen.machine import Machine
from knitc.lint import lint_text

ROOT = Path(__file__).resolve().parent.parent
CORPUS = sorted((ROOT / "tests" / "fixtures" / "dat").glob("*.dat")) + sorted(
    (ROOT / "tests" / "fixtures" / "knitskel_dat").glob("*.dat")
)
from test_dat_read import L, N, R, row  # noqa: E402,F401  the pass-row helper and codes


def dat(*passes: DatPass) -> bytes:
    slots = [s for p in passes for s in p.slots]
    return encode(DatImage(passes=list(passes), min_slot=min(slots), max_slot=max(slots)))


def knits(direction: int, slots: range, **options: int) -> DatPass:
    return row(direction, {s: 51 for s in slots}, **{"R3": 3, "R6": 5, **options})


def the_error(data: bytes) -> tuple[str, tuple[int, int] | None]:
    prog, diags = read_dat(data, "x.dat")
    assert prog is None
    [d] = diags.sorted()
    assert d.code == "E902"
    return d.message, (d.span.line, d.span.column) if d.span else None


def test_a_header_wider_than_the_bed_is_refused_before_the_raster_exists():
    # 65536 x 65536 would be a 4 GiB raster; the header alone decides.
    data = bytes(4) + b"\xff\xff\xff\xff" + bytes(HEADER_SIZE - 8) + b"\x00\x10"
    message, where = the_error(data)
    assert "65536 x 65536" in message and "651" in message and where is None
    # one row wider than the bed, with runs that cover it exactly: still the width
    wide = width_limit(Machine()) + 1
    runs = bytes([0, 255]) * (wide // 255) + bytes([0, wide % 255])
    header = (0).to_bytes(4, "little") + (wide - 1).to_bytes(2, "little") + bytes(2)
    message, _ = the_error(header + bytes(HEADER_SIZE - 8) + runs)
    assert f"{wide} x 1" in message


def test_run_length_data_must_cover_exactly_the_raster():
    data = bytearray((ROOT / "tests/fixtures/dat/rib_2x2.dat").read_bytes())
    message, _ = the_error(bytes(data[:-2]))
    assert "truncated" in message
    message, _ = the_error(bytes(data) + b"\x00\x01")
    assert "overflows" in message


def test_a_carrier_used_before_it_is_in_is_located_at_its_first_stitch():
    message, where = the_error(dat(knits(L, range(1, 5)), knits(R, range(1, 5), R10=103)))
    assert "E802" in message or "not in" in message
    # pass 0 (raster row PASS_Y), leftward: its first stitch is slot 4 (column 3 of the band)
    assert where == (PASS_Y + 1, SLOT_X + 3 + 1)


def test_a_carrier_brought_in_twice_is_located_at_the_second_row():
    message, where = the_error(
        dat(knits(L, range(1, 5), R10=3), knits(R, range(1, 5), R10=3), knits(L, range(1, 5)))
    )
    assert "already in" in message
    assert where is not None and where[0] == PASS_Y + 1 + 1


def test_racking_beyond_the_machine_is_refused_at_the_row_that_racks():
    # L2 = 127 reads racking -127 (one flipped bit away from 0): past the limit of 4
    message, where = the_error(
        dat(knits(L, range(3, 6), R10=3), row(N, {4: 20}, L2=127, R5=1), knits(R, range(3, 6)))
    )
    assert "racking -127 is beyond the machine's limit of 4" in message
    assert where == (PASS_Y + 1 + 1, 48 - 2 + 1)  # the L2 value column


def test_loops_left_at_the_end_are_refused():
    message, _ = the_error(dat(knits(L, range(1, 5), R10=3), knits(R, range(1, 5), R10=103)))
    assert "left on" in message


def test_dat2k_prints_the_location_and_exits_1(tmp_path, capsys):
    path = tmp_path / "bad.dat"
    path.write_bytes(dat(knits(L, range(1, 5)), knits(R, range(1, 5), R10=103)))
    assert main(["dat2k", str(path)]) == 1
    err = capsys.readouterr().err
    assert f"{path}:{PASS_Y + 1}:{SLOT_X + 4}: error[E902]: not a DAT file knitc can read" in err
    assert "= hint:" in err and "Traceback" not in err


def _mutate(data: bytes, rng: random.Random) -> bytes:
    b = bytearray(data)
    kind = rng.randrange(5)
    for _ in range(rng.randint(1, 4)):
        if kind == 0:  # a flipped bit anywhere
            b[rng.randrange(len(b))] ^= 1 << rng.randrange(8)
        elif kind == 1:  # a run's colour
            b[rng.randrange(HEADER_SIZE, len(b)) & ~1] = rng.randrange(256)
        elif kind == 2:  # a run's length
            b[rng.randrange(HEADER_SIZE, len(b)) | 1] = rng.randrange(256)
        elif kind == 3:  # the header's sizes
            b[rng.randrange(8)] = rng.randrange(256)
        else:  # a colour that means something
            b[rng.randrange(HEADER_SIZE, len(b)) & ~1] = rng.choice(
                (0, 1, 2, 3, 4, 5, 13, 16, 20, 30, 40, 51, 52, 61, 71, 81, 91, 99, 101, 171, 255)
            )
    return bytes(b)


def _pixel_mutation(data: bytes, rng: random.Random) -> bytes:
    """One pixel of the raster changed: the layout survives, so the reader gets past the
    container to the rows (raw byte mutations mostly break the run lengths)."""
    raster = read_raster(data).copy()
    height, width = raster.shape
    for _ in range(rng.randint(1, 3)):
        y, x = rng.randrange(5, height - 8), rng.randrange(10, width - 10)
        raster[y, x] = rng.choice((0, 1, 2, 3, 11, 12, 13, 16, 20, 30, 51, 52, 99, 101, 255))
    return pack(raster)


@pytest.mark.parametrize("seed", range(4))
def test_mutated_dats_are_refused_with_a_diagnostic_or_read_to_valid_knitout(seed):
    rng = random.Random(seed)
    datas = [p.read_bytes() for p in CORPUS]
    read = 0
    for _ in range(80):
        source = rng.choice(datas)
        data = _mutate(source, rng) if rng.random() < 0.5 else _pixel_mutation(source, rng)
        prog, diags = read_dat(data, "m.dat")
        if prog is None:
            assert [d.code for d in diags.sorted()] == ["E902"]
            continue
        read += 1
        text = write_knitout(prog)
        errors = [d for d in lint_text(text, "m.k").sorted() if d.is_error]
        assert not errors, errors[0]
    assert read  # some mutations are harmless, and those must read
