"""KnitPaint pattern DATs: the codes and options of a DAT drawn for KnitPaint's own
processing (the DATs knitskel writes, research seed-systems.md §1.13), read into a
`MachineProgram` for `knitc dat2k`.

`dat_read` reads the DATs the CMU converter writes: every pixel is a machine operation,
one pass row per Knitout pass, and the layout is exact (`dat_format.decode`). A KnitPaint
pattern is a level higher: KnitPaint's *link process* still has to turn it into machine
passes, and this reader does that part of its work. The container, the raster's geometry
(55 columns of margin, option bars and gap a side, 5 blank rows below, the width row 7
from the top) and the direction codes (6 right, 7 left, 1 transfer) are the converter's;
what differs:

* every raster row from y = 5 to the blank row under the width row is a course, the
  bed-clearing rows at both ends included (they run the empty carrier 255: their knits are
  drops of the needles that hold loops, their misses and tucks nothing);
* 99 (link process) fills the cells between a course's instructions and over the needles
  that hold stitches, and 13 (carrier position) marks the cells just outside a course's
  first and last instruction, stop-mark columns or not: neither is an operation;
* needle codes name what happens to a stitch, not one machine op (table below), and the
  transfer type L13 says on which bed the knitted body lies (31/51/81/91 front, 32/52/82/92
  back; 51/52/91/92 with sliders), so that a front knit 1 over the back body is a purl:
  transfer to the front, knit, transfer back (KnitPaint's automatic purl transfers);
* transfer courses (direction 1, R5 = 1 knit cancel, or 11 with 7-pitch racking) carry
  cross-bed transfers, same-bed moves and cables whose distance is in the code: there is
  no racking option (L2..L4 must be 0), the reader racks for each distance.

Codes of a knitting course (R5 = 0, or 2 "carriage move", or 6/7 "independent carrier"):

  1 / 2       knit front / back, through the body's bed (link process)
  11 / 12     tuck front / back, likewise
  51 / 52     knit front / back (no link process); 17 / 18 the same with a kickback
  171 / 172   tuck front / back; 175 tuck both
  3, 41, 42, 88   knit both, knit front + tuck back, tuck front + knit back, tuck both
  16, 216, 116 / 117, 217   miss (the carrier passes the needle): front, front/back
  60 / 70     transfer to the front / back, then knit there
  101 / 102   split front -> back / back -> front
  106..149    split moving the new loop along its bed (via the other bed's slider)

Codes of a transfer course:

  20 / 30             cross-bed transfer front -> back / back -> front
  21-23, 43-46 / 24-26, 47-49, 68   front -> back shifted left / right 1..7
  31-33, 53-56 / 34-36, 57-59, 69   back -> front shifted left / right 1..7
  61-67 / 71-77       front-bed move left / right 1..7 (via the back bed, or its sliders)
  81-87 / 91-97       back-bed move left / right 1..7
  40 / 50             restack front / back (over and back in place)
  5, 15 / 4, 14, 10, 100   a cable's upper side / its lower side (second pairs 15/14,
                      behind 10/100), 150 joining cells of one side; each side moves onto
                      the other's needles (upper: right by the lower side's span)

Options: R3 carriers (255: none), R10 the holding hook (carrier code to bring in, 100 +
it to take out), R15 the yarn inserting hook (10 [+ carrier] insert, 20 [+ carrier]
remove, 90 release; a file that never releases the hook inserts its yarn by hand, so its
insertions are plain ``in``), R6 the stitch number (``x-stitch-number``), R11 = 101 the
fabric presser, L5 the speed, L7 = 20 a pause. R1 is KnitPaint's repeat *code* (knitskel
writes the node's ``expansion`` there); how many times the marked block repeats is a
machine setting, not in the file, so every course is read once. L9 (DSCS), L12 (split to
hook), R7 and R9 change nothing a program says. A value of any other option, or a code
the tables do not hold, is an error at its row and column.

The stitches of the design are the pattern codes (1, 2, 11, 12, 17, 18, 60, 70 and the
splits); their ops carry ``phase = "action"``, the casting codes (51, 52, 171, 172, ...)
none, so that a structural comparison can count the design's stitches in the program.
"""

from __future__ import annotations

import numpy as np

from knitc.backends.dat import LEFT, N_OPTIONS, NONE, RIGHT, DatImage
from knitc.backends.dat_format import PASS_Y, POSITION_X, SIDE, SLOT_X, DatError
from knitc.backends.dat_read import (
    _SVS,
    DatReadError,
    Locate,
    _placement,
    carriers_of_code,
    option_x,
)
from knitc.backends.knitout_read import gc_paused
from knitc.codegen.machine import Machine, MachineProgram, Needle, Op
from knitc.records import record

