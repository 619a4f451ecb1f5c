"""Schedule optimisation, the layout stage (ch. 6.7.2; see `scheduling.scheduler`).

**Layouts.** Each slice gets one layout of its family (`scheduling.schedule`), chosen to minimise
the cost tuple of eq. 6.21 between related slices, compared lexicographically:
(Align(Bi) + Align(Bj), Roll = related loops changing bed, Shift = related loops changing
needle once the two layouts are best translated onto each other). Entries of two slices are
related when they are the same stitch or wale-connected; each entry is related to its
previous appearance, or, at its first, to the last appearances of its previous wales.
Related slices form a graph. Where one slice continues exactly one other (1 → 1) the
slices form a *chain* (a node's courses, and nodes joined end to end); everything else is
an *interface* (a merge or a split), and the connected interface slices form a group.

- Between nodes: each group is solved by branch and bound. Its *hub* (the slice with the
  most related pairs, e.g. the ring of a merge) tries its layouts; each order of the nodes
  around it that the hub's *bridges* allow (ch. 6.7.3, Fig. 6-23: course neighbours of the
  hub whose wales go to different nodes must end up side by side) is kept, the others are
  pruned before any cost is computed; the other slices of the group are fitted one by one
  to the ones already fixed, and a branch stops as soon as its partial cost reaches the
  best complete one.
- Within nodes: each chain is laid out greedily from its fixed end (the bottom if both
  ends are fixed, the top if only that one is, as for branches meeting a merge), or, for a
  lone chain, from the best pair of its two first layouts. A slice with as many entries as
  the previous one, related one to one in the same cyclic order (no shaping), *reuses* its
  layout, which is an ideal transition; a shaping slice searches only a window of rolls
  around the best alignment with its neighbour, vectorised with numpy, so the stage is
  linear in the number of cycle entries.
"""

from __future__ import annotations

from collections import defaultdict
from itertools import pairwise

import numpy as np

from knitc import arrays
from knitc.records import record
from knitc.scheduling import schedule as ir
from knitc.scheduling.relations import Relations
from knitc.scheduling.schedule import BACK, CIRCULAR, FLAT
from knitc.shaping.stitch_graph import StitchGraph

WINDOW = 4
"""Rolls searched on each side of the best alignment when a slice shapes."""
FULL_ROLLS = 96
"""Rings of at most this many entries try every roll where a full search is asked."""
HUB_WINDOW = 12
"""Rolls around the natural layout a larger hub tries."""
FLAT_FULL = 40
"""Flat cycles of at most this many entries try every C-shape."""
GROUP_FULL = 12
"""Interface groups with more slices are laid out greedily in time order."""
ORDERS_CAP = 5040
"""Most node orders the bridge search enumerates."""


# ---- layout candidates and their costs ----------------------------------------------------------


@record
class _Cands:
    params: np.ndarray  # (C, 7): kind, nibble, roll, main, side, spread, mirror
    bed: np.ndarray  # (C, n) int8
    rel: np.ndarray  # (C, n) int64
    align: np.ndarray  # (C,) int64: 0 aligned, 1 not
    tie: np.ndarray  # (C,) int64: preference among equal costs (lower first)


def _slot_rolls(
    n: int, nibble: int, ib: np.ndarray, ref_bed: np.ndarray, ref_rel: np.ndarray
) -> int:
    """The roll that puts most related entries in the slot of this shape nearest to their
    reference place, once both are centred: the best alignment a window is searched around."""
    sb, so = ir.circular_shape(n, nibble)
    if ib.size == 0 or n == 0:
        return 0
    nf = int(np.count_nonzero(sb == 0))
    o = ref_rel - ref_rel.mean() + so.mean()
    front_lo = int(so[0]) if nf else 0
    back_hi = int(so[nf]) if nf < n else 0
    fs = np.clip(np.rint(o - front_lo), 0, max(nf - 1, 0)).astype(np.int64)
    bs = nf + np.clip(np.rint(back_hi - o), 0, max(n - nf - 1, 0)).astype(np.int64)
    on_front = (ref_bed == 0) if 0 < nf < n else np.full(ib.shape, nf > 0)
    slot = np.where(on_front, fs, bs)
    r = (slot - ib) % n
    return int(np.argmax(np.bincount(r, minlength=n)))


