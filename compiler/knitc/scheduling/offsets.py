"""Schedule optimisation, the offset stage (ch. 6.7.3; see `scheduling.scheduler`).

**Offsets.** Each slice's layout is a block; a loop waiting on the bed outside the cycle
being knitted (`scheduling.schedule.held_loops`) belongs to a held block (the loops with the same
last and next slice), which keeps one position while it waits (so it moves at most once,
by an alignment right after it starts waiting). Related needles of successive rows (the
same loop, or wale-connected loops) pull the blocks together:

- a first estimate propagates the most common displacement of every relation along a
  maximum spanning tree of the relations, so branches that meet later already sit where
  their interface wants them; pieces on the bed at the same time are packed left to right
  (the thesis's left-to-right packing), the others share the left end;
- blocks are then placed in time order at the best free place, and forward/backward
  sweeps move each block to its best free place until a sweep improves nothing or
  `max_sweeps` is reached. "Best" is lexicographic: fewest related loops that move, then
  least L2 offset error between related needles (the thesis's L2 alone would spread one
  needle of misalignment over many rows, each a transfer pass).

Blocks present at the same time never overlap on a bed they share, and keep their
left-to-right order (a loop cannot travel through other loops) unless no place keeps it.
An active block whose layout changes (anything but a pure translation of its predecessor)
keeps `gap` free needles on both beds around itself and the room it grows into, from every
held block except those of its own split or merge (the interface puts those side by side)
and those it takes in. Half-gauge slices are expanded (front 2r, back 2r + 1, even
offsets). A schedule wider than the machine is error E601, which reports the width needed.
"""

from __future__ import annotations

import numpy as np

from knitc.scheduling import schedule as ir
from knitc.scheduling.layouts import Layouts
from knitc.scheduling.relations import Relations
from knitc.scheduling.schedule import BACK

MARGIN = 2
"""Needles left free at the left end of the bed (as the fixed layout does)."""


# ---- the offset stage ---------------------------------------------------------------------------

_EMPTY = (1 << 40, -(1 << 40))


