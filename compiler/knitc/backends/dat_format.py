"""The DAT container and raster: `DatImage` <-> bytes, and the conformance rows.

A Shima DAT is an indexed-colour raster (shared/research/knitout-and-dat.md §2.1, §2.2):

    0x000  u16 LE x-min = 0, y-min = 0, x-max = W - 1, y-max = H - 1, 1000, (zero), 1000 at 0x010
    0x200  the fixed 768-byte palette (display only, but kept byte-identical to the converter's)
    0x500  zero padding
    0x600  run-length pairs (colour, length 0..255), row by row, bottom row first

and the raster is laid out around the P = max_slot - min_slot + 1 slot columns and the N passes:
W = P + 110 (10 margin, 40 option bar, 4 gap, 1 stop-mark column on each side) and H = N + 19
(5 blank rows, 3 fixed start courses, the passes, 3 fixed end courses, 1 blank, the width row,
6 rows above it). `DatImage` holds only the passes and the few facts that vary (slot range,
position code, the carriage's side at the end); everything else here is fixed layout, so
`encode` renders it and `decode` checks that it is there.

Conventions a reader has to choose, because the raster does not record them:

* **Slot numbers.** A DAT stores slot columns, not needle numbers. `decode` numbers them from
  the position code when there is one (code p >= 1 gives min_slot = p: that is exactly what the
  converter's ``Position: Keep`` writes, and for ``Left``/``Center`` it is a placement that
  ``Keep`` reproduces byte for byte), else from 1; ``decode(data, min_slot=k)`` overrides this.
* **Position code.** ``None`` and 0 are written identically (no code; the converter writes 0
  for ``Position: Right``, "let KnitPaint place it"), and `decode` always returns an int.

`decode` rejects any raster pixel that the layout does not account for, since the image could
not carry it; with ``strict=True`` it also rejects what `DatImage` does not model at all (header
words, palette, a non-canonical run-length form), so that ``encode(decode(b, strict=True)) == b``.

The runs `encode` writes are the converter's, byte for byte: greedy, split at 255, never
crossing a row end, plus one quirk: after a run whose length is a multiple of 255 and that
another colour follows in the same row, the converter also writes a 0-length pair of the run's
colour (a row of 255 transfers, a gap of 255 empty slots, a 245-slot design's width row).
Readers skip it; `read_raster` accepts it, and with ``strict=True`` requires it where the
converter writes it and nowhere else (the fixtures `rle_*` in tests/fixtures/dat/ are the
converter's own files for these cases).
"""

from __future__ import annotations

import re
from itertools import chain
from typing import TYPE_CHECKING

from knitc.backends.dat import (
    KNIT_B,
    KNIT_F,
    KNIT_FB,
    LEFT,
    MISS_F,
    N_OPTIONS,
    NONE,
    RIGHT,
    STOP,
    DatImage,
    DatPass,
    Row,
)

if TYPE_CHECKING:
    import numpy as np

# numpy is imported by the functions that use it, not here: `encode` does without it (the
# rows of a DAT are a few hundred bytes each), so `knitc k2dat` never loads it.

__all__ = ["DatError", "PALETTE", "decode", "encode", "pack", "read_raster", "render", "rows"]


class DatError(ValueError):
    """A DAT that cannot be read, or an image that cannot be written, with the reason and,
    when one pixel is to blame, its raster row `y` (0 = bottom) and column `x`, so that a
    reader can point at it."""

    def __init__(self, message: str, y: int | None = None, x: int | None = None) -> None:
        super().__init__(message)
        self.y = y
        self.x = x


# --- container ------------------------------------------------------------------------------

HEADER_SIZE = 0x600
PALETTE_OFFSET = 0x200
PADDING_OFFSET = 0x500
MAGIC = 1000
"""The two header words at 0x008 and 0x010; their meaning is unknown (§2.10)."""
MAX_RUN = 255
MAX_SIDE = 0xFFFE
"""Largest width/height: the sizes are u16 and the converter asserts both are < 0xFFFF."""

