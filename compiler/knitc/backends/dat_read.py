"""The DAT reader: `DatImage` -> `MachineProgram` (for `knitc dat2k`; Knitout text via
`knitc.backends.knitout.write_knitout`).

It inverts `knitc.backends.dat_write` (the CMU converter's algorithm), following
shared/research/knitout-and-dat.md §2.7 steps 5-6: one pass row after the other, and within
a row

1. ``pause`` if L7 = 20;
2. ``rack R`` when the row's racking differs from the current one (R from L2/L3/L4: L4 = 11
   gives R = L2 + 1, else R = -L2; plus 0.25 when L3 = 1);
3. settings when they change: ``x-stitch-number`` from R6 (rows other than transfers, whose
   R6 is the fixed transfer stitch 0; the state starts at the converter's default 5),
   ``x-speed-number`` from L5 (0, or K + 10), ``x-presser-mode on``/``off`` from R11 = 101
   on rows that do needle work (kick, release and carrier-out rows never carry the presser);
4. ``releasehook`` of the carriers of the last hook-in row when R15 = 90 (the release
   happens before its row);
5. ``in``/``inhook`` when R10 brings the row's carriers in (R10 = R3; with R15 = 10 the
   hook);
6. the row's needle ops: rightward rows by increasing slot, leftward rows by decreasing slot,
   transfer rows by increasing slot; in a quarter-pitch column the front op comes first
   going right and the back op first going left. A front op in slot s is on f(s), a back op
   on b(s - floor(R)). Codes: 51/52 knit (drop without carriers), 11/12 tuck (amiss without
   carriers), 3/41/42/88 the front+back pairs, 216/217 miss, 20/30 xfer (L13 = 1: to
   sliders, 3: from sliders), 101/102 split, 106..149 split via sliders (followed by the
   return transfers at their racking); carriers from R3 (255 and 0: none);
7. ``out``/``outhook`` when R10 = 100 + R3 (R15 = 20: the hook).

Soft misses (code 16) are the converter's own carrier motion: kickbacks, the release and
dummy rows, the carrier-out miss. By default they produce nothing, because Knitout's
kickbacks are implicit (spec §1.5): the writer puts them back where they were, so
``to_dat(dat_to_program(image))`` gives the same rows. With ``explicit_kicks=True`` each soft
miss of a row with carriers becomes ``miss D N CS`` instead, which shows the carrier motion
but converts back to explicit-miss colours (216/217), not to 16.

Carrier codes (R3, R10): 1..10 alone; a pair is its two numbers one after the other, leading
carrier first, with carrier 10 written ``0`` after any carrier but 1 (3 10 -> 30, 1 10 -> 110)
and ``10`` when it leads (10 3 -> 103, knitc's writer). The CMU converter writes 10 leading
as ``1`` (10 3 -> 13), which cannot be told from 1 3 and reads as 1 3; 11 can only be 10 1.

Placement: the position code p and the slot numbers give the ``;;Position:``. `dat_format.decode`
numbers slots from p when p >= 1, so a decoded image has ``min_slot == p`` and reads as
``Keep`` (``Left`` when p = 1), needles as placed on the bed; p = 0 reads as ``Right``; an
image numbered otherwise (``decode(min_slot=k)``, a hand-built image) reads as ``Center`` with
the ``;;Width:`` 2p + P that centres it at p (none when that is the default 540).

Carrier-less rows (transfers, drops, a-misses) may have been split from the row before them
only because a column was taken there; the reader starts such a row with that column, so the
writer splits them at the same place.

What a DAT does not keep, and the program therefore cannot have (research §2.7):

* absolute needle numbers, except through the position code (above);
* which rows the converter added (kicks, releases, dummies, carrier-out misses): every
  soft miss is taken to be its own, since Knitout ``miss`` ops have the colours 216/217;
* the Knitout order of ops inside a pass beyond slot order, and of carrier-less ops
  (drops, transfers) within their pass;
* carrier names (only numbers 1..10), and whether a CMU-written pair code 1X meant 1 X or
  10 X (above);
* ``stitch L T`` (only the table's stitch number: ``stitch 10 15`` reads back as
  ``x-stitch-number 85``), the ``x-presser-mode auto`` mode (read as ``on``/``off`` per row),
  settings changed and changed back between two passes, comments and pause messages;
* the machine name and gauge (defaults: SWG091N2, 15), the exact ``;;Width:`` of a Center
  design (any width with the same rounding gives the same code), and ``in``/``inhook``
  ops' position between passes (they are written just before the row that uses them).

Known cases where ``to_dat(dat_to_program(image))`` differs from the image (random programs
outside them round-trip byte for byte, see tests/test_dat_read.py):

* a front miss and a back miss in one quarter-pitch column have the soft-miss colour 16 and
  read as nothing, so the carrier's position after them is lost;
* two rows the writer would merge, separated in the original only by a setting that leaves
  no trace (``x-presser-mode auto`` next to ``on`` or ``off`` giving the same R11), are
  merged;
* kicks to negative slots: the converter visits them in a different order than positive
  ones, and the reader's needles (placed from the position code) are positive, so a DAT
  converted from Knitout with negative slots may kick in another order when written again.

Ops get no span (a DAT has no lines); a `DatReadError` names the pass row (0-based, fixed
courses excluded, as in `DatImage.passes`) and the slot, and the raster pixel (`y`, `x`).

`read_dat` is `knitc dat2k`: it checks the header against the bed before the raster is
allocated, reads a converter-layout DAT here and any other (a KnitPaint pattern, as the
original system writes) with `dat_codes`, runs the program on knitc's machine model and
reports whatever fails as an E902 at ``FILE:ROW:COLUMN`` of the pixel to blame (docs/dat.md),
so that what dat2k writes is always valid Knitout.
"""

