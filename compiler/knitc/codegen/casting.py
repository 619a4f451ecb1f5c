"""Yarn start, cast-on, cast-off and yarn end passes (thesis ch. 6.8.1, Fig. 6-26/27/33/34).

A yarn that starts on empty needles cannot simply knit: a knit on an empty needle forms a
loop that nothing holds, and a row of single tucks is unstable (the yarn slides across the
open hooks). So a yarn is brought in with the inserting hook, caught by a few tucks, released,
and cast on by a dedicated procedure before the first course knits through. Loops that end
must be closed by a cast-off, else they unravel once off the machine.

Every procedure here is a pure function of the loops it is given; `plan_cast_on` returns
`Step`s so the yarn start can place its catching tucks relative to where the cast-on begins,
and the emitters write each op and update the `Bed` loop model in the same step.

Entries are the needles of a course in yarn order, each with the carriage direction of its
visit (+1 rightward) and its stitch (-1 for a needle that holds no stitch of the graph yet,
e.g. a precast needle). The procedures:

yarn start (Fig. 6-27)
    ``inhook``, three catching tucks on free needles near where the cast-on begins (outside
    the course when there is room, else free needles between, as in half gauge), in the
    order rightmost (leftward), leftmost (rightward), middle (leftward): the first pass after
    ``inhook`` must go leftward and the hook, parked just right of the first tuck, blocks
    every needle to its right until ``releasehook``; then ``releasehook``. A fourth tuck,
    rightward, ends the zigzag unless the cast-on starts rightward to the right of the
    tucks: the release then follows a pass the other way (a Shima DAT releases on a pass of
    its own in the hook's direction, and would need an empty pass to turn the carriage
    first), and a leftward cast-on's first pass turns the carrier instead of needing a
    carrier move back. The catching loops
    are dropped once the first course is knitted. A yarn that starts on live loops is
    brought in with ``in``.
cast-ons (`CAST_ONS` of the skeleton)
    ``interlock`` -- every other entry, then the remaining ones: flat courses forward then
    backward, circular courses twice around (Fig. 6-26); the first course knits directly.
    ``tuck`` -- one tuck on every entry: once around a circular course; on a flat one from
    the far end back to the first entry, so the first course starts where the yarn is
    (knitskel's `tuck` is the catching tucks and then the knitting; here the tuck pass stands
    for the Shima's knit on an empty needle, which a Knitout machine treats as a loop
    nothing holds).
    ``kickback`` -- knitsketching's kickback lattice: for each entry i, the two entries
    behind i-1 forward, i forward, then i-1 backward, so every loop is knitted over several
    times with a kickback between; on a flat course it runs from the far end towards the
    start, so the first course begins where it ends; fewer than 5 (circular) or 3 (flat)
    entries use the interlock.
    ``precast`` -- knitskel's pre-cast: every needle the whole node will use (not only the
    first course's) is cast on, by an interlock along the bed from the end behind the first
    course's start and knits back to it (`plan_precast`), so that later increases knit
    through a waiting loop instead of forming a new one on an empty needle.
    ``none`` -- no cast-on pass: the first course lands on empty needles as tucks.
    A first touch of an empty needle is always a tuck (the Knitout machines treat a knit on
    an empty needle as a hazard); later touches knit.
cast-offs (`CAST_OFFS`, Fig. 6-33)
    the loops that end are bound off in runs of course neighbours, starting from the last one
    knitted: each loop is knitted, moved onto the next one's needle and knitted with it.
    ``direct`` knits towards the next needle and kicks the carrier back with a ``miss``
    before the move (so the yarn is not trapped by the transfer); ``pickup`` does the same
    plus a pick-up tuck on the needle just vacated before each knit, dropped at the end of
    the run (a looser edge); ``reverse`` knits away from the next needle, which leaves the
    carrier clear of the transfer without a kickback; ``none`` drops the loops. A run whose
    last loop has a live course neighbour is closed onto it; otherwise the last loop gets a
    tail (a few knits back and forth on its needle, ending rightward) and is dropped, after
    the ``outhook`` when the yarn ends there, so the end can be closed by hand.
yarn end
    a kickback ``miss`` one needle further in the carriage's last direction (the carrier
    leaves the fabric), ``outhook``, then the tail needle's drop.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

from knitc.codegen.bed import Bed, Pos, Unsupported, needle
from knitc.codegen.transfers import move
from knitc.records import record
from knitc.source import Span


@record(frozen=True)
class StitchNumbers:
    """`x-stitch-number` of each kind of pass (abstract indices into the machine's stitch
    table, so loops are looser the higher the number).

    The values are knitsketching's Knitout constants (seed-systems.md §2.6): NORMAL 5,
    HALF_GAUGE 6, INCREASE 7, CASTON 33, CASTOFF 24, the same numbers knitskel writes into
    the DAT R6 option (§1.13: cast-on 33, cast-off 24, normal 5, 6-8 for larger moves), and
    Fig. 6-27 shows 33 for the yarn start and cast-on and 6 for half-gauge actions, Fig. 6-33
    24 for the cast-off; Fig. 6-30 sets 0 before the shaping transfers (the Shima converter
    writes R6 = 0 on transfer passes anyway).
    """

    yarn_start: int = 33
    cast_on: int = 33
    knit: int = 5
    knit_half_gauge: int = 6
    increase: int = 7
    transfer: int = 0
    cast_off: int = 24


STITCH_NUMBERS = StitchNumbers()

CATCH_TUCKS = 3
"""Tucks that catch a new yarn before the hook releases it (Fig. 6-27 uses three); one more
unless the cast-on starts rightward from their right (see the module docstring)."""
CATCH_REACH = 12
"""Farthest a catching tuck may be from where the cast-on begins (knitc's float limit)."""
TAIL_KNITS = 5
"""Knits of the yarn tail on the last loop of a bind-off (knitsketching's yarn end pass)."""


@record(frozen=True)
class Entry:
    """A needle of a course in yarn order: where, the carriage direction, the stitch."""

    pos: Pos
    dir: int
    stitch: int = -1


@record(frozen=True)
class Step:
    """One cast-on op: `kind` is 'tuck' or 'knit'."""

    kind: str
    dir: int
    pos: Pos
    stitch: int = -1


@record
class Ctx:
    """What every emitter needs: the bed, the working carrier, the stitch numbers, and the
    span that ops belonging to no stitch (catching tucks, pick-up tucks) are reported at."""

    bed: Bed
    carrier: int
    numbers: StitchNumbers = STITCH_NUMBERS
    span: Span | None = None

    @property
    def needles(self) -> int:
        return self.bed.prog.machine.needles


def emit(
    ctx: Ctx, kind: str, d: int, pos: Pos, stitch: int = -1, number: int | None = None
) -> None:
    """One knit / tuck / miss with the working carrier, keeping the loop model right.

    Ops of a graph stitch go through `Bed.stitch_op`; a loop of no stitch is written here so
    that it still carries the span of what made it."""
    bed = ctx.bed
    if number is not None:
        bed.prog.stitch_number(number)
    if stitch >= 0:
        bed.stitch_op(kind, d, pos, stitch, ctx.carrier)
        return
    getattr(bed.prog, kind)(d, needle(pos), (ctx.carrier,), stitch=-1, span=ctx.span)
    if kind == "tuck":
        bed.loops[pos] += 1
    elif kind == "knit":
        for s in bed.at.pop(pos, ()):
            del bed.where[s]
        bed.loops[pos] = 1
    bed.carrier_at[ctx.carrier] = pos[1] + 0.5 * d


# ---- cast-on plans ----------------------------------------------------------------------------


def plan_cast_on(kind: str, entries: Sequence[Entry], circular: bool) -> list[Step]:
    """The cast-on ops for `entries` (see the module docstring); first touches are tucks."""
    if not entries or kind == "none":
        return []
    if kind == "tuck":  # once around, or from the far end back to the first entry
        order = (
            [(e, e.dir) for e in entries] if circular else [(e, -e.dir) for e in reversed(entries)]
        )
    elif kind == "kickback" and len(entries) > (4 if circular else 2):
        order = _kickback(entries, circular)
    else:  # interlock, and kickbacks on too few needles
        order = _interlock(entries, circular)
    steps: list[Step] = []
    touched: set[Pos] = set()
    for e, d in order:
        steps.append(Step("knit" if e.pos in touched else "tuck", d, e.pos, e.stitch))
        touched.add(e.pos)
    return steps


def _interlock(entries: Sequence[Entry], circular: bool) -> list[tuple[Entry, int]]:
    first = [(e, e.dir) for e in entries[0::2]]
    if circular:
        return first + [(e, e.dir) for e in entries[1::2]]
    return first + [(e, -e.dir) for e in reversed(entries[1::2])]


def _kickback(entries: Sequence[Entry], circular: bool) -> list[tuple[Entry, int]]:
    n = len(entries)
    if circular:
        ring = list(entries)
        fwd = [e.dir for e in ring]
    else:  # from the far end towards the first entry, so the first course starts there
        ring = list(reversed(entries))
        fwd = [-e.dir for e in ring]
    out: list[tuple[Entry, int]] = []
    for i in range(1, n):
        for j in (i - 3, i - 2):
            if circular or j >= 0:
                out.append((ring[j % n], fwd[j % n]))
        out.append((ring[i], fwd[i]))
        out.append((ring[i - 1], -fwd[i - 1]))
    return out


def plan_precast(first: Sequence[Entry], cover: set[Pos]) -> list[Step]:
    """Every needle of `cover` (the node's, including the first course's) cast on by an
    interlock along the bed from the end behind the first course's start (forward on every
    other needle, back on the others), then knits on the way back to that start, so the
    yarn is held all along and the first course follows directly (knitskel's `precast`
    covers, then casts back up to the first needle)."""
    if not first:
        return []
    e0 = first[0]
    stitch = {e.pos: e.stitch for e in first}
    line = [
        Entry(p, e0.dir, stitch.get(p, -1))
        for p in sorted(cover, key=lambda p: (p[1] * e0.dir, p[0] != e0.pos[0]))
    ]
    steps = plan_cast_on("interlock", line, circular=False)
    start = line[0].pos[1]
    back = [
        p
        for p in cover
        if p[0] == e0.pos[0] and (p[1] - start) * e0.dir > 0 and (e0.pos[1] - p[1]) * e0.dir > 0
    ]
    back.sort(key=lambda p: p[1] * e0.dir)
    return steps + [Step("knit", e0.dir, p, stitch.get(p, -1)) for p in back]


def emit_plan(ctx: Ctx, steps: Sequence[Step]) -> None:
    for st in steps:
        emit(ctx, st.kind, st.dir, st.pos, st.stitch, ctx.numbers.cast_on)


# ---- yarn start -------------------------------------------------------------------------------


def catch_positions(
    bed: Bed, start: Pos, outward: int, busy: set[Pos], needles: int, count: int = CATCH_TUCKS
) -> list[Pos]:
    """Up to `count` free needles for the catching tucks: empty, not `busy` (needles the
    cast-on or the first course will use), nearest `start`, outside (on the `outward` side)
    first, the back bed first at equal distance (the first tuck goes on the bed opposite the
    inserting hook, ch. 6.8.1)."""
    cands = []
    lo, hi = max(0, start[1] - CATCH_REACH), min(needles - 1, start[1] + CATCH_REACH)
    for idx in range(lo, hi + 1):
        for b in ("b", "f"):
            p = (b, idx)
            if p in busy or bed.loops.get(p, 0):
                continue
            off = (idx - start[1]) * outward
            cands.append((0 if off > 0 else 1, abs(idx - start[1]), b != "b", p))
    cands.sort()
    return [c[3] for c in cands[:count]]


def yarn_start(ctx: Ctx, start: Step | Entry, busy: set[Pos], stitch: int) -> list[Pos]:
    """`inhook`, the catching tucks, `releasehook`; returns the catching needles, to drop
    once the first course holds the yarn. `start` is the first op of the cast-on (or of the
    first course): the tucks are placed on the side the carriage comes from."""
    bed = ctx.bed
    bed.prog.stitch_number(ctx.numbers.yarn_start)
    bed.prog.inhook((ctx.carrier,), stitch=stitch, span=ctx.span)
    catch = catch_positions(bed, start.pos, -start.dir or -1, busy, ctx.needles, CATCH_TUCKS + 1)
    if not catch:
        raise Unsupported(
            f"no free needle within {CATCH_REACH} needles of "
            f"{start.pos[0]}{start.pos[1]} to catch the new yarn on"
        )
    order = sorted(catch, key=lambda p: (p[1], p[0] == "b"))
    if (
        len(catch) > CATCH_TUCKS
        and (
            order[-1][0] != "b"
            or (  # the first tuck goes on the back
                start.dir > 0 and all(p[1] < start.pos[1] for p in catch[:CATCH_TUCKS])
            )
        )
    ):
        catch = catch[:CATCH_TUCKS]  # (or the cast-on starts rightward from the tucks' right)
        order = sorted(catch, key=lambda p: (p[1], p[0] == "b"))
    # rightmost leftward, leftmost rightward, then inwards from both ends the same way: a
    # zigzag that never goes right of the first tuck, where the hook sits until released
    seq: list[tuple[Pos, int]] = []
    lo, hi = 0, len(order) - 1
    while lo <= hi:
        seq.append((order[hi], -1))
        hi -= 1
        if lo <= hi:
            seq.append((order[lo], 1))
            lo += 1
    for p, d in seq:
        emit(ctx, "tuck", d, p)
    bed.prog.releasehook((ctx.carrier,))
    return [p for p, _ in seq]


# ---- cast-off ---------------------------------------------------------------------------------


def runs(
    ends: Sequence[int], neighbours: Callable[[int, int], bool], circular: bool
) -> list[list[int]]:
    """`ends` (stitches in yarn order) split into runs of course neighbours; on a circular
    course a run that wraps around the start is joined."""
    out: list[list[int]] = []
    for s in ends:
        if out and neighbours(out[-1][-1], s):
            out[-1].append(s)
        else:
            out.append([s])
    if circular and len(out) > 1 and neighbours(out[-1][-1], out[0][0]):
        out[0] = out.pop() + out[0]
    return out


def cast_off_run(
    ctx: Ctx, kind: str, run: Sequence[int], closing: int, last_dir: int
) -> tuple[int, int]:
    """Bind off `run` (yarn order) starting from its last stitch; `closing` is a live stitch
    the final loop is moved onto (-1: none). Returns the stitch whose loop is left for the
    tail (-1 when the run was closed onto `closing`) and the direction of the last knit."""
    bed = ctx.bed
    chain = list(reversed(run))
    tucks: list[Pos] = []
    prev: Pos | None = None
    d = last_dir or 1
    for i, s in enumerate(chain):
        src = bed.where.get(s)
        if src is None:
            continue
        nxt = chain[i + 1] if i + 1 < len(chain) else closing
        dst = bed.where.get(nxt) if nxt >= 0 else None
        if dst is not None and dst[1] != src[1]:
            d = 1 if dst[1] > src[1] else -1
        kd = -d if kind == "reverse" else d
        if kind == "pickup" and prev is not None and not bed.loops.get(prev, 0):
            emit(ctx, "tuck", kd, prev, number=ctx.numbers.cast_off)
            tucks.append(prev)
        emit(ctx, "knit", kd, src, s, ctx.numbers.cast_off)
        if dst is None:
            _drop_all(bed, tucks, s)
            return s, kd
        if kind != "reverse" and dst[0] == src[0]:
            emit(ctx, "miss", -kd, src, s)  # kickback: the carrier leaves the transfer's way
        bed.prog.stitch_number(ctx.numbers.transfer)
        r = dst[1] - src[1] if dst[0] == "f" else src[1] - dst[1]  # b(k) faces f(k + r)
        if src[0] != dst[0] and abs(r) <= bed.max_rack:
            # the next loop faces it across the beds (a zigzag edge): one transfer
            bed.set_rack(r)
            bed.xfer(src, dst, s)
            bed.set_rack(0)
        else:
            move(bed, [(s, src, dst)])
        prev = src
    _drop_all(bed, tucks, chain[-1] if chain else -1)
    return -1, d


def _drop_all(bed: Bed, positions: Sequence[Pos], stitch: int) -> None:
    for p in positions:
        if bed.loops.get(p, 0):
            bed.drop(p, stitch)


def drop_run(ctx: Ctx, run: Sequence[int]) -> None:
    """Cast-off `none`: the loops are dropped."""
    for s in run:
        p = ctx.bed.where.get(s)
        if p is not None:
            ctx.bed.drop(p, s)


def tail(ctx: Ctx, stitch: int, last_dir: int) -> Pos | None:
    """A few knits back and forth on the last loop of a bind-off, ending rightward (where the
    yarn is taken out), so there is yarn to close it by hand. Returns its needle."""
    pos = ctx.bed.where.get(stitch)
    if pos is None:
        return None
    d = -(last_dir or 1)
    count = TAIL_KNITS if (TAIL_KNITS % 2 == 1) == (d > 0) else TAIL_KNITS - 1
    for _ in range(count):
        emit(ctx, "knit", d, pos, stitch, ctx.numbers.cast_off)
        d = -d
    return pos


# ---- yarn end ---------------------------------------------------------------------------------


def last_move(ctx: Ctx) -> tuple[int, int] | None:
    """(needle index, direction) of the working carrier's last knit/tuck/miss, if any."""
    for op in reversed(ctx.bed.prog.ops):
        if op.kind in ("knit", "tuck", "split", "miss") and ctx.carrier in op.carriers:
            assert op.needle is not None
            return op.needle.index, op.dir
        if op.kind in ("in", "inhook") and ctx.carrier in op.carriers:
            return None
    return None


def yarn_end(ctx: Ctx, tail_pos: Pos | None, stitch: int) -> None:
    """The carrier kicks back one needle past its last loop, in the direction it was going,
    so it leaves the fabric; `outhook`; then the tail's loop is dropped."""
    bed = ctx.bed
    last = last_move(ctx)
    if last is not None:
        idx, d = last
        d = d or 1
        park = idx + d
        if not 0 <= park < ctx.needles:
            park, d = idx - d, -d
        if 0 <= park < ctx.needles:
            emit(ctx, "miss", d, ("f", park), stitch)
    bed.prog.outhook((ctx.carrier,), stitch=stitch, span=ctx.span)
    if tail_pos is not None and bed.loops.get(tail_pos, 0):
        bed.drop(tail_pos, stitch)