# The converter's palette (its comment: copied from an "argyle" KnitPaint pattern): three
# 256-byte planes R, G, B, each apparently stored with pairs of entries swapped (§2.1).
# KnitPaint most likely reads it for display only; it is kept identical so that knitc's DATs
# are byte-identical with the converter's. SHA-256 49205708dfab...3631ca (checked in the tests).
_PALETTE_HEX = (
    # red plane
    "ff00ff00ff00ff006c4affb4999080cf5251eb00fcb2fcfcfcfc64d8eba09073"
    "9d73d8ebffb4acd7d87fd890cad8aebc809fffdcfcc0d8fc90fffdb400a03232"
    "0035d8d8a8c0ff99b700e2c590c090904a00906d00006633859978cab4907dff"
    "ffff7f69fa81fcac7fb2b4b4b4d4ff90ffc0c073d8a9bfb4ff90d8b2aa00d800"
    "fb90819d37acddbfb93fefd7defdfe732f8dfbfffeed06f5eaedad3dfcfaeffd"
    "668d7f7a5f799b71ffeea8ff9fdbf5ffcdf3e0fec879731fbfe5f3f6e0def0cc"
    "4b6440a1f71ae067ff64f53f97ef1496d767b7eebaea6cbd264e642fbf9f7ff3"
    "aaffe6bf57eb06fe4fed6aef62b7ddcf666bb27a5af79c4c969d00006ec80064"
    # green plane
    "0000ffff0000ffff248967b4996c809091ffeb7cb4766c94b4d8c890ac66d873"
    "7fb2d8eb00b4acc34800d86ca7b48d9a607f9076fcfffcfcff90eb90ffffcae9"
    "d5af6c6c5460ff66bca0c5aecfffb4d88970c0a59966c1ad7ad630286c488f00"
    "9966003fa364d8eb7fb26c90d895bf6ccfcf90b2d8e56ad8ddd8b47300009d96"
    "fd65df5a9dacf3dff76effdbfffbfbab31c7faaf6aaf039dfeea0c9fdea7f57d"
    "00c7ff67bf7f7f87fccebf2f6fbebafdf25f2ddfc87f5bb5776f8fdb927ef05f"
    "ff9d40baf7ec6dfb646496e3c7f7d3ffaf7ff5f673f7b25a5f8889b7bcfd7fe9"
    "7f7e2ffa7cf703a5c7eafb8dffff795b00e78d67b9ec59f700bd96af00007d64"
    # blue plane
    "00000000ffffffff9099bdd899b4ffc0dbde24916cb24863fcfcc8fceb0048b2"
    "017348aca06cebe1907ffcd8e1d8f546ffff9075b4904890c0cfc790ffffe9e9"
    "00edb4d8b4b4ffffbca0b2b7c0cffcfc9999cfb4ffffffff03ff9c91d8b4a58f"
    "d2bb0024b90c6cac00736c48d895bf6c9090cfb2b4e76990adfc6c73007f4900"
    "fefda56f7fff7bbeab1167ffb9559d7ffbde7f7f7ffbf093fefbebbfef5df7fc"
    "8adeff963abddfbbf83db0cf9efe5ffdf3d9ff93c8bdaa37fd817fbeff7ff091"
    "4b4c404b67ceffa97dff64d36ff7b4f7adcffce9cd7f81af64f751f5a47ddf3f"
    "cff7fdf97fdff04d5ffbfffb4fdfa9f08a45ba96fcbd09b700f2000000000064"
)
PALETTE = bytes.fromhex(_PALETTE_HEX)


def _header(width: int, height: int) -> bytes:
    head = bytearray(HEADER_SIZE)
    head[4:8] = (width - 1).to_bytes(2, "little") + (height - 1).to_bytes(2, "little")
    head[8:10] = MAGIC.to_bytes(2, "little")
    head[0x10:0x12] = MAGIC.to_bytes(2, "little")
    head[PALETTE_OFFSET:PADDING_OFFSET] = PALETTE
    return bytes(head)


def _rle(raster: np.ndarray) -> bytes:
    """The converter's run-length pairs, row by row: a run starts at every row start and every
    colour change, a run longer than 255 becomes 255-runs plus the remainder, and a run whose
    length is a multiple of 255 and that another colour follows in its row also gets a
    0-length pair of its colour. That last pair is what the converter's encoder writes (it
    flushes at 255 and then flushes the empty run again at the colour change); readers skip
    it, and writing it keeps knitc's DATs byte-identical with the converter's."""
    import numpy as np

    height, width = raster.shape
    flat = raster.reshape(-1)
    starts_mask = np.ones((height, width), dtype=bool)
    starts_mask[:, 1:] = raster[:, 1:] != raster[:, :-1]
    starts = np.flatnonzero(starts_mask)
    lengths = np.diff(starts, append=flat.size)
    full = (lengths + MAX_RUN - 1) // MAX_RUN
    empty = (lengths % MAX_RUN == 0) & ((starts + lengths) % width != 0)
    pieces = full + empty
    out_lengths = np.full(int(pieces.sum()), MAX_RUN, dtype=np.int64)
    last = np.cumsum(pieces) - 1
    out_lengths[last] = np.where(empty, 0, lengths - MAX_RUN * (full - 1))
    pairs = np.empty((out_lengths.size, 2), dtype=np.uint8)
    pairs[:, 0] = np.repeat(flat[starts], pieces)
    pairs[:, 1] = out_lengths
    return pairs.tobytes()