def _circular_cands(
    n: int, ib: np.ndarray, ref_bed: np.ndarray, ref_rel: np.ndarray, window: int | None
) -> _Cands:
    """Ring layouts: every roll (window None, or a small ring), else `window` rolls on each
    side of each nibble's best alignment."""
    params, beds, rels, aligns, ties = [], [], [], [], []
    for nb in range(ir.n_nibbles(n)):
        est = _slot_rolls(n, nb, ib, ref_bed, ref_rel)
        if window is None or 2 * window + 1 >= n:
            rolls = np.arange(n)
        else:
            rolls = arrays.unique((est + np.arange(-window, window + 1)) % n)
        b, o = ir.circular_layouts(n, nb, rolls)
        dist = np.abs(rolls - est)
        dist = np.minimum(dist, n - dist)
        p = np.zeros((rolls.size, 7), np.int64)
        p[:, 0], p[:, 1], p[:, 2] = CIRCULAR, nb, rolls
        params.append(p)
        beds.append(b)
        rels.append(o.astype(np.int64))
        aligns.append(np.full(rolls.size, 0 if ir.aligned(CIRCULAR, n, nb, 0) else 1))
        ties.append(dist * 8 + nb)
    return _Cands(
        np.concatenate(params),
        np.concatenate(beds),
        np.concatenate(rels),
        np.concatenate(aligns),
        np.concatenate(ties),
    )


def _flat_cands(
    n: int, ib: np.ndarray, ref_bed: np.ndarray, ref_rel: np.ndarray, full: bool
) -> _Cands:
    """C-shapes: all of them for a short row (or when asked), else the unfolded rows and
    the folds within a few entries of the related entries' share of one bed."""
    allp = ir.flat_params(n)
    if not full and n > FLAT_FULL:
        share = np.bincount(ref_bed.astype(np.int64), minlength=2).max() / max(ib.size, 1)
        m_ref = int(round(share * n))
        allp = [p for p in allp if p[0] == n or abs(p[0] - m_ref) <= WINDOW]
    inc = 1
    if ib.size > 1 and np.ptp(ref_rel) > 0 and np.ptp(ib) > 0:
        inc = 1 if np.corrcoef(ib, ref_rel)[0, 1] >= 0 else -1
    params = np.zeros((len(allp), 7), np.int64)
    params[:, 0], params[:, 1] = FLAT, -1
    params[:, 3:] = np.array(allp, np.int64).reshape(-1, 4)
    beds, rel32 = ir.flat_layouts(n, params[:, 3:])
    rels = rel32.astype(np.int64)
    align = (params[:, 3] != n).astype(np.int64)
    majority = int(np.argmax(np.bincount(ref_bed.astype(np.int64), minlength=2))) if ib.size else 0
    tie = (
        np.abs(params[:, 3] - n) * 4 + (params[:, 4] != majority) * 2 + (params[:, 6] != (inc < 0))
    )
    return _Cands(params, beds, rels, align, tie)


