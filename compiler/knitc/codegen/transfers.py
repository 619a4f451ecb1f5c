"""Transfer planning: moving loops between needles with xfer and rack (thesis ch. 6.8.2-4).

`move(bed, moves)` takes (stitch, from, to) triples for the loops that must change needle
before the next course (shaping, merges, gauge changes, bind-off) and emits transfers that
bring every loop to its needle, any distance and to either bed, with every racking within
`bed.max_rack`, and ends at racking 0.

The problem (McCann et al. 2016, thesis 6.8.3): the loops of a course form a cycle around
the needle beds, and its wales must not cross, so a loop never passes another loop of its
own bed; it can only go *around* the others by changing bed at an end of the cycle (a
roll), or move along its bed through the other bed's sliders or free hooks. The planner
works on a model of the beds and emits nothing until a whole plan is found:

- the *cycle* is the moving loops plus the unmoving loops of the same courses, in
  counter-clockwise order (front left to right, back right to left). Its *winding numbers*
  (McCann's; made 0 on the unmoving loops, else as small as possible) say for every loop
  how many times it must go around an end of the beds, and which end: roll > 0 around the
  right end, < 0 around the left. A closed cycle (a tube) may rotate; an open one (a flat
  piece) may fold around an end but its loops never wrap past each other. Loops of other
  pieces are obstacles: they bound the free needle range and are never passed.
- **Rotate** (a corner collapse): the extreme loop of a bed whose roll asks for that end
  crosses to the other bed, landing beyond that bed's extreme loop (or stacked onto its
  decrease partner) within the racking limit. As many corners as possible per round.
- **Shift**: every loop not where it should be moves at most `max_rack` needles along its
  bed per round: towards its needle or, for the loop leading the way to the end it must
  roll around, far enough that a landing beyond the other bed's extreme loop comes within
  reach. Loops waiting to roll stay put unless they hold up a loop going their way; then
  they move on towards their end (a conveyor, which lets tubes rotate in little room).
  The loops of a round leave their hooks together at racking 0 (collapse) and come back at
  the racking of their displacement (shift and expand), one racking per distinct
  displacement. New positions keep the order of each bed: a loop may end on a needle
  another loop holds only when both are at their common final needle (a decrease).
  Rotate and Shift alternate until every loop is home.
- Half gauge (front loops on needles of one parity, back loops on the other, or
  `gauge=2`): the other bed's hooks between stitches are free, so they are the layer the
  loops collapse onto, as in CSE (thesis 6.8.3), and no slider is used; displacements stay
  even so the parity layout is kept. Full gauge (Rotate-Shift, thesis 6.8.4): the loops
  collapse onto the sliders. This is a greedy planner in the spirit of both, not McCann's
  search for the cheapest sequence of collapses.
- Cycles whose target is not a counter-clockwise cycle of the same loops (rib-like moves
  of single loops to the facing bed) have no winding: a loop changes bed directly, onto a
  free needle of the other bed that keeps that bed's target order.

Carriers (thesis 6.8.4): the yarn of every carrier in action runs from the loop it made
last (its *barrier* loop) to the carrier's rest position between two needles, and while
loops are on sliders the carriage cannot move carriers. A loop other than the barrier loop
that moved across that position would trap the yarn. So before a round in which some loop
would cross a carrier's position, the carrier is parked with a `miss` just outside the
needles the shaping can touch (on its nearer side), at a moment when every loop is on a
hook. Its yarn then floats from its barrier loop to a point no loop crosses. The next
course simply brings the carrier back.

Racking: at racking r, back needle k faces front needle k + r, so a front loop moves by +r
when it comes back from the back row and a back loop by -r. `Unsupported` is raised only
when no plan exists within these rules (a target off the bed, stacked loops that would have
to split, no free needle to roll around an end, a loop that would have to pass an unmoving
loop), with the reason.
"""

from __future__ import annotations

import weakref
from collections import defaultdict
from dataclasses import field
from operator import itemgetter
from typing import Any, cast

from knitc.codegen.bed import BEDS, SLIDERS, Bed, Pos, Unsupported
from knitc.records import record

Move = tuple[int, Pos, Pos]

_OTHER = {"f": "b", "b": "f"}
_PARK = {"f": ("b", "bs"), "b": ("f", "fs")}
"""Where a loop of a bed waits during a shift: the other bed's hook, else its slider."""


@record(frozen=True)
class Xfer:
    src: Pos
    dst: Pos
    stitch: int
    rack: int


@record(frozen=True)
class Park:
    """Move `carrier` with a miss so it rests at `to` (a half-integer needle position)."""

    carrier: int
    to: float
    stitch: int


