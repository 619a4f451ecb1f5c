"""Code generation: traced yarn + layout → machine operations (thesis ch. 6.8).

Courses are knitted in trace order. Before each course, every loop its stitches knit
through is moved from where it is to the stitch's needle (shaping); then the course is
knitted in the trace's direction, tucking where a needle is still empty (an increase),
and stitches without a next wale are cast off once their course is done.

Passes, as in ch. 6.8.1:
- yarn start: `inhook`, the first cast-on pass going leftward from the course's rightmost
  needle (the hook sits right of the first stitch), `releasehook` after it; a yarn that
  starts on live loops (a branch knitted with its own yarn) is brought in with `in`;
- cast-on: alternate tucks leftward then rightward, so every needle holds one loop before
  the first course is knitted through them;
- shaping: loops changing bed are transferred directly at the racking that aligns them;
  loops shifting along their bed are parked on the opposite bed's sliders and put back
  one racking at a time (so no loop lands on a needle another loop has not left yet);
- cast-off: a chain bind-off along the stitches that end (each loop knitted, moved onto
  its neighbour and knitted together with it), the last loop dropped;
- yarn end: `outhook`.

Every operation keeps the stitch it came from; the span is the stitch's declaration.
"""

from __future__ import annotations

from collections import defaultdict
from dataclasses import dataclass, field

import numpy as np

from knitc.diagnostics import Diagnostics
from knitc.ir import trace as tr
from knitc.ir.machine import Machine, MachineProgram
from knitc.ir.stitch_graph import StitchGraph
from knitc.passes.layout import Layout

FRONT, BACK = 0, 1
BEDS = ("f", "b")
SLIDERS = ("fs", "bs")


