"""The DAT container and raster (knitc.backends.dat_format): byte-for-byte round trips of the
CMU converter's fixtures, the layout rules of shared/research/knitout-and-dat.md §2.1-§2.5,
run-length edge cases, and clear DatErrors on damaged files."""

from __future__ import annotations

import hashlib
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from knitc.backends.dat import (
    KNIT_B,
    KNIT_F,
    KNIT_FB,
    LEFT,
    MISS_F,
    NONE,
    RIGHT,
    STOP,
    DatImage,
    DatPass,
)
from knitc.backends.dat_format import (
    HEADER_SIZE,
    PALETTE,
    DatError,
    decode,
    encode,
    pack,
    read_raster,
    render,
    rows,
)

FIXTURES = Path(__file__).resolve().parent / "fixtures" / "dat"
DATS = sorted(FIXTURES.glob("*.dat"))
NAMES = [p.stem for p in DATS]


def fixture(name: str) -> bytes:
    return (FIXTURES / f"{name}.dat").read_bytes()


def runs_of(data: bytes) -> np.ndarray:
    return np.frombuffer(data, dtype=np.uint8, offset=HEADER_SIZE).reshape(-1, 2)


# --- fixtures -------------------------------------------------------------------------------


def test_fixture_corpus_is_present() -> None:
    assert len(DATS) == 19


def test_palette_is_the_converters() -> None:
    assert len(PALETTE) == 768
    assert hashlib.sha256(PALETTE).hexdigest() == (
        "49205708dfab261492ddb5cca5fba552fdb9494a4e742c87c1a365e4eb3631ca"
    )
    for path in DATS:
        assert path.read_bytes()[0x200:0x500] == PALETTE


@pytest.mark.parametrize("name", NAMES)
def test_fixture_round_trips_byte_for_byte(name: str) -> None:
    data = fixture(name)
    image = decode(data, strict=True)
    assert encode(image) == data
    # the geometry rules: W = P + 110, H = N + 19, stored as x-max / y-max
    p = image.max_slot - image.min_slot + 1
    assert int.from_bytes(data[4:6], "little") + 1 == p + 110 == image.width
    assert int.from_bytes(data[6:8], "little") + 1 == len(image.passes) + 19 == image.height
    # the conformance rows are the same whether read from the bytes or rendered from the image
    assert rows(data) == rows(image)
    assert len(rows(data)) == image.height


@pytest.mark.parametrize("name", NAMES)
def test_fixture_fixed_rows(name: str) -> None:
    data = fixture(name)
    image = decode(data)
    table = rows(data)
    p, n = image.max_slot - image.min_slot + 1, len(image.passes)
    fixed = {
        5: (MISS_F, RIGHT),
        6: (KNIT_F, LEFT),
        7: (KNIT_B, RIGHT),
        n + 8: (KNIT_F, LEFT),
        n + 9: (KNIT_B, RIGHT),
        n + 10: (KNIT_FB, LEFT),
    }
    for y, (colour, direction) in fixed.items():
        row = table[y]
        assert row.slots == (STOP, *[colour] * p, STOP)
        assert row.direction == direction
        assert row.right[2] == 255 and row.right[8] == 1 and row.left[3] == 10
    assert table[n + 8].right[4] == (2 if image.carriage_left_at_end else 0)
    assert table[n + 10].left[2] == 1 and table[n + 10].right[6] == 11
    width_row = table[n + 12]
    assert width_row.slots == (1,) * (p + 2)
    assert width_row.left[0] == image.position % 100
    assert table[n + 13].left[0] == image.position // 100
    blank = [y for y in range(len(table)) if y not in fixed and not 8 <= y < 8 + n]
    for y in blank:
        assert table[y].direction == 0 and not any(table[y].right)
    for pass_row in table[8 : 8 + n]:
        assert pass_row.direction in (RIGHT, LEFT, NONE)
        used = [i for i, c in enumerate(pass_row.slots) if c]
        assert pass_row.slots[used[0]] == pass_row.slots[used[-1]] == STOP


