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

from typing import TYPE_CHECKING, Any, cast

import numpy as np

from knitc import arrays

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
ITERATIONS = 12


def layout(
    graph: StitchGraph,
    three_d: bool = False,
    *,
    schedule: Schedule | None = None,
    exact_needles: bool = False,
    iterations: int = ITERATIONS,
) -> np.ndarray:
    """Positions of every stitch, (n, 2) or (n, 3) float64, in stitch widths: x across,
    y up (knitting time), z towards the viewer (the front bed) in 3-D.

    `schedule` (when the design has one) gives the starting needles; without it the
    stitches start at the graph's needle hints, each node placed over its parents, or
    exactly at them with `exact_needles` (a graph of a program's loops, whose needles are
    the machine's)."""
    n = graph.n_stitches
    dim = 3 if three_d else 2
    if n == 0:
        return np.zeros((0, dim))
    x0 = start(graph, three_d, schedule=schedule, exact_needles=exact_needles)
    if iterations <= 0 or n == 1:
        return x0
    i, j, d, w = springs(graph)
    return _smacof(x0, i, j, d, w, iterations)


def start(
    graph: StitchGraph,
    three_d: bool = False,
    *,
    schedule: Schedule | None = None,
    exact_needles: bool = False,
) -> np.ndarray:
    """The starting positions of `layout` (see the module docstring)."""
    n = graph.n_stitches
    x = graph.needle.astype(np.float64) if exact_needles else across(graph, schedule)
    y = depth(graph).astype(np.float64) * WALE_LEN
    if not three_d:
        # the back of a flattened tube a hair behind and above its front, so no spring
        # starts at length zero (the majorization has no direction for it)
        return np.column_stack([x, y + 1e-3 * graph.side])
    # a program's loops have no rings: its beds a stitch apart, so a tube has two sides
    z = -COURSE_LEN * graph.side.astype(np.float64) if exact_needles else np.zeros(n)
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
    pos = np.column_stack([x, y, z])
    return pos if exact_needles else grow(graph, pos)


def grow(graph: StitchGraph, pos: np.ndarray) -> np.ndarray:
    """Knit the 3-D start course by course: every stitch a wale's height along its parents'
    growth direction from them, each ring then refitted as a round course of its size in
    the plane its stitches lie in, whose normal becomes the direction its children grow.
    So short rows on one side tilt the next ring and a heel turns the foot, which springs
    started from a straight tube would not find; a ring where pieces merge grows on their
    mean direction instead (sleeves shorter than the body must not tip the yoke). Courses with no wales below them (where
    pieces start) keep the positions of `pos`."""
    out = pos.copy()
    up = np.zeros_like(pos)
    up[:, 1] = 1.0
    wp = graph.wale_prev
    radius_of = graph.course_len * COURSE_LEN / (2 * np.pi)
    for c in range(graph.n_courses):
        a = int(graph.course_start[c])
        b = a + int(graph.course_len[c])
        p = wp[a:b]
        h = p >= 0
        k = h.sum(axis=1)
        got = k > 0
        if not got.any():
            continue
        q = np.maximum(p, 0)
        pp = (out[q] * h[..., None]).sum(axis=1)[got] / k[got, None]
        pu = (up[q] * h[..., None]).sum(axis=1)[got] / k[got, None]
        pu /= np.maximum(np.linalg.norm(pu, axis=1), 1e-12)[:, None]
        new = out[a:b].copy()
        new[got] = pp + WALE_LEN * pu
        if not got.all():  # stitches with no wale below move with their course
            new[~got] += (new[got] - out[a:b][got]).mean(axis=0)
        mean_up = pu.mean(axis=0)
        mean_up /= max(float(np.linalg.norm(mean_up)), 1e-12)
        if graph.course_circular[c] and b - a >= 3:
            centre = new.mean(axis=0)
            _, sv, vt = np.linalg.svd(new - centre, full_matrices=False)
            normal = vt[2]
            merge = arrays.unique(graph.node[q[h]]).shape[0] > 1
            if merge or sv[1] < 0.25 * sv[0]:
                # where pieces merge (their tops at their own heights), or on a ring that is
                # nearly a line (an arc of a flattened piece), keep growing the parents' way
                e1 = vt[0]
                normal = mean_up - (mean_up @ e1) * e1
            if normal @ mean_up < 0:
                normal = -normal
            normal /= max(float(np.linalg.norm(normal)), 1e-12)
            e1 = new[0] - centre
            e1 -= (e1 @ normal) * normal
            if np.linalg.norm(e1) < 1e-9:
                e1 = vt[0] - (vt[0] @ normal) * normal
            e1 /= max(float(np.linalg.norm(e1)), 1e-12)
            e2 = np.cross(normal, e1)
            # the ring runs the way its stitches do around the normal
            rel = new - centre
            ang = np.unwrap(np.arctan2(rel @ e2, rel @ e1))
            turn = 1.0 if ang[-1] >= ang[0] else -1.0
            t = turn * 2 * np.pi * np.arange(b - a) / (b - a)
            r = float(radius_of[c])
            new = centre + r * (np.cos(t)[:, None] * e1 + np.sin(t)[:, None] * e2)
            up[a:b] = normal
        else:
            up[a:b][got] = pu
            up[a:b][~got] = mean_up
        out[a:b] = new
    return out


