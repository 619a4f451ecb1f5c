"""Regular grids on irregular regions: `wale_grid` and `stitch_grid` (thesis ch. 6.9.1-6.9.2).

On a shaped piece the course/wale coordinates of `patterning.query` are ranks within each
course: after a decrease on the left every stitch of the course moves one wale to the left,
and a chart drawn in those coordinates shears. A grid instead gives each stitch the column
of the *wale* it lies on, traced through the stitch graph from a row of seed stitches, and
the row of its distance (in wale steps) from the seed. A motif tiled or stretched on such a
grid follows the wales through the shaping.

Tracing follows each stitch's first wale link (`wale_next[:, 0]` going up, `wale_prev[:, 0]`
going down), as the original did. Where two traced wales meet (a decrease going up, an
increase going down) the stitch keeps the smaller column and the other wale ends there; a
wale that starts inside the region (an increase going up) was never seeded and is not on
the grid. So a grid is densest when traced from the wide end of a shaped piece towards
the narrow one. A stitch is never claimed twice: the first trace to reach it wins.

The loops here run once per traced row (wale step), over arrays of the whole row; never
once per stitch.
"""

from __future__ import annotations

import numpy as np

from knitc.records import record
from knitc.shaping.stitch_graph import StitchGraph

UNSET = np.iinfo(np.int64).min


@record(frozen=True)
class GridCoords:
    on: np.ndarray  # bool: stitches on the grid
    row: np.ndarray  # int64 (UNSET off the grid)
    col: np.ndarray  # int64 (-1 off the grid)


def extrude(
    g: StitchGraph,
    seeds: np.ndarray,
    cols: np.ndarray,
    rows: np.ndarray,
    up: int | None,
    down: int | None,
    domain: np.ndarray,
) -> GridCoords:
    """Trace the wales of `seeds` (stitch ids with their grid column and row) `up` steps
    upwards and `down` steps downwards (None: until the wale leaves `domain` or its node:
    a grid belongs to one node); each step adds 1 to (upwards) or takes 1 from (downwards)
    the row."""
    n = g.n_stitches
    on = np.zeros(n, dtype=bool)
    row = np.full(n, UNSET, dtype=np.int64)
    col = np.full(n, -1, dtype=np.int64)
    seeds = np.asarray(seeds, dtype=np.int64)
    keep = _first_claims(seeds, np.asarray(cols, dtype=np.int64), on)
    seeds, cols, rows = seeds[keep], np.asarray(cols)[keep], np.asarray(rows)[keep]
    on[seeds], row[seeds], col[seeds] = True, rows, cols
    for links, steps, d in ((g.wale_next, up, 1), (g.wale_prev, down, -1)):
        fr, fc, frow = seeds, cols, rows
        k = 0
        while fr.size and (steps is None or k < steps):
            k += 1
            nxt = links[fr, 0].astype(np.int64)
            ok = nxt >= 0
            ok[ok] = domain[nxt[ok]] & (g.node[nxt[ok]] == g.node[fr[ok]])
            fr, fc, frow = nxt[ok], fc[ok], frow[ok] + d
            keep = _first_claims(fr, fc, on)
            fr, fc, frow = fr[keep], fc[keep], frow[keep]
            on[fr], row[fr], col[fr] = True, frow, fc
    return GridCoords(on, row, col)


def _first_claims(ids: np.ndarray, cols: np.ndarray, taken: np.ndarray) -> np.ndarray:
    """Mask of the entries that claim their stitch: not taken yet, and the smallest column
    among the entries reaching the same stitch."""
    if ids.size == 0:
        return np.zeros(0, dtype=bool)
    order = np.lexsort((cols, ids))
    first = np.ones(ids.size, dtype=bool)
    first[1:] = ids[order][1:] != ids[order][:-1]
    keep = np.zeros(ids.size, dtype=bool)
    keep[order[first]] = True
    return keep & ~taken[ids]


def stitch_at(g: StitchGraph, wale: np.ndarray) -> np.ndarray:
    """Table from (course start + wale coordinate) to the stitch id: wale coordinates are a
    permutation of 0..len-1 within each course."""
    at = np.empty(g.n_stitches, dtype=np.int64)
    at[g.course_start[g.course].astype(np.int64) + wale] = np.arange(g.n_stitches)
    return at


def course_runs(
    g: StitchGraph, wale: np.ndarray, anchors: np.ndarray, width: int | None, align: str
) -> tuple[np.ndarray, np.ndarray]:
    """The stitches of a run of `width` stitches along each anchor's course (None: the
    whole course), placed so the anchor is its left end, centre or right end; with their
    columns in the run. Flat courses clip the run at their ends, tubular ones wrap."""
    at = stitch_at(g, wale)
    ids, cols = [], []
    for a in anchors.tolist():  # one run per anchor (one anchor per node)
        cid = int(g.course[a])
        length = int(g.course_len[cid])
        w = length if width is None else min(width, length)
        wa = int(wale[a])
        start = {"left": wa, "center": wa - w // 2, "right": wa - w + 1}[align]
        pos = start + np.arange(w, dtype=np.int64)
        colv = np.arange(w, dtype=np.int64)
        if g.course_circular[cid]:
            pos = np.mod(pos, length)
        else:
            ok = (pos >= 0) & (pos < length)
            pos, colv = pos[ok], colv[ok]
        ids.append(at[int(g.course_start[cid]) + pos])
        cols.append(colv)
    if not ids:
        z = np.zeros(0, dtype=np.int64)
        return z, z
    return np.concatenate(ids), np.concatenate(cols)


def vertical_span(height: int | None, align: str) -> tuple[int, int | None, int | None]:
    """(row of the anchor, steps up, steps down) of a grid `height` stitches tall whose
    anchor is at its bottom, middle or top (None: unbounded)."""
    if height is None:
        return 0, (None if align != "top" else 0), (None if align != "bottom" else 0)
    if align == "bottom":
        return 0, height - 1, 0
    if align == "top":
        return height - 1, 0, height - 1
    down = (height - 1) // 2
    return down, height - 1 - down, down
