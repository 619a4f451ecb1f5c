"""Slicing: traced yarn → bed slices (thesis ch. 6.7.1).

The trace is walked in order; each visit either extends the last slice (its stitch is
EXPECTED there and nothing forces a cut), *updates* it (the stitch is a decrease whose two
parents are SUSPENDED there: they are replaced by it), or starts a new slice, *derived*
from the last slice of the visit's node (`scheduling.slices.derive`) when the stitch is in that
derived cycle, else *fresh*. A new slice is cut when one of the thesis's constraints would
break: (1) one yarn, (2) no two wale-connected stitches (a visited stitch that is not
EXPECTED in the cycle), (3) one cast-on and one cast-off need, (4) one carriage direction,
(5) at most `limit` increases + decreases among the active stitches; and also at a change
of node or gauge, so every slice is one region in one gauge.

Fresh cycles (`scheduling.slices.fresh_cycle`): the thesis builds them from "all the knit-once stitches of the row"; here a
regular or interface course is a full row, so the fresh cycle is that whole course in cycle
order (flat: left to right; rings: front left to right, then back right to left), all
EXPECTED. A short row or a continuity course is not a row of the bed: a fresh slice opened
on one of its stitches (the first visit of a joint, or of a merge, whose first own course
is such a course) starts from the course holding the visited stitch's previous wale
instead. Either way the course is taken as the yarn finds it, which is `derive` of it with
every stitch ACTIVE: unfinished stitches stay EXPECTED and finished ones give way to their
next wales (SUSPENDED, if decreasing). So a joint's first slice is the short row plus the
continuity and top stitches of the other columns, a merge's first slice is the frontier of
the branch the yarn starts on, and the base ring of a merge, when the yarn reaches a branch
that frontier does not hold, opens fresh with its already knitted stitches replaced by the
next course's.

Derivation uses the node's last slice whichever yarn knits the stitch, since that slice is
the node's bed; a stitch not found there (a split's second branch, whose course that slice
does not hold, or a jump to a course the cycle does not hold) opens a fresh slice. The
first visit of a slice is always taken, even if its stitch alone shapes more than the
limit (it cannot be cut further; the verifier allows exactly that).

Linear time: the per-visit properties are numpy arrays, consecutive visits with the same
(node, yarn, direction, gauge, cast needs) form segments, and a segment extends the open
slice in vectorised windows that grow while they succeed; each new slice costs one pass
over its cycle. A merge marks its second parent's entry REMOVED (a scratch state) so it
costs O(1); entries are compacted when the slice closes.
"""

from __future__ import annotations

import numpy as np

from knitc.scheduling import slices as sl
from knitc.scheduling.slices import ACTIVE, EXPECTED, SUSPENDED
from knitc.scheduling.trace import Trace
from knitc.shaping.stitch_graph import StitchGraph

REMOVED = 3
"""Scratch state of an entry merged away while its slice is open; never in the output."""

_WINDOW = 32


def slice_trace(g: StitchGraph, t: Trace, *, flat_limit: int = 2, tube_limit: int = 4) -> sl.Slices:
    """Cut trace `t` over graph `g` into bed slices (see the module docstring). The shaping
    limit of a slice is `tube_limit` when its cycle lies on both beds as it opens, else
    `flat_limit`."""
    return _Slicer(g, t, flat_limit, tube_limit).run()


