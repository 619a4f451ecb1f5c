"""The garment's shape (`knitc view --shape`): a force layout of the stitch graph.

The thesis previews a design as a force layout of its stitch graph (ch. 5.1.3, Fig. 5-6):
course neighbours and wale neighbours pulled to a stitch's width and height apart, so a
glove shows its fingers, a sock its heel turn and a sweater its sleeves. `layout` computes
it; `render` draws it, pieces coloured by node.

The layout is stress majorization (SMACOF) restricted to the graph's springs: course and
wale springs, plus springs two stitches apart along courses and wales that resist folding.
Its matrix (the weighted Laplacian, anchored weakly to the starting positions so it is
invertible and the pieces keep their places) never changes, so it is factorised once and
every iteration is a sparse back-solve: a 100k-stitch design lays out in about a second.
A spring layout only finds the local minimum near where it starts, so the start matters
most: each stitch at its needle across (from the schedule, in stitches, not needles, so a
half-gauge piece is not twice as wide) and at its wale depth up (the longest chain of
wales below it, so short rows lengthen one side and a heel turns); in 3-D each tube's
course starts as the ring its flattened bed layout inflates to.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from knitc.scheduling.schedule import Schedule
    from knitc.shaping.stitch_graph import StitchGraph
    from knitc.view.source import ViewInput

COURSE_LEN = 1.0
"""Rest length of a course spring: a stitch's width."""
WALE_LEN = 0.75
"""Rest length of a wale spring: a stitch's height (stitches are wider than tall, about
20 stitches to 27 rows in 10 cm on a medium gauge)."""
BEND_WEIGHT = 0.5
"""Weight of the springs two stitches apart (against the neighbour springs' 1)."""
ANCHOR = 1e-3
"""Pull towards the start, relative to a spring: enough to make the system solvable and
keep unconnected pieces where the schedule put them, small enough not to shape anything."""
ITERATIONS = 25


def layout(
    graph: StitchGraph,
    three_d: bool = False,
    *,
    schedule: Schedule | None = None,
    iterations: int = ITERATIONS,
) -> np.ndarray:
    """Positions of every stitch, (n, 2) or (n, 3) float64, in stitch widths: x across,
    y up (knitting time), z towards the viewer (the front bed) in 3-D.

    `schedule` (when the design has one) gives the starting needles; without it the
    stitches start at the graph's needle hints, each node placed over its parents."""
    n = graph.n_stitches
    dim = 3 if three_d else 2
    if n == 0:
        return np.zeros((0, dim))
    x0 = start(graph, three_d, schedule=schedule)
    if iterations <= 0 or n == 1:
        return x0
    i, j, d, w = springs(graph)
    return _smacof(x0, i, j, d, w, iterations)


def start(
    graph: StitchGraph, three_d: bool = False, *, schedule: Schedule | None = None
) -> np.ndarray:
    """The starting positions of `layout` (see the module docstring)."""
    n = graph.n_stitches
    x = across(graph, schedule)
    y = depth(graph).astype(np.float64) * WALE_LEN
    if not three_d:
        # the back of a flattened tube a hair behind and above its front, so no spring
        # starts at length zero (the majorization has no direction for it)
        return np.column_stack([x, y + 1e-3 * graph.side])
    z = np.zeros(n)
    circ = graph.course_circular[graph.course]
    if np.any(circ):
        c = graph.course.astype(np.int64)
        nc = graph.n_courses
        big = np.inf
        lo = np.full(nc, big)
        hi = np.full(nc, -big)
        np.minimum.at(lo, c, x)
        np.maximum.at(hi, c, x)
        cx = 0.5 * (lo + hi)[c]
        half = np.maximum(0.5 * (hi - lo)[c], 1e-9)
        radius = graph.course_len[graph.course] * COURSE_LEN / (2 * np.pi)
        u = np.clip((x - cx) / half, -1.0, 1.0)  # -1 left end .. 1 right end
        ang = np.arccos(-u)  # 0 at the left end, pi at the right
        front = graph.side == 0
        xr = cx - radius * np.cos(ang)
        zr = np.where(front, 1.0, -1.0) * radius * np.sin(ang)
        x = np.where(circ, xr, x)
        z = np.where(circ, zr, z)
    return np.column_stack([x, y, z])


def across(graph: StitchGraph, schedule: Schedule | None) -> np.ndarray:
    """Each stitch's position across the bed, in stitch widths: its scheduled needle (where
    it was knitted) divided by its slice's gauge step; without a schedule its needle hint,
    each node shifted over the stitches it grows from (roots side by side)."""
    n = graph.n_stitches
    if schedule is not None:
        from knitc.scheduling.slices import ACTIVE

        sl = schedule.slices
        act = np.nonzero(sl.state == ACTIVE)[0]
        k = np.repeat(np.arange(sl.n_slices), sl.length)[act]
        x = np.full(n, np.nan)
        x[sl.stitch[act]] = schedule.needle[act] / schedule.step[k]
        if not np.any(np.isnan(x)):
            return x
        hint = _hinted(graph)
        return np.where(np.isnan(x), hint, x)
    return _hinted(graph)


