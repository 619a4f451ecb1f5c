"""The fixed node-frame layout knitc used before it had a scheduler, kept as the baseline
the schedule is measured against (tests/test_schedule.py).

Needle layout: which physical needle holds each stitch's loop.

Each node keeps the frame the shape pass gave it (logical needles per bed); this pass
places the frames on the bed. A node continuing others is placed where its wale parents
already are (the median offset of its incoming wales, so shaping moves are as short as
possible); a node that starts a yarn of its own is placed to the right of everything
placed so far, so branches waiting for a merge sit side by side. Half-gauge nodes use
every other needle (front even, back odd), which leaves the facing needle free for the
transfers of shaping and reverse stitches.

The result is two arrays over stitches (bed, needle) and a check that no two loops that
are on the bed at the same time were given the same needle.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from knitc.diagnostics import Diagnostics
from knitc.shaping.stitch_graph import StitchGraph

MARGIN = 2
"""Needles left free at the left end of the bed and between independent pieces."""


@dataclass
class Layout:
    bed: np.ndarray  # int8 per stitch: 0 front, 1 back
    needle: np.ndarray  # int32 per stitch: physical needle index
    step: np.ndarray  # int8 per node: 1 full gauge, 2 half gauge
    frame: np.ndarray  # int32 per node: needle of logical needle 0

    @property
    def width(self) -> int:
        return int(self.needle.max()) + 1 if self.needle.size else 0


def _physical(g: StitchGraph, ids: np.ndarray, step: int, frame: int) -> np.ndarray:
    back = (g.side[ids] == 1) & (step == 2)
    return frame + g.needle[ids].astype(np.int64) * step + back.astype(np.int64)


def layout(g: StitchGraph, needles: int, diags: Diagnostics) -> Layout | None:
    n_nodes = len(g.node_names)
    step = np.ones(n_nodes, np.int8)
    for c in range(g.n_courses):
        if g.course_gauge[c] == 2:
            step[g.course_node[c]] = 2
    frame = np.zeros(n_nodes, np.int64)
    placed = np.zeros(n_nodes, bool)
    needle = np.full(g.n_stitches, -1, np.int64)
    right_edge = MARGIN
    # nodes in order of their first course
    first_course: dict[int, int] = {}
    for c in range(g.n_courses):
        first_course.setdefault(int(g.course_node[c]), c)
    root_slot = _root_slots(g, step, first_course)
    for node in sorted(first_course, key=first_course.__getitem__):
        ids = np.nonzero(g.node == node)[0]
        s = int(step[node])
        parents = g.wale_prev[ids]
        has = parents >= 0
        src = parents[has]
        child = np.repeat(ids[:, None], 2, axis=1)[has]
        known = needle[src] >= 0 if src.size else np.zeros(0, bool)
        if np.any(known):
            rel = needle[src[known]] - _physical(g, child[known], s, 0)
            f = int(np.median(rel))
        else:
            lo = int(_physical(g, ids, s, 0).min()) if ids.size else 0
            f = root_slot.get(node, right_edge) - lo
        # keep the gauge parity: half-gauge fronts on even needles
        if s == 2 and f % 2:
            f += 1
        frame[node] = f
        placed[node] = True
        needle[ids] = _physical(g, ids, s, f)
        right_edge = max(
            right_edge, int(needle[ids].max()) + 1 + MARGIN, max(root_slot.values(), default=0)
        )
    lo = int(needle.min()) if needle.size else 0
    if lo < MARGIN:
        shift = MARGIN - lo
        shift += shift % 2  # keep half-gauge parity
        needle += shift
        frame += shift
    out = Layout(g.side.astype(np.int8), needle.astype(np.int32), step, frame.astype(np.int32))
    if out.width > needles:
        diags.error(
            "E601",
            f"the garment needs {out.width} needles but the machine has {needles}",
            None,
            hint="narrow the design or use a wider machine",
        )
        return None
    return out


def _root_slots(g: StitchGraph, step: np.ndarray, first_course: dict[int, int]) -> dict[int, int]:
    """Left needles for the pieces that start a yarn of their own, side by side in the order
    in which they will meet: pieces feeding one merge are placed in the order of the
    branches they enter, so their loops never cross on the way into it."""
    n_nodes = len(g.node_names)
    src, slot = np.nonzero(g.wale_next >= 0)
    dst = g.wale_next[src, slot]
    cross = g.node[src] != g.node[dst]
    edges = set(zip(g.node[src][cross].tolist(), g.node[dst][cross].tolist(), strict=True))
    producers: dict[int, set[int]] = {n: set() for n in range(n_nodes)}
    consumers: dict[int, set[int]] = {n: set() for n in range(n_nodes)}
    for a, b in edges:
        consumers[a].add(b)
        producers[b].add(a)
    roots = [n for n in sorted(first_course, key=first_course.__getitem__) if not producers[n]]
    keys: dict[int, tuple[float, float]] = {}
    extent: dict[int, int] = {}
    for r in roots:
        chain, frontier, merge = [r], [r], None
        while frontier and merge is None:
            nxt = []
            for n in frontier:
                for c in consumers[n]:
                    if len(producers[c]) > 1:
                        merge = (c, n)
                        break
                    chain.append(c)
                    nxt.append(c)
                if merge:
                    break
            frontier = nxt
        width = 0
        for n in chain:
            ids = np.nonzero(g.node == n)[0]
            if ids.size:
                width = max(
                    width, int((g.needle[ids].max() - g.needle[ids].min() + 1) * step[n] + 1)
                )
        extent[r] = width
        if merge is None:
            keys[r] = (first_course[r], 0.0)
        else:
            c, n = merge
            land = dst[cross][(g.node[src][cross] == n) & (g.node[dst][cross] == c)]
            keys[r] = (first_course[c], float(np.mean(g.needle[land])))
    slots: dict[int, int] = {}
    edge = MARGIN
    for r in sorted(roots, key=lambda n: (keys[n], first_course[n])):
        slots[r] = edge
        edge += extent[r] + MARGIN
    return slots