@dataclass
class _Gen:
    g: StitchGraph
    lay: Layout
    t: tr.Trace
    carriers: tuple[int, ...]
    max_rack: int
    diags: Diagnostics
    prog: MachineProgram
    loops: dict[tuple[str, int], int] = field(default_factory=lambda: defaultdict(int))
    where: dict[int, tuple[str, int]] = field(default_factory=dict)
    """Current position (bed or slider name, needle) of each live stitch's loop."""
    at: dict[tuple[str, int], set[int]] = field(default_factory=lambda: defaultdict(set))
    """The inverse of `where`: the stitches whose loops are on a needle."""
    rack: int = 0
    carrier_of: dict[int, int] = field(default_factory=dict)
    where_span: object = None
    """The span of the course being generated, for diagnostics."""

    # -- primitive emitters keeping the loop model in step
    def span(self, s: int):
        return self.g.spans[int(self.g.span[s])] if s >= 0 else None

    def set_rack(self, r: int) -> None:
        if r != self.rack:
            if abs(r) > self.max_rack:
                raise _Unsupported(f"a transfer needs racking {r}, beyond the machine's "
                                   f"{self.max_rack}")
            self.prog.rack(r)
            self.rack = r

    def xfer(self, src: tuple[str, int], dst: tuple[str, int], stitch: int) -> None:
        self.prog.xfer(f"{src[0]}{src[1]}", f"{dst[0]}{dst[1]}", stitch=stitch,
                       span=self.span(stitch))
        moved = self.loops.pop(src, 0)
        self.loops[dst] += moved
        for s in self.at.pop(src, ()):
            self.where[s] = dst
            self.at[dst].add(s)

    def stitch_op(self, kind: str, d: int, pos: tuple[str, int], stitch: int,
                  carrier: int) -> None:
        emit = self.prog.knit if kind == "knit" else self.prog.tuck
        emit(d, f"{pos[0]}{pos[1]}", (carrier,), stitch=stitch, span=self.span(stitch))
        if kind == "knit":
            for s in self.at.pop(pos, ()):
                del self.where[s]
            self.loops[pos] = 1
        elif kind == "tuck":
            self.loops[pos] += 1
        if stitch >= 0:  # cast-on loops belong to no stitch of the graph: count them only
            self._place(stitch, pos)

    def _place(self, stitch: int, pos: tuple[str, int]) -> None:
        old = self.where.get(stitch)
        if old is not None:
            self.at[old].discard(stitch)
        self.where[stitch] = pos
        self.at[pos].add(stitch)

    def drop(self, pos: tuple[str, int], stitch: int) -> None:
        self.prog.drop(f"{pos[0]}{pos[1]}", stitch=stitch, span=self.span(stitch))
        self.loops.pop(pos, None)
        for s in self.at.pop(pos, ()):
            del self.where[s]

    # -- geometry
    def pos(self, s: int) -> tuple[str, int]:
        return BEDS[int(self.lay.bed[s])], int(self.lay.needle[s])

    def move(self, moves: list[tuple[int, tuple[str, int], tuple[str, int]]]) -> None:
        """Move loops (stitch, from, to): cross-bed moves directly, then same-bed shifts
        parked on the opposite sliders and returned one racking at a time."""
        if not moves:
            return
        shift = [m for m in moves if m[1][0] == m[2][0] and m[1] != m[2]]
        cross = []
        for s, src, dst in moves:
            if src[0] != dst[0]:
                # at racking r, back k faces front k + r
                r = src[1] - dst[1] if src[0] == "f" else dst[1] - src[1]
                cross.append((r, s, src, dst))
        self._cross(cross)
        self._shift(shift)

    def _cross(self, cross: list) -> None:
        for r, s, src, dst in sorted(cross, key=lambda m: (m[0], m[2])):
            self.set_rack(r)
            if self.where.get(s) == src:
                self.xfer(src, dst, s)
        self.set_rack(0)

    def _shift(self, shift: list) -> None:
        if not shift:
            return
        # Same-bed shifts, in rounds: every loop still away from its target is parked on
        # the facing slider and put back at most `max_rack` needles closer. The loops of a
        # course transition keep their order (wales never cross), so a loop never lands
        # on a needle another loop still holds, except its decrease partner.
        todo = {s: dst for s, src, dst in shift}
        final = set(todo.values())
        rounds = 0
        while True:
            rounds += 1
            if rounds > 4 + max((abs(d[1] - p[1]) for _s, p, d in shift), default=0):
                raise _Unsupported("shaping moves do not converge")
            pending = [(s, self.where[s], dst) for s, dst in todo.items()
                       if s in self.where and self.where[s] != dst]
            if not pending:
                break
            parked = []
            seen: set[tuple[str, int]] = set()
            for s, src, dst in sorted(pending, key=lambda m: m[1]):
                if src in seen:  # stacked loops travel together
                    continue
                seen.add(src)
                slider = (SLIDERS[1] if src[0] == "f" else SLIDERS[0], src[1])
                self.xfer(src, slider, s)
                step = max(-self.max_rack, min(self.max_rack, dst[1] - src[1]))
                parked.append((s, slider, (src[0], src[1] + step)))
            by_rack: dict[int, list] = defaultdict(list)
            for s, slider, land in parked:
                # back slider i faces front i + r; front slider i faces back i - r
                r = land[1] - slider[1] if land[0] == "f" else slider[1] - land[1]
                by_rack[r].append((s, slider, land))
            for r in sorted(by_rack, key=lambda x: (abs(x), x)):
                self.set_rack(r)
                for s, slider, land in sorted(by_rack[r], key=lambda m: m[1]):
                    if self.loops.get(land, 0) and land not in final:
                        raise _Unsupported(f"a shaping move would land on {land[0]}{land[1]}, "
                                           "which holds another loop")
                    self.xfer(slider, land, s)
            self.set_rack(0)


class _Unsupported(Exception):
    pass


def generate(g: StitchGraph, lay: Layout, t: tr.Trace, *, machine: Machine,
             carriers: tuple[int, ...], diags: Diagnostics) -> MachineProgram | None:
    """The machine program for the whole trace; None (with an error) if something cannot
    be knitted yet."""
    gen = _Gen(g, lay, t, carriers, machine.racking_limit, diags, MachineProgram(machine))
    try:
        _run(gen)
    except _Unsupported as exc:
        diags.error("E602", f"cannot generate machine code: {exc}", gen.where_span,
                    hint="the code generator does not plan this transfer yet; keep shaping "
                         "within 4 needles per course and avoid gauge changes in one piece")
        return None
    return gen.prog