__all__ = ["read_pattern"]

BLANK_BELOW = 5
"""Blank rows under the first course."""
ABOVE = 8
"""Rows above the last course: 1 blank, the width row, the position row and 5 blank."""
LINK, CARRIER_MARK, CABLE_JOINT = 99, 13, 150
NO_OP = (0, LINK, CARRIER_MARK)

# Knitting-course codes: (front op, back op); "knit"/"tuck" ops on the named bed.
_STITCH: dict[int, tuple[str | None, str | None]] = {
    51: ("knit", None),
    52: (None, "knit"),
    17: ("knit", None),
    18: (None, "knit"),
    171: ("tuck", None),
    172: (None, "tuck"),
    175: ("tuck", "tuck"),
    3: ("knit", "knit"),
    41: ("knit", "tuck"),
    42: ("tuck", "knit"),
    88: ("tuck", "tuck"),
    16: ("miss", None),
    216: ("miss", None),
    116: ("miss", None),
    117: (None, "miss"),
    217: (None, "miss"),
}
_LINKED: dict[int, tuple[str, str]] = {1: ("knit", "f"), 2: ("knit", "b"), 11: ("tuck", "f")}
_LINKED[12] = ("tuck", "b")
"""Link-process codes: the op and the bed it is made on, through the body's bed (L13)."""
_KICKBACK = (17, 18)
_XFER_THEN_KNIT = {60: "f", 70: "b"}
_SPLIT = {101: ("f", "b"), 102: ("b", "f")}

_FRONT_BODY, _BACK_BODY = (31, 51, 81, 91), (32, 52, 82, 92)
_SLIDERS = (51, 52, 91, 92)
_L13 = (0, 1, 3, *_FRONT_BODY, *_BACK_BODY)


def _shifts(codes: tuple[int, ...], sign: int) -> dict[int, int]:
    return {c: sign * (k + 1) for k, c in enumerate(codes)}


# Transfer-course codes: cross-bed (source bed, shift), same-bed moves (bed, shift).
_CROSS: dict[int, tuple[str, int]] = {20: ("f", 0), 30: ("b", 0)}
for _bed, _left, _right in (
    ("f", (21, 22, 23, 43, 44, 45, 46), (24, 25, 26, 47, 48, 49, 68)),
    ("b", (31, 32, 33, 53, 54, 55, 56), (34, 35, 36, 57, 58, 59, 69)),
):
    for _c, _k in (_shifts(_left, -1) | _shifts(_right, 1)).items():
        _CROSS[_c] = (_bed, _k)
_MOVE: dict[int, tuple[str, int]] = {}
for _bed, _base in (("f", 60), ("b", 80)):
    for _k in range(1, 8):
        _MOVE[_base + _k] = (_bed, -_k)
        _MOVE[_base + 10 + _k] = (_bed, _k)
_RESTACK = {40: "f", 50: "b"}
_CABLE_UPPER, _CABLE_LOWER = (5, 15), (4, 14, 10, 100)
_CABLE_PAIRS = {5: (4, 10), 15: (14, 100), 4: (5,), 10: (5,), 14: (15,), 100: (15,)}

_IGNORED = {"L9", "L12", "R1", "R7", "R9"}
"""Options read and left alone (module docstring)."""
_READ = {"L2", "L3", "L4", "L5", "L7", "L13", "R3", "R5", "R6", "R10", "R11", "R15"}


@record
class _Course:
    y: int
    direction: int
    codes: dict[int, int]
    """Slot column (0 = the first) -> code, links and carrier marks left out."""
    left: list[int]
    right: list[int]

    def option(self, name: str) -> int:
        k = int(name[1:]) - 1
        return self.left[k] if name[0] == "L" else self.right[k]


def read_pattern(raster: np.ndarray, machine: Machine) -> tuple[MachineProgram, Locate]:
    """The program of a KnitPaint pattern raster (module docstring) on `machine`, and where
    each op was read from. Raises DatError for a pixel the layout has no place for and
    DatReadError for a course no program makes, each with the pixel to blame."""
    courses, base, position = _layout(raster)
    used = raster.shape[1] - 2 * SIDE
    image = DatImage(min_slot=base, max_slot=base + used - 1, position=position)
    place, width = _placement(image)
    prog = MachineProgram(machine, position=place, width=width)
    reader = _Pattern(courses, base, used, machine)
    with gc_paused():
        reader.run()
        prog.extend(reader.ops)
    return prog, reader.at.__getitem__