from __future__ import annotations

import math
from bisect import bisect_right
from collections.abc import Callable

import numpy as np

from knitc.backends.dat import (
    KNIT_B,
    KNIT_F,
    KNIT_F_TUCK_B,
    KNIT_FB,
    LEFT,
    MISS_B,
    MISS_F,
    NONE,
    RIGHT,
    SOFT_MISS,
    SPLIT_BF,
    SPLIT_FB,
    TUCK_B,
    TUCK_F,
    TUCK_F_KNIT_B,
    TUCK_FB,
    XFER_BF,
    XFER_FB,
    DatImage,
    DatPass,
)
from knitc.backends.dat_format import PASS_Y, SIDE, SLOT_X, TOP, DatError, decode, read_raster
from knitc.backends.knitout_read import gc_paused
from knitc.codegen.machine import Machine, MachineProgram, Needle, Op
from knitc.codegen.simulate import simulate
from knitc.diagnostics import Diagnostics, Note
from knitc.source import Span

__all__ = [
    "DEFAULT_WIDTH",
    "DatReadError",
    "carriers_of_code",
    "dat_to_program",
    "racking_of",
    "read_dat",
]

DEFAULT_WIDTH = 540
"""Bed width the converter assumes without a ``;;Width:`` header."""

PAUSE, SPLIT_PASS, AMISS_PASS = 20, 10, 20
HOOK_IN, HOOK_OUT, HOOK_RELEASE = 10, 20, 90
PRESSER_ON = 101
TO_SLIDERS, FROM_SLIDERS = 1, 3
NO_YARN = (0, 255)

# (front op, back op) of every needle colour; None = nothing on that bed.
_PAIRS: dict[int, tuple[str | None, str | None]] = {
    KNIT_F: ("knit", None),
    KNIT_B: (None, "knit"),
    TUCK_F: ("tuck", None),
    TUCK_B: (None, "tuck"),
    KNIT_FB: ("knit", "knit"),
    KNIT_F_TUCK_B: ("knit", "tuck"),
    TUCK_F_KNIT_B: ("tuck", "knit"),
    TUCK_FB: ("tuck", "tuck"),
    MISS_F: ("miss", None),
    MISS_B: (None, "miss"),
}
_SVS: dict[int, tuple[bool, int]] = {
    106: (True, -1),
    107: (True, 1),
    108: (False, 1),
    109: (False, -1),
    126: (True, -2),
    127: (True, 2),
    128: (False, 2),
    129: (False, -2),
    146: (True, -4),
    147: (True, 4),
    148: (False, 4),
    149: (False, -4),
}
"""Split-via-sliders colour -> (splits from the front, return racking - split racking)."""


