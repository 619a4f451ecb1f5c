"""Stripes on flat fabric: each course starts where its yarn's carrier rests.

The shape pass lays the courses of a sheet out back and forth, one yarn's way: each course
starts at the end where the one before it stopped. With stripes (`knit red where
courses(...)`), a yarn that rests while another knits is parked at the side where its last
course ended, and it picks up from there: a stripe of an odd number of courses leaves the
next yarn on the other side. A knitter then simply knits the next course the other way,
and so does this pass: it reverses every flat course that would otherwise start at the end
away from its yarn's carrier (thesis ch. 6.6: a course's direction belongs to its yarn).

Reversing a course renumbers its stitches (a course is a contiguous id range in knitting
order, `stitch_graph`), so the pass permutes every per-stitch array and maps every stitch
reference; the fabric is the same, only the knitting order within those courses changes.
Tubes need nothing: a round always starts at the same fold.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from knitc.shaping.stitch_graph import COURSE_KINDS, StitchGraph

_FLAT_KINDS = (COURSE_KINDS.index("regular"), COURSE_KINDS.index("interface"))
"""Courses the pass may reverse: a short row or a continuity course turns where its
shaping says, whatever the yarn."""


def orient_stripes(g: StitchGraph) -> StitchGraph:
    """`g` with each flat course of a striped design starting at its yarn's carrier (the
    same graph when there are no stripes or nothing to reverse)."""
    if not g.colourwork:
        return g
    assert g.yarn is not None
    order = np.arange(g.n_stitches, dtype=np.int64)  # new id -> old id
    flipped = np.zeros(g.n_courses, bool)
    rest: dict[int, tuple[int, int, int]] = {}  # yarn -> (node, side, needle) of its carrier
    carrying = g.course_yarn()
    for c in range(g.n_courses):
        s, n = int(g.course_start[c]), int(g.course_len[c])
        if n == 0:
            continue
        y, node = int(carrying[c]), int(g.course_node[c])
        at = rest.get(y)
        if (
            at is not None
            and at[0] == node
            and n > 1
            and not g.course_circular[c]
            and g.course_kind[c] in _FLAT_KINDS
            and _gap(g, at, s + n - 1) < _gap(g, at, s)
        ):
            order[s : s + n] = order[s : s + n][::-1].copy()
            flipped[c] = True
        last = int(order[s + n - 1])
        # (fair isle: every yarn of the course ends where it ends; an intarsia course's
        # regions have carriers of their own, and its yarns rest where they were)
        ys = {y} if y == len(g.yarn_names) else set(g.yarn[s : s + n].tolist())
        for k in ys:
            rest[k] = (node, int(g.side[last]), int(g.needle[last]))
    if not flipped.any():
        return g
    return _renumber(g, order, flipped)


def _gap(g: StitchGraph, at: tuple[int, int, int], s: int) -> int:
    """How far stitch s is from a carrier resting at `at` (needles; another bed is far)."""
    return abs(int(g.needle[s]) - at[2]) + (0 if int(g.side[s]) == at[1] else 1 << 20)


def _renumber(g: StitchGraph, order: np.ndarray, flipped: np.ndarray) -> StitchGraph:
    """The graph with stitch `order[i]` renamed i; the courses in `flipped` run the other
    way, so their course links swap (next becomes previous)."""
    new_of = np.empty_like(order)
    new_of[order] = np.arange(order.shape[0])

    def ids(a: np.ndarray) -> np.ndarray:
        """Stitch references through the renaming (-1 stays -1)."""
        return np.where(a >= 0, new_of[np.maximum(a, 0)], -1).astype(a.dtype)

    turned = flipped[g.course]  # per old stitch
    cprev = np.where(turned, g.cnext, g.cprev)
    cnext = np.where(turned, g.cprev, g.cnext)
    assert g.origin is not None and g.yarn is not None
    return dataclasses.replace(
        g,
        node=g.node[order],
        course=g.course[order],
        side=g.side[order],
        needle=g.needle[order],
        cprev=ids(cprev)[order],
        cnext=ids(cnext)[order],
        wale_prev=ids(g.wale_prev)[order],
        wale_next=ids(g.wale_next)[order],
        instr=g.instr[order],
        action=g.action[order],
        span=g.span[order],
        origin=g.origin[order],
        yarn=g.yarn[order],
        yarn_origin=None if g.yarn_origin is None else g.yarn_origin[order],
        backing=None if g.backing is None else g.backing[order],
        backing_origin=None if g.backing_origin is None else g.backing_origin[order],
        inlay=None if g.inlay is None else g.inlay[order],
        inlay_origin=None if g.inlay_origin is None else g.inlay_origin[order],
    )