def pack(raster: np.ndarray) -> bytes:
    """The DAT bytes of a raster (row 0 = bottom row, the first in the file)."""
    import numpy as np

    if raster.ndim != 2 or raster.dtype != np.uint8:
        raise DatError("a DAT raster is a 2-D array of uint8 colour indices")
    height, width = raster.shape
    if not (1 <= width <= MAX_SIDE and 1 <= height <= MAX_SIDE):
        raise DatError(f"a {width} x {height} raster does not fit a DAT (each side 1..{MAX_SIDE})")
    return _header(width, height) + _rle(raster)


def _u16(data: bytes, offset: int) -> int:
    return int.from_bytes(data[offset : offset + 2], "little")


def read_raster(data: bytes, *, strict: bool = False, max_width: int = MAX_SIDE) -> np.ndarray:
    """The raster of DAT bytes (row 0 = bottom). Checks the header sizes (width at most
    `max_width`: a reader passes its bed plus the margins, so a header asking for more than
    any machine knits is refused before the raster is allocated) and that the runs fill
    exactly W x H pixels; `strict` also wants the converter's header words, palette, padding and
    canonical (greedy, per-row) runs, i.e. ``pack(read_raster(b, strict=True)) == b``."""
    import numpy as np

    data = bytes(data)
    if len(data) < HEADER_SIZE:
        raise DatError(
            f"truncated DAT: {len(data)} bytes, shorter than the {HEADER_SIZE}-byte header"
        )
    if (len(data) - HEADER_SIZE) % 2:
        raise DatError("truncated DAT: the run-length data has an odd number of bytes")
    x_min, y_min, x_max, y_max = (_u16(data, k) for k in (0, 2, 4, 6))
    if x_min or y_min:
        raise DatError(f"DAT header gives x-min {x_min}, y-min {y_min}; only 0, 0 is supported")
    width, height = x_max + 1, y_max + 1
    if width > max_width or height > MAX_SIDE:
        raise DatError(
            f"DAT header gives a {width} x {height} raster; the largest this reader takes is "
            f"{max_width} x {MAX_SIDE} (the bed's needles plus {2 * SIDE} columns of margins "
            "and option bars)"
        )
    if strict:
        _check_container(data)
    runs = np.frombuffer(data, dtype=np.uint8, offset=HEADER_SIZE).reshape(-1, 2)
    lengths = runs[:, 1].astype(np.int64)
    total, wanted = int(lengths.sum()), width * height
    if total != wanted:
        if total < wanted:
            raise DatError(
                f"truncated DAT: the run-length data gives {total} pixels, the "
                f"{width} x {height} raster needs {wanted}"
            )
        raise DatError(
            f"DAT run-length data overflows: {total} pixels for a "
            f"{width} x {height} raster of {wanted}"
        )
    raster = np.repeat(runs[:, 0], lengths).reshape(height, width)
    if strict and _rle(raster) != data[HEADER_SIZE:]:
        raise DatError(
            "DAT run-length data is not in the canonical form (one greedy run per "
            "colour change, split at 255, never crossing a row end, a 0-length run "
            "after a multiple of 255 that another colour follows)"
        )
    return raster


def _check_container(data: bytes) -> None:
    for offset in (8, 0x10):
        if _u16(data, offset) != MAGIC:
            raise DatError(
                f"DAT header word at 0x{offset:03x} is {_u16(data, offset)}, not {MAGIC}"
            )
    zero = data[0xA:0x10] + data[0x12:PALETTE_OFFSET] + data[PADDING_OFFSET:HEADER_SIZE]
    if any(zero):
        raise DatError("DAT header has non-zero bytes outside its size and magic words")
    if data[PALETTE_OFFSET:PADDING_OFFSET] != PALETTE:
        raise DatError("DAT palette differs from the converter's fixed palette")


# --- raster layout --------------------------------------------------------------------------

SLOT_X = 55
"""x of the first slot column (10 margin + 40 option bar + 4 gap + the stop-mark column)."""
SIDE = 55
"""Columns on each side of the slot band."""
PASS_Y = 8
"""y of the first pass row: 5 blank rows and the 3 fixed start courses below it."""
TOP = 11
"""Rows above the last pass: 3 fixed end courses, 1 blank, the width row and 6 more."""
POSITION_X = 48
"""x of the position code (the L1 value column), in the width row and the row above."""