class DatReadError(ValueError):
    """A pass row that no program produces, with its index in `DatImage.passes` (and slot),
    and, when the reader knows it, the raster pixel to blame (`y` from the bottom, `x`)."""

    def __init__(
        self,
        message: str,
        row: int,
        slot: int | None = None,
        *,
        y: int | None = None,
        x: int | None = None,
    ) -> None:
        where = f"pass {row}" + (f", slot {slot}" if slot is not None else "")
        super().__init__(f"{where}: {message}")
        self.message = message
        self.row = row
        self.slot = slot
        self.y = y
        self.x = x


def racking_of(p: DatPass) -> float:
    """The racking of a pass row (L4 = 11: R = L2 + 1, else R = -L2; + 0.25 if L3 = 1)."""
    l2, l3, l4 = p.left[1], p.left[2], p.left[3]
    r = l2 + 1 if l4 == 11 else -l2
    return r + 0.25 if l3 == 1 else r


def carriers_of_code(code: int) -> tuple[int, ...]:
    """The carrier set of an R3/R10 carrier code (module docstring); () for 0 and 255.
    Raises ValueError for a code that names no carrier set."""
    if code in NO_YARN:
        return ()
    if 1 <= code <= 10:
        return (code,)
    if code == 11:
        return (10, 1)
    if 12 <= code <= 99:
        a, b = divmod(code, 10)
        return (a, b or 10)
    if code == 110:
        return (1, 10)
    if 102 <= code <= 109 or code == 101:
        return (10, code - 100)
    raise ValueError(f"carrier code {code} names no carrier set")