def test_position_codes_and_slot_numbering() -> None:
    """Keep writes the first slot as the position code, so numbering from it gives back the
    program's needles (f21..b40 in pos_keep); Left is code 1, Center 115 on a 250 bed."""
    keep = decode(fixture("pos_keep"))
    assert (keep.position, keep.min_slot, keep.max_slot) == (21, 21, 40)
    assert decode(fixture("pos_left")).position == 1
    assert decode(fixture("pos_center")).position == 115
    # the three differ only in the position code (and so in the default numbering)
    left = decode(fixture("pos_left"))
    assert (left.min_slot, left.max_slot) == (1, 20)
    assert decode(fixture("pos_left"), min_slot=21).passes == keep.passes
    renumbered = decode(fixture("pos_center"), min_slot=21)
    assert renumbered.passes == keep.passes and renumbered.max_slot == 40


def test_fixture_pass_content() -> None:
    """A few pass rows read back as the converter wrote them (README / §3.3 numbers)."""
    image = decode(fixture("pos_keep"))
    first = image.passes[0]  # inhook 2, tucks leftward from b40 to f21
    assert first.direction == LEFT
    assert first.get("R3") == 2 and first.get("R15") == 10 and first.get("R10") == 2
    assert min(first.slots) == 21 and max(first.slots) == 40
    stitch = decode(fixture("stitch_number"))
    assert {q.get("R6") for q in stitch.passes} >= {20, 61, 0, 5, 85}
    assert decode(fixture("tube_20x200")).passes[100].slots.keys() == set(range(260, 280))


# --- the writer -----------------------------------------------------------------------------


def small_image(**kw) -> DatImage:
    q = DatPass(direction=RIGHT, slots={3: KNIT_F, 5: KNIT_B})
    q.set("R3", 4)
    return DatImage(passes=[q], min_slot=1, max_slot=6, **kw)


def test_render_layout_of_one_pass() -> None:
    raster = render(small_image(position=123, carriage_left_at_end=True))
    assert raster.shape == (20, 116)
    row = raster[8]
    assert row[49] == row[66] == RIGHT  # L1 / R1 markers hold the direction
    assert list(row[11:49:2]) == list(range(20, 1, -1))  # L20..L2 markers
    assert list(row[68:106:2]) == list(range(2, 21))  # R2..R20 markers
    assert row[67 + 4] == 4  # R3 value at x = 59 + P + 2*3
    assert list(row[54:62]) == [0, 0, STOP, KNIT_F, 0, KNIT_B, STOP, 0]
    assert raster[9, 75] == 2  # first end course, R5 (x = 59 + P + 10): carriage move
    assert list(raster[13, 50:66]) == [1] * 16  # width row
    assert raster[13, 48] == 23 and raster[14, 48] == 1  # position 123


def test_position_none_and_zero_are_the_same_bytes() -> None:
    assert encode(small_image(position=None)) == encode(small_image(position=0))
    assert decode(encode(small_image(position=None))).position == 0


@pytest.mark.parametrize(
    "change, message",
    [
        (lambda im: im.passes[0].slots.update({7: KNIT_F}), "outside the image's slot range"),
        (lambda im: im.passes[0].slots.update({2: STOP}), "not the stop mark"),
        (lambda im: im.passes[0].slots.update({2: 0}), "1..255"),
        (lambda im: im.passes[0].slots.update({2: 256}), "1..255"),
        (lambda im: im.passes[0].right.__setitem__(4, 300), "R5 = 300"),
        (lambda im: im.passes[0].left.append(0), "21 L option values"),
        (lambda im: im.passes[0].slots.clear(), "uses no slot"),
        (lambda im: setattr(im.passes[0], "direction", 2), "direction code 2"),
        (lambda im: setattr(im, "position", 25600), "position code 25600"),
        (lambda im: setattr(im, "max_slot", 0), "empty slot range"),
        (lambda im: setattr(im, "max_slot", 70000), "does not fit a DAT"),
    ],
)
def test_encode_rejects_images_no_dat_can_hold(change, message) -> None:
    image = small_image()
    change(image)
    with pytest.raises(DatError, match=message):
        encode(image)


def test_empty_program_has_only_fixed_rows() -> None:
    image = DatImage(passes=[], min_slot=1, max_slot=1)
    data = encode(image)
    assert decode(data) == DatImage(passes=[], min_slot=1, max_slot=1, position=0)
    assert len(rows(data)) == 19


# --- run-length edge cases ------------------------------------------------------------------