def _costs(
    c: _Cands, ib: np.ndarray, ref_bed: np.ndarray, ref_rel: np.ndarray, step: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(roll, shift, delta) of every candidate against reference places of its entries
    `ib` (relative physical needles): loops changing bed, and loops changing needle once
    the candidate, expanded to its gauge `step`, is moved by the translation `delta` that
    keeps the most of them in place."""
    n_c, n_p = c.bed.shape[0], ib.shape[0]
    if n_p == 0:
        z = np.zeros(n_c, np.int64)
        return z, z, z
    roll = (c.bed[:, ib] != ref_bed[None, :]).sum(1).astype(np.int64)
    cb = c.bed[:, ib]
    d = c.rel[:, ib] * step + (cb == BACK) * (step == 2) - ref_rel[None, :]
    lo = int(d.min())
    span = int(d.max()) - lo + 1
    keys = (np.arange(n_c, dtype=np.int64)[:, None] * span + (d - lo)).ravel()
    cnt = np.bincount(keys, minlength=n_c * span).reshape(n_c, span)
    return roll, n_p - cnt.max(1), cnt.argmax(1) + lo


Cost = tuple[int, int, int]


def _add(a: Cost, b: Cost) -> Cost:
    return (a[0] + b[0], a[1] + b[1], a[2] + b[2])


# ---- the layout stage ---------------------------------------------------------------------------


class Layouts:
    def __init__(self, ctx: Relations) -> None:
        self.ctx = ctx
        ns, ne = ctx.ns, ctx.ne
        self.kind = np.where(ctx.sl.circular, CIRCULAR, FLAT).astype(np.int64)
        self.nibble = np.full(ns, -1, np.int64)
        self.roll = np.zeros(ns, np.int64)
        self.main = np.zeros(ns, np.int64)
        self.side = np.zeros(ns, np.int64)
        self.spread = np.zeros(ns, np.int64)
        self.mirror = np.zeros(ns, np.int64)
        self.reuse = np.zeros(ns, bool)
        self.done = np.zeros(ns, bool)
        self.bed = np.zeros(ne, np.int64)
        self.rel = np.zeros(ne, np.int64)

    # -- setting layouts

    def _set(
        self, k: int, p: np.ndarray, bed: np.ndarray, rel: np.ndarray, reuse: bool = False
    ) -> None:
        (
            self.kind[k],
            self.nibble[k],
            self.roll[k],
            self.main[k],
            self.side[k],
            self.spread[k],
            self.mirror[k],
        ) = (int(x) for x in p)
        if self.kind[k] == FLAT:
            self.nibble[k] = -1
        e = self.ctx.entries(k)
        self.bed[e], self.rel[e] = bed, rel
        self.reuse[k] = reuse
        self.done[k] = True

    def params(self, k: int) -> np.ndarray:
        return np.array(
            [
                self.kind[k],
                self.nibble[k],
                self.roll[k],
                self.main[k],
                self.side[k],
                self.spread[k],
                self.mirror[k],
            ],
            np.int64,
        )

    def align_of(self, k: int) -> int:
        n = int(self.ctx.length[k])
        return 0 if ir.aligned(int(self.kind[k]), n, int(self.nibble[k]), int(self.main[k])) else 1

    # -- candidates, fits and reuse

    def cands(
        self, k: int, ib: np.ndarray, ref_bed: np.ndarray, ref_rel: np.ndarray, window: int | None
    ) -> _Cands:
        n = int(self.ctx.length[k])
        if self.ctx.sl.circular[k]:
            return _circular_cands(n, ib, ref_bed, ref_rel, window)
        return _flat_cands(n, ib, ref_bed, ref_rel, window is None)

    def phys(self, k: int, bed: np.ndarray, rel: np.ndarray) -> np.ndarray:
        """Relative needles of slice k expanded to its gauge (ch. 6.8.2), so that slices
        of different gauges compare where their loops really are."""
        step = int(self.ctx.step[k])
        return rel * step + (bed == BACK) * (step == 2)

    def fit(
        self,
        k: int,
        ib: np.ndarray,
        ref_bed: np.ndarray,
        ref_rel: np.ndarray,
        window: int | None = WINDOW,
    ) -> tuple[int, Cost, int, _Cands]:
        """The best candidate of slice k against reference places (bed, relative physical
        needle) of its entries `ib` (local indices): (index, (align, roll, shift), delta,
        candidates)."""
        step = int(self.ctx.step[k])
        ref_rel = np.asarray(ref_rel, np.int64)
        ref_log = (ref_rel - (ref_bed == BACK) * (step == 2)) / step
        c = self.cands(k, ib, ref_bed, ref_log, window)
        roll, shift, delta = _costs(c, ib, ref_bed, ref_rel, step)
        i = int(np.lexsort((c.tie, shift, roll, c.align))[0])
        return i, (int(c.align[i]), int(roll[i]), int(shift[i])), int(delta[i]), c

    def fit_hint(self, k: int) -> None:
        """A slice related to nothing: the aligned layout nearest the shape pass's own."""
        e = self.ctx.entries(k)
        n = int(self.ctx.length[k])
        ib = np.arange(n)
        hint = self.phys(k, self.ctx.hint_bed[e], self.ctx.hint_rel[e])
        i, _, _, c = self.fit(
            k, ib, self.ctx.hint_bed[e], hint, None if n <= FULL_ROLLS else HUB_WINDOW
        )
        self._set(k, c.params[i], c.bed[i], c.rel[i])

    def refs(self, k: int, other: int, e: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Pairs of edge e between slices k and `other` (laid out) as (local entries of k,
        the other's beds and relative needles there)."""
        pa, pb = self.ctx.edge_pairs(e)
        mine, theirs = (pb, pa) if int(self.ctx.e_b[e]) == k else (pa, pb)
        return (
            mine - self.ctx.start[k],
            self.bed[theirs],
            self.phys(other, self.bed[theirs], self.rel[theirs]),
        )

    def reuse_shift(self, a: int, b: int) -> int | None:
        """Whether b can take a's layout (same cardinality, related one to one in the same
        cyclic order: no shaping) and by how many entries b's cycle is rotated from a's."""
        ctx = self.ctx
        n = int(ctx.length[a])
        if n != int(ctx.length[b]) or bool(ctx.sl.circular[a]) != bool(ctx.sl.circular[b]):
            return None
        e = ctx.edge_of.get((a, b))
        if e is None or int(ctx.e_count[e]) != n:
            return None
        pa, pb = ctx.edge_pairs(e)
        ia, ib = pa - ctx.start[a], pb - ctx.start[b]
        if (np.bincount(ia, minlength=n) != 1).any() or (np.bincount(ib, minlength=n) != 1).any():
            return None
        d = (ib - ia) % n
        if (d != d[0]).any() or (not ctx.sl.circular[a] and d[0] != 0):
            return None
        return int(d[0])

    def copy(self, src: int, dst: int, d: int, forward: bool) -> None:
        """Lay `dst` out as `src`, its cycle rotated by d entries (forward: dst comes
        after src, entry j of dst relates to entry j - d of src)."""
        s = d if forward else -d
        e = self.ctx.entries(src)
        p = self.params(src)
        n = int(self.ctx.length[src])
        if p[0] == CIRCULAR:
            p[2] = (p[2] - s) % max(n, 1)
        self._set(dst, p, np.roll(self.bed[e], s), np.roll(self.rel[e], s), reuse=forward)
        if not forward:
            self.reuse[src] = True

    def step(self, fixed: int, k: int, forward: bool) -> None:
        """Greedy step of a chain: lay out k from its fixed neighbour."""
        a, b = (fixed, k) if forward else (k, fixed)
        d = self.reuse_shift(a, b)
        if d is not None:
            self.copy(fixed, k, d, forward)
            return
        e = self.ctx.edge_of[(a, b)]
        ib, rb, rr = self.refs(k, fixed, e)
        i, _, _, c = self.fit(k, ib, rb, rr)
        self._set(k, c.params[i], c.bed[i], c.rel[i])

    # -- structure

    def run(self) -> None:
        ctx = self.ctx
        n_in = np.array([len(x) for x in ctx.ins], np.int64)
        n_out = np.array([len(x) for x in ctx.outs], np.int64)
        link = (n_in[ctx.e_b] == 1) & (n_out[ctx.e_a] == 1)
        self.nxt = np.full(ctx.ns, -1, np.int64)
        self.prv = np.full(ctx.ns, -1, np.int64)
        self.nxt[ctx.e_a[link]] = ctx.e_b[link]
        self.prv[ctx.e_b[link]] = ctx.e_a[link]
        # interface groups: connected components of the other relations
        parent = list(range(ctx.ns))

        def find(x: int) -> int:
            while parent[x] != x:
                parent[x] = parent[parent[x]]
                x = parent[x]
            return x

        iface = np.flatnonzero(~link)
        for e in iface.tolist():
            ra, rb = find(int(ctx.e_a[e])), find(int(ctx.e_b[e]))
            if ra != rb:
                parent[max(ra, rb)] = min(ra, rb)
        groups: dict[int, list[int]] = defaultdict(list)
        members = set()
        for e in iface.tolist():
            members.add(int(ctx.e_a[e]))
            members.add(int(ctx.e_b[e]))
        for k in sorted(members):
            groups[find(k)].append(k)
        self.group_edges: dict[int, list[int]] = defaultdict(list)
        for e in iface.tolist():
            self.group_edges[find(int(ctx.e_a[e]))].append(e)
        for root, ks in groups.items():
            self.solve_group(ks, self.group_edges[root])
        # chains, greedily from their fixed ends
        for k in range(ctx.ns):
            if self.prv[k] >= 0:
                continue
            chain = [k]
            while self.nxt[chain[-1]] >= 0:
                chain.append(int(self.nxt[chain[-1]]))
            self.solve_chain(chain)

    def solve_chain(self, chain: list[int]) -> None:
        if self.done[chain[0]]:
            for a, b in pairwise(chain):
                if not self.done[b]:
                    self.step(a, b, True)
            return
        if self.done[chain[-1]]:
            for b, a in pairwise(chain[::-1]):
                self.step(b, a, False)
            return
        self.bottom_pair(chain[0], chain[1] if len(chain) > 1 else None)
        for a, b in pairwise(chain):
            if not self.done[b]:
                self.step(a, b, True)

    def bottom_pair(self, k: int, nxt: int | None) -> None:
        """A lone chain: the best pair of layouts for its two first slices (the first one
        near the shape pass's own layout when several are as good)."""
        if nxt is None or self.reuse_shift(k, nxt) is not None:
            self.fit_hint(k)
            return
        e = self.ctx.entries(k)
        n = int(self.ctx.length[k])
        c = self.cands(k, np.arange(n), self.ctx.hint_bed[e], self.ctx.hint_rel[e], WINDOW)
        edge = self.ctx.edge_of[(k, nxt)]
        pa, pb = self.ctx.edge_pairs(edge)
        ia, ib = pa - self.ctx.start[k], pb - self.ctx.start[nxt]
        best: tuple | None = None
        for i in np.argsort(c.align * (1 << 20) + c.tie, kind="stable").tolist():
            j, cost, _, cn = self.fit(
                nxt, ib, c.bed[i][ia], self.phys(k, c.bed[i][ia], c.rel[i][ia])
            )
            key = (int(c.align[i]) + cost[0], cost[1], cost[2], int(c.tie[i]))
            if best is None or key < best[0]:
                best = (key, i, j, cn)
        assert best is not None
        _, i, j, cn = best
        self._set(k, c.params[i], c.bed[i], c.rel[i])
        self._set(nxt, cn.params[j], cn.bed[j], cn.rel[j])

    # -- between nodes

    def solve_group(self, ks: list[int], edges: list[int]) -> None:
        ctx = self.ctx
        weight: dict[int, int] = defaultdict(int)
        adj: dict[int, list[tuple[int, int]]] = defaultdict(list)
        for e in edges:
            a, b = int(ctx.e_a[e]), int(ctx.e_b[e])
            weight[a] += int(ctx.e_count[e])
            weight[b] += int(ctx.e_count[e])
            adj[a].append((b, e))
            adj[b].append((a, e))
        if len(ks) > GROUP_FULL:
            for k in ks:  # time order: fit each slice to its laid-out neighbours
                if any(self.done[o] for o, _ in adj[k]):
                    self.fit_to_fixed(k, adj[k])
                else:
                    self.fit_hint(k)
            return
        hub = max(ks, key=lambda k: (weight[k], int(ctx.length[k]), -k))
        order = [hub]
        seen = {hub}
        for k in order:
            for o, _ in sorted(adj[k], key=lambda t: (-int(ctx.e_count[t[1]]), t[0])):
                if o not in seen:
                    seen.add(o)
                    order.append(o)
        e_h = ctx.entries(hub)
        n = int(ctx.length[hub])
        window = None if n <= FULL_ROLLS else HUB_WINDOW
        hc = self.cands(hub, np.arange(n), ctx.hint_bed[e_h], ctx.hint_rel[e_h], window)
        labels = self.hub_labels(hub, adj[hub])
        valid = valid_orders(*hub_bridges(ctx.g, bool(ctx.sl.circular[hub]), labels))
        best: tuple | None = None
        for i in np.argsort(hc.align * (1 << 20) + hc.tie, kind="stable").tolist():
            bound: Cost = (int(hc.align[i]), 0, 0)
            if best is not None and bound >= best[0]:
                continue
            if valid is not None and _induced_order(labels[0], labels[1], hc.rel[i]) not in valid:
                continue
            got = self.try_hub(hub, hc, i, order[1:], adj, best[0] if best else None)
            if got is not None and (best is None or got[0] < best[0]):
                best = got
        if best is None:  # every order pruned: fall back to the best without bridges
            for i in np.argsort(hc.align * (1 << 20) + hc.tie, kind="stable").tolist()[:64]:
                got = self.try_hub(hub, hc, i, order[1:], adj, best[0] if best else None)
                if got is not None and (best is None or got[0] < best[0]):
                    best = got
        assert best is not None
        for k, (p, b, r) in best[1].items():
            self._set(k, p, b, r)

    def try_hub(
        self,
        hub: int,
        hc: _Cands,
        i: int,
        rest: list[int],
        adj: dict[int, list[tuple[int, int]]],
        bound: Cost | None,
    ) -> tuple[Cost, dict] | None:
        """Branch: the hub in candidate i, then each other slice of the group fitted to the
        ones already placed (in the hub's frame); None as soon as the partial cost reaches
        `bound`."""
        frame: dict[int, tuple[np.ndarray, np.ndarray, np.ndarray]] = {
            hub: (hc.params[i], hc.bed[i], self.phys(hub, hc.bed[i], hc.rel[i]))
        }
        total: Cost = (int(hc.align[i]), 0, 0)
        for k in rest:
            ibs, rbs, rrs = [], [], []
            for o, e in adj[k]:
                if o not in frame:
                    continue
                pa, pb = self.ctx.edge_pairs(e)
                mine, theirs = (pb, pa) if int(self.ctx.e_b[e]) == k else (pa, pb)
                so = self.ctx.start[o]
                ibs.append(mine - self.ctx.start[k])
                rbs.append(frame[o][1][theirs - so])
                rrs.append(frame[o][2][theirs - so])
            ib, rb, rr = np.concatenate(ibs), np.concatenate(rbs), np.concatenate(rrs)
            j, cost, delta, c = self.fit(k, ib, rb, rr)
            total = _add(total, cost)
            if bound is not None and total >= bound:
                return None
            frame[k] = (c.params[j], c.bed[j], self.phys(k, c.bed[j], c.rel[j]) - delta)
        out = {}
        for k, (p, _b, _r) in frame.items():
            out[k] = (
                p,
                *ir.layout(
                    int(p[0]),
                    int(self.ctx.length[k]),
                    int(p[1]),
                    int(p[2]),
                    int(p[3]),
                    int(p[4]),
                    int(p[5]),
                    int(p[6]),
                ),
            )
        return total, out

    def fit_to_fixed(self, k: int, nbrs: list[tuple[int, int]]) -> None:
        ibs, rbs, rrs = [], [], []
        for o, e in nbrs:
            if self.done[o]:
                ib, rb, rr = self.refs(k, o, e)
                ibs.append(ib)
                rbs.append(rb)
                rrs.append(rr)
        i, _, _, c = self.fit(k, np.concatenate(ibs), np.concatenate(rbs), np.concatenate(rrs))
        self._set(k, c.params[i], c.bed[i], c.rel[i])

    def hub_labels(self, hub: int, nbrs: list[tuple[int, int]]) -> tuple[np.ndarray, np.ndarray]:
        """Per hub entry the node across the interface it relates to (-1: none or the hub's
        own node), and the related stitch there (for the bridge test)."""
        ctx = self.ctx
        n = int(ctx.length[hub])
        lab = np.full(n, -1, np.int64)
        other = np.full(n, -1, np.int64)
        own = int(ctx.sl.node[hub])
        for o, e in sorted(nbrs, key=lambda t: t[0]):
            node = int(ctx.sl.node[o])
            if node == own:
                continue
            pa, pb = ctx.edge_pairs(e)
            mine, theirs = (pb, pa) if int(ctx.e_b[e]) == hub else (pa, pb)
            li = mine - ctx.start[hub]
            free = lab[li] < 0
            lab[li[free]] = node
            other[li[free]] = ctx.st[theirs[free]]
        return lab, other

    def total_cost(self) -> Cost:
        """The cost tuple of the chosen layouts summed over every related pair of slices."""
        ctx = self.ctx
        total: Cost = (0, 0, 0)
        for e in range(ctx.e_a.shape[0]):
            a, b = int(ctx.e_a[e]), int(ctx.e_b[e])
            pa, pb = ctx.edge_pairs(e)
            total = _add(
                total,
                ir.pair_cost(
                    self.align_of(a),
                    self.align_of(b),
                    self.bed[pa],
                    self.phys(a, self.bed[pa], self.rel[pa]),
                    self.bed[pb],
                    self.phys(b, self.bed[pb], self.rel[pb]),
                ),
            )
        return total


# ---- bridges and node orders (Fig. 6-23) ---------------------------------------------------------


def hub_bridges(
    g: StitchGraph, circular: bool, labels: tuple[np.ndarray, np.ndarray]
) -> tuple[list[int], set[frozenset[int]]]:
    """(nodes, bridges) of a hub cycle: course neighbours of the hub whose related stitches
    across the interface are not course neighbours there. Bridges between two different
    nodes say that those nodes must be side by side on the bed."""
    lab, other = labels
    n = lab.shape[0]
    nodes = sorted(set(lab[lab >= 0].tolist()))
    bridges: set[frozenset[int]] = set()
    if n < 2:
        return nodes, bridges
    i = np.arange(n if circular else n - 1)
    j = (i + 1) % n
    ok = (lab[i] >= 0) & (lab[j] >= 0)
    oi, oj = other[i], other[j]
    adjacent = (g.cnext[np.maximum(oi, 0)] == oj) | (g.cprev[np.maximum(oi, 0)] == oj) | (oi == oj)
    br = ok & ~adjacent & (lab[i] != lab[j])
    for a, b in zip(lab[i][br].tolist(), lab[j][br].tolist(), strict=True):
        bridges.add(frozenset((a, b)))
    return nodes, bridges


def valid_orders(nodes: list[int], bridges: set[frozenset[int]]) -> set[tuple[int, ...]] | None:
    """Left-to-right orders of `nodes` in which every bridge joins two neighbours, by
    branch and bound: a partial order is dropped as soon as a placed node cannot have all
    its bridge partners next to it. None (no pruning) when there is nothing to order or
    no order satisfies every bridge (a ring of bridges, as in an unfolded split)."""
    if len(nodes) < 2 or len(nodes) > 8 or not bridges:
        return None
    partners: dict[int, set[int]] = {u: set() for u in nodes}
    for br in bridges:
        a, b = tuple(br)
        partners[a].add(b)
        partners[b].add(a)
    if any(len(p) > 2 for p in partners.values()):
        return None
    out: list[tuple[int, ...]] = []

    def ok(seq: list[int]) -> bool:
        last = len(seq) - 1
        for i, x in enumerate(seq):
            near = {seq[i - 1]} if i > 0 else set()
            if i < last:
                near.add(seq[i + 1])
                if not partners[x] <= near:
                    return False
            else:
                placed = {p for p in partners[x] if p in seq}
                if not placed <= near or len(partners[x] - placed) > 1:
                    return False
        return True

    def grow(seq: list[int], rest: list[int]) -> None:
        if len(out) >= ORDERS_CAP:
            return
        if not rest:
            out.append(tuple(seq))
            return
        for u in rest:
            nxt = seq + [u]
            if ok(nxt):
                grow(nxt, [r for r in rest if r != u])

    grow([], list(nodes))
    return set(out) or None


def _induced_order(lab: np.ndarray, _other: np.ndarray, rel: np.ndarray) -> tuple[int, ...]:
    """The left-to-right order of the nodes across a hub laid out with relative needles
    `rel`: by the mean needle of the hub entries each relates to."""
    m = lab >= 0
    if not np.any(m):
        return ()
    nodes, inv = np.unique(lab[m], return_inverse=True)
    mean = np.bincount(inv, weights=rel[m]) / np.bincount(inv)
    return tuple(int(x) for x in nodes[np.lexsort((nodes, mean))])