class _Reader:
    def __init__(self, image: DatImage, explicit_kicks: bool, machine: Machine) -> None:
        self.image = image
        self.explicit = explicit_kicks
        self.limit = machine.racking_limit
        self.ops: list[Op] = []
        self.row_starts: list[int] = []
        """Index of the first op of every pass row (`where`)."""
        self.slot_of: dict[int, int] = {}
        """Op index -> the slot whose colour made it."""
        self.racking: float = 0
        self.stitch = 5
        self.speed = 0
        self.presser = "off"
        self.hook: tuple[int, ...] | None = None
        self.row = 0
        self._needles: dict[tuple[str, int], Needle] = {}

    def needle(self, bed: str, index: int) -> Needle:
        n = self._needles.get((bed, index))
        if n is None:
            n = self._needles[bed, index] = Needle(bed, index)
        return n

    def fail(self, message: str, slot: int | None = None) -> DatReadError:
        return DatReadError(message, self.row, slot)

    def carriers(self, code: int) -> tuple[int, ...]:
        try:
            return carriers_of_code(code)
        except ValueError as e:
            raise self.fail(str(e)) from None

    def rack(self, r: float, slot: int | None = None) -> None:
        if abs(r) > self.limit:
            e = self.fail(f"racking {r:g} is beyond the machine's limit of {self.limit}", slot)
            if slot is None:  # the row's own racking: point at its L2 value
                e.y = PASS_Y + self.row
                e.x = option_x("L2", self.image.max_slot - self.image.min_slot + 1)
            raise e
        if r != self.racking:
            self.ops.append(Op("rack", value=r))
            self.racking = r

    def run(self) -> None:
        for i, p in enumerate(self.image.passes):
            self.row = i
            self.row_starts.append(len(self.ops))
            self.one(p)

    def where(self, op: int) -> tuple[int, int | None]:
        """The pass row and slot that op number `op` was read from."""
        return bisect_right(self.row_starts, op) - 1, self.slot_of.get(op)

    def one(self, p: DatPass) -> None:
        ops = self.ops
        left, right = p.left, p.right
        if left[6] == PAUSE:
            ops.append(Op("pause"))
        self.rack(racking_of(p))
        codes = p.slots
        transfers = bool(codes) and all(c in (XFER_FB, XFER_BF) for c in codes.values())
        needle_work = any(c != SOFT_MISS for c in codes.values())
        if not transfers and right[5] != self.stitch:
            self.stitch = right[5]
            ops.append(Op("stitch_number", value=self.stitch))
        l5 = left[4]
        if 0 < l5 <= 10:
            raise self.fail(f"L5 = {l5} is not a speed code (0, or 11 and up for speed 1..)")
        speed = l5 - 10 if l5 else 0
        if speed != self.speed:
            self.speed = speed
            ops.append(Op("speed", value=speed))
        if needle_work and not transfers:
            mode = "on" if right[10] == PRESSER_ON else "off"
            if mode != self.presser:
                self.presser = mode
                ops.append(Op("presser", value=mode))
        r3, r10, hook = right[2], right[9], right[14]
        cs = self.carriers(r3)
        if hook == HOOK_RELEASE:
            if self.hook is None:
                raise self.fail("hook release (R15 = 90) but no row brought yarn in with the hook")
            ops.append(Op("releasehook", carriers=self.hook))
            self.hook = None
        taken_out: tuple[int, ...] = ()
        if r10:
            bring_in = r10 == r3 or (r10 != r3 + 100 and r10 < 100)
            if bring_in:
                incs = cs if r10 == r3 else self.carriers(r10)
                kind = "inhook" if hook == HOOK_IN else "in"
                ops.append(Op(kind, carriers=incs))
                if kind == "inhook":
                    self.hook = incs
            else:
                taken_out = cs if r10 == r3 + 100 else self.carriers(r10 - 100)
        elif hook == HOOK_IN and cs:
            ops.append(Op("inhook", carriers=cs))
            self.hook = cs
        elif hook == HOOK_OUT and cs:
            taken_out = cs
        if codes:
            self.needle_ops(p, cs)
        if taken_out:
            ops.append(Op("outhook" if hook == HOOK_OUT else "out", carriers=taken_out))

    def restart_first(self, order: list[int], p: DatPass, quarter: bool) -> list[int]:
        """Carrier-less ops (transfers, drops, a-misses) join the previous pass wherever
        their column is free, so a row of them that follows a row they could have joined
        began with an op whose column was taken there: put such a column first, or the
        writer would fold the row's first ops into the previous row."""
        before = self.image.passes[self.row - 1]
        if (
            before.right[2] != p.right[2]
            or before.left[1:4] != p.left[1:4]
            or before.left[11:13] != p.left[11:13]
        ):
            return order  # other carriers, racking or pass type: no merging anyway
        prev = before.slots
        for k, s in enumerate(order):
            if s in prev and _collide(prev[s], p.slots[s], quarter):
                return [s] + order[:k] + order[k + 1 :] if k else order
        return order

    def emit(self, op: Op, slot: int | None = None) -> None:
        """Append `op`, remembering the slot it was read from (`where`)."""
        if slot is not None:
            self.slot_of[len(self.ops)] = slot
        self.ops.append(op)

    def needle_ops(self, p: DatPass, cs: tuple[int, ...]) -> None:
        emit, nd = self.emit, self.needle
        d = 1 if p.direction == RIGHT else -1 if p.direction == LEFT else 0
        if p.direction not in (RIGHT, LEFT, NONE):
            raise self.fail(f"direction code {p.direction} is not {RIGHT}, {LEFT} or {NONE}")
        r = self.racking
        fl = math.floor(r)
        l13 = p.left[12]
        returns: list[tuple[Op, int]] = []
        ret_racking: float | None = None
        order = sorted(p.slots, reverse=d < 0)
        if not cs and self.row > 0:
            order = self.restart_first(order, p, r != fl)
        for s in order:
            code = p.slots[s]
            pair = _PAIRS.get(code)
            if pair is not None:
                front, back = (pair[0], nd("f", s)), (pair[1], nd("b", s - fl))
                for kind, n in (back, front) if d < 0 else (front, back):
                    if kind is None:
                        continue
                    if cs:
                        if not d:
                            raise self.fail(
                                f"colour {code} with carriers in a row without a direction", s
                            )
                        emit(Op(kind, d, n, None, cs), s)
                    elif kind == "miss":
                        raise self.fail(f"miss colour {code} in a row without carriers", s)
                    else:
                        emit(Op("drop" if kind == "knit" else "amiss", needle=n), s)
            elif code == SOFT_MISS:
                if self.explicit and cs and d:
                    emit(Op("miss", d, nd("f", s), None, cs), s)
            elif code in (XFER_FB, XFER_BF):
                if r != fl:
                    raise self.fail(f"transfer colour {code} at quarter-pitch racking {r:g}", s)
                to_back = code == XFER_FB
                front_slider = l13 == (FROM_SLIDERS if to_back else TO_SLIDERS)
                back_slider = l13 == (TO_SLIDERS if to_back else FROM_SLIDERS)
                f, b = (
                    nd("fs" if front_slider else "f", s),
                    nd("bs" if back_slider else "b", s - fl),
                )
                emit(
                    Op("xfer", needle=f, needle2=b) if to_back else Op("xfer", needle=b, needle2=f),
                    s,
                )
            elif code in (SPLIT_FB, SPLIT_BF):
                if not cs or not d:
                    raise self.fail(
                        f"split colour {code} in a row without carriers or direction", s
                    )
                f, b = nd("f", s), nd("b", s - fl)
                a, t = (f, b) if code == SPLIT_FB else (b, f)
                emit(Op("split", d, a, t, cs), s)
            elif code in _SVS:
                if not cs or not d:
                    raise self.fail(
                        f"split colour {code} in a row without carriers or direction", s
                    )
                from_front, delta = _SVS[code]
                ret = r + delta
                if ret_racking is not None and ret != ret_racking:
                    raise self.fail(
                        "splits via sliders with different return rackings in one row", s
                    )
                ret_racking = ret
                if from_front:  # f(s) -> bs(s - R), back at the return racking to f(. + ret)
                    src, slider = nd("f", s), nd("bs", s - fl)
                    home = nd("f", int(slider.index + ret))
                else:  # b(s - R) -> fs(s), back to b(s - ret)
                    src, slider = nd("b", s - fl), nd("fs", s)
                    home = nd("b", int(slider.index - ret))
                emit(Op("split", d, src, slider, cs), s)
                returns.append((Op("xfer", needle=slider, needle2=home), s))
            else:
                raise self.fail(f"colour {code} is not a needle operation knitc reads", s)
        if ret_racking is not None:
            self.rack(ret_racking, returns[0][1])
            for op, s in returns:
                emit(op, s)