class Offsets:
    """Offsets of the slice blocks (variables 0..ns-1) and of the held blocks (ns..): see
    the module docstring."""

    def __init__(
        self, ctx: Relations, lay: Layouts, needles: int, max_sweeps: int, gap: int
    ) -> None:
        self.ctx, self.lay = ctx, lay
        self.needles, self.max_sweeps, self.gap = int(needles), int(max_sweeps), int(gap)
        na = ctx.sl.node[ctx.soe[ctx.pa]]
        nb = ctx.sl.node[ctx.soe[ctx.pb]]
        cross = na != nb
        self.links = set(zip(na[cross].tolist(), nb[cross].tolist(), strict=True))
        self.failed_slice: int | None = None
        ns = ctx.ns
        step = ctx.step[ctx.soe]
        self.relp = lay.rel * step + (lay.bed == BACK) * (step == 2)
        self.loops = ir.held_loops(ctx.g, ctx.sl)
        lp = self.loops
        gk = lp.src * max(ns, 1) + lp.cons
        self.g_key, g_inv = np.unique(gk, return_inverse=True)
        self.g_of_hold = g_inv
        n_g = self.g_key.shape[0]
        self.nv = ns + n_g
        self.src = np.concatenate([np.arange(ns), self.g_key // max(ns, 1)]).astype(np.int64)
        self.cons = np.concatenate([np.full(ns, -1), self.g_key % max(ns, 1)]).astype(np.int64)
        self.even = ctx.step[self.src] == 2
        self._geometry(n_g)
        self._edges(n_g)
        self.alive: list[list[int]] = [[] for _ in range(ns)]
        for gi in range(n_g):
            for r in range(int(self.src[ns + gi]) + 1, int(self.cons[ns + gi])):
                self.alive[r].append(ns + gi)
        self.x = np.zeros(self.nv, np.int64)
        self.placed = np.zeros(self.nv, bool)
        # (`run`'s lists of the same, and of the arrays its placement reads)
        self._xl: list[int] = []
        self._pl: list[bool] = []
        self._src: list[int] = []
        self._cons: list[int] = []
        self._lo: list[list[int]] = []
        self._hi: list[list[int]] = []
        self._any_lo: list[int] = []
        self._any_hi: list[int] = []
        self._centre: list[float] = []
        self._even: list[bool] = []

    # -- blocks

    def _geometry(self, n_g: int) -> None:
        ctx, lay = self.ctx, self.lay
        nv, ns = self.nv, ctx.ns
        self.lo = np.full((nv, 2), _EMPTY[0], np.int64)
        self.hi = np.full((nv, 2), _EMPTY[1], np.int64)
        var_e = ctx.soe
        var_h = ns + self.g_of_hold
        bed_h = lay.bed[self.loops.src_entry]
        rel_h = self.relp[self.loops.src_entry]
        for var, bed, rel in ((var_e, lay.bed, self.relp), (var_h, bed_h, rel_h)):
            for b in (0, 1):
                m = bed == b
                np.minimum.at(self.lo[:, b], var[m], rel[m])
                np.maximum.at(self.hi[:, b], var[m], rel[m])
        self.any_lo = self.lo.min(1)
        self.any_hi = self.hi.max(1)
        self.zone: dict[int, tuple[int, int]] = {}

    def _edges(self, n_g: int) -> None:
        """Aggregate the related pairs into edges between offset variables: a slice and the
        next row's slice (or any later one with no hold between), a slice and the held
        block its loops wait in, and the held block and the slice that takes them back."""
        ctx, lp, ns = self.ctx, self.loops, self.ctx.ns
        held = set(self.g_key.tolist())
        direct = [
            (b == a + 1 or a * max(ns, 1) + b not in held)
            for a, b in zip(ctx.e_a.tolist(), ctx.e_b.tolist(), strict=True)
        ]
        d_all = self.relp[ctx.pa] - self.relp[ctx.pb]
        c_all = self.lay.bed[ctx.pa] != self.lay.bed[ctx.pb]
        groups = [
            (int(ctx.e_a[e]), int(ctx.e_b[e]), int(ctx.e_first[e]), int(ctx.e_count[e]))
            for e in np.flatnonzero(direct).tolist()
        ]
        # holds: the loops of one held block, sorted together
        o = np.argsort(self.g_of_hold, kind="stable")
        hg = self.g_of_hold[o]
        hd = (self.relp[lp.src_entry] - self.relp[lp.cons_entry])[o]
        hc = (self.lay.bed[lp.src_entry] != self.lay.bed[lp.cons_entry])[o]
        starts = np.flatnonzero(np.r_[True, hg[1:] != hg[:-1]]) if hg.size else hg
        ends = np.r_[starts[1:], hg.shape[0]] if hg.size else hg
        eu, ev, ew, em, eh, ech = [], [], [], [], [], []

        def add(u: int, v: int, d: np.ndarray, chg: bool) -> None:
            lo, hi = int(d.min()), int(d.max())
            if lo == hi:
                h = {lo: int(d.shape[0])}
            else:
                vals, cnt = np.unique(d, return_counts=True)
                h = dict(zip(vals.tolist(), cnt.tolist(), strict=True))
            eu.append(u)
            ev.append(v)
            ew.append(float(d.shape[0]))
            em.append(float(d.mean()))
            eh.append(h)
            ech.append(chg or lo != hi)

        for a, b, f, c in groups:
            add(a, b, d_all[f : f + c], bool(c_all[f : f + c].any()))
        for i0, i1 in zip(starts.tolist(), ends.tolist(), strict=True):
            gv = ns + int(hg[i0])
            add(int(self.src[gv]), gv, np.zeros(i1 - i0, np.int64), False)
            add(gv, int(self.cons[gv]), hd[i0:i1], bool(hc[i0:i1].any()))
        self.eu = np.array(eu, np.int64)
        self.ev = np.array(ev, np.int64)
        self.ew = np.array(ew, np.float64)
        self.emode = np.array([max(h, key=lambda x: (h[x], -abs(x))) for h in eh], np.int64)
        changes = np.array(ech, bool)
        adj: list[list[tuple[int, float, float, dict[int, int]]]] = [[] for _ in range(self.nv)]
        for u, v, w, m, h in zip(eu, ev, ew, em, eh, strict=True):
            adj[v].append((u, w, m, h))
            adj[u].append((v, w, -m, {-x: c for x, c in h.items()}))
        self.adj = adj
        # the room an active block needs to change into its layout (ch. 6.7.3): its own
        # extent and its predecessors' at their related place, one needle more each side
        for i in np.flatnonzero(changes).tolist():
            a, k = int(self.eu[i]), int(self.ev[i])
            if k >= ns or (a >= ns and self.cons[a] != k):
                continue
            m = int(self.emode[i])  # X_k = X_a + m: a's extent sits at -m relative to k
            zl, zh = self.zone.get(
                k, (int(self.any_lo[k]) - self.gap, int(self.any_hi[k]) + self.gap)
            )
            self.zone[k] = (
                min(zl, int(self.any_lo[a]) - m - self.gap),
                max(zh, int(self.any_hi[a]) - m + self.gap),
            )

    # -- placement

    def _forbidden(self, v: int, ordered: bool) -> list[tuple[int, int]]:
        """Values of v's offset at which its block would meet a placed block present at the
        same time on a bed they share (or enter the room of a changing active block, or
        let one enter its). `ordered`: also every value that would take it past such a
        block, so blocks keep the left-to-right order of the first estimate (loops cannot
        travel through other loops)."""
        ns = self.ctx.ns
        src, cons, centre, placed, xs = self._src, self._cons, self._centre, self._pl, self._xl
        lo_, hi_, any_lo, any_hi = self._lo, self._hi, self._any_lo, self._any_hi
        rows = [v] if v < ns else range(src[v] + 1, cons[v])
        out: list[tuple[int, int]] = []
        inf = 1 << 40

        def add(lo: int, hi: int, w: int) -> None:
            if ordered:
                if centre[w] >= centre[v]:
                    hi = inf
                else:
                    lo = -inf
            out.append((lo, hi))

        for r in rows:
            others = ([r] if v >= ns else []) + self.alive[r]
            for w in others:
                if w == v or not placed[w]:
                    continue
                xw = xs[w]
                lv, hv, lw, hw = lo_[v], hi_[v], lo_[w], hi_[w]
                for b in (0, 1):
                    if lv[b] <= hv[b] and lw[b] <= hw[b]:
                        add(xw + lw[b] - hv[b], xw + hw[b] - lv[b], w)
                if v < ns and v in self.zone and w >= ns and not self._related(v, w):
                    zl, zh = self.zone[v]
                    add(xw + any_lo[w] - zh, xw + any_hi[w] - zl, w)
                if w < ns and w in self.zone and v >= ns and not self._related(w, v):
                    zl, zh = self.zone[w]
                    add(xw + zl - any_hi[v], xw + zh - any_lo[v], w)
        return out

    def _related(self, k: int, g: int) -> bool:
        """Whether held block g may touch the changing active block k: its loops go into k,
        or it comes from or goes to k's node, its parent node or its child node (the pieces
        of one split or merge, which the interface layout puts side by side)."""
        node = self.ctx.sl.node
        n, a, b = int(node[k]), int(node[self._src[g]]), int(node[self._cons[g]])
        return self._cons[g] == k or n in (a, b) or (n, b) in self.links or (a, n) in self.links

    def _free(self, v: int, ordered: bool) -> list[tuple[int, int]]:
        """The free places of v's offset, as closed intervals (see `_forbidden`)."""
        lo = MARGIN - self._any_lo[v]
        hi = self.needles - 1 - self._any_hi[v]
        segs = []
        cur = lo
        for a, b in sorted(self._forbidden(v, ordered)):
            if cur > hi:
                break
            if b < cur:
                continue
            if a > cur:
                segs.append((cur, min(a - 1, hi)))
            cur = max(cur, b + 1)
        if cur <= hi:
            segs.append((cur, hi))
        return segs

    def _nearest(self, v: int, segs: list[tuple[int, int]], target: float) -> int | None:
        best = None
        for s0, s1 in segs:
            t = int(min(max(round(target), s0), s1))
            for c in (t - 1, t + 1) if self._even[v] and t % 2 else (t,):
                if s0 <= c <= s1 and (
                    best is None or (abs(c - target), c) < (abs(best - target), best)
                ):
                    best = c
        return best

    def _score(self, v: int, t: int, placed_only: bool) -> tuple[float, float]:
        """(related loops that move, L2 offset error) of v at offset t."""
        moved = err = 0.0
        placed, xs = self._pl, self._xl
        for o, w, m, h in self.adj[v]:
            if placed_only and not placed[o]:
                continue
            rel = t - xs[o]
            moved += w - h.get(rel, 0)
            err += w * (rel - m) ** 2
        return moved, err

    def _best(self, v: int, placed_only: bool, seed: float) -> int | None:
        """v's best free offset: fewest moved loops, then least L2 error; candidates are the
        L2 optimum and the offsets that keep each neighbour's most common displacement.
        Places that keep the blocks' order come first; only if there are none can a block
        go anywhere free."""
        for ordered in (True, False):
            got = self._best_in(v, self._free(v, ordered), placed_only, seed)
            if got is not None:
                return got
        return None

    def _best_in(
        self, v: int, segs: list[tuple[int, int]], placed_only: bool, seed: float
    ) -> int | None:
        if not segs:
            return None
        sw = sx = 0.0
        targets: list[float] = []
        placed, xs = self._pl, self._xl
        for o, w, m, h in self.adj[v]:
            if placed_only and not placed[o]:
                continue
            sw += w
            sx += w * (xs[o] + m)
            for val in sorted(h, key=lambda x: -h[x])[:3]:
                targets.append(float(xs[o] + val))
        targets.append(sx / sw if sw else seed)
        best = None
        for tg in targets:
            c = self._nearest(v, segs, tg)
            if c is None:
                continue
            key = (*self._score(v, c, placed_only), abs(c - seed))
            if best is None or key < best[0]:
                best = (key, c)
        return None if best is None else best[1]

    def _seed(self) -> np.ndarray:
        """First estimate (the thesis's left-to-right packing, made aware of interfaces):
        within each connected piece, the most common displacement of every relation is
        propagated along a maximum spanning tree, so branches that meet later already sit
        where their merge wants them; pieces on the bed at the same time are then packed
        left to right with `gap` free needles between them, the others share the left end."""
        nv, ns = self.nv, self.ctx.ns
        parent = list(range(nv))

        def find(x: int) -> int:
            while parent[x] != x:
                parent[x] = parent[parent[x]]
                x = parent[x]
            return x

        tree: list[list[tuple[int, float]]] = [[] for _ in range(nv)]
        for i in np.argsort(-self.ew, kind="stable").tolist():
            a, b = int(self.eu[i]), int(self.ev[i])
            ra, rb = find(a), find(b)
            if ra == rb:
                continue
            parent[ra] = rb
            tree[a].append((b, float(self.emode[i])))
            tree[b].append((a, -float(self.emode[i])))
        x = np.zeros(nv, np.float64)
        seen = np.zeros(nv, bool)
        last_row = np.where(np.arange(nv) < ns, self.src, self.cons - 1)
        packed: list[tuple[float, float, int, int]] = []
        for root in sorted(range(nv), key=lambda v: (int(self.src[v]), v)):
            if seen[root]:
                continue
            comp = [root]
            seen[root] = True
            for u in comp:
                for w, dd in tree[u]:
                    if not seen[w]:
                        seen[w] = True
                        x[w] = x[u] + dd
                        comp.append(w)
            c = np.array(comp)
            lo, hi = float((x[c] + self.any_lo[c]).min()), float((x[c] + self.any_hi[c]).max())
            t0, t1 = int(self.src[c].min()), int(last_row[c].max())
            left = float(MARGIN)
            for _lo, phi, p0, p1 in packed:
                if p0 <= t1 and t0 <= p1:
                    left = max(left, phi + 1 + self.gap)
            x[c] += left - lo
            packed.append((left, left + hi - lo, t0, t1))
        self.centre = x + (self.any_lo + self.any_hi) / 2
        return x

    def run(self) -> bool:
        ns = self.ctx.ns
        seed = self._seed()
        # The placement reads a few values of a block at a time, thousands of times: from
        # lists (a numpy scalar costs several times a list item to read), `x` and
        # `placed` kept there too and written back to the arrays at the end.
        self._src, self._cons = self.src.tolist(), self.cons.tolist()
        self._lo, self._hi = self.lo.tolist(), self.hi.tolist()
        self._any_lo, self._any_hi = self.any_lo.tolist(), self.any_hi.tolist()
        self._centre, self._even = self.centre.tolist(), self.even.tolist()
        xs, placed = self._xl, self._pl = [0] * self.nv, [False] * self.nv
        try:
            # time order: a slice at its row, a held block right after the slice it leaves
            order = sorted(range(self.nv), key=lambda v: (self._src[v], v >= ns, v))
            for v in order:
                got = self._best(v, True, float(seed[v]))
                if got is None:
                    self.failed_slice = self._src[v]
                    return False
                xs[v] = got
                placed[v] = True
            for _ in range(max(self.max_sweeps // 2, 0)):
                moved = False
                for seq in (order[::-1], order):
                    for v in seq:
                        if not self.adj[v]:
                            continue
                        got = self._best(v, False, float(xs[v]))
                        if got is None or got == xs[v]:
                            continue
                        if self._score(v, got, False) < self._score(v, xs[v], False):
                            xs[v] = got
                            moved = True
                if not moved:
                    break
            return True
        finally:
            self.x = np.array(xs, np.int64)
            self.placed = np.array(placed, bool)

    # -- results

    def needle(self) -> np.ndarray:
        return self.x[self.ctx.soe] + self.relp

    def width(self) -> int:
        """Needles used, as `Schedule.width` counts them."""
        return int(max(self.needle().max(), self.alignments()[3].max(initial=0))) + 1

    def alignments(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        lp, ns = self.loops, self.ctx.ns
        gv = ns + self.g_of_hold
        dx = self.x[gv] - self.x[lp.src]
        m = dx != 0
        sl_ = (lp.src[m] + 1).astype(np.int32)
        st = lp.stitch[m].astype(np.int32)
        bed = self.lay.bed[lp.src_entry[m]].astype(np.int8)
        nd = (self.x[lp.src[m]] + self.relp[lp.src_entry[m]] + dx[m]).astype(np.int32)
        o = np.lexsort((st, sl_))
        return sl_[o], st[o], bed[o], nd[o]
