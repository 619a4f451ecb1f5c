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

from dataclasses import dataclass

import numpy as np

from knitc.diagnostics import Diagnostics
from knitc.ir import trace as tr
from knitc.ir.machine import Machine, MachineProgram
from knitc.ir.stitch_graph import StitchGraph
from knitc.passes.bed import BEDS, Bed, Pos, Unsupported
from knitc.passes.casting import cast_off, cast_on
from knitc.passes.layout import Layout
from knitc.passes.transfers import move


@dataclass
class _Gen:
    g: StitchGraph
    lay: Layout
    t: tr.Trace
    carriers: tuple[int, ...]
    bed: Bed
    where_span: object = None
    """The span of the course being generated, for diagnostics."""

    def pos(self, s: int) -> Pos:
        return BEDS[int(self.lay.bed[s])], int(self.lay.needle[s])


def generate(g: StitchGraph, lay: Layout, t: tr.Trace, *, machine: Machine,
             carriers: tuple[int, ...], diags: Diagnostics) -> MachineProgram | None:
    """The machine program for the whole trace; None (with an error) if something cannot
    be knitted yet."""
    prog = MachineProgram(machine)
    gen = _Gen(g, lay, t, carriers, Bed(g, prog, machine.racking_limit))
    try:
        _run(gen)
    except Unsupported as exc:
        diags.error("E602", f"cannot generate machine code: {exc}", gen.where_span,
                    hint="the code generator does not plan this transfer yet; keep shaping "
                         "within 4 needles per course and avoid gauge changes in one piece")
        return None
    return prog


def _run(gen: _Gen) -> None:
    g, t = gen.g, gen.t
    free = list(gen.carriers) + [c for c in range(1, 11) if c not in gen.carriers]
    started: set[int] = set()
    carrier_of: dict[int, int] = {}
    # visit indices of each course, in trace order
    course_of_visit = g.course[t.stitch]
    boundaries = np.nonzero(np.diff(course_of_visit) != 0)[0] + 1
    chunks = np.split(np.arange(t.n_visits), boundaries)
    for chunk in chunks:
        if chunk.size == 0:
            continue
        ids = t.stitch[chunk]
        yarn = int(t.yarn[chunk[0]])
        gen.where_span = gen.bed.span(int(ids[0]))
        fresh = all(int(g.wale_prev[s, 0]) < 0 for s in ids)
        # shaping: bring every parent loop to its child's needle
        moves = []
        in_course = set(int(s) for s in ids)
        for p in np.unique(g.wale_prev[ids]):
            p = int(p)
            if p < 0 or p not in gen.bed.where:
                continue
            # an increase parent's loop goes to its first child; the second child tucks
            child = next((int(c) for c in g.wale_next[p] if int(c) in in_course), -1)
            if child >= 0 and gen.bed.where[p] != gen.pos(child):
                moves.append((p, gen.bed.where[p], gen.pos(child)))
        if moves:
            move(gen.bed, moves)
        if yarn not in started:
            if not free:
                raise Unsupported("more than 10 yarns would be in use at once")
            carrier = free.pop(0)
            carrier_of[yarn] = carrier
            started.add(yarn)
            if fresh:
                cast_on(gen.bed, ids, gen.pos, carrier)
            else:
                gen.bed.prog.in_((carrier,), stitch=int(ids[0]),
                                 span=gen.bed.span(int(ids[0])))
        carrier = carrier_of[yarn]
        for v in chunk:
            s = int(t.stitch[v])
            pos = gen.pos(s)
            d = int(t.dir[v]) or 1
            kind = "knit" if gen.bed.loops.get(pos, 0) > 0 else "tuck"
            gen.bed.stitch_op(kind, d, pos, s, carrier)
        # stitches that end here are cast off once their course is done
        ends = [int(s) for s in ids if g.wale_next[s, 0] < 0]
        if ends:
            cast_off(gen.bed, ends, gen.pos, carrier)
        if t.flags[chunk[-1]] & tr.END:
            gen.bed.prog.outhook((carrier,))
            free.append(carrier)  # reuse carriers last: a carrier brought back keeps its yarn
    leftover = [pos for pos, n in gen.bed.loops.items() if n > 0]
    if leftover:
        raise Unsupported(f"{len(leftover)} loops would be left on the needles")