def _hinted(graph: StitchGraph) -> np.ndarray:
    hint = graph.needle.astype(np.float64)
    x = hint.copy()
    placed_right = 0.0
    for v in range(len(graph.node_names)):
        m = graph.node == v
        if not np.any(m):
            continue
        ids = np.nonzero(m)[0]
        par = graph.wale_prev[ids, 0]
        outside = (par >= 0) & (graph.node[np.maximum(par, 0)] != v)
        if np.any(outside):
            shift = float(np.mean(x[par[outside]] - hint[ids[outside]]))
        else:
            shift = placed_right - float(hint[ids].min())
        x[ids] = hint[ids] + shift
        placed_right = max(placed_right, float(x[ids].max()) + 4.0)
    return x


def depth(graph: StitchGraph) -> np.ndarray:
    """Per stitch, the longest chain of wales below it (0 on a first course), one pass over
    the courses in knitting order (wales go forward in time, so parents come first). A
    stitch without wales below it takes its course's deepest parent level."""
    n = graph.n_stitches
    out = np.zeros(n, np.int64)
    wp = graph.wale_prev
    has = wp >= 0
    for c in range(graph.n_courses):
        a = int(graph.course_start[c])
        b = a + int(graph.course_len[c])
        p = wp[a:b]
        h = has[a:b]
        if not h.any():
            continue
        lv = np.where(h, out[np.maximum(p, 0)] + 1, -1).max(axis=1)
        if np.any(lv < 0):
            lv[lv < 0] = lv.max()
        out[a:b] = lv
    return out


def springs(graph: StitchGraph) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(i, j, rest length, weight) of every spring: course neighbours, wale neighbours, and
    the stitches two apart along a course or a wale (their bending stiffness). Weights are
    1 / length^2, as stress majorization weighs distances."""
    ids = np.arange(graph.n_stitches, dtype=np.int64)
    parts: list[tuple[np.ndarray, np.ndarray, float, float]] = []
    cn = graph.cnext.astype(np.int64)
    ok = cn >= 0
    parts.append((ids[ok], cn[ok], COURSE_LEN, 1.0))
    cn2 = np.where(ok, cn[np.maximum(cn, 0)], -1)
    ok2 = (cn2 >= 0) & (cn2 != ids)
    parts.append((ids[ok2], cn2[ok2], 2 * COURSE_LEN, BEND_WEIGHT))
    for s in (0, 1):
        wn = graph.wale_next[:, s].astype(np.int64)
        ok = wn >= 0
        parts.append((ids[ok], wn[ok], WALE_LEN, 1.0))
    wn = graph.wale_next[:, 0].astype(np.int64)
    wn2 = np.where(wn >= 0, graph.wale_next[np.maximum(wn, 0), 0], -1)
    ok = wn2 >= 0
    parts.append((ids[ok], wn2[ok], 2 * WALE_LEN, BEND_WEIGHT))
    i = np.concatenate([p[0] for p in parts])
    j = np.concatenate([p[1] for p in parts])
    d = np.concatenate([np.full(p[0].shape[0], p[2]) for p in parts])
    w = np.concatenate([np.full(p[0].shape[0], p[3] / p[2] ** 2) for p in parts])
    return i, j, d, w


def _smacof(
    x0: np.ndarray, i: np.ndarray, j: np.ndarray, d: np.ndarray, w: np.ndarray, iterations: int
) -> np.ndarray:
    """Stress majorization: minimise sum w (|xi - xj| - d)^2 + ANCHOR |x - x0|^2 by
    repeatedly solving L x' = B(x) x + ANCHOR x0 with the fixed Laplacian L (factorised
    once); each step never increases the stress."""
    import scipy.sparse as sp
    from scipy.sparse.linalg import splu

    n = x0.shape[0]
    diag = np.bincount(i, w, n) + np.bincount(j, w, n) + ANCHOR
    lap = sp.coo_matrix(
        (
            np.concatenate([-w, -w, diag]),
            (np.concatenate([i, j, np.arange(n)]), np.concatenate([j, i, np.arange(n)])),
        ),
        shape=(n, n),
    ).tocsc()
    solve = splu(lap, permc_spec="MMD_AT_PLUS_A").solve
    x = x0.copy()
    anchor = ANCHOR * x0
    wd = w * d
    for _ in range(iterations):
        delta = x[i] - x[j]
        dist = np.sqrt((delta * delta).sum(axis=1))
        coef = np.where(dist > 1e-12, wd / np.maximum(dist, 1e-12), 0.0)
        f = delta * coef[:, None]
        rhs = anchor.copy()
        for k in range(x.shape[1]):
            rhs[:, k] += np.bincount(i, f[:, k], n) - np.bincount(j, f[:, k], n)
        x = solve(rhs)
    return x


def render(input: ViewInput, fmt: str, *, three_d: bool = False) -> bytes:
    """The shape picture of `input` (see the module docstring) as SVG or PNG bytes."""
    raise NotImplementedError