def _l_value_x() -> np.ndarray:
    """L1..L20 value columns (x = 50 - 2o); each marker sits just right of its value."""
    import numpy as np

    return np.arange(48, 9, -2)


def _r_value_x(p: int) -> np.ndarray:
    """R1..R20 value columns (x = 59 + P + 2o); each marker sits just left of its value."""
    import numpy as np

    return np.arange(61 + p, 100 + p, 2)


def _fixed_bars(right: dict[int, int], left: dict[int, int]) -> tuple[list[int], list[int]]:
    lv, rv = [0] * N_OPTIONS, [0] * N_OPTIONS
    for k, v in left.items():
        lv[k - 1] = v
    for k, v in right.items():
        rv[k - 1] = v
    return lv, rv


# The fixed courses (§2.5): (colour over every slot, direction, L values, R values). All run
# without yarn (R3 255), ignore the links process (R9 1) and use L4 10 and stitch 0.
_START = [
    (MISS_F, RIGHT, *_fixed_bars({3: 255, 9: 1}, {4: 10})),
    (KNIT_F, LEFT, *_fixed_bars({3: 255, 9: 1}, {4: 10})),
    (KNIT_B, RIGHT, *_fixed_bars({3: 255, 9: 1}, {4: 10})),
]


def _end_courses(carriage_left: bool) -> list[tuple[int, int, list[int], list[int]]]:
    """The 3 fixed end courses; the first carries a carriage move (R5 2) when the carriage is
    on the left, the last knits both beds at quarter pitch (L3 1) with drop detection (R7 11)."""
    move = {5: 2} if carriage_left else {}
    return [
        (KNIT_F, LEFT, *_fixed_bars({3: 255, 9: 1, **move}, {4: 10})),
        (KNIT_B, RIGHT, *_fixed_bars({3: 255, 9: 1}, {4: 10})),
        (KNIT_FB, LEFT, *_fixed_bars({3: 255, 7: 11, 9: 1}, {3: 1, 4: 10})),
    ]


def _slot_range(image: DatImage) -> int:
    p = image.max_slot - image.min_slot + 1
    if p < 1:
        raise DatError(f"empty slot range {image.min_slot}..{image.max_slot}")
    return p


def _option_matrix(passes: list[DatPass], side: str) -> np.ndarray:
    import numpy as np

    values = [p.left if side == "L" else p.right for p in passes]
    for i, v in enumerate(values):
        if len(v) != N_OPTIONS:
            raise DatError(f"pass {i}: {len(v)} {side} option values, not {N_OPTIONS}")
    matrix = np.array(values, dtype=np.int64).reshape(len(values), N_OPTIONS)
    bad = np.argwhere((matrix < 0) | (matrix > 255))
    if bad.size:
        i, k = bad[0]
        raise DatError(
            f"pass {i}: option {side}{k + 1} = {matrix[i, k]} does not fit a colour index (0..255)"
        )
    return matrix