Step = Xfer | Park


def move(
    bed: Bed, moves: list[Move], *, gauge: int | None = None, free: tuple[int, int] | None = None
) -> None:
    """Move every loop of `moves` from its needle to its target and return to racking 0.

    `gauge` forces the half-gauge (2: park on the other bed's hooks) or full-gauge (1: park
    on the sliders) strategy; by default it is read from the needle parities. `free` limits
    the needles the loops may use (default: up to the nearest loops of other pieces)."""
    steps = plan(bed, moves, gauge=gauge, free=free)
    for step in steps:
        if isinstance(step, Xfer):
            bed.set_rack(step.rack)
            bed.xfer(step.src, step.dst, step.stitch)
        else:
            here = bed.carrier_at.get(step.carrier, step.to)
            d = 1 if step.to > here else -1
            bed.stitch_op("miss", d, ("f", int(step.to - 0.5 * d)), step.stitch, step.carrier)
    bed.set_rack(0)


def plan(
    bed: Bed, moves: list[Move], *, gauge: int | None = None, free: tuple[int, int] | None = None
) -> list[Step]:
    """The steps `move` would emit, without emitting them (the bed is left as it is).
    Moves of a loop onto its own needle, or from a needle without loops, are dropped."""
    moves = [m for m in moves if m[1] != m[2] and bed.loops.get(m[1], 0)]
    if not moves:
        return []
    if FAST_ALONG_BED and len(moves) == 1 and gauge is None and free is None:
        steps = _along_bed(bed, *moves[0])
        if steps is not None:
            return steps
    return _Planner(bed, moves, gauge, free).run()


FAST_ALONG_BED = True
"""Whether `plan` takes `_along_bed`'s short cut (tests switch it off to hold it to the
planner's own plan, step for step)."""


def _along_bed(bed: Bed, s: int, src: Pos, dst: Pos) -> list[Step] | None:
    """The planner's plan for one loop moving along its bed within the racking limit, with
    no loop between its needle and its target, made without building the planner; None
    when the case is not that simple (the caller then plans it in full).

    This is a bind-off's move, once per stitch: the full planner sets up its model of every
    loop on the bed for it (its cycle, winding numbers, gauge and free range), a few
    milliseconds on a wide course. For this case the planner's answer is known: no
    loop changes order, so every winding is 0 and nothing rotates; one Shift round parks
    the loop at racking 0 on the other bed's hook (half gauge, when that hook is empty)
    or its slider, and brings it back at the racking of its displacement. What still needs
    the whole bed is read in one tight pass: the gauge (the parity of every loop, as
    `_gauge`) and that no loop waits on a slider; so a cast-off is still quadratic in the
    course's width, but with a far smaller constant (a 500-wide tube: 2.7 -> 1.5 s). A
    carrier whose yarn the move would cross needs parking, which the planner decides; so
    does a bed of mixed parity around a move that keeps it."""
    b, x = src
    needles = bed.prog.machine.needles
    if b not in BEDS or dst[0] != b or not (0 <= x < needles and 0 <= dst[1] < needles):
        return None  # (a needle off the bed: the planner says so)
    d = dst[1] - x
    lo, hi = (x, dst[1]) if d > 0 else (dst[1], x)
    loops = bed.loops
    for n in range(lo + 1, hi):
        if loops.get((b, n), 0) > 0:
            return None  # a loop in the way: the planner says what to do (or why not)
    back = b == "b"
    parity: int | None = (x + back) % 2
    if (dst[1] + back) % 2 != parity:
        parity = None  # the move itself changes parity: full gauge whatever the bed holds
    for (pb, pn), k in loops.items():
        if k > 0:
            if pb in SLIDERS:
                return None  # the planner refuses this (a loop waits on a slider)
            if parity is not None and (pn + (pb == "b")) % 2 != parity:
                return None  # mixed: the planner's parity depends on its free range
    R = bed.max_rack
    reach = R - (R % 2 if parity is not None else 0)
    if abs(d) > reach:
        return None
    if any(lo < cx < hi for cx in bed.carrier_at.values()):  # (else no carrier to read)
        for cx, anchor in _carriers(bed).values():
            if lo < cx < hi and anchor != src:
                return None  # a carrier to park first
    hook, slider = _PARK[b]
    slot = (hook, x) if parity is not None and loops.get((hook, x), 0) <= 0 else (slider, x)
    return [Xfer(src, slot, s, 0), Xfer(slot, dst, s, d if b == "f" else -d)]


# ---- carriers -----------------------------------------------------------------------------