def test_long_runs_split_at_255() -> None:
    """A 710-pixel blank row is 255 + 255 + 200, each row encoded on its own."""
    image = DatImage(
        passes=[DatPass(direction=LEFT, slots={600: KNIT_F})], min_slot=1, max_slot=600
    )
    data = encode(image)
    runs = runs_of(data)
    assert runs[:15].tolist() == [[0, 255], [0, 255], [0, 200]] * 5
    assert decode(data, strict=True) == DatImage(
        passes=image.passes, min_slot=1, max_slot=600, position=0
    )


def test_rle_row_ending_in_a_different_pixel_and_exact_255_runs() -> None:
    """A run of 255 (or 510) that another colour follows gets the converter's 0-length pair;
    at a row end it does not. The converter's encoder would also lose a row's last pixel if it
    differed from its left neighbour; that never happens in a DAT (the right margin is blank),
    and `pack` keeps the pixel of any raster."""
    raster = np.zeros((3, 600), dtype=np.uint8)
    raster[0, 255:] = 9
    raster[0, -1] = 7
    raster[1, :255] = 3
    raster[1, 255:] = 4
    raster[2, 90:] = 5
    data = pack(raster)
    assert runs_of(data).tolist() == [
        [0, 255], [0, 0], [9, 255], [9, 89], [7, 1],
        [3, 255], [3, 0], [4, 255], [4, 90],
        [0, 90], [5, 255], [5, 255],
    ]  # fmt: skip
    assert np.array_equal(read_raster(data, strict=True), raster)


def assert_converter_runs(runs: np.ndarray, width: int, height: int) -> None:
    """The pairs are the converter's form: per row, each colour run is 255-pairs and a
    remainder of 1..255, plus a 0-length pair exactly when the run is a multiple of 255 and
    another colour follows it in the row."""
    pairs = runs.tolist()
    i = 0
    for _ in range(height):
        filled = 0
        groups: list[tuple[int, list[int]]] = []
        while filled < width:
            colour, length = pairs[i]
            i += 1
            if groups and groups[-1][0] == colour:
                groups[-1][1].append(length)
            else:
                groups.append((colour, [length]))
            filled += length
        assert filled == width  # no run crosses a row end
        for k, (_, lengths) in enumerate(groups):
            inner = k < len(groups) - 1
            body = lengths[:-1] if inner and lengths[-1] == 0 else lengths
            assert body and all(n == 255 for n in body[:-1]) and 1 <= body[-1] <= 255
            assert (lengths[-1] == 0) == (inner and body[-1] == 255)
    assert i == len(pairs)


@settings(max_examples=150, deadline=None)
@given(st.integers(1, 4), st.integers(1, 700), st.data())
def test_rle_round_trip_property(height: int, width: int, data) -> None:
    palette = data.draw(st.lists(st.integers(0, 255), min_size=1, max_size=3))
    # long stretches of one colour, so that runs over 255 and exact multiples occur
    cuts = sorted(data.draw(st.lists(st.integers(0, height * width), max_size=6)))
    raster = np.zeros(height * width, dtype=np.uint8)
    for start, stop in zip([0, *cuts], [*cuts, height * width], strict=True):
        raster[start:stop] = data.draw(st.sampled_from(palette))
    raster = raster.reshape(height, width)
    packed = pack(raster)
    assert_converter_runs(runs_of(packed), width, height)
    assert np.array_equal(read_raster(packed, strict=True), raster)


def test_lenient_reader_accepts_non_canonical_runs() -> None:
    """Zero-length runs and split runs decode to the same raster; only strict refuses them."""
    data = fixture("plain_in_out")
    runs = runs_of(data).tolist()
    colour, length = runs[0]
    tweaked = [[colour, 0], [colour, length - 1], [colour, 1], *runs[1:]]
    other = data[:HEADER_SIZE] + np.array(tweaked, dtype=np.uint8).tobytes()
    assert decode(other) == decode(data)
    with pytest.raises(DatError, match="canonical"):
        decode(other, strict=True)