# --- layout ----------------------------------------------------------------------------------


def _layout(raster: np.ndarray) -> tuple[list[_Course], int, int]:
    """The courses, the needle number of the first slot column and the position code; every
    pixel outside the courses, bars, width row and position code must be 0."""
    height, width = raster.shape
    used = width - 2 * SIDE
    if used < 1 or height < BLANK_BELOW + 1 + ABOVE:
        raise DatError(
            f"a {width} x {height} raster has no room for a course: a KnitPaint DAT is at "
            f"least {2 * SIDE + 1} wide and {BLANK_BELOW + 1 + ABOVE} high"
        )
    top = height - ABOVE  # the blank row above the last course
    width_y = top + 1
    expected = np.zeros(raster.shape, dtype=bool)
    expected[BLANK_BELOW:top, 10:50] = True
    expected[BLANK_BELOW:top, SLOT_X - 1 : SLOT_X + used + 1] = True
    expected[BLANK_BELOW:top, 60 + used : 100 + used] = True
    expected[width_y, SLOT_X - 5 : SLOT_X + used + 5] = True
    expected[width_y : width_y + 2, POSITION_X] = True
    stray = np.argwhere(~expected & (raster != 0))
    if stray.size:
        y, x = (int(v) for v in stray[0])
        raise DatError(f"colour {raster[y, x]} outside the layout of a KnitPaint DAT", y, x)
    bar = raster[width_y, SLOT_X - 5 : SLOT_X + used + 5]
    if (bad := np.flatnonzero(bar != 1)).size:
        x = SLOT_X - 5 + int(bad[0])
        raise DatError(f"the width row has colour {raster[width_y, x]}, not 1", width_y, x)
    low, high = int(raster[width_y, POSITION_X]), int(raster[width_y + 1, POSITION_X])
    if low > 99:
        raise DatError(f"position code low part {low} is not 0..99", width_y, POSITION_X)
    position = high * 100 + low
    base = position if position >= 1 else 1
    if base + used - 1 > 25599:
        raise DatError(f"position code {position} places needles past the bed", width_y, 48)
    return [_course(raster, y, used) for y in range(BLANK_BELOW, top)], base, position


def _course(raster: np.ndarray, y: int, used: int) -> _Course:
    row = raster[y].tolist()
    r1 = 60 + used
    direction = row[49]
    if direction != row[r1] or direction not in (RIGHT, LEFT, NONE):
        raise DatError(
            f"direction codes {direction} (left bar) and {row[r1]} (right bar) are not one "
            f"of {RIGHT} (right), {LEFT} (left), {NONE} (transfer)",
            y,
            49,
        )
    for k in range(2, N_OPTIONS + 1):
        for x in (51 - 2 * k, r1 - 2 + 2 * k):
            if row[x] != k:
                raise DatError(f"option marker {row[x]} where the bar has {k}", y, x)
    for x in (SLOT_X - 1, SLOT_X + used):
        if row[x] not in (0, CARRIER_MARK):
            raise DatError(f"colour {row[x]} in the stop-mark column", y, x)
    band = row[SLOT_X : SLOT_X + used]
    codes = {c: v for c, v in enumerate(band) if v not in NO_OP}
    return _Course(
        y=y,
        direction=direction,
        codes=codes,
        left=[row[48 - 2 * k] for k in range(N_OPTIONS)],
        right=[row[r1 + 1 + 2 * k] for k in range(N_OPTIONS)],
    )


# --- decoding --------------------------------------------------------------------------------