def render(image: DatImage) -> np.ndarray:
    """The raster of an image (row 0 = bottom), with the fixed courses, width row and position
    code added. Raises DatError for an image no DAT can hold."""
    import numpy as np

    p = _slot_range(image)
    passes = image.passes
    n = len(passes)
    width, height = p + 2 * SIDE, n + PASS_Y + TOP
    if width > MAX_SIDE or height > MAX_SIDE:
        raise DatError(f"a {width} x {height} raster does not fit a DAT (each side <= {MAX_SIDE})")
    raster = np.zeros((height, width), dtype=np.uint8)

    # Pass slots, scattered in one go (the program may have 100k ops).
    counts = np.fromiter((len(q.slots) for q in passes), dtype=np.int64, count=n)
    if n and counts.min() == 0:
        raise DatError(f"pass {int(np.argmin(counts))} uses no slot")
    total = int(counts.sum())
    slots = np.fromiter(chain.from_iterable(q.slots for q in passes), np.int64, total)
    codes = np.fromiter(chain.from_iterable(q.slots.values() for q in passes), np.int64, total)
    pass_of = np.repeat(np.arange(n), counts)
    outside = np.flatnonzero((slots < image.min_slot) | (slots > image.max_slot))
    if outside.size:
        k = outside[0]
        raise DatError(
            f"pass {pass_of[k]}: slot {slots[k]} outside the image's slot range "
            f"{image.min_slot}..{image.max_slot}"
        )
    bad = np.flatnonzero((codes < 1) | (codes > 255) | (codes == STOP))
    if bad.size:
        k = bad[0]
        raise DatError(
            f"pass {pass_of[k]}: slot {slots[k]} has colour {codes[k]}; a slot "
            f"colour is 1..255 and not the stop mark {STOP}"
        )
    x = slots - image.min_slot + SLOT_X
    ys = pass_of + PASS_Y
    raster[ys, x] = codes
    if n:
        offsets = np.concatenate(([0], np.cumsum(counts)[:-1]))
        rows_y = np.arange(n) + PASS_Y
        raster[rows_y, np.minimum.reduceat(x, offsets) - 1] = STOP
        raster[rows_y, np.maximum.reduceat(x, offsets) + 1] = STOP

    # Fixed courses: every slot, stop marks at both ends.
    fixed = _START + _end_courses(image.carriage_left_at_end)
    fixed_y = [5, 6, 7, n + 8, n + 9, n + 10]
    for y, (colour, _, _, _) in zip(fixed_y, fixed, strict=True):
        raster[y, SLOT_X : SLOT_X + p] = colour
        raster[y, SLOT_X - 1] = raster[y, SLOT_X + p] = STOP

    # Option bars of every course (fixed and pass rows): markers, values, direction.
    directions = [q.direction for q in passes]
    bad_dir = [i for i, d in enumerate(directions) if d not in (RIGHT, LEFT, NONE)]
    if bad_dir:
        i = bad_dir[0]
        raise DatError(
            f"pass {i}: direction code {directions[i]} is not "
            f"{RIGHT} (right), {LEFT} (left) or {NONE} (none)"
        )
    course_y = np.array(fixed_y[:3] + list(range(PASS_Y, PASS_Y + n)) + fixed_y[3:])
    course_dir = np.array([f[1] for f in fixed[:3]] + directions + [f[1] for f in fixed[3:]])
    lefts = np.vstack(
        [
            np.array([f[2] for f in fixed[:3]]),
            _option_matrix(passes, "L"),
            np.array([f[2] for f in fixed[3:]]),
        ]
    )
    rights = np.vstack(
        [
            np.array([f[3] for f in fixed[:3]]),
            _option_matrix(passes, "R"),
            np.array([f[3] for f in fixed[3:]]),
        ]
    )
    markers = np.arange(1, N_OPTIONS + 1)
    l_x, r_x = _l_value_x(), _r_value_x(p)
    raster[course_y[:, None], l_x] = lefts
    raster[course_y[:, None], l_x + 1] = markers
    raster[course_y[:, None], r_x] = rights
    raster[course_y[:, None], r_x - 1] = markers
    raster[course_y, l_x[0] + 1] = course_dir
    raster[course_y, r_x[0] - 1] = course_dir

    # Width row (slots min-5 .. max+5) and the position code in the L1 value column.
    width_y = height - 7
    raster[width_y, SLOT_X - 5 : SLOT_X + p + 5] = 1
    pos = image.position or 0
    if not 0 <= pos <= 255 * 100 + 99:
        raise DatError(f"position code {pos} does not fit a DAT (0..25599)")
    raster[width_y, POSITION_X] = pos % 100
    raster[width_y + 1, POSITION_X] = pos // 100
    return raster


def encode(image: DatImage) -> bytes:
    """The DAT bytes of an image: header, the converter's palette, greedy row-by-row runs."""
    data = _encode_rows(image)
    return data if data is not None else pack(render(image))


# `encode` without numpy: the raster built row by row as bytes (each row the left option bar,
# the slot band, the right option bar) and run-length encoded row by row, a row seen before
# (most of a fabric's) from a cache. Exactly `pack(render(image))` for any image `render`
# takes; anything it might refuse (or take only after converting, such as a float or a numpy
# number) makes it give up, and `render` then raises or converts as it does.

_RUN = re.compile(rb"(.)\1*", re.S)
_L_MARKERS = bytes(range(N_OPTIONS, 0, -1))
_R_MARKERS = bytes(range(1, N_OPTIONS + 1))
_BAR = SLOT_X - 1
"""Columns left of the slot band (margin, L option bar, gap), and right of it."""


def _left_bar(values: list[int], direction: int) -> bytes:
    """Columns 0..53 of a course: L20..L1 values at x = 10, 12, .., 48, each with its marker
    (20..1) just right of it, the L1 marker being the direction code."""
    bar = bytearray(_BAR)
    bar[10:50:2] = bytes(reversed(values))
    bar[11:50:2] = _L_MARKERS
    bar[49] = direction
    return bytes(bar)