@record
class _CarrierTrack:
    seen: int = 0
    active: set[int] = field(default_factory=set)
    known: set[int] = field(default_factory=set)
    anchor: dict[int, Pos] = field(default_factory=dict)


_TRACKS: dict[int, tuple[weakref.ref, _CarrierTrack]] = {}
"""Per program (by identity; programs are not hashable), what has been read of it."""


def _carriers(bed: Bed) -> dict[int, tuple[float, Pos | None]]:
    """Carriers in action: rest position and the needle of the loop their yarn holds.

    Read incrementally from the program: a carrier is in after in/inhook until out/outhook;
    its barrier loop is the last loop it made, followed through transfers."""
    key = id(bed.prog)
    ref, t = _TRACKS.get(key, (None, None))
    if ref is None or ref() is not bed.prog or t is None:
        t = _CarrierTrack()
        _TRACKS[key] = (weakref.ref(bed.prog, lambda _r: _TRACKS.pop(key, None)), t)
    ops = bed.prog.ops
    for op in ops[t.seen :]:
        if op.kind in ("in", "inhook"):
            for c in op.carriers:
                t.active.add(c)
                t.known.add(c)
                t.anchor.pop(c, None)
        elif op.kind in ("out", "outhook"):
            for c in op.carriers:
                t.active.discard(c)
                t.known.add(c)
                t.anchor.pop(c, None)
        elif op.kind in ("knit", "tuck", "split") and op.needle is not None:
            for c in op.carriers:
                t.anchor[c] = (op.needle.bed, op.needle.index)
        elif op.kind == "xfer" and op.needle is not None and op.needle2 is not None:
            a = (op.needle.bed, op.needle.index)
            b = (op.needle2.bed, op.needle2.index)
            for c, n in t.anchor.items():
                if n == a:
                    t.anchor[c] = b
    t.seen = len(ops)
    return {
        c: (float(x), t.anchor.get(c))
        for c, x in bed.carrier_at.items()
        if c in t.active or c not in t.known
    }


# ---- the planner --------------------------------------------------------------------------


@record
class _Unit:
    """The loops of one needle that travel together (stacked loops cannot be split)."""

    stitches: list[int]
    pos: Pos
    goal: Pos
    roll: int = 0
    """Ends still to go around: > 0 the right end, < 0 the left (cycles with a winding)."""

    @property
    def stitch(self) -> int:
        return self.stitches[0]

    @property
    def home(self) -> bool:
        return self.pos == self.goal and self.roll == 0


def _swaps(p: Pos, n: Pos) -> int:
    """Bed changes between consecutive loops of a counter-clockwise cycle (McCann)."""
    if p[0] != n[0]:
        return 1
    if p[0] == "f":
        return 0 if p[1] <= n[1] else 2
    return 0 if p[1] >= n[1] else 2


def _ccw(cycle: list[tuple[Pos, Pos]]) -> bool:
    """Whether the targets, in the order of the sources, form a counter-clockwise cycle."""
    turns = sum(_swaps(a[1], b[1]) for a, b in zip(cycle, cycle[1:] + cycle[:1], strict=True))
    return turns <= 2