def _run(gen: _Gen) -> None:
    g, t = gen.g, gen.t
    free = list(gen.carriers) + [c for c in range(1, 11) if c not in gen.carriers]
    started: set[int] = set()
    # visit indices of each course, in trace order
    course_of_visit = g.course[t.stitch]
    boundaries = np.nonzero(np.diff(course_of_visit) != 0)[0] + 1
    chunks = np.split(np.arange(t.n_visits), boundaries)
    for chunk in chunks:
        if chunk.size == 0:
            continue
        ids = t.stitch[chunk]
        yarn = int(t.yarn[chunk[0]])
        gen.where_span = gen.span(int(ids[0]))
        fresh = all(int(g.wale_prev[s, 0]) < 0 for s in ids)
        # shaping: bring every parent loop to its child's needle
        moves = []
        in_course = set(int(s) for s in ids)
        for p in np.unique(g.wale_prev[ids]):
            p = int(p)
            if p < 0 or p not in gen.where:
                continue
            # an increase parent's loop goes to its first child; the second child tucks
            child = next((int(c) for c in g.wale_next[p] if int(c) in in_course), -1)
            if child >= 0 and gen.where[p] != gen.pos(child):
                moves.append((p, gen.where[p], gen.pos(child)))
        if moves:
            gen.move(moves)
        if yarn not in started:
            if not free:
                raise _Unsupported("more than 10 yarns would be in use at once")
            carrier = free.pop(0)
            gen.carrier_of[yarn] = carrier
            started.add(yarn)
            if fresh:
                _cast_on(gen, ids, carrier)
            else:
                gen.prog.in_((carrier,), stitch=int(ids[0]), span=gen.span(int(ids[0])))
        carrier = gen.carrier_of[yarn]
        for v in chunk:
            s = int(t.stitch[v])
            pos = gen.pos(s)
            d = int(t.dir[v]) or 1
            kind = "knit" if gen.loops.get(pos, 0) > 0 else "tuck"
            gen.stitch_op(kind, d, pos, s, carrier)
        # stitches that end here are cast off once their course is done
        ends = [int(s) for s in ids if g.wale_next[s, 0] < 0]
        if ends:
            _cast_off(gen, ends, carrier, int(t.dir[chunk[-1]]) or 1)
        if t.flags[chunk[-1]] & tr.END:
            gen.prog.outhook((carrier,))
            free.append(carrier)  # reuse carriers last: a carrier brought back keeps its yarn
    leftover = [pos for pos, n in gen.loops.items() if n > 0]
    if leftover:
        raise _Unsupported(f"{len(leftover)} loops would be left on the needles")


def _cast_on(gen: _Gen, ids: np.ndarray, carrier: int) -> None:
    """inhook, alternate tucks leftward from the rightmost needle, releasehook, then the
    other needles rightward: every needle of the first course holds one loop."""
    order = sorted((int(s) for s in ids), key=lambda s: (-gen.pos(s)[1], gen.pos(s)[0]))
    gen.prog.inhook((carrier,), stitch=int(ids[0]), span=gen.span(int(ids[0])))
    first, second = order[0::2], order[1::2]
    for s in first:
        gen.stitch_op("tuck", -1, gen.pos(s), -1, carrier)
    gen.prog.releasehook((carrier,))
    for s in reversed(second):
        gen.stitch_op("tuck", 1, gen.pos(s), -1, carrier)
    # The yarn is now at the right. If the first course starts at its left end, knit one
    # plain leftward pass over the tucks so the yarn is where that course begins.
    start = gen.pos(int(ids[0]))
    if start[1] < gen.pos(order[0])[1]:
        for s in order:
            gen.stitch_op("knit", -1, gen.pos(s), -1, carrier)


def _cast_off(gen: _Gen, ends: list[int], carrier: int, d: int) -> None:
    """Chain bind-off: from the last knitted end stitch back along the course, move each
    loop onto the next one's needle and knit them together; drop the final loop."""
    chain = list(reversed(ends))
    for a, b in zip(chain, chain[1:], strict=False):
        src, dst = gen.where.get(a), gen.pos(b)
        if src is None or gen.where.get(b) != dst:
            continue
        if src != dst:
            gen.move([(a, src, dst)])
        d = 1 if dst[1] >= src[1] else -1
        gen.stitch_op("knit", d, dst, b, carrier)
    last = gen.where.get(chain[-1])
    if last is not None:
        gen.drop(last, chain[-1])
