"""Cast-on and cast-off passes (thesis ch. 6.8.1): how a yarn starts on empty needles and
how the loops of a finished edge are secured so they do not unravel."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from knitc.passes.bed import Bed, Pos
from knitc.passes.transfers import move


def cast_on(bed: Bed, ids: np.ndarray, pos: Callable[[int], Pos], carrier: int) -> None:
    """inhook, alternate tucks leftward from the rightmost needle, releasehook, then the
    other needles rightward: every needle of the first course holds one loop."""
    order = sorted((int(s) for s in ids), key=lambda s: (-pos(s)[1], pos(s)[0]))
    bed.prog.inhook((carrier,), stitch=int(ids[0]), span=bed.span(int(ids[0])))
    first, second = order[0::2], order[1::2]
    for s in first:
        bed.stitch_op("tuck", -1, pos(s), -1, carrier)
    bed.prog.releasehook((carrier,))
    for s in reversed(second):
        bed.stitch_op("tuck", 1, pos(s), -1, carrier)
    # The yarn is now at the right. If the first course starts at its left end, knit one
    # plain leftward pass over the tucks so the yarn is where that course begins.
    start = pos(int(ids[0]))
    if start[1] < pos(order[0])[1]:
        for s in order:
            bed.stitch_op("knit", -1, pos(s), -1, carrier)


def cast_off(bed: Bed, ends: list[int], pos: Callable[[int], Pos], carrier: int) -> None:
    """Chain bind-off: from the last knitted end stitch back along the course, move each
    loop onto the next one's needle and knit them together; drop the final loop."""
    chain = list(reversed(ends))
    for a, b in zip(chain, chain[1:], strict=False):
        src, dst = bed.where.get(a), pos(b)
        if src is None or bed.where.get(b) != dst:
            continue
        if src != dst:
            move(bed, [(a, src, dst)])
        d = 1 if dst[1] >= src[1] else -1
        bed.stitch_op("knit", d, dst, b, carrier)
    last = bed.where.get(chain[-1])
    if last is not None:
        bed.drop(last, chain[-1])