def _right_bar(values: list[int], direction: int) -> bytes:
    """The 54 columns right of the slot band: R1..R20 values at 5, 7, .., 43 past it, each with
    its marker (1..20) just left of it, the R1 marker being the direction code."""
    bar = bytearray(_BAR)
    bar[5:44:2] = bytes(values)
    bar[4:43:2] = _R_MARKERS
    bar[4] = direction
    return bytes(bar)


def _band(slots: dict[int, int], lo: int, p: int) -> bytearray | None:
    """The slot band of a pass (stop-mark column to stop-mark column, P + 2 wide), or None if
    a slot is outside lo..lo + P - 1 or its colour is not one a slot can have."""
    band = bytearray(p + 2)
    keys = list(slots)
    k0, m = keys[0], len(keys)
    if keys == list(range(k0, k0 + m)):  # a pass to the right: slots in order
        first, last = k0, k0 + m - 1
        codes = bytes(slots.values())
    elif keys == list(range(k0, k0 - m, -1)):  # to the left
        first, last = k0 - m + 1, k0
        codes = bytes(reversed(slots.values()))
    else:
        first, last = min(keys), max(keys)
        if first < lo or last >= lo + p:
            return None
        for s, c in slots.items():
            if c == 0 or c == STOP:
                return None
            band[s - lo + 1] = c
        band[first - lo] = band[last - lo + 2] = STOP
        return band
    if first < lo or last >= lo + p or 0 in codes or STOP in codes:
        return None
    band[first - lo + 1 : last - lo + 2] = codes
    band[first - lo] = band[last - lo + 2] = STOP
    return band


def _encode_rows(image: DatImage) -> bytes | None:
    """`pack(render(image))` without numpy, or None (see above)."""
    lo, pos = image.min_slot, image.position or 0
    if type(lo) is not int or type(image.max_slot) is not int or type(pos) is not int:
        return None
    p, passes = image.max_slot - lo + 1, image.passes
    n = len(passes)
    width, height = p + 2 * SIDE, n + PASS_Y + TOP
    if p < 1 or width > MAX_SIDE or height > MAX_SIDE or not 0 <= pos <= 255 * 100 + 99:
        return None
    lefts: dict[tuple[object, ...], bytes] = {}
    rights: dict[tuple[object, ...], bytes] = {}

    def course(band: bytes | bytearray, direction: int, left: list[int], right: list[int]) -> bytes:
        lkey, rkey = (direction, *left), (direction, *right)
        lbar, rbar = lefts.get(lkey), rights.get(rkey)
        if lbar is None:
            lbar = lefts[lkey] = _left_bar(left, direction)
        if rbar is None:
            rbar = rights[rkey] = _right_bar(right, direction)
        return b"".join((lbar, band, rbar))

    def fixed(courses: list[tuple[int, int, list[int], list[int]]]) -> list[bytes]:
        return [
            course(bytes((STOP,)) + bytes((colour,)) * p + bytes((STOP,)), d, left, right)
            for colour, d, left, right in courses
        ]

    blank = bytes(width)
    try:
        rows = [blank] * 5 + fixed(_START)
        for q in passes:
            slots, d = q.slots, q.direction
            if (
                not slots
                or d not in (RIGHT, LEFT, NONE)
                or len(q.left) != N_OPTIONS
                or len(q.right) != N_OPTIONS
            ):
                return None
            band = _band(slots, lo, p)
            if band is None:
                return None
            rows.append(course(band, d, q.left, q.right))
        rows += fixed(_end_courses(image.carriage_left_at_end))
    except (TypeError, ValueError, AttributeError):  # a value that is no byte, or no dict
        return None
    width_row = bytearray(width)
    width_row[SLOT_X - 5 : SLOT_X + p + 5] = bytes((1,)) * (p + 10)
    width_row[POSITION_X] = pos % 100
    above = bytearray(width)
    above[POSITION_X] = pos // 100
    rows += [blank, bytes(width_row), bytes(above)] + [blank] * (TOP - 6)
    assert len(rows) == height
    return _header(width, height) + _runs(rows)


def _runs(rows: list[bytes]) -> bytes:
    """`_rle` of the raster whose rows (bottom first) are `rows`."""
    done: dict[bytes, bytes] = {}
    out = []
    for row in rows:
        runs = done.get(row)
        if runs is None:
            pairs = bytearray()
            end = len(row)
            for m in _RUN.finditer(row):
                start, stop = m.span()
                colour, length = row[start], stop - start
                while length > MAX_RUN:
                    pairs += bytes((colour, MAX_RUN))
                    length -= MAX_RUN
                pairs += bytes((colour, length))
                if length == MAX_RUN and stop != end:
                    pairs += bytes((colour, 0))  # the converter's quirk (see `_rle`)
            runs = done[row] = bytes(pairs)
        out.append(runs)
    return b"".join(out)


