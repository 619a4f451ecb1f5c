"""The DAT writer: `MachineProgram` -> `DatImage`, i.e. Knitout-level ops grouped into passes.

A Shima DAT has one raster row per carriage pass, so the writer's job is to group the
program's ops into passes and give each pass its option values. knitc follows the CMU
Knitout-to-DAT converter exactly, so that a Knitout file converted by knitc gives the same
DAT, row for row and byte for byte (shared/research/knitout-and-dat.md §2.3-§2.6):

* **Slots.** A front needle's slot is its number, a back needle's its number plus
  floor(racking) at the time of the op, so a transfer lands in the column of its front needle.
  Slots may be negative; the raster is placed from the smallest used slot (`DatImage.min_slot`).
* **Merging.** Every needle op becomes a one-slot record that joins the *previous* pass only
  (no look-back), when type, racking, stitch number, speed, direction and carrier list (in
  order) are equal, presser modes agree, hook and gripper actions are compatible and the slot
  continues the pass's direction; an occupied slot only takes a soft miss, or at quarter-pitch
  racking the back op of a front/back pair in carriage order (codes 3/41/42/88). Otherwise a
  new pass starts.
* **Kickbacks.** Before a new pass, carriers it uses that are parked on the wrong side are
  kicked (soft-miss passes the other way); before any needle op but a miss, every other
  carrier whose yarn hangs on one side of the needle and is not parked beyond it there is
  kicked to where its yarn hangs. These are the converter's conservative rules, kept as they
  are because they decide the rows.
* **Carriers.** ``in``/``inhook`` mark the next pass of the set (gripper R10, hook R15 10);
  ``releasehook`` is always a new soft-miss pass without yarn (after a dummy pass the other
  way if the previous pass ran in the release direction: KnitPaint refuses a release on a
  carriage-move row); ``out``/``outhook`` is a rightward soft miss at the carriers' rightmost
  stitch, usually absorbed by their last rightward pass.
* **Options.** Carriage side and R5 (2 = carriage move, 1 = knit cancel on transfer passes),
  racking L2/L3/L4, speed L5/L6, pause L7, split/a-miss L12, slider transfers L13, carrier R3,
  stitch number R6, links process R9 = 1, gripper R10, presser R11, hook R15.

Where the converter would write garbage or crash, the writer raises `DatWriteError` with the
index of the op responsible (the caller maps it to a source line). It also refuses a few
programs the converter accepts but no machine can knit; those and the one deliberate encoding
difference (carrier 10 leading a pair) are listed at `DatWriteError` and `carrier_code`.

The work is one pass over the ops with constant work per op (the active carriers, at most
10, are checked per needle op); passes are objects, ops are not. The writer reads each op as
an `OpRecord` tuple, and a run of one-carrier knits, tucks and misses that extend the last
pass, the bulk of a fabric, is taken inline in `_Writer.run` after one check of the pass and
the writer's state; everything else goes through the converter's rules in full.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import field
from operator import attrgetter
from typing import cast

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
from knitc.codegen.machine import Machine, MachineProgram, Needle
from knitc.records import record

OpRecord = tuple[
    str,
    int,
    Needle | None,
    Needle | None,
    tuple[int, ...],
    float | int | str | tuple[float | int, float | int] | None,
]
"""An op as the writer reads it: (kind, dir, needle, needle2, carriers, value), the first
fields of `Op` in order."""

_RECORD = attrgetter("kind", "dir", "needle", "needle2", "carriers", "value")

__all__ = [
    "DEFAULT_WIDTH",
    "DatWriteError",
    "STITCH_TABLE",
    "carrier_code",
    "stitch_number",
    "OpRecord",
    "records_to_dat",
    "to_dat",
]

DEFAULT_WIDTH = 540
"""Bed width in needles when the program has no ``;;Width:`` (the converter's default)."""

MAX_RACKING = 8
"""The converter refuses |racking| > 8; the machine profile's `racking_limit` may be lower."""

MAX_SIDE = 0xFFFE
"""Largest raster width/height (u16 sizes; the converter asserts both are < 0xFFFF)."""

MAX_CARRIER = 10
"""A Shima DAT names carriers 1..10."""

MAX_STITCH_NUMBER = 255
"""Largest ``x-stitch-number``: it is written as one option-bar colour (R6)."""

MAX_SPEED_NUMBER = 245
"""Largest ``x-speed-number``: it is written plus 10 as one option-bar colour (L5, L6)."""

STITCH_TABLE: dict[tuple[int, int], int] = {
    (-10, 10): 81,
    (0, 10): 82,
    (10, 10): 83,
    (5, 15): 84,
    (10, 15): 85,
    (15, 15): 86,
    (10, 20): 87,
    (15, 20): 88,
    (20, 20): 89,
    (15, 25): 90,
    (20, 25): 91,
    (25, 25): 92,
    (25, 30): 93,
    (25, 35): 94,
    (25, 40): 95,
    (25, 45): 96,
    (25, 50): 97,
    (25, 55): 98,
    (25, 60): 99,
    (25, 65): 100,
}
"""Knitout ``stitch L T`` -> machine stitch number, keyed (L, T) = (leading, stitch): the
converter's fixed table (research §2.6.7); ``stitch 10 15`` is stitch number 85."""


class DatWriteError(ValueError):
    """A program the DAT writer refuses, with the index of the op responsible (None when the
    whole program is at fault, e.g. it makes no pass or its raster is too large).

    Refused like the CMU converter: racking not an integer or integer + 0.25, |racking| beyond
    the machine's limit (and never beyond 8); more than two carriers in a set; a carrier outside
    1..10, used before ``in``, brought in twice, or still in at the end; a first use that does
    not name exactly the carriers of its ``in``; hook misuse (inhook while the hook holds yarn,
    releasehook of another set, out of a hooked carrier, outhook while the hook holds yarn); a
    miss without carriers, a drop/amiss/xfer with carriers; transfers between needles that are
    not aligned, slider to slider, split from a slider, and the split-via-sliders combinations
    that have no colour code; an unknown ``stitch L T`` pair; any option value above 255; a
    ``Keep`` placement outside 1..Width; a raster of 0xFFFF rows or columns or more.

    Refused though the converter accepts (it would write a DAT no machine can use): a transfer
    or split between needles of the same bed (f -> fs), knit/tuck/drop/amiss on a slider, a
    carrier listed twice in one set, a design wider than the bed (more slots than the Width for
    ``Center``, which would give a negative position code, or than the machine has needles),
    a program that makes no pass.
    """

    def __init__(self, message: str, op_index: int | None = None) -> None:
        super().__init__(message)
        self.message = message
        self.op_index = op_index


def carrier_code(carriers: tuple[int, ...]) -> int:
    """The R3/R10 code of a carrier set: its number, or for a pair the two numbers written one
    after the other, leading carrier first. Carrier 10 is written "0" when it follows any
    carrier but 1 (3, 10 -> 30; 1, 10 -> 110) and "10" when it leads (10, 3 -> 103).

    Deliberate difference: the converter writes 10 leading as "1" (10, 3 -> 13, the code of
    1, 3), against its own comment; knitc writes the documented 103 (as the Python port does).
    """
    if len(carriers) == 1:
        return carriers[0]
    a, b = carriers
    if b == 10 and a != 1:
        return a * 10
    return int(f"{a}{b}")


def stitch_number(leading: float, stitch: float) -> int | None:
    """The machine stitch number of Knitout ``stitch leading stitch``, None if not in the table
    (or not integers: the converter accepts only integer values)."""
    if not (float(leading).is_integer() and float(stitch).is_integer()):
        return None
    return STITCH_TABLE.get((int(leading), int(stitch)))


# ---- pass records ------------------------------------------------------------------------------

# Pass types (the converter's: they must match for ops to share a pass).
T_KNIT, T_AMISS, T_SPLIT, T_SVS, T_XFER, T_XFER_TO, T_XFER_FROM = range(7)
_XFER_TYPES = (T_XFER, T_XFER_TO, T_XFER_FROM)

# Hook and gripper actions of a pass.
HOOK_IN, HOOK_RELEASE, HOOK_OUT = 1, 2, 3
GRIP_IN, GRIP_OUT = 1, 2

# Slot contents are colour codes, except the front/back pairs "X then a miss on the other
# bed": they show X's colour but no longer combine with anything (the converter keeps them as
# distinct objects), so they get colour + _TERMINAL until the raster is written.
_TERMINAL = 1000
_COMBINE: dict[tuple[int, int], int] = {
    (MISS_F, MISS_B): SOFT_MISS + _TERMINAL,
    (MISS_F, TUCK_B): TUCK_B + _TERMINAL,
    (MISS_F, KNIT_B): KNIT_B + _TERMINAL,
    (TUCK_F, MISS_B): TUCK_F + _TERMINAL,
    (TUCK_F, TUCK_B): TUCK_FB,
    (TUCK_F, KNIT_B): TUCK_F_KNIT_B,
    (KNIT_F, MISS_B): KNIT_F + _TERMINAL,
    (KNIT_F, TUCK_B): KNIT_F_TUCK_B,
    (KNIT_F, KNIT_B): KNIT_FB,
}
"""Front op then back op in one column (rightward order), at quarter pitch only."""
_FRONT = frozenset(
    {
        TUCK_F,
        KNIT_F,
        KNIT_FB,
        KNIT_F_TUCK_B,
        TUCK_F_KNIT_B,
        TUCK_FB,
        TUCK_F + _TERMINAL,
        KNIT_F + _TERMINAL,
    }
)
_BACK = frozenset(
    {
        TUCK_B,
        KNIT_B,
        KNIT_FB,
        KNIT_F_TUCK_B,
        TUCK_F_KNIT_B,
        TUCK_FB,
        TUCK_B + _TERMINAL,
        KNIT_B + _TERMINAL,
    }
)
"""Slot contents that use a front / back hook (misses and transfers use neither): a pass
with the presser on may not mix them."""

# Split-via-sliders colours by (return racking - split racking): (front op, back op).
_SVS_CODES: dict[float, tuple[int, int]] = {
    1: (107, 108),
    2: (127, 128),
    4: (147, 148),
    -1: (106, 109),
    -2: (126, 129),
    -4: (146, 149),
}


def _combine(a: int, b: int, quarter: bool) -> int | None:
    """What one column does for `a` then `b` (moving right), or None if it cannot do both."""
    if a == SOFT_MISS:
        return b
    if b == SOFT_MISS:
        return a
    if not quarter:
        return None
    return _COMBINE.get((a, b))


class _Pass:
    """One pass under construction: the converter's pass record plus running slot bounds."""

    __slots__ = (
        "type",
        "racking",
        "stitch",
        "speed",
        "dir",
        "carriers",
        "presser",
        "hook",
        "gripper",
        "pause",
        "slots",
        "lo",
        "hi",
        "front",
        "back",
        "ret",
        "op",
    )

    def __init__(
        self,
        typ: int,
        racking: float,
        stitch: int,
        speed: int,
        d: int,
        carriers: tuple[int, ...],
        presser: str | None,
        hook: int,
        gripper: int,
        pause: bool,
        slot: int,
        code: int,
        op: int,
    ) -> None:
        self.type = typ
        self.racking = racking
        self.stitch = stitch
        self.speed = speed
        self.dir = d
        self.carriers = carriers
        self.presser = presser
        self.hook = hook
        self.gripper = gripper
        self.pause = pause
        self.slots = {slot: code}
        self.lo = self.hi = slot
        self.front = code in _FRONT
        self.back = code in _BACK
        self.ret: float | None = None
        """Return racking of a split-via-sliders pass."""
        self.op = op
        """Index of the op that started the pass (for errors found at the end)."""


class _Carrier:
    """An active carrier: pending ``in``, whether the hook holds it, where its yarn hangs
    (`last`, the needle and direction of its last stitch) and where it is parked (`kick`)."""

    __slots__ = ("pending", "used_hook", "last", "last_dir", "kick", "kick_dir", "op")

    def __init__(self, pending: tuple[str, tuple[int, ...]], op: int) -> None:
        self.pending: tuple[str, tuple[int, ...]] | None = pending
        self.used_hook = pending[0] == "inhook"
        self.last: Needle | None = None
        self.last_dir = 0
        self.kick: Needle | None = None
        self.kick_dir = 0
        self.op = op


@record
class _SplitViaSliders:
    """Splits to sliders waiting for their return transfers: the racking they were made at,
    the sliders holding their loops, and the racking of the returns once one is seen."""

    racking: float
    needles: set[Needle] = field(default_factory=set)
    ret: float | None = None


_IS_BACK = {"f": False, "fs": False, "b": True, "bs": True}
_STITCH_KINDS = frozenset(("knit", "tuck", "miss"))
_FRONT_CODES = {"knit": KNIT_F, "tuck": TUCK_F, "miss": MISS_F}
_BACK_CODES = {"knit": KNIT_B, "tuck": TUCK_B, "miss": MISS_B}
"""The colour of a knit, tuck or miss on the front / back bed."""


def _js_key_order(keys: list[int]) -> list[int]:
    """Slots in the order the converter visits an object keyed by them: non-negative integers
    ascending, then the others as inserted (it matters only for kicks to negative slots)."""
    return sorted(k for k in keys if k >= 0) + [k for k in keys if k < 0]


# ---- the writer --------------------------------------------------------------------------------


class _Writer:
    """The converter's state machine over one program (research §2.6.1)."""

    def __init__(self, ops: Sequence[OpRecord], machine: Machine) -> None:
        self.ops = ops
        self.machine = machine
        self.limit = min(machine.racking_limit, MAX_RACKING)
        self.passes: list[_Pass] = []
        self.carriers: dict[int, _Carrier] = {}
        self.order: list[int] = []
        """Active carriers, ascending (the order the converter checks them in)."""
        self.hook: tuple[int, tuple[int, ...]] | None = None
        """(direction, carriers) while the inserting hook holds yarn."""
        self.racking: float = 0
        self.fl = 0
        """floor(racking): what a back needle adds to its number to give its slot."""
        self.stitch = 5
        self.speed = 0
        self.presser = "off"
        self.pause_pending = False
        self.svs: _SplitViaSliders | None = None
        self.i = -1
        """Index of the op being converted."""
        self.good_sets: set[tuple[int, ...]] = set()
        """Carrier sets already checked (one to two carriers, each 1..10)."""
        self.lo: tuple[int, int] | None = None
        self.hi: tuple[int, int] | None = None
        """(slot, op index) of the leftmost and rightmost slot so far, so that a design too
        wide for the bed is reported at the op that made it so."""

    # -- helpers --------------------------------------------------------------------------------

    def fail(self, message: str) -> DatWriteError:
        return DatWriteError(message, self.i)

    def slot(self, n: Needle) -> int:
        return n.index + self.fl if _IS_BACK[n.bed] else n.index

    def check_carriers(self, cs: tuple[int, ...], what: str) -> None:
        if cs in self.good_sets:
            return
        if len(cs) > 2:
            raise self.fail(
                f"{what} uses {len(cs)} carriers {list(cs)}; a Shima pass carries at most 2"
            )
        if len(cs) == 2 and cs[0] == cs[1]:
            raise self.fail(f"{what} lists carrier {cs[0]} twice")
        for c in cs:
            if not (isinstance(c, int) and 1 <= c <= MAX_CARRIER):
                raise self.fail(
                    f"{what} uses carrier {c!r}; a Shima DAT has carriers 1..{MAX_CARRIER}"
                )
        self.good_sets.add(cs)

    def no_svs(self, what: str) -> None:
        if self.svs is not None:
            raise self.fail(
                f"cannot {what} while splits via sliders wait for their return transfers"
            )

    # -- merging (research §2.6.3, §2.6.4) ------------------------------------------------------

    def append(
        self,
        p: _Pass,
        typ: int,
        d: int,
        cs: tuple[int, ...],
        stitch: int,
        slot: int,
        code: int,
        presser: str | None,
        hook: int,
        gripper: int,
    ) -> bool:
        """Add a one-slot record to pass `p` if the converter would; say whether it did."""
        if (
            p.type != typ
            or p.racking != self.racking
            or p.stitch != stitch
            or p.speed != self.speed
            or p.dir != d
            or p.carriers != cs
        ):
            return False
        if presser is not None and p.presser is not None and presser != p.presser:
            return False
        if p.presser == "on":
            if (p.front and code in _BACK) or (p.back and code in _FRONT) or hook:
                return False
        if hook == HOOK_OUT:
            if p.hook:
                return False
        elif hook or p.hook == HOOK_OUT:
            return False
        if gripper == GRIP_OUT:
            if p.gripper:
                return False
        elif gripper or p.gripper == GRIP_OUT:
            return False
        slots = p.slots
        merged: int | None = code
        if d > 0:
            if slot < p.hi:
                return False
            if slot == p.hi:
                merged = _combine(slots[slot], code, p.racking != math.floor(p.racking))
                if merged is None:
                    return False
        elif d < 0:
            if slot > p.lo:
                return False
            if slot == p.lo:
                merged = _combine(code, slots[slot], p.racking != math.floor(p.racking))
                if merged is None:
                    return False
        elif slot in slots:
            quarter = p.racking != math.floor(p.racking)
            old = slots[slot]
            merged = _combine(old, code, quarter)
            if merged is None:
                merged = _combine(code, old, quarter)
                if merged is None:
                    return False
        if presser is not None:
            p.presser = presser
        if hook:
            p.hook = hook
        if gripper:
            p.gripper = gripper
        assert merged is not None  # every None above returned False
        self.extend(slot)
        slots[slot] = merged
        if slot < p.lo:
            p.lo = slot
        if slot > p.hi:
            p.hi = slot
        if merged in _FRONT:
            p.front = True
        if merged in _BACK:
            p.back = True
        return True

    def extend(self, slot: int) -> None:
        """Note a slot a pass takes (for the bounds of the design and who set them)."""
        if self.lo is None or slot < self.lo[0]:
            self.lo = (slot, self.i)
        if self.hi is None or slot > self.hi[0]:
            self.hi = (slot, self.i)

    def new_pass(
        self,
        typ: int,
        d: int,
        cs: tuple[int, ...],
        stitch: int,
        slot: int,
        code: int,
        presser: str | None,
        hook: int,
        gripper: int,
        pause: bool,
    ) -> None:
        r = self.racking
        if abs(r) > self.limit:
            raise self.fail(f"racking {r:g} is beyond the machine's limit of {self.limit}")
        self.extend(slot)
        self.passes.append(
            _Pass(
                typ, r, stitch, self.speed, d, cs, presser, hook, gripper, pause, slot, code, self.i
            )
        )

    def merge(
        self,
        typ: int,
        d: int,
        cs: tuple[int, ...],
        stitch: int,
        slot: int,
        code: int,
        presser: str | None = None,
        hook: int = 0,
        gripper: int = 0,
        pause: bool = False,
    ) -> None:
        """Add a one-slot record: to the previous pass if it fits, else as a new pass after
        kicking its carriers to the side it starts from. A pending pause goes on the first new
        pass (a kick, possibly)."""
        do_pause = self.pause_pending
        self.pause_pending = False
        passes = self.passes
        if (
            passes
            and not do_pause
            and not pause
            and self.append(passes[-1], typ, d, cs, stitch, slot, code, presser, hook, gripper)
        ):
            return
        kicks: dict[int, list[int]] | None = None
        for c in cs:
            car = self.carriers[c]
            if car.last is None:
                continue  # being brought in: nothing to kick
            k = car.kick
            assert k is not None  # set together with `last`
            kslot = k.index + self.fl if _IS_BACK[k.bed] else k.index
            if car.kick_dir < 0:
                if d < 0:
                    target = kslot  # parked left of kslot, possibly far: move it back
                elif kslot > slot:
                    target = slot
                else:
                    continue
            else:
                if d > 0:
                    target = kslot
                elif kslot < slot:
                    target = slot
                else:
                    continue
            if kicks is None:
                kicks = {}
            kicks.setdefault(target, []).append(c)
        if kicks is None:
            self.new_pass(typ, d, cs, stitch, slot, code, presser, hook, gripper, pause or do_pause)
            return
        for target in _js_key_order(list(kicks)):
            group = tuple(kicks[target])
            self.merge(T_KNIT, -d, group, self.stitch, target, SOFT_MISS, pause=do_pause)
            do_pause = False
            parked = Needle("f", target)
            for c in group:
                car = self.carriers[c]
                car.kick, car.kick_dir = parked, -d
        self.merge(typ, d, cs, stitch, slot, code, presser, hook, gripper, pause)

    def kick_others(self, n: Needle, cs: tuple[int, ...]) -> None:
        """Before a needle op at `n`: park every other stitched carrier on the side its yarn
        hangs, at least as far out as `n` (research §2.6.4, second rule)."""
        at = self.slot(n)
        fl = self.fl
        for c in self.order:
            if c in cs:
                continue
            car = self.carriers[c]
            last = car.last
            if last is None:
                continue
            last_slot = last.index + fl if _IS_BACK[last.bed] else last.index
            k = car.kick
            kslot = k.index + fl if _IS_BACK[k.bed] else k.index  # type: ignore[union-attr]
            if last_slot < at or (last_slot == at and car.last_dir < 0):
                if car.kick_dir < 0 and kslot <= at:
                    continue
                side = -1
            else:
                if car.kick_dir > 0 and kslot >= at:
                    continue
                side = 1
            self.merge(T_KNIT, side, (c,), self.stitch, last_slot, SOFT_MISS)
            car.kick, car.kick_dir = Needle("f", last_slot), side

    def take_in(self, cs: tuple[int, ...], d: int) -> tuple[int, int]:
        """The (hook, gripper) actions of the first pass of carriers just brought in."""
        pending = None
        carriers = self.carriers
        for c in cs:
            car = carriers.get(c)
            if car is None:
                raise self.fail(f"carrier {c} is used but not in action (no in/inhook)")
            if car.pending is not None:
                pending = car.pending
                car.pending = None
        if pending is None:
            return 0, 0
        kind, in_cs = pending
        if in_cs != cs:
            raise self.fail(
                f"the first use of carriers {list(cs)} must name exactly the "
                f"carriers brought in together ({kind} {' '.join(map(str, in_cs))})"
            )
        if kind == "in":
            return 0, GRIP_IN
        if self.hook is not None:
            raise self.fail(
                f"cannot bring in carriers {list(cs)} with the hook: it holds {list(self.hook[1])}"
            )
        self.hook = (d, cs)
        return HOOK_IN, GRIP_IN

    def set_last(self, cs: tuple[int, ...], d: int, n: Needle) -> None:
        for c in cs:
            car = self.carriers[c]
            car.last = car.kick = n
            car.last_dir = car.kick_dir = d

    # -- ops ------------------------------------------------------------------------------------

    def run(self) -> None:
        passes, carriers, good_sets = self.passes, self.carriers, self.good_sets
        is_back = _IS_BACK
        # The common case, inline: a one-carrier knit, tuck or miss that joins the last pass
        # at its moving end, with no other carrier to kick. `fast_cs` and `fast_dir` are the
        # carriers and direction of such ops that the last pass and the writer's state (its
        # settings, the carrier, no pause or split via sliders pending) have been checked
        # for, with those values in the locals below; fast_cs None: not checked. Any other
        # op goes through the converter's full rules (and every error is found there) and
        # then the state is checked again.
        fast_cs: tuple[int, ...] | None = None
        fast_dir = 0
        p, car = cast(_Pass, None), cast(_Carrier, None)  # set whenever fast_cs is
        fl, single, on, presser, lo, hi = 0, False, False, "", (0, 0), (0, 0)
        for i, (k, d, n, n2, cs, value) in enumerate(self.ops):
            if k in _STITCH_KINDS:
                if fast_cs is None or cs is not fast_cs or d != fast_dir:
                    fast_cs = None
                    if (
                        len(cs) == 1
                        and self.svs is None
                        and cs in good_sets
                        and (d == 1 or d == -1)
                        and passes
                        and not self.pause_pending
                    ):
                        got = carriers.get(cs[0])
                        p = passes[-1]
                        presser = self.presser
                        if (
                            got is not None
                            and got.pending is None
                            and p.type == T_KNIT
                            and p.dir == d
                            and p.carriers == cs
                            and p.racking == self.racking
                            and p.stitch == self.stitch
                            and p.speed == self.speed
                            and p.hook != HOOK_OUT
                            and p.gripper != GRIP_OUT
                            and (p.presser is None or p.presser == presser)
                        ):
                            fast_cs, fast_dir, car = cs, d, got
                            fl, single, on = self.fl, len(self.order) == 1, presser == "on"
                            assert self.lo is not None and self.hi is not None  # (a pass is)
                            lo, hi = self.lo, self.hi
                if fast_cs is not None and n is not None:
                    bed, index = n
                    back = is_back[bed]
                    slot = index + fl if back else index
                    # (knit and tuck kick other carriers, and not on sliders; the presser,
                    # when on, keeps a pass on one bed's hooks)
                    if (
                        (slot > p.hi if d > 0 else slot < p.lo)
                        and (k == "miss" or (single and bed != "fs" and bed != "bs"))
                        and (not on or k == "miss" or not (p.back if not back else p.front))
                    ):
                        p.presser = presser
                        if slot < lo[0]:
                            lo = self.lo = (slot, i)
                        if slot > hi[0]:
                            hi = self.hi = (slot, i)
                        if back:
                            p.slots[slot] = _BACK_CODES[k]
                            if k != "miss":
                                p.back = True
                        else:
                            p.slots[slot] = _FRONT_CODES[k]
                            if k != "miss":
                                p.front = True
                        if d > 0:
                            p.hi = slot
                        else:
                            p.lo = slot
                        car.last = car.kick = n
                        car.last_dir = car.kick_dir = d
                        continue
                fast_cs = None
                self.i = i
                self.stitch_op(k, d, n, cs)
                continue
            if k == "comment":
                continue
            fast_cs = None
            self.i = i
            if k == "drop" or k == "amiss":
                self.stitch_op(k, d, n, cs)
            elif k == "split" or k == "xfer":
                self.split_op(k, d, n, n2, cs)
            elif k == "rack":
                self.rack(value)
            elif k == "in" or k == "inhook":
                self.bring_in(k, cs)
            elif k == "releasehook":
                self.release(cs)
            elif k == "out" or k == "outhook":
                self.take_out(k, cs)
            elif k == "stitch":
                self.no_svs("change the stitch")
                lead, tight = cast("tuple[float, float]", value)
                number = stitch_number(lead, tight)
                if number is None:
                    raise self.fail(
                        f"stitch {lead:g} {tight:g} is not in the machine's stitch "
                        "table (integer leading/stitch pairs such as 10 15)"
                    )
                self.stitch = number
            elif k == "stitch_number":
                self.no_svs("change the stitch number")
                self.stitch = self.setting(value, MAX_STITCH_NUMBER, "stitch number")
            elif k == "speed":
                self.no_svs("change the speed")
                self.speed = self.setting(value, MAX_SPEED_NUMBER, "speed number")
            elif k == "presser":
                self.no_svs("change the presser mode")
                if value not in ("on", "off", "auto"):
                    raise self.fail(f"presser mode {value!r} is not on, off or auto")
                self.presser = cast(str, value)
            elif k == "pause":
                self.no_svs("pause")
                self.pause_pending = True
            else:
                raise self.fail(f"op kind {k!r} has no DAT form")
        self.i = -1
        for c in self.order:
            raise DatWriteError(
                f"carrier {c} is still in action at the end; take it out with out or outhook",
                self.carriers[c].op,
            )

    def setting(self, value: object, top: int, what: str) -> int:
        if isinstance(value, float) and value.is_integer():
            value = int(value)
        if not isinstance(value, int) or isinstance(value, bool) or value < 0:
            raise self.fail(f"{what} {value!r} is not a non-negative integer")
        if value > top:
            raise self.fail(f"{what} {value} does not fit the DAT's option bar (at most {top})")
        return value

    def rack(self, value: object) -> None:
        if (
            isinstance(value, bool)
            or not isinstance(value, int | float)
            or not math.isfinite(value)
        ):
            raise self.fail(f"racking {value!r} is not a number")
        if value - math.floor(value) not in (0, 0.25):
            raise self.fail(
                f"racking {value:g} is neither an integer nor an integer + 0.25 (quarter pitch)"
            )
        self.racking = value
        self.fl = math.floor(value)

    def bring_in(self, kind: str, cs: tuple[int, ...]) -> None:
        self.no_svs(kind)
        if not cs:
            raise self.fail(f"{kind} without carriers")
        self.check_carriers(cs, kind)
        for c in cs:
            if c in self.carriers:
                raise self.fail(f"cannot bring in carrier {c}: it is already in action")
        pending = (kind, cs)
        for c in cs:
            self.carriers[c] = _Carrier(pending, self.i)
        self.order = sorted(self.carriers)

    def release(self, cs: tuple[int, ...]) -> None:
        self.no_svs("releasehook")
        if self.hook is None:
            raise self.fail(f"releasehook {' '.join(map(str, cs))}: the hook holds no yarn")
        d, held = self.hook
        if held != cs:
            raise self.fail(
                f"releasehook {' '.join(map(str, cs))}: the hook holds carriers "
                f"{' '.join(map(str, held))}"
            )
        for c in cs:
            self.carriers[c].used_hook = False
        first = self.carriers[cs[0]].last
        assert first is not None  # the hook is set on the carriers' first stitch
        at = self.slot(first)
        # The release happens before its pass, which must not be a carriage move: if the
        # previous pass already ran that way, a dummy pass goes the other way first.
        if self.passes[-1].dir == d:
            self.new_pass(T_KNIT, -d, (), self.stitch, at, SOFT_MISS, None, 0, 0, False)
        self.new_pass(T_KNIT, d, (), self.stitch, at, SOFT_MISS, None, HOOK_RELEASE, 0, False)
        self.hook = None

    def take_out(self, kind: str, cs: tuple[int, ...]) -> None:
        self.no_svs(kind)
        if not cs:
            raise self.fail(f"{kind} without carriers")
        self.check_carriers(cs, kind)
        at: int | None = None
        for c in cs:
            car = self.carriers.get(c)
            if car is None:
                raise self.fail(f"cannot take out carrier {c}: it is not in action")
            if car.last is None:
                raise self.fail(f"cannot take out carrier {c}: it has not made a stitch yet")
            if kind == "out" and car.used_hook:
                raise self.fail(
                    f"cannot take out carrier {c} with out: the hook still holds "
                    "it (releasehook first)"
                )
            s = self.slot(car.last)
            if at is None or s > at:
                at = s
        if kind == "outhook" and self.hook is not None:
            raise self.fail(
                f"cannot outhook carriers {list(cs)}: the hook holds {list(self.hook[1])}"
            )
        assert at is not None
        self.merge(
            T_KNIT,
            1,
            cs,
            self.stitch,
            at,
            SOFT_MISS,
            hook=HOOK_OUT if kind == "outhook" else 0,
            gripper=GRIP_OUT,
        )
        for c in cs:
            del self.carriers[c]
        self.order = sorted(self.carriers)

    def stitch_op(self, kind: str, d: int, n: Needle | None, cs: tuple[int, ...]) -> None:
        self.no_svs(kind)
        if n is None:
            raise self.fail(f"{kind} without a needle")
        if kind in ("drop", "amiss"):
            if cs:
                raise self.fail(
                    f"{kind} takes no carriers (use {'knit' if kind == 'drop' else 'tuck'})"
                )
            kind = "knit" if kind == "drop" else "tuck"
        if cs:
            self.check_carriers(cs, kind)
            if d not in (1, -1):
                raise self.fail(f"{kind} needs a direction")
        elif kind == "miss":
            raise self.fail("a miss needs carriers")
        else:
            d = 0  # drop / a-miss: no direction
        front = not _IS_BACK[n.bed]
        if kind == "miss":
            code = MISS_F if front else MISS_B
        else:
            if n.bed in ("fs", "bs"):
                raise self.fail(
                    f"cannot {'knit' if kind == 'knit' else 'tuck'} on slider needle {n}"
                )
            self.kick_others(n, cs)
            if kind == "knit":
                code = KNIT_F if front else KNIT_B
            else:
                code = TUCK_F if front else TUCK_B
        typ = T_AMISS if kind == "tuck" and not cs else T_KNIT
        hook = gripper = 0
        if cs:
            hook, gripper = self.take_in(cs, d)
        self.merge(typ, d, cs, self.stitch, self.slot(n), code, self.presser, hook, gripper)
        if cs:
            self.set_last(cs, d, n)

    def split_op(
        self, kind: str, d: int, n: Needle | None, t: Needle | None, cs: tuple[int, ...]
    ) -> None:
        if n is None or t is None:
            raise self.fail(f"{kind} needs two needles")
        if kind == "xfer" and cs:
            raise self.fail("xfer takes no carriers (use split)")
        if cs:
            self.check_carriers(cs, "split")
            if d not in (1, -1):
                raise self.fail("split needs a direction")
        n_back, t_back = _IS_BACK[n.bed], _IS_BACK[t.bed]
        if n_back == t_back:
            raise self.fail(f"{kind} {n} {t}: both needles are on the same bed")
        r = self.racking
        if (n.index + r != t.index) if n_back else (n.index != t.index + r):
            raise self.fail(f"{kind} {n} {t}: the needles are not aligned at racking {r:g}")
        n_slider, t_slider = n.bed in ("fs", "bs"), t.bed in ("fs", "bs")
        to_other = XFER_BF if n_back else XFER_FB
        split_code = SPLIT_BF if n_back else SPLIT_FB
        if n_slider and t_slider:
            raise self.fail(f"{kind} {n} {t}: cannot move loops from slider to slider")
        if not n_slider and not t_slider:
            self.no_svs(kind)
            typ, code = (T_SPLIT, split_code) if cs else (T_XFER, to_other)
        elif n_slider:
            if cs:
                raise self.fail(f"split {n} {t}: cannot split from a slider")
            if self.svs is not None:
                self.svs_return(n)
                return
            typ, code = T_XFER_FROM, to_other
        elif not cs:
            self.no_svs(kind)
            typ, code = T_XFER_TO, to_other
        else:
            svs = self.svs
            if svs is None:
                svs = self.svs = _SplitViaSliders(r)
            if svs.ret is not None:
                raise self.fail(f"split {n} {t}: cannot split to sliders while returning from them")
            if svs.racking != r:
                raise self.fail(
                    f"split {n} {t}: splits via sliders must all be at racking {svs.racking:g}"
                )
            if t in svs.needles:
                raise self.fail(f"split {n} {t}: slider {t} already holds a split loop")
            svs.needles.add(t)
            typ, code = T_SVS, split_code
        if not cs:
            d = 0
        self.kick_others(n, cs)
        hook = gripper = 0
        if cs:
            hook, gripper = self.take_in(cs, d)
        self.merge(typ, d, cs, self.stitch if cs else 0, self.slot(n), code, None, hook, gripper)
        for car in self.carriers.values():
            if car.last == n:
                car.last = t
        if cs:
            self.set_last(cs, d, n)

    def svs_return(self, n: Needle) -> None:
        """``xfer`` from a slider back to the hooks while splits via sliders are pending: the
        split's colour already includes the return, so only its racking is recorded."""
        svs = self.svs
        assert svs is not None
        if svs.ret is None:
            svs.ret = self.racking
            self.passes[-1].ret = self.racking
        if svs.ret != self.racking:
            raise self.fail(
                f"xfer from {n}: returns from sliders must all be at racking {svs.ret:g}"
            )
        if n not in svs.needles:
            raise self.fail(f"xfer from {n}: no split-via-sliders loop waits there")
        svs.needles.discard(n)
        if not svs.needles:
            self.svs = None

    # -- options and raster rows (research §2.4, §2.6.5) -----------------------------------------

    def image(self, width: int, position: str) -> DatImage:
        passes = self.passes
        if not passes:
            raise DatWriteError("the program makes no carriage pass; a DAT needs at least one")
        assert self.lo is not None and self.hi is not None  # every slot came through extend
        (lo, lo_op), (hi, hi_op) = self.lo, self.hi
        widest = max(lo_op, hi_op)  # the op that stretched the design last
        used = hi - lo + 1
        if used + 110 > MAX_SIDE or len(passes) + 19 > MAX_SIDE:
            raise DatWriteError(
                f"the DAT raster would be {used + 110} x {len(passes) + 19}; "
                f"each side must stay below {MAX_SIDE + 1}",
                widest if used + 110 > MAX_SIDE else passes[MAX_SIDE - 19].op,
            )
        needles = self.machine.needles
        if used > needles:
            raise DatWriteError(
                f"the design spans {used} needles (slots {lo}..{hi}); the machine has {needles}",
                widest,
            )
        out: list[DatPass] = []
        carriage = 1  # after the fixed start courses the carriage is on the right
        hook_active = False
        for p in passes:
            slots = p.slots
            if p.type == T_SVS:
                codes = None if p.ret is None else _SVS_CODES.get(p.ret - p.racking)
                if codes is None:
                    ret = "no return" if p.ret is None else f"return racking {p.ret:g}"
                    raise DatWriteError(
                        f"splits via sliders at racking {p.racking:g} with "
                        f"{ret} have no DAT colour (the return racking must "
                        "differ by 1, 2 or 4)",
                        p.op,
                    )
                slots = {s: codes[0] if c == SPLIT_FB else codes[1] for s, c in slots.items()}
            elif max(slots.values()) >= _TERMINAL:  # (every pass has a slot)
                slots = {s: c % _TERMINAL for s, c in slots.items()}
            left = [0] * 20
            right = [0] * 20
            cs = p.carriers
            typ = p.type
            right[2] = carrier_code(cs) if cs else (255 if typ == T_KNIT else 0)
            right[5] = p.stitch
            right[8] = 1
            if typ == T_XFER_TO:
                left[12] = 1
            elif typ == T_XFER_FROM:
                left[12] = 3
            elif typ == T_SPLIT:
                left[11] = 10
            elif typ == T_AMISS:
                left[11] = 20
            if p.gripper == GRIP_IN:
                right[9] = right[2]
            elif p.gripper == GRIP_OUT:
                right[9] = 100 + right[2]
            if p.pause:
                left[6] = 20
            if p.presser == "on" or (
                p.presser == "auto" and not hook_active and not p.hook and not (p.front and p.back)
            ):
                right[10] = 101
            if p.hook == HOOK_IN:
                right[14] = 10
                hook_active = True
            elif p.hook == HOOK_OUT:
                right[14] = 20
            elif p.hook == HOOK_RELEASE:
                right[14] = 90
                hook_active = False
            if p.speed:
                left[4] = left[5] = p.speed + 10
            if typ in _XFER_TYPES:
                right[4] = 1  # knit cancel: transfers are written with knit+xfer colours
            r = p.racking
            fl = math.floor(r)
            if r >= 1:
                left[3], left[1] = 11, math.floor(r - 1)
            else:
                left[3], left[1] = 10, -fl
            if r != fl:
                left[2] = 1
            d = p.dir
            if d == 0 and typ in (T_KNIT, T_AMISS):
                d = 1 if carriage < 0 else -1  # drops and a-misses run away from the carriage
            if d and d != -carriage:
                right[4] = 2  # carriage move: the carriage starts from the other side
            if d:
                carriage = d
            out.append(
                DatPass(
                    direction=RIGHT if d > 0 else LEFT if d < 0 else NONE,
                    slots=slots,
                    left=left,
                    right=right,
                )
            )
        if position == "Center":
            code = math.floor((width - used) / 2 + 0.5)  # JavaScript's Math.round
            if code < 0:
                raise DatWriteError(
                    f"the design spans {used} needles, wider than the bed "
                    f"({width}); it cannot be centred",
                    widest,
                )
        elif position == "Keep":
            if not (lo > 0 and hi <= width):
                raise DatWriteError(
                    f"cannot use position Keep: slots {lo}..{hi} are outside "
                    f"the bed's needles 1..{width}",
                    lo_op if lo <= 0 else hi_op,
                )
            code = lo
        elif position == "Left":
            code = 1
        elif position == "Right":
            code = 0  # KnitPaint places it at the right edge
        else:
            raise DatWriteError(f"position {position!r} is not Left, Center, Right or Keep")
        if code // 100 > 255:
            raise DatWriteError(
                f"position code {code} does not fit the DAT (bed width {width} is too large)"
            )
        return DatImage(
            passes=out, min_slot=lo, max_slot=hi, position=code, carriage_left_at_end=carriage < 0
        )


def to_dat(
    prog: MachineProgram, *, width: int | None = None, position: str | None = None
) -> DatImage:
    """The DAT passes of a program, grouped and optioned as the CMU converter does.

    `width` is the bed width in needles used to place a ``Center`` or ``Keep`` design (default:
    the program's ``;;Width:``, else 540); `position` the placement (default: the program's
    ``;;Position:``). Raises DatWriteError for a program a Shima machine or its DAT cannot
    take, with the index of the op responsible.
    """
    return records_to_dat(
        list(map(_RECORD, prog.ops)),
        prog.machine,
        width=width if width is not None else prog.width,
        position=position if position is not None else prog.position,
    )


def records_to_dat(
    ops: Sequence[OpRecord], machine: Machine, *, width: int | None, position: str
) -> DatImage:
    """`to_dat` of a program given as its ops' `OpRecord`s and its machine (`width` None:
    540). What `knitc k2dat` converts a Knitout file through, without making its ops."""
    w = width if width is not None else DEFAULT_WIDTH
    if isinstance(w, bool) or not isinstance(w, int) or w < 1:
        raise DatWriteError(f"bed width {w!r} is not a positive integer")
    writer = _Writer(ops, machine)
    writer.run()
    return writer.image(w, position)