class _Pattern:
    """Courses -> ops, keeping what the link process needs: which needles hold loops."""

    def __init__(self, courses: list[_Course], base: int, used: int, machine: Machine) -> None:
        self.courses = courses
        self.base = base
        self.used = used
        self.limit = machine.racking_limit
        self.ops: list[Op] = []
        self.at: list[tuple[int, int]] = []
        """Op index -> (y, x) of the pixel it was read from."""
        self.loops: set[Needle] = set()
        self.racking = 0
        self.stitch: int | None = None
        self.presser = "off"
        self.speed = 0
        self.hook: tuple[int, ...] | None = None
        self.hooked_in: set[int] = set()
        self.by_hook = any(c.option("R15") == 90 for c in courses)
        self.y = 0
        self._needles: dict[tuple[str, int], Needle] = {}

    # -- helpers

    def needle(self, bed: str, col: int) -> Needle:
        key = (bed, self.base + col)
        n = self._needles.get(key)
        if n is None:
            n = self._needles[key] = Needle(bed, self.base + col)
        return n

    def fail(self, message: str, col: int | None = None, option: str | None = None) -> Exception:
        x = SLOT_X + col if col is not None else option_x(option or "R3", self.used)
        where = f"slot column {col}" if col is not None else (option or "its options")
        return DatReadError(f"{message} ({where})", self.y - PASS_Y, col, y=self.y, x=x)

    def emit(self, op: Op, col: int | None = None, option: str = "R3") -> None:
        x = SLOT_X + col if col is not None else option_x(option, self.used)
        self.ops.append(op)
        self.at.append((self.y, x))
        self._track(op)

    def _track(self, op: Op) -> None:
        """Which needles hold loops after `op` (drops of empty needles are left out)."""
        loops = self.loops
        if op.kind in ("knit", "tuck") and op.needle is not None:
            loops.add(op.needle)
        elif op.kind == "split" and op.needle is not None and op.needle2 is not None:
            if op.needle in loops:
                loops.add(op.needle2)
            loops.add(op.needle)
        elif op.kind == "xfer" and op.needle is not None and op.needle2 is not None:
            if op.needle in loops:
                loops.discard(op.needle)
                loops.add(op.needle2)
        elif op.kind == "drop" and op.needle is not None:
            loops.discard(op.needle)

    def rack(self, r: int, col: int | None = None) -> None:
        if abs(r) > self.limit:
            raise self.fail(f"a shift needing racking {r} is beyond the limit {self.limit}", col)
        if r != self.racking:
            self.emit(Op("rack", value=r), col, "L2")
            self.racking = r

    def xfer(self, a: Needle, b: Needle, col: int) -> None:
        self.emit(Op("xfer", needle=a, needle2=b), col)

    # -- courses

    def run(self) -> None:
        for c in self.courses:
            self.y = c.y
            self.check_options(c)
            if c.option("L7") == 20:
                self.emit(Op("pause"), None, "L7")
            if c.direction == NONE:
                self.transfer_course(c)
            else:
                self.knitting_course(c)

    def check_options(self, c: _Course) -> None:
        for side, values in (("L", c.left), ("R", c.right)):
            for k, v in enumerate(values):
                name = f"{side}{k + 1}"
                if v and name not in _IGNORED and name not in _READ:
                    raise self.fail(f"option {name} = {v} is not one knitc reads", None, name)
        for name in ("L2", "L3", "L4"):
            if c.option(name):
                raise self.fail(
                    f"racking option {name} = {c.option(name)}: a KnitPaint pattern's "
                    "transfers carry their distance in their codes",
                    None,
                    name,
                )
        if c.option("L13") not in _L13:
            raise self.fail(f"transfer type L13 = {c.option('L13')} is unknown", None, "L13")
        r5 = c.option("R5")
        if c.direction == NONE and r5 not in (0, 1, 11):
            raise self.fail(f"R5 = {r5} on a transfer course (1 or 11 expected)", None, "R5")
        if c.direction != NONE and r5 not in (0, 2, 6, 7):
            raise self.fail(f"R5 = {r5} on a knitting course", None, "R5")
        if c.option("R11") not in (0, 101):
            raise self.fail(f"fabric presser R11 = {c.option('R11')} is unknown", None, "R11")
        l5 = c.option("L5")
        if 0 < l5 <= 10:
            raise self.fail(f"L5 = {l5} is not a speed code (0, or 11 and up)", None, "L5")

    def carriers(self, code: int, option: str) -> tuple[int, ...]:
        try:
            return carriers_of_code(code)
        except ValueError as e:
            raise self.fail(str(e), None, option) from None

    def settings(self, c: _Course) -> None:
        l5 = c.option("L5")
        speed = l5 - 10 if l5 else 0
        if speed != self.speed:
            self.speed = speed
            self.emit(Op("speed", value=speed), None, "L5")
        r6 = c.option("R6")
        if r6 and r6 != self.stitch:
            self.stitch = r6
            self.emit(Op("stitch_number", value=r6), None, "R6")
        mode = "on" if c.option("R11") == 101 else "off"
        if mode != self.presser:
            self.presser = mode
            self.emit(Op("presser", value=mode), None, "R11")

    def yarn(self, c: _Course, cs: tuple[int, ...]) -> tuple[str, tuple[int, ...]] | None:
        """Bring the course's yarn in before it (releasing the hook first when R15 = 90);
        returns the out op to write after it, if any."""
        r3, r10, r15 = c.option("R3"), c.option("R10"), c.option("R15")
        if r15 == 90:
            if self.hook is None:
                raise self.fail("hook release (R15 = 90) with no yarn on the hook", None, "R15")
            self.emit(Op("releasehook", carriers=self.hook), None, "R15")
            self.hook = None
        elif r15 and not (10 <= r15 <= 29):
            raise self.fail(f"yarn inserting hook R15 = {r15} is unknown", None, "R15")
        inserting, removing = 10 <= r15 <= 19, 20 <= r15 <= 29
        for on, low in ((inserting, 10), (removing, 20)):
            if on and r15 > low and (r15 - low,) != cs:
                raise self.fail(
                    f"R15 = {r15} names carrier {r15 - low}, the course's carriers are "
                    f"{' '.join(map(str, cs)) or 'none'}",
                    None,
                    "R15",
                )
        if not cs and (r10 or inserting or removing):
            raise self.fail("a holding-hook or inserting-hook option without carriers", None, "R3")
        brought: tuple[int, ...] = ()
        taken: tuple[int, ...] = ()
        if r10 and r10 < 100:
            brought = cs if r10 == r3 else self.carriers(r10, "R10")
        elif r10 > 100:
            taken = cs if r10 == r3 + 100 else self.carriers(r10 - 100, "R10")
        elif r10:
            raise self.fail("holding hook R10 = 100 names no carrier", None, "R10")
        if inserting and not brought:
            brought = cs
        if removing and not taken:
            taken = cs
        if brought:
            kind = "inhook" if inserting and self.by_hook else "in"
            self.emit(Op(kind, carriers=brought), None, "R10" if r10 else "R15")
            if kind == "inhook":
                self.hook = brought
                self.hooked_in.update(brought)
        if not taken:
            return None
        kind = "outhook" if removing and set(taken) <= self.hooked_in else "out"
        self.hooked_in.difference_update(taken)
        return kind, taken

    def knitting_course(self, c: _Course) -> None:
        d = 1 if c.direction == RIGHT else -1
        cs = self.carriers(c.option("R3"), "R3")
        if cs:
            self.settings(c)
        self.rack(0)
        l13 = c.option("L13")
        body = "f" if l13 in _FRONT_BODY else "b" if l13 in _BACK_BODY else None
        order = sorted(c.codes, reverse=d < 0)
        before: list[tuple[Needle, Needle, int]] = []
        after: list[tuple[Needle, Needle, int]] = []
        stitches: list[tuple[Op, int]] = []
        returns: dict[int, list[tuple[Needle, Needle, int]]] = {}
        for col in order:
            code = c.codes[col]
            f, b = self.needle("f", col), self.needle("b", col)
            if code in _STITCH:
                pair = _STITCH[code]
                for kind, n in ((pair[1], b), (pair[0], f)) if d < 0 else zip(pair, (f, b)):
                    if kind is None:
                        continue
                    if cs:
                        phase = "action" if code in _KICKBACK else ""
                        stitches.append((Op(kind, d, n, None, cs, phase=phase), col))
                    elif kind == "knit" and n in self.loops:
                        stitches.append((Op("drop", needle=n), col))
            elif code in _LINKED:
                kind, bed = _LINKED[code]
                n = f if bed == "f" else b
                if not cs:
                    if kind == "knit" and n in self.loops:
                        stitches.append((Op("drop", needle=n), col))
                    continue
                if body is not None and body != bed:
                    home = f if body == "f" else b
                    before.append((home, n, col))
                    after.append((n, home, col))
                stitches.append((Op(kind, d, n, None, cs, phase="action"), col))
            elif code in _XFER_THEN_KNIT:
                if not cs:
                    raise self.fail(f"transfer-then-knit code {code} without carriers", col)
                to = f if _XFER_THEN_KNIT[code] == "f" else b
                before.append((b if to is f else f, to, col))
                stitches.append((Op("knit", d, to, None, cs, phase="action"), col))
            elif code in _SPLIT or code in _SVS:
                if not cs:
                    raise self.fail(f"split code {code} without carriers", col)
                stitches.append((self.split(code, d, col, cs, returns), col))
            else:
                raise self.fail(f"code {code} is not a knitting-course code knitc reads", col)
        if before:
            for a, t, col in sorted(before, key=lambda s: s[2]):
                self.xfer(a, t, col)
        out = self.yarn(c, cs)
        for op, col in stitches:
            self.emit(op, col)
        for r, moves in sorted(returns.items()):
            self.rack(r, moves[0][2])
            for a, t, col in moves:
                self.xfer(a, t, col)
        if after:
            self.rack(0)
            for a, t, col in sorted(after, key=lambda s: s[2]):
                self.xfer(a, t, col)
        if out is not None:
            self.emit(Op(out[0], carriers=out[1]), None, "R10")

    def split(
        self,
        code: int,
        d: int,
        col: int,
        cs: tuple[int, ...],
        returns: dict[int, list[tuple[Needle, Needle, int]]],
    ) -> Op:
        """A split: in place (101/102), or with the new loop parked on the other bed's
        slider and moved back along its own bed at the return racking (106..149)."""
        if code in _SPLIT:
            a, t = _SPLIT[code]
            return Op("split", d, self.needle(a, col), self.needle(t, col), cs, phase="action")
        from_front, delta = _SVS[code]
        if from_front:
            src, slider = self.needle("f", col), self.needle("bs", col)
            home = self.needle("f", col + delta)
        else:
            src, slider = self.needle("b", col), self.needle("fs", col)
            home = self.needle("b", col - delta)
        returns.setdefault(delta, []).append((slider, home, col))
        return Op("split", d, src, slider, cs, phase="action")

    def transfer_course(self, c: _Course) -> None:
        sliders = c.option("L13") in _SLIDERS
        body = "b" if c.option("L13") in _BACK_BODY else "f"
        first: list[tuple[Needle, Needle, int]] = []
        second: dict[tuple[int, int], list[tuple[Needle, Needle, int]]] = {}
        cables: list[tuple[int, int]] = []

        def move(bed: str, col: int, k: int, layer: int) -> None:
            """`bed`(col) to `bed`(col + k) through the other bed (or its slider)."""
            other = ("b" if bed == "f" else "f") + ("s" if sliders else "")
            via = self.needle(other, col)
            first.append((self.needle(bed, col), via, col))
            r = k if bed == "f" else -k
            second.setdefault((layer, r), []).append((via, self.needle(bed, col + k), col))

        for col in sorted(c.codes):
            code = c.codes[col]
            if code in _CROSS:
                bed, k = _CROSS[code]
                other = "b" if bed == "f" else "f"
                a, t = self.needle(bed, col), self.needle(other, col + k)
                if k == 0:
                    first.append((a, t, col))
                else:
                    second.setdefault((0, -k if bed == "f" else k), []).append((a, t, col))
            elif code in _MOVE:
                bed, k = _MOVE[code]
                move(bed, col, k, 0)
            elif code in _RESTACK:
                bed = _RESTACK[code]
                other = "b" if bed == "f" else "f"
                a, t = self.needle(bed, col), self.needle(other, col)
                first.append((a, t, col))
                second.setdefault((2, 0), []).append((t, a, col))
            elif code in _CABLE_PAIRS:
                cables.append((col, code))
            elif code != CABLE_JOINT:
                raise self.fail(f"code {code} is not a transfer-course code knitc reads", col)
        for col, code, k in self.cable_shifts(cables):
            move(body, col, k, 1 if code in _CABLE_UPPER else 0)
        if first:
            self.rack(0)
        for a, t, col in first:
            self.xfer(a, t, col)
        for (_, r), steps in sorted(second.items()):
            self.rack(r, steps[0][2])
            for a, t, col in steps:
                self.xfer(a, t, col)

    def cable_shifts(self, cells: list[tuple[int, int]]) -> list[tuple[int, int, int]]:
        """(column, code, shift) of every cable cell: each cable is a run of one side's code
        followed by a run of a matching code; the first side moves right onto the second's
        last needles, the second left onto the first's first ones."""
        out: list[tuple[int, int, int]] = []
        k = 0
        while k < len(cells):
            col, code = cells[k]
            a = [col]
            k += 1
            while k < len(cells) and cells[k][1] == code:
                a.append(cells[k][0])
                k += 1
            if k == len(cells) or cells[k][1] not in _CABLE_PAIRS[code]:
                raise self.fail(f"cable code {code} has no other side", col)
            other = cells[k][1]
            b = []
            while k < len(cells) and cells[k][1] == other:
                b.append(cells[k][0])
                k += 1
            out += [(x, code, b[-1] - a[-1]) for x in a]
            out += [(x, other, a[0] - b[0]) for x in b]
        return out