# --- reading --------------------------------------------------------------------------------


def _describe(y: int, x: int, p: int, n: int) -> str:
    """Where a pixel sits in the layout, for error messages."""
    if y < 5:
        row = f"row {y} (blank)"
    elif y < PASS_Y:
        row = f"row {y} (fixed start course {y - 4})"
    elif y < PASS_Y + n:
        row = f"row {y} (pass {y - PASS_Y})"
    elif y < PASS_Y + n + 3:
        row = f"row {y} (fixed end course {y - PASS_Y - n + 1})"
    elif y == PASS_Y + n + 4:
        row = f"row {y} (width row)"
    else:
        row = f"row {y} (blank)"
    if x < 10 or x >= 100 + p:
        col = "margin"
    elif x < 50:
        o = (51 - x) // 2
        col = f"L{o} {'marker' if (x % 2) else 'value'}"
    elif x < SLOT_X - 1 or SLOT_X + p < x < 60 + p:
        col = "gap"
    elif x == SLOT_X - 1 or x == SLOT_X + p:
        col = "stop-mark column"
    elif x < SLOT_X + p:
        col = f"slot column {x - SLOT_X}"
    else:
        o = (x - 58 - p) // 2
        col = f"R{o} {'value' if (x - p) % 2 else 'marker'}"
    return f"{row}, x {x} ({col})"


def _geometry(raster: np.ndarray) -> tuple[int, int]:
    height, width = raster.shape
    if width < 2 * SIDE + 1:
        raise DatError(
            f"DAT raster is {width} wide; the layout needs at least {2 * SIDE + 1} "
            "(110 columns of margins and option bars plus one slot)"
        )
    if height < PASS_Y + TOP:
        raise DatError(
            f"DAT raster is {height} high; the layout needs at least "
            f"{PASS_Y + TOP} rows (blank, fixed and width rows)"
        )
    return width - 2 * SIDE, height - PASS_Y - TOP


def _first(mask: np.ndarray) -> int | None:
    """The first row index where `mask` holds, or None."""
    import numpy as np

    hits = np.flatnonzero(mask)
    return int(hits[0]) if hits.size else None


def _read_passes(raster: np.ndarray, p: int, n: int, min_slot: int) -> list[DatPass]:
    """The pass rows, vectorised over rows: stop marks, slots between them, option bars."""
    import numpy as np

    body = raster[PASS_Y : PASS_Y + n]
    band = body[:, SLOT_X - 1 : SLOT_X + p + 1].astype(np.int64)
    stop = band == STOP
    stops = stop.sum(axis=1)
    if (i := _first(stops != 2)) is not None:
        raise DatError(
            f"{_describe(PASS_Y + i, SLOT_X, p, n)}: a pass row has "
            f"{stops[i]} stop marks ({STOP}) over its slots, not 2",
            y=PASS_Y + i,
            x=SLOT_X,
        )
    first = np.argmax(stop, axis=1)
    last = band.shape[1] - 1 - np.argmax(stop[:, ::-1], axis=1)
    rows_i = np.arange(n)
    loose = (
        (last - first < 2)
        | (band[rows_i, first + 1] == 0)
        | (band[rows_i, np.maximum(last - 1, 0)] == 0)
    )
    if (i := _first(loose)) is not None:
        raise DatError(
            f"{_describe(PASS_Y + i, SLOT_X, p, n)}: the stop marks of a pass "
            "must sit right next to its first and last slot",
            y=PASS_Y + i,
            x=SLOT_X,
        )
    cols = np.arange(band.shape[1])
    inside = (cols > first[:, None]) & (cols < last[:, None])
    stray = np.argwhere((band != 0) & ~inside & ~stop)
    if stray.size:
        i, c = stray[0]
        raise DatError(
            f"{_describe(PASS_Y + int(i), SLOT_X - 1 + int(c), p, n)}: colour "
            f"{band[i, c]} outside the pass's stop marks",
            y=PASS_Y + int(i),
            x=SLOT_X - 1 + int(c),
        )
    ri, ci = np.nonzero(inside & (band != 0))
    slot_list = (ci - 1 + min_slot).tolist()
    code_list = band[ri, ci].tolist()
    bounds = np.searchsorted(ri, np.arange(n + 1)).tolist()

    l_x = _l_value_x()
    direction = body[:, l_x[0] + 1].astype(np.int64)
    r_x = _r_value_x(p)
    if (i := _first(direction != body[:, r_x[0] - 1])) is not None:
        raise DatError(
            f"{_describe(PASS_Y + i, 49, p, n)}: direction code "
            f"{direction[i]} differs from the right bar's {body[i, r_x[0] - 1]}",
            y=PASS_Y + i,
            x=49,
        )
    if (i := _first(~np.isin(direction, (RIGHT, LEFT, NONE)))) is not None:
        raise DatError(
            f"{_describe(PASS_Y + i, 49, p, n)}: direction code "
            f"{direction[i]} is not {RIGHT}, {LEFT} or {NONE}",
            y=PASS_Y + i,
            x=49,
        )
    lefts = body[:, l_x].tolist()
    rights = body[:, r_x].tolist()
    dirs = direction.tolist()
    return [
        DatPass(
            direction=dirs[i],
            slots=dict(
                zip(
                    slot_list[bounds[i] : bounds[i + 1]],
                    code_list[bounds[i] : bounds[i + 1]],
                    strict=True,
                )
            ),
            left=lefts[i],
            right=rights[i],
        )
        for i in range(n)
    ]