def _collide(a: int, b: int, quarter: bool) -> bool:
    """Whether colours `a` and `b` cannot share a column of one pass: a soft miss joins
    anything; otherwise only a front op and a back op at quarter pitch."""
    if a == SOFT_MISS or b == SOFT_MISS:
        return False
    if not quarter:
        return True
    pa, pb = _PAIRS.get(a), _PAIRS.get(b)
    if pa is None or pb is None:
        return True
    return not ((pa[1] is None and pb[0] is None) or (pa[0] is None and pb[1] is None))


def _placement(image: DatImage) -> tuple[str, int | None]:
    """``(position, width)`` for the image's position code and slot numbering."""
    p = image.position or 0
    used = image.max_slot - image.min_slot + 1
    if p == 0:
        return "Right", None
    if image.min_slot == p:
        if p == 1:
            return "Left", None
        return "Keep", (None if image.max_slot <= DEFAULT_WIDTH else image.max_slot)
    width = 2 * p + used
    return "Center", (None if width == DEFAULT_WIDTH else width)


def dat_to_program(
    image: DatImage, *, explicit_kicks: bool = False, machine: Machine | None = None
) -> MachineProgram:
    """The program of a DAT image (module docstring), on `machine` (default: knitc's
    SWG091N2 profile). Raises DatReadError for a row no program would produce."""
    return _decode(image, explicit_kicks, machine or Machine())[0]


Locate = Callable[[int], tuple[int, int]]
"""Op index -> the raster pixel (y from the bottom, x) that op was read from."""


def _decode(
    image: DatImage, explicit_kicks: bool, machine: Machine
) -> tuple[MachineProgram, Locate]:
    r = _Reader(image, explicit_kicks, machine)
    position, width = _placement(image)
    prog = MachineProgram(machine, position=position, width=width)
    used = image.max_slot - image.min_slot + 1
    with gc_paused():
        try:
            r.run()
        except DatReadError as e:
            if e.y is None:
                e.y = PASS_Y + e.row
                e.x = SLOT_X + e.slot - image.min_slot if e.slot is not None else 49
            raise
        prog.extend(r.ops)

    def locate(op: int) -> tuple[int, int]:
        row, slot = r.where(op)
        x = SLOT_X + slot - image.min_slot if slot is not None else _option_x(r.ops[op], used)
        return PASS_Y + max(row, 0), x

    return prog, locate