def across(graph: StitchGraph, schedule: Schedule | None) -> np.ndarray:
    """Each stitch's position across the bed, in stitch widths: its scheduled needle (where
    it was knitted), a half-gauge slice's shrunk by half about its centre; without a schedule its needle hint,
    each node shifted over the stitches it grows from (roots side by side)."""
    n = graph.n_stitches
    if schedule is not None:
        from knitc.scheduling.slices import ACTIVE

        sl = schedule.slices
        act = np.nonzero(sl.state == ACTIVE)[0]
        slice_of = np.repeat(np.arange(sl.n_slices), sl.length)
        # a half-gauge slice shrunk about its centre, so it stays under the piece it joins
        centre = np.bincount(slice_of, schedule.needle, sl.n_slices) / np.maximum(sl.length, 1)
        k = slice_of[act]
        x = np.full(n, np.nan)
        x[sl.stitch[act]] = centre[k] + (schedule.needle[act] - centre[k]) / schedule.step[k]
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


def faces(graph: StitchGraph) -> np.ndarray:
    """(m, 4) stitch ids of the fabric's quads: a stitch, its next course neighbour, and the
    stitches knitted into each (a triangle, last corner repeated, where the two meet at one
    decrease). At an increase the corner is the child nearer the other corner's."""
    n = graph.n_stitches
    ids = np.arange(n, dtype=np.int64)
    c = graph.cnext.astype(np.int64)
    ok = c >= 0
    s, c = ids[ok], c[ok]
    wn = graph.wale_next.astype(np.int64)
    b = _nearest_child(wn[c], s)
    a = _nearest_child(wn[s], np.where(b >= 0, b, c))
    ok = (a >= 0) & (b >= 0)
    quads = np.column_stack([s[ok], c[ok], b[ok], a[ok]])
    return quads


def _nearest_child(kids: np.ndarray, near: np.ndarray) -> np.ndarray:
    """Of each row's (up to two) children, the one with the id nearest `near` (-1: none)."""
    k0, k1 = kids[:, 0], kids[:, 1]
    d0 = np.where(k0 >= 0, np.abs(k0 - near), np.iinfo(np.int64).max)
    d1 = np.where(k1 >= 0, np.abs(k1 - near), np.iinfo(np.int64).max)
    return np.where(d1 < d0, k1, k0)


AZIMUTH = np.radians(-35.0)
ELEVATION = np.radians(18.0)