def decode(
    data: bytes, *, min_slot: int | None = None, strict: bool = False, max_width: int = MAX_SIDE
) -> DatImage:
    """The image of DAT bytes: the pass rows with the fixed courses stripped.

    Every pixel must be where the layout (module docstring) puts it; a DAT that is truncated,
    inconsistent or holds anything else raises DatError saying which row and column. Slots are
    numbered from `min_slot`, by default the position code if it is >= 1, else 1. With `strict`,
    the container must also be exactly the converter's (so ``encode(decode(b)) == b``);
    `max_width` bounds the raster's width (`read_raster`).
    """
    import numpy as np

    raster = read_raster(data, strict=strict, max_width=max_width)
    p, n = _geometry(raster)
    height = raster.shape[0]
    low, high = int(raster[height - 7, POSITION_X]), int(raster[height - 6, POSITION_X])
    if low > 99:
        raise DatError(
            f"{_describe(height - 7, POSITION_X, p, n)}: position code low part {low} is not 0..99",
            y=height - 7,
            x=POSITION_X,
        )
    position = high * 100 + low
    if min_slot is None:
        min_slot = position if position >= 1 else 1
    end_r5 = int(raster[PASS_Y + n, _r_value_x(p)[4]])
    if end_r5 not in (0, 2):
        raise DatError(
            f"{_describe(PASS_Y + n, int(_r_value_x(p)[4]), p, n)}: the first fixed "
            f"end course has R5 = {end_r5}, not 0 or 2 (carriage move)",
            y=PASS_Y + n,
            x=int(_r_value_x(p)[4]),
        )
    image = DatImage(
        passes=_read_passes(raster, p, n, min_slot),
        min_slot=min_slot,
        max_slot=min_slot + p - 1,
        position=position,
        carriage_left_at_end=end_r5 == 2,
    )
    expected = render(image)
    diff = np.argwhere(expected != raster)
    if diff.size:
        y, x = (int(v) for v in diff[0])
        raise DatError(
            f"{_describe(y, x, p, n)}: colour {raster[y, x]} where the DAT layout "
            f"has {expected[y, x]}",
            y=y,
            x=x,
        )
    return image


def rows(data_or_image: bytes | DatImage) -> list[Row]:
    """Every raster row, bottom first, in the conformance form: direction code (the L1 marker),
    L1..L20 and R1..R20 values, and the colours from the left stop-mark column to the right one.
    Only the container and the raster size are checked, so two DATs can be compared row by row
    even when one does not follow the layout."""

    if isinstance(data_or_image, DatImage):
        raster = render(data_or_image)
    else:
        raster = read_raster(data_or_image)
    height, width = raster.shape
    if width < 2 * SIDE + 1:
        raise DatError(f"DAT raster is {width} wide; the layout needs at least {2 * SIDE + 1}")
    p = width - 2 * SIDE
    l_x = _l_value_x()
    directions = raster[:, l_x[0] + 1].tolist()
    lefts = raster[:, l_x].tolist()
    rights = raster[:, _r_value_x(p)].tolist()
    bands = raster[:, SLOT_X - 1 : SLOT_X + p + 1].tolist()
    return [
        Row(
            y=y,
            direction=directions[y],
            left=tuple(lefts[y]),
            right=tuple(rights[y]),
            slots=tuple(bands[y]),
        )
        for y in range(height)
    ]
