"""The regions of an intarsia band (thesis ch. 6.9.6): where each carrier knits.

In an intarsia course (`intarsia where Q`) no yarn floats behind another's stitches: the
course falls into *runs*, maximal stretches of stitches of one yarn, and each run is
knitted by a carrier of its own. A run continues the run of the same yarn below it (a wale
joins them), so runs connected that way through the band are one *region*, knitted by one
carrier from the region's first course to its last: the thesis' local yarn (rule R7,
`scheduling.tracing._Locals`: a strand of the trace per region), brought in where the
region starts and taken out where it ends. Two regions of the same
yarn side by side (the background left and right of a motif) are two carriers.

A region whose runs fork around another region (a U of one yarn) knits both arms with its
one carrier, which floats behind the inner region between them. On a tube a round's runs
go around: the run that ends the round and the one that starts it, of one yarn, are one.
"""

from __future__ import annotations

import numpy as np

from knitc import arrays
from knitc.shaping.stitch_graph import StitchGraph


def regions(g: StitchGraph) -> np.ndarray:
    """int32 per stitch: its intarsia region (0, 1, ... in order of first stitch), -1 for
    stitches of courses that are not intarsia (`StitchGraph.intarsia_courses`). A course is a contiguous id range in
    knitting order, so a run is a range of ids of one yarn within one course."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    n = g.n_stitches
    out = np.full(n, -1, np.int32)
    if g.backing is None or g.yarn is None or n == 0:
        return out
    on = g.intarsia_courses()[g.course]
    ids = np.nonzero(on)[0]
    if ids.size == 0:
        return out
    starts = np.ones(ids.size, bool)  # a run starts at a new course, a new yarn or a gap
    starts[1:] = (
        (g.course[ids[1:]] != g.course[ids[:-1]])
        | (g.yarn[ids[1:]] != g.yarn[ids[:-1]])
        | (ids[1:] != ids[:-1] + 1)
    )
    run = np.full(n, -1, np.int64)
    run[ids] = np.cumsum(starts) - 1
    n_runs = int(run[ids[-1]]) + 1
    # a wale between two stitches of intarsia courses, of one yarn, joins their runs
    src, slot = np.nonzero(g.wale_prev[ids] >= 0)
    child = ids[src]
    parent = g.wale_prev[child, slot]
    keep = on[parent] & (g.yarn[parent] == g.yarn[child])
    a, b = run[parent[keep]], run[child[keep]]
    # a round's first and last runs of one yarn are one run across the wrap
    circ = arrays.unique(g.course[ids][g.course_circular[g.course[ids]]])
    head = g.course_start[circ]
    tail = head + g.course_len[circ] - 1
    wrap = g.yarn[head] == g.yarn[tail]
    a = np.r_[a, run[head[wrap]]]
    b = np.r_[b, run[tail[wrap]]]
    graph = coo_matrix((np.ones(a.size, np.int8), (a, b)), shape=(n_runs, n_runs))
    _, label = connected_components(graph, directed=False)
    # number the regions in order of their first stitch (a stable, readable order)
    first = np.full(int(label.max()) + 1, n, np.int64)
    np.minimum.at(first, label[run[ids]], ids)
    rank = np.empty_like(first)
    rank[np.argsort(first, kind="stable")] = np.arange(first.size)
    out[ids] = rank[label[run[ids]]]
    return out