def test_converters_zero_run_after_an_exact_255_run() -> None:
    """Like the converter, the encoder writes (c, 255), (c, 0) when a run of exactly 255 is
    followed by another colour (here the gap between knits on f1 and f257). The form without
    the 0-length pair decodes to the same image, but only leniently."""
    image = DatImage(
        passes=[DatPass(direction=RIGHT, slots={1: KNIT_F, 257: KNIT_F})], min_slot=1, max_slot=257
    )
    data = encode(image)
    runs = runs_of(data).tolist()
    at = next(i for i in range(len(runs) - 2) if runs[i : i + 3] == [[0, 255], [0, 0], [KNIT_F, 1]])
    greedy = data[:HEADER_SIZE] + np.array(runs[: at + 1] + runs[at + 2 :], np.uint8).tobytes()
    assert decode(greedy) == decode(data, strict=True)
    assert encode(decode(greedy)) == data
    with pytest.raises(DatError, match="canonical"):
        decode(greedy, strict=True)


@pytest.mark.parametrize("name", ["rle_runs", "rle_sheet_145", "rle_sheet_245"])
def test_the_converters_run_edge_cases_re_encode_byte_for_byte(name: str) -> None:
    """The converter's own DATs for runs of 254, 255, 256, 510 and 511 pixels, a raster 255
    wide and a width row of 255 (tests/fixtures/dat/README.md): strict decoding accepts them
    and encoding gives them back."""
    data = fixture(name)
    raster = read_raster(data, strict=True)
    assert_converter_runs(runs_of(data), raster.shape[1], raster.shape[0])
    assert encode(decode(data, strict=True)) == data
    zero_pairs = {"rle_runs": 8, "rle_sheet_145": 0, "rle_sheet_245": 1}[name]
    assert int((runs_of(data)[:, 1] == 0).sum()) == zero_pairs


def test_strict_checks_the_container() -> None:
    data = bytearray(fixture("rib_2x2"))
    data[0x300] ^= 1
    assert decode(bytes(data)) == decode(fixture("rib_2x2"))
    with pytest.raises(DatError, match="palette"):
        decode(bytes(data), strict=True)
    data = bytearray(fixture("rib_2x2"))
    data[8] = 0
    with pytest.raises(DatError, match="header word at 0x008"):
        decode(bytes(data), strict=True)


# --- generated images -----------------------------------------------------------------------

SLOT_COLOURS = st.integers(1, 255).filter(lambda c: c != STOP)


@st.composite
def images(draw, *, keep_numbering: bool = True) -> DatImage:
    """Random images; with `keep_numbering` they follow decode's default slot numbering
    (min_slot = position code if >= 1, else 1) so that decode(encode(image)) == image."""
    position = draw(st.one_of(st.just(0), st.integers(1, 25599)))
    p = draw(st.integers(1, 40))
    min_slot = (position or 1) if keep_numbering else draw(st.integers(-50, 50))
    passes = []
    for _ in range(draw(st.integers(0, 6))):
        slots = draw(
            st.dictionaries(
                st.integers(min_slot, min_slot + p - 1), SLOT_COLOURS, min_size=1, max_size=p
            )
        )
        passes.append(
            DatPass(
                direction=draw(st.sampled_from([RIGHT, LEFT, NONE])),
                slots=slots,
                left=draw(st.lists(st.integers(0, 255), min_size=20, max_size=20)),
                right=draw(st.lists(st.integers(0, 255), min_size=20, max_size=20)),
            )
        )
    return DatImage(
        passes=passes,
        min_slot=min_slot,
        max_slot=min_slot + p - 1,
        position=position,
        carriage_left_at_end=draw(st.booleans()),
    )


@settings(max_examples=120, deadline=None)
@given(images())
def test_generated_images_round_trip(image: DatImage) -> None:
    data = encode(image)
    assert decode(data, strict=True) == image
    assert encode(decode(data)) == data
    assert rows(data) == rows(image)


@settings(max_examples=60, deadline=None)
@given(images(keep_numbering=False))
def test_generated_images_round_trip_with_explicit_numbering(image: DatImage) -> None:
    assert decode(encode(image), min_slot=image.min_slot) == image


# --- damaged input --------------------------------------------------------------------------


@pytest.mark.parametrize(
    "cut, message",
    [
        (0, "shorter than the"),
        (HEADER_SIZE - 1, "shorter than the"),
        (-1, "odd number of bytes"),
        (-2, "truncated DAT: the run-length data gives"),
        (HEADER_SIZE, "truncated DAT: the run-length data gives 0 pixels"),
    ],
)
def test_truncated_files(cut: int, message: str) -> None:
    with pytest.raises(DatError, match=message):
        decode(fixture("tuck_stitch")[:cut])


