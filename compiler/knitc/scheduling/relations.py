"""Relations between bed slices (ch. 6.7.2): the entries of two slices are related when
they are the same stitch or wale-connected; the layout and offset stages of the
scheduler (`scheduling.layouts`, `scheduling.offsets`) both read them from here."""

from __future__ import annotations

import numpy as np

from knitc.scheduling.slices import Slices
from knitc.shaping.stitch_graph import StitchGraph

# ---- relations between slices -----------------------------------------------------------------


class Relations:
    """The slices as the stages see them: entry → slice, each entry's related previous
    entries (`pa[i]` → `pb[i]`), and those pairs grouped into edges between slices."""

    def __init__(self, g: StitchGraph, sl: Slices) -> None:
        self.g, self.sl = g, sl
        self.ns, self.ne = sl.n_slices, int(sl.stitch.shape[0])
        self.soe = np.repeat(np.arange(self.ns, dtype=np.int64), sl.length)
        self.start = sl.start.astype(np.int64)
        self.length = sl.length.astype(np.int64)
        self.step = sl.gauge.astype(np.int64)
        st = sl.stitch.astype(np.int64)
        self.st = st
        self.hint_bed = g.side[st].astype(np.int8) if self.ne else np.zeros(0, np.int8)
        self.hint_rel = g.needle[st].astype(np.int64) if self.ne else np.zeros(0, np.int64)
        self._pairs()
        self._edges()

    def _pairs(self) -> None:
        ne, st = self.ne, self.st
        ent = np.arange(ne, dtype=np.int64)
        order = np.argsort(st, kind="stable")  # by stitch, then entry
        prev_same = np.full(ne, -1, np.int64)
        if ne > 1:
            same = st[order[1:]] == st[order[:-1]]
            prev_same[order[1:][same]] = order[:-1][same]
        b = [np.flatnonzero(prev_same >= 0)]
        a = [prev_same[b[0]]]
        key = st[order] * max(ne, 1) + order
        first = prev_same < 0
        for j in (0, 1):
            p = self.g.wale_prev[st, j].astype(np.int64) if ne else np.zeros(0, np.int64)
            m = first & (p >= 0)
            q = p[m] * max(ne, 1) + ent[m]
            i = np.searchsorted(key, q) - 1
            ok = i >= 0
            ok[ok] = st[order[i[ok]]] == p[m][ok]
            b.append(ent[m][ok])
            a.append(order[i[ok]])
        self.pa = np.concatenate(a)
        self.pb = np.concatenate(b)

    def _edges(self) -> None:
        ns = max(self.ns, 1)
        ek = self.soe[self.pa] * ns + self.soe[self.pb]
        o = np.argsort(ek, kind="stable")
        self.pa, self.pb, ek = self.pa[o], self.pb[o], ek[o]
        keys, first, counts = np.unique(ek, return_index=True, return_counts=True)
        self.e_a = keys // ns
        self.e_b = keys % ns
        self.e_first = first
        self.e_count = counts
        self.edge_of: dict[tuple[int, int], int] = {
            (int(a), int(b)): i for i, (a, b) in enumerate(zip(self.e_a, self.e_b, strict=True))
        }
        self.ins: list[list[int]] = [[] for _ in range(self.ns)]
        self.outs: list[list[int]] = [[] for _ in range(self.ns)]
        for i, (a, b) in enumerate(zip(self.e_a.tolist(), self.e_b.tolist(), strict=True)):
            self.outs[a].append(i)
            self.ins[b].append(i)

    def edge_pairs(self, e: int) -> tuple[np.ndarray, np.ndarray]:
        f = int(self.e_first[e])
        c = int(self.e_count[e])
        return self.pa[f : f + c], self.pb[f : f + c]

    def entries(self, k: int) -> slice:
        a = int(self.start[k])
        return slice(a, a + int(self.length[k]))