_OPTION_OF_OP = {
    "in": "R10",
    "inhook": "R10",
    "out": "R10",
    "outhook": "R10",
    "releasehook": "R15",
    "stitch_number": "R6",
    "presser": "R11",
    "speed": "L5",
    "pause": "L7",
    "rack": "L2",
}


def option_x(name: str, used: int) -> int:
    """The raster column of option `name`'s value (``"R10"``) in a DAT with `used` slots."""
    k = int(name[1:])
    return 50 - 2 * k if name[0] == "L" else 59 + used + 2 * k


def _option_x(op: Op, used: int) -> int:
    """Where an op that no slot made was read from: the value of its option line."""
    return option_x(_OPTION_OF_OP.get(op.kind, "R3"), used)


def is_converter_layout(raster: np.ndarray) -> bool:
    """Whether a raster has the CMU converter's fixed end courses (its last course knits
    both beds at quarter pitch, L3 = 1): then `dat_format.decode` reads it strictly. Any
    other DAT is a KnitPaint pattern (`dat_codes`)."""
    height, width = raster.shape
    top = height - PASS_Y - 1
    return height >= PASS_Y + TOP and width > 2 * SIDE and int(raster[top, option_x("L3", 0)]) == 1


def read_dat(
    data: bytes, path: str, *, machine: Machine | None = None
) -> tuple[MachineProgram | None, Diagnostics]:
    """`knitc dat2k`: the program of DAT bytes read from `path`, and E902 diagnostics at the
    raster pixel to blame (``path:ROW:COLUMN``, counted from 1 at the bottom-left pixel).

    Every value is checked where it enters, before work is done: the header's size against
    the bed (`Machine.needles` plus the margins) before the raster is allocated, and every
    row as it is read. The decoded program must then run clean on knitc's machine model
    (`codegen.simulate`), so that what dat2k writes is valid Knitout: a carrier used before
    it is brought in, a racking past the limit or loops left on the needles are located at
    the row (and column) whose ops break the rule. Returns (None, errors) for a DAT that
    cannot be read."""
    from knitc.backends import dat_codes

    m = machine or Machine()
    diags = Diagnostics()
    try:
        raster = read_raster(data, max_width=width_limit(m))
        if is_converter_layout(raster):
            prog, locate = _decode(decode(data, max_width=width_limit(m)), False, m)
        else:
            prog, locate = dat_codes.read_pattern(raster, m)
    except DatError as e:
        _error(diags, path, str(e), e.y, e.x)
        return None, diags
    except DatReadError as e:
        _error(diags, path, str(e), e.y, e.x)
        return None, diags
    broken = [f for f in simulate(prog, placed=True) if f.is_error]
    if broken:
        f = broken[0]
        y, x = locate(f.op) if 0 <= f.op < len(prog.ops) else (None, None)
        notes = [Note(f"the decoded operation: `{prog.ops[f.op]}`")] if y is not None else []
        if len(broken) > 1:
            notes.append(Note(f"and {len(broken) - 1} more problem(s) after it"))
        _error(
            diags,
            path,
            f"the decoded program breaks a machine rule ({f.code}): {f.message}",
            y,
            x,
            notes,
        )
        return None, diags
    return prog, diags


def _error(
    diags: Diagnostics,
    path: str,
    message: str,
    y: int | None,
    x: int | None,
    notes: list[Note] | None = None,
) -> None:
    if y is None:  # the container or the raster as a whole
        diags.error("E902", f"`{path}` is not a DAT file knitc can read: {message}", None)
        return
    col = (x or 0) + 1
    diags.error(
        "E902",
        f"not a DAT file knitc can read: {message}",
        Span(path, y + 1, col, y + 1, col + 1),
        notes=notes or [],
        hint="the location is the raster pixel (row and column from 1 at the bottom left); "
        "`knitc dat2k --passes` prints every row's codes and option values",
    )


def width_limit(machine: Machine) -> int:
    """The widest raster a DAT for `machine` has: its needles plus the margins and bars."""
    return machine.needles + 2 * SIDE