def project(pos: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Screen (x, y) and depth (towards the viewer) of 3-D positions: turned about the
    vertical by AZIMUTH, then tilted by ELEVATION, seen from the front."""
    p = pos - (pos.mean(axis=0) if pos.shape[0] else 0.0)
    x, y, z = p[:, 0], p[:, 1], p[:, 2]
    ca, sa = np.cos(AZIMUTH), np.sin(AZIMUTH)
    xr = ca * x + sa * z
    zr = -sa * x + ca * z
    ce, se = np.cos(ELEVATION), np.sin(ELEVATION)
    ys = ce * y - se * zr
    depth = se * y + ce * zr
    return np.column_stack([xr, ys]), depth


def render(input: ViewInput, fmt: str, *, three_d: bool = False, dpi: float = 100) -> bytes:
    """The shape picture of `input` (see the module docstring) as SVG or PNG bytes."""
    from knitc.view import figure

    fig, _, _ = draw(input, three_d=three_d, fmt=fmt)
    return figure.save(fig, fmt, dpi=dpi)


def draw(
    input: ViewInput, *, three_d: bool = False, fmt: str = "png"
) -> tuple[Any, Any, np.ndarray]:
    """The figure of the shape view, its axes and every stitch's drawn (x, y) there (the
    tests find a stitch's pixel through the axes' data transform)."""
    from matplotlib.collections import PolyCollection
    from matplotlib.patches import Patch

    from knitc.view import figure
    from knitc.view.chart import graph_of

    g, hz, loops = graph_of(input)
    pos = layout(g, three_d, schedule=None if loops else input.schedule, exact_needles=loops)
    q = faces(g)
    palette = np.array([figure.rgb(c) for c in figure.NODE_COLOURS])
    base = palette[g.node[q[:, 0]] % len(palette)] if q.size else np.zeros((0, 3))
    if three_d:
        xy, depth_of = project(pos)
        p3 = pos[q]
        normal = np.cross(p3[:, 1] - p3[:, 0], p3[:, 3] - p3[:, 0])
        norm = np.linalg.norm(normal, axis=1)
        normal = normal / np.maximum(norm, 1e-12)[:, None]
        light = np.array([0.3, 0.6, 0.75])
        light /= np.linalg.norm(light)
        shade = 0.35 + 0.65 * np.abs(normal @ light)
        colour = base * shade[:, None]
        order = np.argsort(depth_of[q].mean(axis=1), kind="stable")
    else:
        xy = pos
        back = g.side[q[:, 0]] == 1
        colour = np.where(back[:, None], base * 0.6, base)
        order = np.argsort(~back, kind="stable")  # the back faces first, under the front
    verts = xy[q[order]]
    if xy.shape[0]:
        lo, hi = xy.min(axis=0), xy.max(axis=0)
    else:  # nothing knitted: an empty picture with its title
        lo, hi = np.zeros(2), np.ones(2)
    span = np.maximum(hi - lo, 1.0)
    aspect = float(span[1] / span[0])
    width = 9.0
    height = float(np.clip(width * aspect, 4.0, 10.0))
    width = float(np.clip(height / aspect, 6.0, 11.0)) + 2.2
    fig = figure.new_figure(width, height)
    ax = fig.add_axes((0.02, 0.02, 1 - 2.4 / width, 0.92))
    many = q.shape[0] > 6000
    coll = PolyCollection(
        cast(Any, verts),
        facecolors=colour[order],
        edgecolors=(0, 0, 0, 0.25) if not many else "face",
        linewidths=0.2 if not many else 0.1,
        rasterized=many and fmt == "svg",
    )
    ax.add_collection(coll)
    if hz.size:
        ax.scatter(
            xy[hz, 0],
            xy[hz, 1],
            marker="o",
            s=60,
            facecolors="none",
            edgecolors=figure.HAZARD_COLOUR,
            linewidths=1.5,
            zorder=5,
        )
    pad = 0.03 * span
    ax.set_xlim(lo[0] - pad[0], hi[0] + pad[0])
    ax.set_ylim(lo[1] - pad[1], hi[1] + pad[1])
    ax.set_aspect("equal")
    ax.set_axis_off()
    handles: list[Any] = [
        Patch(facecolor=figure.NODE_COLOURS[v % len(figure.NODE_COLOURS)], label=name)
        for v, name in enumerate(g.node_names)
        if np.any(g.node == v)
    ]
    if len(handles) > 24:
        handles = handles[:23] + [Patch(facecolor="white", label=f"... {len(handles) - 23} more")]
    if hz.size:
        from matplotlib.lines import Line2D

        handles.append(
            Line2D(
                [],
                [],
                marker="o",
                linestyle="none",
                markerfacecolor="none",
                markeredgecolor=figure.HAZARD_COLOUR,
                label=figure.hazard_label(input.findings),
            )
        )
    fig.legend(
        handles=handles,
        loc="upper right",
        bbox_to_anchor=(0.995, 0.94),
        frameon=False,
        title="yarns" if loops else "nodes",
    )
    name = input.path.rsplit("/", 1)[-1]
    fig.suptitle(
        f"{name}: shape ({'3-D' if three_d else '2-D'} force layout of {g.n_stitches} "
        f"{'loops' if loops else 'stitches'})",
        y=0.99,
    )
    return fig, ax, xy
