"""The DAT IR: a Shima Seiki KnitPaint DAT file as a list of carriage passes.

A DAT is an indexed-colour raster where each row is one carriage pass, each column of the
middle band one needle slot, and the margins hold "option bars": per-pass machine settings
(shared/research/knitout-and-dat.md §2). This module holds the passes as knitc builds and
reads them, between the MachineProgram and the bytes:

    MachineProgram ──backends.dat_write──▶ DatImage ──backends.dat_format──▶ bytes
    bytes ──backends.dat_format──▶ DatImage ──backends.dat_read──▶ MachineProgram / Knitout

`DatImage.passes` are the pass rows in execution order, *without* the three fixed start and
three fixed end courses, which the container adds and strips (they depend only on the slot
range and on which side the carriage ends). Slots are the raster's needle columns: a front
needle's slot is its number, a back needle's its number plus floor(racking), so a transfer
lands in the column of its front needle.

`rows()` is the conformance view: every raster row with its direction code, the 20 left and
20 right option values and the colour codes over the slot band (stop marks included). Two
DATs "match" when their rows are equal (shared/fixtures/dat/README.md).
"""

from __future__ import annotations

from dataclasses import field
from typing import Any

from knitc.records import record

N_OPTIONS = 20
"""Option lines per side: L1..L20 and R1..R20."""

RIGHT, LEFT, NONE = 6, 7, 1
"""Direction codes, written in the L1 and R1 marker pixels: rightward (+), leftward (-),
no direction (transfer passes)."""

# Slot colour codes (knitout-and-dat.md §2.3).
STOP = 13
KNIT_F, KNIT_B = 51, 52
TUCK_F, TUCK_B = 11, 12
KNIT_FB, KNIT_F_TUCK_B, TUCK_F_KNIT_B, TUCK_FB = 3, 41, 42, 88
XFER_FB, XFER_BF = 20, 30
SPLIT_FB, SPLIT_BF = 101, 102
MISS_F, MISS_B = 216, 217
SOFT_MISS = 16


def option_index(name: str) -> tuple[str, int]:
    """'L7' -> ('L', 6), 'R15' -> ('R', 14): which bar and which 0-based line."""
    side, k = name[0], int(name[1:])
    if side not in "LR" or not 1 <= k <= N_OPTIONS:
        raise ValueError(f"no option line {name!r}")
    return side, k - 1


@record
class DatPass:
    """One pass row: its direction code, the colour code of every slot it uses (stop marks
    excluded: the container writes them one slot beyond each end), and its option values."""

    direction: int = NONE
    slots: dict[int, int] = field(default_factory=dict)
    left: list[int] = field(default_factory=lambda: [0] * N_OPTIONS)
    """L1..L20 values (index 0 = L1)."""
    right: list[int] = field(default_factory=lambda: [0] * N_OPTIONS)
    """R1..R20 values (index 0 = R1)."""

    def get(self, name: str) -> int:
        side, k = option_index(name)
        return (self.left if side == "L" else self.right)[k]

    def set(self, name: str, value: int) -> None:
        if not 0 <= value <= 255:
            raise ValueError(f"option {name} = {value} does not fit in a colour index")
        side, k = option_index(name)
        (self.left if side == "L" else self.right)[k] = value


@record
class DatImage:
    """A whole DAT: its pass rows, the slot range they span, the position code, and whether
    the carriage ends on the left (the first fixed end course then carries R5 = 2)."""

    passes: list[DatPass] = field(default_factory=list)
    min_slot: int = 0
    max_slot: int = 0
    position: int | None = None
    """KnitPaint's position code (x = 48 of the width row and the row above); None: absent."""
    carriage_left_at_end: bool = False

    @property
    def width(self) -> int:
        """Raster width: the used slots plus 55 columns of margin, bar and gap a side."""
        return self.max_slot - self.min_slot + 1 + 110

    @property
    def height(self) -> int:
        """Raster height: the passes plus 5 blank, 3 + 3 fixed, 1 blank, the width row and
        6 rows above."""
        return len(self.passes) + 19


@record(frozen=True)
class Row:
    """One raster row as the conformance tests compare it."""

    y: int
    direction: int
    left: tuple[int, ...]
    right: tuple[int, ...]
    slots: tuple[int, ...]
    """Colour codes from the left stop-mark column to the right one, inclusive."""

    def to_json(self) -> dict[str, Any]:
        return {
            "y": self.y,
            "dir": self.direction,
            "L": list(self.left),
            "R": list(self.right),
            "slots": list(self.slots),
        }
