"""The back of a jacquard course: which yarn knits which back needle (thesis ch. 6.9.5).

In a jacquard course every yarn of the region makes one pass (one main step per yarn, as
in fair isle): it knits the front stitches that show it, and on the other bed, behind the
stitches, the back needles its *backing* gives it (the thesis' yarn stack, Table 6.1: a
front yarn and back yarns that miss, tuck or knit). The back knits bind every float to a
back layer, so the fabric is two layers joined wherever a yarn crosses between them.

The backings (`stitch_graph.BACKINGS`), for the region's yarns `Y` (n of them, in yarn
order), a stitch at needle `x` in the region's course `y` (counted from the node's first)
and its front yarn `f`:

- ``tubular``: the yarns that do not show knit the back, in turn along the course (for two
  yarns, the other one: the back is the negative of the front);
- ``birdseye``: `Y[(x + y) % n]`, a checkerboard that moves one needle each course (the
  thesis' *alternate*);
- ``pique``: the front yarn on one needle of two (`x + y` even), the others in turn on the
  rest;
- ``horizontal``: every yarn knits every back needle (stripes on the back; twice the back
  loops, so the fabric comes out taller);
- ``vertical``: `Y[x % n]`, the same yarn up each back wale.

Each back needle of a backed stitch is knitted at least once per course, so a back loop is
always knitted through by the next course, and no yarn floats further than `n` needles.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from knitc.shaping.stitch_graph import BACKINGS

TUBULAR, BIRDSEYE, PIQUE, HORIZONTAL, VERTICAL = (
    BACKINGS.index(k) for k in ("tubular", "birdseye", "pique", "horizontal", "vertical")
)


def back_knits(
    kind: np.ndarray, front: np.ndarray, x: np.ndarray, y: np.ndarray, yarns: Sequence[int]
) -> np.ndarray:
    """bool (len(yarns), n): whether `yarns[i]` knits the back needle behind stitch j in its
    pass. `kind` (BACKINGS index), `front` (design yarn), `x` (needle) and `y` (course in the
    region) per stitch; `yarns` the region's yarns, ascending, every `front` among them. A
    stitch of no two-bed backing (none, float) gets no back knit."""
    n = len(yarns)
    out = np.zeros((n, kind.shape[0]), bool)
    if n == 0 or kind.size == 0:
        return out
    f = np.searchsorted(np.asarray(yarns), front)  # the front yarn's place in `yarns`
    t = x.astype(np.int64) + y
    others = max(n - 1, 1)

    def other(j: np.ndarray) -> np.ndarray:
        """The j-th yarn that is not the front one (the front one when it is alone)."""
        return np.where(n == 1, f, np.where(j < f, j, j + 1))

    chosen = np.full(kind.shape[0], -1, np.int64)
    chosen = np.where(kind == TUBULAR, other(t % others), chosen)
    chosen = np.where(kind == BIRDSEYE, t % n, chosen)
    chosen = np.where(kind == PIQUE, np.where(t % 2 == 0, f, other((t // 2) % others)), chosen)
    chosen = np.where(kind == VERTICAL, x % n, chosen)
    cols = np.nonzero(chosen >= 0)[0]
    out[chosen[cols], cols] = True
    out[:, kind == HORIZONTAL] = True
    return out