def _windings(cycle: list[tuple[Pos, Pos]], fixed: list[int] | tuple = ()) -> list[int]:
    """McCann's winding numbers: how many bed changes each loop's target has gained over
    its source along the cycle, shifted by the even number that makes them smallest, or
    that makes them 0 on the loops that do not move (indices `fixed`), if any."""
    w = [0 if cycle[0][0][0] == cycle[0][1][0] else 1]
    for (pf, pt), (nf, nt) in zip(cycle, cycle[1:], strict=False):
        w.append(w[-1] - _swaps(pf, nf) + _swaps(pt, nt))
    if fixed:
        best = w[fixed[0]]
    else:
        med = sorted(w)[len(w) // 2]
        best = min(
            (2 * (med // 2) + k for k in (-2, 0, 2)),
            key=lambda e: (sum(abs(x - e) for x in w), abs(e)),
        )
    return [x - best for x in w]


_FIRST = itemgetter(0)


class _Planner:
    def __init__(
        self, bed: Bed, moves: list[Move], gauge: int | None, free: tuple[int, int] | None
    ) -> None:
        self.bed = bed
        self.R = bed.max_rack
        self.needles = bed.prog.machine.needles
        by_src: dict[Pos, _Unit] = {}
        for s, src, dst in moves:
            for p in (src, dst):
                if p[0] not in BEDS or not 0 <= p[1] < self.needles:
                    raise Unsupported(
                        f"the loop of stitch {s} would have to use needle "
                        f"{p[0]}{p[1]}, which is not a hook of the bed"
                    )
            u = by_src.get(src)
            if u is None:
                by_src[src] = _Unit([s], src, dst)
            elif u.goal != dst:
                raise Unsupported(
                    f"stitches {u.stitch} and {s} share needle {src[0]}"
                    f"{src[1]} but go to different needles: a transfer cannot "
                    "split the loops of a needle"
                )
            else:
                u.stitches.append(s)
        self.units = list(by_src.values())
        self.fixed: dict[Pos, int] = {}
        """Loops that do not move (needle -> a stitch of it, -1 if none is known)."""
        fixed, at_get = self.fixed, bed.at.get  # (this is the plan's cost per loop on the bed)
        for pos, n in bed.loops.items():
            if n > 0 and pos not in by_src:
                ss = at_get(pos)
                fixed[pos] = min(ss) if ss else -1
        for pos in self.fixed:
            if pos[0] in SLIDERS:
                raise Unsupported(f"a loop waits on slider {pos[0]}{pos[1]}")
        self._free_range(free)
        self.folded: list[tuple[_Unit, Pos]] = []
        """Units of a closing fold planned to the facing needle first (`_unfold`)."""
        self._cycle()
        if not self.ccw and self._unfold():
            self._cycle()
            if not self.ccw:
                for u, goal in self.folded:
                    u.goal = goal
                self.folded = []
                self._cycle()
        self._gauge(gauge)
        self.carriers: dict[int, list[Any]] = {c: [x, a] for c, (x, a) in _carriers(bed).items()}
        self.steps: list[Step] = []
        self.at: dict[Pos, list[_Unit]] = defaultdict(list)
        for u in self.units:
            self.at[u.pos].append(u)
        self.reason: dict[int, str] = {}
        """Why a unit could not move in the last round (for the error message)."""

    # -- set-up -------------------------------------------------------------------------------

    def _course(self, s: int) -> int | None:
        course = self.bed.stitch_courses()
        if s < 0 or course is None or s >= len(course):
            return None
        return course[s]

    def _pieces(self) -> list[int] | None:
        """Per stitch, its piece (`_piece`), or None when the graph has neither nodes nor
        courses: one list for the loops of a whole bed, looked up without a call each."""
        node = self.bed.stitch_nodes()
        return self.bed.stitch_courses() if node is None else node

    def _piece(self, s: int) -> int | None:
        """The node of stitch s: the loops of one node on the bed form one cycle (a slice's
        ring holds the end of one course and the start of the next)."""
        piece = self._pieces()
        if s < 0 or piece is None or s >= len(piece):
            return None
        return piece[s]

    def _free_range(self, free: tuple[int, int] | None) -> None:
        """The needles the plan may use: those between the nearest loops of other pieces
        (loops of the moving loops' nodes are part of the cycle, not obstacles)."""
        pieces = {self._piece(s) for u in self.units for s in u.stitches} - {None}
        piece = self._pieces() or []
        n = len(piece)
        self.member = {pos for pos, s in self.fixed.items() if 0 <= s < n and piece[s] in pieces}
        ends = [n for u in self.units for n in (u.pos[1], u.goal[1])]
        lo, hi = min(ends), max(ends)
        left = [p[1] for p in self.fixed if p not in self.member and p[1] < lo]
        right = [p[1] for p in self.fixed if p not in self.member and p[1] > hi]
        self.lo = max(left) + 1 if left else 0
        self.hi = min(right) - 1 if right else self.needles - 1
        if free is not None:
            self.lo, self.hi = max(self.lo, free[0]), min(self.hi, free[1])
            if self.lo > lo or self.hi < hi:
                raise Unsupported(f"loops move outside the free needles {free[0]}..{free[1]}")
        self.fixed = {p: s for p, s in self.fixed.items() if self.lo <= p[1] <= self.hi}
        self._fixed_items: dict[str, list[tuple[int, _Unit | None]]] = {}
        self.member &= set(self.fixed)

    def _cycle(self) -> None:
        """Winding numbers (rolls) when sources and targets are both counter-clockwise
        cycles; otherwise loops change bed directly (`self.ccw` False).

        The cycle is closed when one of its courses is circular (a tube): its loops may then
        rotate around the beds. An open course (a flat piece) has no edge from its last loop
        back to its first, so its loops may fold around an end but never wrap past each
        other: a target that needs it gets no winding (and fails if a loop must pass)."""
        items: list[tuple[Pos, Pos, _Unit | None]] = [(u.pos, u.goal, u) for u in self.units]
        items += [(p, p, None) for p in self.member]
        items.sort(key=lambda it: (it[0][0] != "f", it[0][1] if it[0][0] == "f" else -it[0][1]))
        cycle = [(a, b) for a, b, _ in items]
        self.ccw = _ccw(cycle)
        if self.ccw and not self._closed():
            inner = [_swaps(a[1], b[1]) for a, b in zip(cycle, cycle[1:], strict=False)]
            self.ccw = 2 not in inner
        if not self.ccw:
            return
        rolls = []
        fixed = [i for i, it in enumerate(items) if it[2] is None]
        for (src, _dst, u), w in zip(items, _windings(cycle, fixed), strict=True):
            roll = w if src[0] == "f" else -w
            if u is None and roll:
                self.ccw = False  # an unmoving loop would have to go around: no winding
                return
            rolls.append((u, roll))
        for u, roll in rolls:
            if u is not None:
                u.roll = roll

    def _unfold(self) -> bool:
        """A tube closing onto one bed (a collapsed end: front stitch k and back stitch k
        stacked on needle k) has no winding: its target folds the cycle flat. Plan it as the
        ring it folds, instead: the loops of the tube's other side first go to the needles
        facing their goals, then one transfer at racking 0 stacks them (`run`). The sides
        are the design's (`StitchGraph.side`), which survive any rotation of the layout.
        Returns whether some goal was unfolded (the caller checks the winding again)."""
        side = getattr(self.bed.g, "side", None)
        beds = {u.goal[0] for u in self.units} | {p[0] for p in self.member}
        if side is None or len(beds) != 1:
            return False
        (bed,) = beds
        own = 0 if bed == "f" else 1
        sides = {int(side[s]) for u in self.units for s in u.stitches if s >= 0}
        if len(sides) != 2:
            return False
        for u in self.units:
            if all(s >= 0 and int(side[s]) != own for s in u.stitches):
                facing = (_OTHER[bed], u.goal[1])
                self.folded.append((u, u.goal))
                u.goal = facing
        return bool(self.folded)

    def _closed(self) -> bool:
        circular = getattr(self.bed.g, "course_circular", None)
        if circular is None:
            return True
        ss = [s for u in self.units for s in u.stitches] + [self.fixed[p] for p in self.member]
        course = self.bed.stitch_courses()
        if course is None:
            return False
        n = len(course)
        return any(bool(circular[c]) for c in {course[s] for s in ss if 0 <= s < n})

    def _gauge(self, gauge: int | None) -> None:
        """Half gauge: park on the other bed's hooks; with a parity layout, keep it."""
        pos = [p for u in self.units for p in (u.pos, u.goal)] + list(self.fixed)
        par = {(p[1] + (p[0] == "b")) % 2 for p in pos}
        self.parity = par.pop() if len(par) == 1 and gauge != 1 else None
        self.hooks = gauge == 2 or (gauge is None and self.parity is not None)
        self.step = 2 if self.parity is not None else 1

    # -- the model ----------------------------------------------------------------------------

    def fits(self, bed: str, n: int) -> bool:
        """Needle `n` of `bed` is in range and keeps the half-gauge parity."""
        if not self.lo <= n <= self.hi:
            return False
        return self.parity is None or (n + (bed == "b")) % 2 == self.parity

    def items(self, bed: str) -> list[tuple[int, _Unit | None]]:
        """Everything on a bed's hooks, left to right: units and unmoving loops (None)."""
        fixed = self._fixed_items.get(bed)
        if fixed is None:  # (`fixed` is final once the free range is known: sorted once)
            fixed = self._fixed_items[bed] = sorted(
                ((p[1], None) for p in self.fixed if p[0] == bed), key=_FIRST
            )
        out: list[tuple[int, _Unit | None]] = list(fixed)
        out += [(u.pos[1], u) for u in self.units if u.pos[0] == bed]
        out.sort(key=_FIRST)  # (stable: an unmoving loop before a unit on its needle)
        return out

    def final_at(self, it: _Unit | None, bed: str, n: int) -> bool:
        """The item will stay on needle n of bed for good (a decrease partner there)."""
        if it is None:
            return (bed, n) in self.fixed
        return it.roll == 0 and it.goal == (bed, n)

    def stackable(self, u: _Unit, pos: Pos) -> bool:
        """`u` may land on `pos` although loops are there: all of them end there too."""
        if not self.final_at(u, *pos):
            return False
        return all(self.final_at(v, *pos) for v in self.at.get(pos, ()))

    def free_at(self, pos: Pos) -> bool:
        return pos not in self.fixed and not self.at.get(pos)

    def relocate(self, u: _Unit, dst: Pos) -> None:
        self.at[u.pos].remove(u)
        for c in self.carriers.values():
            if c[1] == u.pos:
                c[1] = dst
        u.pos = dst
        self.at[dst].append(u)

    # -- the plan -----------------------------------------------------------------------------

    def run(self) -> list[Step]:
        span = self.hi - self.lo + 1
        limit = 8 * (min(span, 4 * len(self.units) + 64) // max(1, self.R) + 8)
        limit += 4 * len(self.units)
        for _ in range(limit):
            if all(u.home for u in self.units):
                if self.folded:  # the ring is laid out: fold it onto its bed
                    self.commit([(u, u.pos, goal, 0) for u, goal in self.folded])
                    for u, goal in self.folded:
                        u.goal = goal
                return self.steps
            moved = self.rotate()
            moved = self.shift() or moved
            if not moved:
                raise Unsupported(self.why())
        raise Unsupported("transfer planning does not converge: " + self.why())

    def why(self) -> str:
        left = [u for u in self.units if not u.home]
        u = min(left, key=lambda u: (id(u) not in self.reason, u.roll == 0))
        what = (
            f"the loop of stitch {u.stitch} cannot go from {u.pos[0]}{u.pos[1]} to "
            f"{u.goal[0]}{u.goal[1]}"
        )
        return what + ": " + self.reason.get(id(u), "it would have to pass another loop of its bed")

    def commit(self, seq: list[tuple[_Unit, Pos, Pos, int]]) -> None:
        """Append a round given as moves (unit, from, to, racking) in an order that works,
        regrouped so that moves at one racking go together: the racking of the first move
        not yet done is set, then every move at that racking that can be done is done.
        Carriers whose position a loop would cross in the round are parked first."""
        first: dict[int, Pos] = {}
        last: dict[int, Pos] = {}
        for u, src, dst, _r in seq:
            first.setdefault(id(u), src)
            last[id(u)] = dst
        self.park_carriers([(u, first[id(u)], last[id(u)][1]) for u, *_ in seq])
        pending = list(seq)
        while pending:
            r = pending[0][3]
            rest: list[tuple[_Unit, Pos, Pos, int]] = []
            for m in pending:
                u, src, dst, mr = m
                if (
                    mr == r
                    and u.pos == src
                    and (not rest or self.free_at(dst) or self.stackable(u, dst))
                ):
                    self.steps.append(Xfer(src, dst, u.stitch, r))
                    self.relocate(u, dst)
                else:
                    rest.append(m)
            pending = rest

    def park_carriers(self, lateral: list[tuple[_Unit, Pos, int]]) -> None:
        for c, (x, anchor) in self.carriers.items():
            if any(min(a[1], b) < x < max(a[1], b) and a != anchor for _u, a, b in lateral):
                ns = [n for u in self.units for n in (u.pos[1], u.goal[1])]
                ns += [p[1] for p in self.member]
                lo, hi = min(ns) - self.R - 1.5, max(ns) + self.R + 1.5
                options = [t for t in (lo, hi) if -0.5 <= t <= self.needles - 0.5]
                if not options:
                    raise Unsupported(
                        f"carrier {c} at {x} is in the way of the transfers and "
                        "there is no room to move it aside"
                    )
                to = min(options, key=lambda t: abs(t - x))
                self.steps.append(Park(c, to, lateral[0][0].stitch))
                self.carriers[c][0] = to

    # -- Rotate: loops change bed ---------------------------------------------------------------

    def rotate(self) -> bool:
        """Every bed change possible now, decided one at a time on the model (each landing
        sees the previous ones), then committed as one round."""
        seq: list[tuple[_Unit, Pos, Pos, int]] = []
        carriers = {c: list(v) for c, v in self.carriers.items()}
        progress = True
        while progress:
            progress = False
            if self.ccw:
                cands = [self.corner(bed, side) for side in (1, -1) for bed in BEDS]
            else:
                cands = [self.direct(u) for u in self.units if u.pos[0] != u.goal[0]]
            for m in cands:
                if m is not None:
                    seq.append(m)
                    progress = True
        if not seq:
            return False
        for u, src, _dst, _r in reversed(seq):
            self.relocate(u, src)  # back to the start: commit replays the round
        self.carriers = carriers
        self.commit(seq)
        return True

    def cross(self, u: _Unit, dst: Pos) -> tuple[_Unit, Pos, Pos, int]:
        src = u.pos
        r = src[1] - dst[1] if src[0] == "f" else dst[1] - src[1]
        self.relocate(u, dst)
        return (u, src, dst, r)

    def corner(self, bed: str, side: int) -> tuple[_Unit, Pos, Pos, int] | None:
        """Roll the extreme unit of `bed` at end `side` (+1 right, -1 left) to the other bed,
        beyond that bed's extreme loop, if its roll asks for that end."""
        items = self.items(bed)
        if not items:
            return None
        x, u = items[-1] if side > 0 else items[0]
        if u is None or u.roll * side <= 0:
            return None
        if any(v is not u and n == x for n, v in items):
            return None  # stacked with something that stays
        other = _OTHER[bed]
        there = [n for n, _ in self.items(other)]
        edge = (max(there) if side > 0 else min(there)) if there else None
        after = -(u.roll - side)
        aim = u.goal[1] if after == 0 else (self.lo if after < 0 else self.hi)
        best = None
        for y in range(x - self.R, x + self.R + 1):
            if not self.fits(other, y):
                continue
            beyond = edge is None or (y - edge) * side > 0
            if not beyond:
                partners = self.at.get((other, y), ())
                if not (
                    y == edge
                    and after == 0
                    and u.goal == (other, y)
                    and all(self.final_at(v, other, y) for v in partners)
                ):
                    continue  # behind the edge, unless stacking onto a decrease partner
            elif not self.free_at((other, y)):
                continue
            key = (abs(y - aim), abs(y - x))
            if best is None or key < best[0]:
                best = (key, y)
        if best is None:
            where = "right" if side > 0 else "left"
            self.reason[id(u)] = (
                f"to roll it around the {where} end it needs a free needle of the "
                f"{'back' if other == 'b' else 'front'} bed {where} of needle "
                f"{edge if edge is not None else x}, within {self.R} needles and the free "
                f"range {self.lo}..{self.hi}"
            )
            return None
        u.roll = after
        return self.cross(u, (other, best[1]))

    def direct(self, u: _Unit) -> tuple[_Unit, Pos, Pos, int] | None:
        """A loop of a cycle without winding changes bed onto a free needle of the other bed
        that keeps that bed's target order."""
        x = u.pos[1]
        other = u.goal[0]
        stay = [(n, v) for n, v in self.items(other) if v is None or v.goal[0] == other]
        best = None
        for y in range(x - self.R, x + self.R + 1):
            if not self.fits(other, y):
                continue
            if not self.free_at((other, y)) and not self.stackable(u, (other, y)):
                continue
            ok = True
            for n, v in stay:
                g = n if v is None else v.goal[1]
                if (g < u.goal[1] and n >= y) or (g > u.goal[1] and n <= y):
                    ok = False
                    break
            if ok:
                key = (abs(y - u.goal[1]), abs(y - x))
                if best is None or key < best[0]:
                    best = (key, y)
        if best is None:
            self.reason[id(u)] = (
                f"no free needle of the other bed within {self.R} needles "
                "keeps the order of that bed"
            )
            return None
        return self.cross(u, (other, best[1]))

    # -- Shift: loops move along their bed -------------------------------------------------------

    def waypoint(self, u: _Unit, ext: dict[str, tuple | None]) -> int:
        """Where a unit heads along its bed this round: its needle, or for a unit that must
        roll and is the extreme of its bed, far enough towards the end that a landing beyond
        the other bed's extreme loop comes within the racking limit."""
        bed, x = u.pos
        if u.roll == 0 or not self.ccw:
            return u.goal[1]
        side = 1 if u.roll > 0 else -1
        own, other = ext[bed], ext[_OTHER[bed]]
        if own is None or (own[1] if side > 0 else own[0]) is not u or other is None:
            return x
        edge = other[2] if side > 0 else other[3]
        need = edge + side * (self.step - self.R)  # the first landing beyond the edge
        target = max(x, need) if side > 0 else min(x, need)
        if self.parity is not None and not self.fits(bed, target):
            target += side
        if not self.lo <= target <= self.hi:
            target = self.hi if side > 0 else self.lo
            if self.parity is not None and not self.fits(bed, target):
                target -= side
        return max(x, target) if side > 0 else min(x, target)

    def extremes(self, bed: str) -> tuple | None:
        """(leftmost item, rightmost item, max needle, min needle) of a bed, None if empty."""
        items = self.items(bed)
        if not items:
            return None
        return items[0][1], items[-1][1], items[-1][0], items[0][0]

    def shift(self) -> bool:
        """One round of moves along the beds (see `plan_bed`), parked at racking 0 on the
        other bed's free hooks (half gauge) or sliders, and brought back by racking."""
        new: dict[int, int] = {}
        ext = {bed: self.extremes(bed) for bed in BEDS}
        for bed in BEDS:
            items = self.items(bed)
            for (x, u), n in zip(items, self.plan_bed(bed, items, ext), strict=True):
                if u is not None and n != x:
                    new[id(u)] = n
        movers = [u for u in self.units if id(u) in new]
        if not movers:
            return False
        landing = {(u.pos[0], new[id(u)]) for u in movers}
        parks, returns = [], []
        for u in movers:
            bed, x = u.pos
            hook, slider = _PARK[bed]
            slot = (hook, x)
            if not (self.hooks and self.free_at(slot) and slot not in landing):
                slot = (slider, x)
                if not self.free_at(slot):
                    raise Unsupported(f"slider {slider}{x} is not free")
            d = new[id(u)] - x
            parks.append((u, u.pos, slot, 0))
            returns.append((u, slot, (bed, new[id(u)]), d if bed == "f" else -d))
        # by racking, then by the bed they come back from: a DAT row takes transfers of one
        # kind only, so interleaving the beds would cut the pass into a row per loop
        returns.sort(key=lambda m: (m[3], m[1][0], m[2][1]))
        self.commit(parks + returns)
        return True

    def plan_bed(
        self, bed: str, items: list[tuple[int, _Unit | None]], ext: dict[str, tuple | None]
    ) -> list[int]:
        """Where the items of a bed go this round: each unit at most the racking limit
        towards its waypoint, then pulled back until the bed keeps its order. A unit that
        must roll waits where it is unless it leads the way to its end; but when it holds
        up a unit going the same way, it and every unit rolling that way beyond it move on
        towards that end (a conveyor), so that the loops around the tube can circulate."""
        reach = self.R - (self.R % 2 if self.parity is not None else 0)

        def toward(x: int, wp: int) -> int:
            d = max(-reach, min(reach, wp - x))
            if self.parity is not None and d % 2:
                d -= 1 if d > 0 else -1
            return min(self.hi, max(self.lo, x + d))

        aim = [x if u is None or u.home else self.waypoint(u, ext) for x, u in items]
        pushed: set[int] = set()
        while True:
            # (an item that stays, most of the bed, is where it wants to be: every item is
            # within lo..hi, so toward(x, x) is x)
            want = [x if a == x else toward(x, a) for (x, _u), a in zip(items, aim, strict=True)]
            first = list(want)
            self.relax(bed, items, want)
            more = set()
            for i, (x, u) in enumerate(items):
                if u is None or want[i] == first[i]:
                    continue
                side = 1 if first[i] > x else -1
                beyond = range(i + 1, len(items)) if side > 0 else range(i)
                more |= {
                    j
                    for j in beyond
                    if j not in pushed
                    and items[j][1] is not None
                    and cast(_Unit, items[j][1]).roll * side > 0
                }
            if not more:
                return want
            for j in more:
                aim[j] = self.hi if cast(_Unit, items[j][1]).roll > 0 else self.lo
            pushed |= more

    def relax(self, bed: str, items: list[tuple[int, _Unit | None]], want: list[int]) -> None:
        """Pull wanted positions back towards the current ones until the bed keeps its order:
        strictly increasing, except loops meeting at their common final needle."""
        step = self.step
        changed = True
        while changed:
            changed = False
            for i in range(len(items) - 1):
                (xa, a), (xb, b) = items[i], items[i + 1]
                na, nb = want[i], want[i + 1]
                if na < nb or (
                    na == nb and self.final_at(a, bed, na) and self.final_at(b, bed, nb)
                ):
                    continue
                if na > xa:
                    stack = na >= nb and self.final_at(a, bed, nb) and self.final_at(b, bed, nb)
                    want[i] = max(xa, nb if stack else nb - step)
                elif nb < xb:
                    stack = self.final_at(b, bed, na) and self.final_at(a, bed, na)
                    want[i + 1] = min(xb, na if stack else na + step)
                else:
                    continue
                if want[i] != na or want[i + 1] != nb:
                    changed = True
                    if a is not None and want[i] == xa != na:
                        self.reason[id(a)] = self.blocker(a, b, xb)
                    if b is not None and want[i + 1] == xb != nb:
                        self.reason[id(b)] = self.blocker(b, a, xa)

    def blocker(self, u: _Unit, v: _Unit | None, n: int) -> str:
        who = (
            f"stitch {v.stitch}"
            if v is not None
            else (f"stitch {self.fixed.get((u.pos[0], n), -1)}, which does not move")
        )
        return f"the loop on {u.pos[0]}{n} ({who}) is in the way"