class _Slicer:
    """The walk's state: the open slice (its cycle arrays and a stitch → entry map), the
    closed slices, and each node's last slice."""

    def __init__(self, g: StitchGraph, t: Trace, flat_limit: int, tube_limit: int) -> None:
        self.g, self.t = g, t
        self.limits = (int(flat_limit), int(tube_limit))
        n = g.n_stitches
        self.ccw = sl.ccw_courses(g)
        self.kids = sl.ccw_kids(g, self.ccw)
        self.fold = sl.folds(g, self.kids)
        self.dec = sl.waiting(g)
        self.merging = sl.decreasing(g)  # a fresh cycle is of one gauge (`sl.waiting`)
        vs = t.stitch
        self.vs = vs
        n_prev = (g.wale_prev >= 0).sum(1)
        n_next = (g.wale_next >= 0).sum(1)
        self.merge_v = n_prev[vs] == 2
        self.shp_v = sl.stitch_shaping(g)[vs].astype(np.int64)
        self.node_v = g.node[vs]
        self.gauge_v = g.course_gauge[g.course[vs]]
        self.con_v = n_prev[vs] == 0
        self.coff_v = n_next[vs] == 0
        # segments: runs of visits that may share a slice as far as the per-visit keys go
        same = np.ones(t.n_visits, bool)
        same[:1] = False
        for arr in (self.node_v, t.yarn, t.dir, self.gauge_v, self.con_v, self.coff_v):
            same[1:] &= arr[1:] == arr[:-1]
        self.same_as_prev = same
        starts = np.flatnonzero(~same)
        ends = np.r_[starts[1:], t.n_visits][: starts.size]
        self.seg_end = np.repeat(ends, ends - starts)
        self.done = np.zeros(n, np.int32)
        self.pos = np.full(n, -1, np.int64)
        # the open slice
        self.cur_st = np.zeros(0, np.int32)
        self.cur_state = np.zeros(0, np.uint8)
        self.open = False
        self.shaping = 0
        self.limit = 0
        self.meta: tuple[int, int] = (0, -1)
        # closed slices
        self.rows: list[tuple] = []
        self.cycles: list[tuple[np.ndarray, np.ndarray]] = []
        self.last_of_node: dict[int, int] = {}

    # -- the walk ----------------------------------------------------------------------------

    def run(self) -> sl.Slices:
        i, n_visits = 0, self.t.n_visits
        while i < n_visits:
            if self.open and self.same_as_prev[i]:
                j = self._extend(i, int(self.seg_end[i]))
                if j > i:
                    i = j
                    continue
                if self.shaping + self.shp_v[i] <= self.limit and self._merge(i):
                    i += 1
                    continue
            self._new_slice(i)
            i += 1
        self._close()
        return self._build()

    def _extend(self, i: int, end: int) -> int:
        """Activate visits i.. while their stitches are EXPECTED in the open cycle and the
        shaping stays within the limit; returns the first visit not taken."""
        j, w = i, _WINDOW
        while j < end:
            b = min(end, j + w)
            blk = self.vs[j:b]
            p = self.pos[blk]
            ok = p >= 0
            ok[ok] = self.cur_state[p[ok]] == EXPECTED
            cs = self.shaping + np.cumsum(self.shp_v[j:b])
            ok &= cs <= self.limit
            if self.t.passes > 1:  # a stitch visited twice in a window: only the first
                first = np.zeros(b - j, bool)
                first[np.unique(blk, return_index=True)[1]] = True
                ok &= first
            f = b - j if ok.all() else int(np.argmin(ok))
            if f:
                self.cur_state[p[:f]] = ACTIVE
                self.done[blk[:f]] += 1
                self.shaping = int(cs[f - 1])
            if f < b - j:
                return j + f
            j = b
            w *= 2
        return j

    def _activate(self, i: int) -> bool:
        s = int(self.vs[i])
        p = int(self.pos[s])
        if p < 0 or self.cur_state[p] != EXPECTED:
            return False
        self.cur_state[p] = ACTIVE
        self.done[s] += 1
        self.shaping += int(self.shp_v[i])
        return True

    def _merge(self, i: int) -> bool:
        """Update the open slice: a decrease whose two parents are SUSPENDED in it takes the
        first parent's entry and becomes ACTIVE; the second entry is removed."""
        if not self.merge_v[i]:
            return False
        s = int(self.vs[i])
        a, b = (int(x) for x in self.g.wale_prev[s])
        pa, pb = int(self.pos[a]), int(self.pos[b])
        if pa < 0 or pb < 0 or self.cur_state[pa] != SUSPENDED or self.cur_state[pb] != SUSPENDED:
            return False
        lo, hi = min(pa, pb), max(pa, pb)
        self.cur_st[lo], self.cur_state[lo], self.cur_state[hi] = s, ACTIVE, REMOVED
        self.pos[a] = self.pos[b] = -1
        self.pos[s] = lo
        self.done[s] += 1
        self.shaping += int(self.shp_v[i])
        return True

    def _new_slice(self, i: int) -> None:
        self._close()
        node = int(self.node_v[i])
        src = self.last_of_node.get(node, -1)
        holding = sl.holding_course(self.g, self.t, i)
        if src >= 0:
            st, state = self.cycles[src]
            dst, dstate = sl.derive(
                self.kids,
                self.dec,
                st,
                state,
                self.done,
                self.t.passes,
                self.fold,
                self.g.course,
                holding,
            )
            self._open(i, dst, dstate, src)
            if self._activate(i) or self._merge(i):
                return
            self._discard()
        self._open(
            i,
            *sl.fresh_cycle(
                self.g,
                self.ccw,
                self.kids,
                self.merging,
                int(self.vs[i]),
                self.done,
                self.t.passes,
                self.fold,
                holding,
            ),
            -1,
        )
        if not (self._activate(i) or self._merge(i)):
            raise AssertionError(f"slicing: visit {i} is not in its own fresh cycle")

    # -- opening and closing slices ----------------------------------------------------------

    def _open(self, i: int, st: np.ndarray, state: np.ndarray, src: int) -> None:
        self.cur_st = st.astype(np.int32, copy=True)
        self.cur_state = state.astype(np.uint8, copy=True)
        self.pos[self.cur_st] = np.arange(st.shape[0])
        self.limit = self.limits[int(self._both_beds(self.cur_st))]
        self.shaping = 0
        self.open = True
        self.meta = (i, src)

    def _both_beds(self, st: np.ndarray) -> bool:
        side = self.g.side[st]
        return bool((side == 0).any() and (side == 1).any())

    def _discard(self) -> None:
        self.pos[self.cur_st] = -1
        self.open = False

    def _close(self) -> None:
        if not self.open:
            return
        self.pos[self.cur_st] = -1
        keep = self.cur_state != REMOVED
        k = len(self.rows)
        i, src = self.meta
        st = self.cur_st[keep]
        self.cycles.append((st, self.cur_state[keep]))
        self.rows.append((i, src, self._both_beds(st), self.shaping, self.limit))
        self.last_of_node[int(self.node_v[i])] = k
        self.open = False

    def _build(self) -> sl.Slices:
        k = len(self.rows)
        first = np.array([r[0] for r in self.rows], np.int64)
        visits = np.diff(np.r_[first, self.t.n_visits]).astype(np.int32)
        lengths = np.array([c[0].shape[0] for c in self.cycles], np.int32)
        start = np.zeros(k, np.int64)
        if k:
            start[1:] = np.cumsum(lengths, dtype=np.int64)[:-1]
        src = np.array([r[1] for r in self.rows], np.int64)

        def cat(j: int, dt: type) -> np.ndarray:
            return np.concatenate([c[j] for c in self.cycles]).astype(dt) if k else np.zeros(0, dt)

        return sl.Slices(
            node=self.node_v[first].astype(np.int32),
            yarn=self.t.yarn[first].astype(np.int16),
            dir=self.t.dir[first].astype(np.int8),
            fresh=src < 0,
            circular=np.array([r[2] for r in self.rows], bool),
            visit=first,
            visits=visits,
            start=start,
            length=lengths,
            shaping=np.array([r[3] for r in self.rows], np.int32),
            limit=np.array([r[4] for r in self.rows], np.int32),
            cast_on=self.con_v[first].astype(bool),
            cast_off=self.coff_v[first].astype(bool),
            gauge=self.gauge_v[first].astype(np.int8),
            derived_from=src,
            stitch=cat(0, np.int32),
            state=cat(1, np.uint8),
        )