def test_overflow_and_wrong_sizes() -> None:
    data = fixture("tuck_stitch")
    with pytest.raises(DatError, match="overflows"):
        decode(data + b"\x00\x05")
    wider = bytearray(data)
    wider[4] += 1
    with pytest.raises(DatError, match="truncated"):
        decode(bytes(wider))
    shifted = bytearray(data)
    shifted[0] = 1
    with pytest.raises(DatError, match="x-min 1"):
        decode(bytes(shifted))
    tiny = pack(np.zeros((19, 100), dtype=np.uint8))
    with pytest.raises(DatError, match="at least 111"):
        decode(tiny)
    with pytest.raises(DatError, match="at least 111"):
        rows(tiny)
    with pytest.raises(DatError, match="at least 19 rows"):
        decode(pack(np.zeros((18, 120), dtype=np.uint8)))


def test_layout_errors_name_the_row_and_column() -> None:
    image = small_image()
    raster = render(image)
    stray = raster.copy()
    stray[8, 52] = 5
    with pytest.raises(DatError, match=r"row 8 \(pass 0\), x 52 \(gap\)"):
        decode(pack(stray))
    unfixed = raster.copy()
    unfixed[6, 57] = KNIT_B
    with pytest.raises(DatError, match=r"row 6 \(fixed start course 2\), x 57"):
        decode(pack(unfixed))
    no_stop = raster.copy()
    no_stop[8, 56] = 0
    with pytest.raises(DatError, match="1 stop marks"):
        decode(pack(no_stop))
    loose = raster.copy()
    loose[8, 57] = 0  # the mark at 56 no longer touches the first slot
    with pytest.raises(DatError, match="right next to"):
        decode(pack(loose))
    outside = raster.copy()
    outside[8, 55] = KNIT_F
    with pytest.raises(DatError, match="outside the pass's stop marks"):
        decode(pack(outside))
    arrow = raster.copy()
    arrow[8, 49] = LEFT
    with pytest.raises(DatError, match="differs from the right bar"):
        decode(pack(arrow))
    position = raster.copy()
    position[13, 48] = 150
    with pytest.raises(DatError, match="low part 150"):
        decode(pack(position))
    end = raster.copy()
    end[9, 75] = 1
    with pytest.raises(DatError, match="R5 = 1"):
        decode(pack(end))


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.sampled_from(["plain_in_out", "allneedle_quarter", "stripes_3_6"]), st.data())
def test_damaged_bytes_raise_only_dat_errors(name: str, data) -> None:
    raw = bytearray(fixture(name))
    for _ in range(data.draw(st.integers(1, 4))):
        kind = data.draw(st.sampled_from(["flip", "cut", "insert", "header"]))
        if kind == "flip" and raw:
            raw[data.draw(st.integers(0, len(raw) - 1))] = data.draw(st.integers(0, 255))
        elif kind == "header" and len(raw) >= 8:
            raw[data.draw(st.integers(0, 7))] = data.draw(st.integers(0, 255))
        elif kind == "cut":
            del raw[data.draw(st.integers(0, len(raw))) :]
        else:
            at = data.draw(st.integers(0, len(raw)))
            raw[at:at] = data.draw(st.binary(min_size=1, max_size=4))
    for read in (decode, rows):
        try:
            read(bytes(raw))
        except DatError:
            pass
    try:
        image = decode(bytes(raw), strict=True)
    except DatError:
        return
    assert encode(image) == raw


@settings(max_examples=300, deadline=None)
@given(st.sampled_from(["plain_in_out", "allneedle_quarter", "increase_split"]), st.data())
def test_damaged_pixels_are_rejected_or_read_faithfully(name: str, data) -> None:
    """Pixel damage gets past the RLE checks and reaches the layout checks: decode either
    names the problem or reads an image that writes back exactly the damaged raster."""
    raster = read_raster(fixture(name)).copy()
    height, width = raster.shape
    for _ in range(data.draw(st.integers(1, 3))):
        y = data.draw(st.integers(0, height - 1))
        x = data.draw(st.integers(0, width - 1))
        raster[y, x] = data.draw(st.sampled_from([0, 1, 2, 6, 7, STOP, KNIT_F, 255]))
    damaged = pack(raster)
    try:
        image = decode(damaged, strict=True)
    except DatError:
        return
    assert encode(image) == damaged
