"""The schedule IR: where each loop of each bed slice sits on the machine (thesis ch. 6.7.2-3).

A schedule gives every slice a *layout* and an *offset*. The layout is one member of a small
parameterised family (ch. 6.7.2) that places the slice's cycle entries on the two beds at
relative needles `rel` such that consecutive entries are at most one needle apart (the
slack constraint, eq. 6.19):

- circular cycles (rings): a *nibble* (which corners of the ring are left out: for an even
  number N of entries none, FL+FR, BL+BR, FL+BR or FR+BL; for odd N one of FL, FR, BL, BR)
  and a *roll* (which slot of that shape the first entry takes, 0..N-1): 5N or 4N layouts;
- flat cycles: the simplified C-shape, `main` entries on side `side` with the other N-main
  folded onto the other bed at the `left`, `right` or `both` ends, optionally `mirror`ed
  (right to left). main = N is the plain unfolded row, a fold at one end the single fold.

The offset is the physical needle of the layout's relative needle 0. Half-gauge slices are
expanded after the layout is chosen (ch. 6.8.2): relative needle r of the front bed is
physical `offset + 2r`, of the back bed `offset + 2r + 1`, with an even offset, so the
needle facing every loop is empty. So each cycle entry gets a physical (bed, needle).

Loops can also wait on the bed outside the cycle of the slice being knitted: a branch's
loops while another branch is knitted, a base's loops before the next branch of a split.
Such a *held* loop stays where its slice left it, unless the schedule moves it out of the
way: an *alignment* record (slice, stitch, bed, needle) says that before slice k, the loop
of `stitch` moves to (bed, needle). `held_loops` finds those loops from the slices alone,
so the code generator, the verifier and the pass agree on them.

The code generator needs only `positions(sched, k)` and `alignments(sched, k)`.

Invariants (`verify`): every layout is the member of its family its parameters name and
satisfies the slack constraint; physical needles are the expansion of the relative ones and
lie on the bed; half-gauge fronts are on even needles and backs on odd ones; at every slice,
no two loops that are on the bed at that time (the cycle's entries and the held loops)
share a needle; alignment records only move held loops.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import field
from typing import Any

import numpy as np

from knitc.records import record
from knitc.scheduling.slices import ACTIVE, STATE_NAMES, SUSPENDED, Slices
from knitc.shaping.stitch_graph import StitchGraph

CIRCULAR, FLAT = 0, 1
KIND_NAMES = ("circular", "flat")
EVEN_NIBBLES = ("none", "FL+FR", "BL+BR", "FL+BR", "FR+BL")
ODD_NIBBLES = ("FL", "FR", "BL", "BR")
SPREADS = ("left", "right", "both")
FRONT, BACK = 0, 1


# ---- the layout families (ch. 6.7.2) -----------------------------------------------------------


def circular_shape(n: int, nibble: int) -> tuple[np.ndarray, np.ndarray]:
    """(bed, rel) of the n slots of a ring shape, counter-clockwise from the front-left
    slot: the front slots left to right, then the back slots right to left."""
    h = n // 2
    if n % 2 == 0:
        front, back = {
            0: ((0, h - 1), (0, h - 1)),
            1: ((1, h - 1), (0, h)),
            2: ((0, h), (1, h - 1)),
            3: ((1, h), (0, h - 1)),
            4: ((0, h - 1), (1, h)),
        }[nibble]
    else:
        front, back = {
            0: ((1, h), (0, h)),
            1: ((0, h - 1), (0, h)),
            2: ((0, h), (1, h)),
            3: ((0, h), (0, h - 1)),
        }[nibble]
    f = np.arange(front[0], front[1] + 1, dtype=np.int32)
    b = np.arange(back[1], back[0] - 1, -1, dtype=np.int32)
    bed = np.concatenate([np.zeros(f.size, np.int8), np.ones(b.size, np.int8)])
    return bed, np.concatenate([f, b])


def n_nibbles(n: int) -> int:
    return 5 if n % 2 == 0 else 4


def nibble_name(n: int, nibble: int) -> str:
    return (EVEN_NIBBLES if n % 2 == 0 else ODD_NIBBLES)[nibble]


def circular_layouts(n: int, nibble: int, rolls: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(bed, rel), each (len(rolls), n): entry i of the cycle takes slot (i + roll) mod n."""
    sb, so = circular_shape(n, nibble)
    idx = (np.arange(n)[None, :] + np.asarray(rolls, np.int64)[:, None]) % max(n, 1)
    return sb[idx], so[idx]


def flat_layout(
    n: int, main: int, side: int, spread: int, mirror: int
) -> tuple[np.ndarray, np.ndarray]:
    """(bed, rel) of a flat cycle of n entries in the simplified C-shape: entries l .. l+main-1
    on `side` at relative needles 0..main-1, the l first entries folded back under the left
    end and the r last ones under the right end (l + r = n - main, split by `spread`);
    `mirror` lays the same shape out right to left."""
    bed, rel = flat_layouts(n, np.array([(main, side, spread, mirror)], np.int64))
    return bed[0], rel[0]


def flat_layouts(n: int, params: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """`flat_layout` of every row (main, side, spread, mirror) of `params` at once: (bed,
    rel), each (len(params), n). A short row weighs all of its C-shapes, about 6n of them,
    and laying them out one by one was most of a small design's scheduling."""
    p = np.asarray(params, np.int64).reshape(-1, 4)
    main, side, spread, mirror = (p[:, k : k + 1] for k in range(4))
    rest = n - main
    left = np.where(spread == 0, rest, np.where(spread == 1, 0, rest // 2))
    i = np.arange(n)[None, :]
    rel = np.where(
        i < left, left - 1 - i, np.where(i < left + main, i - left, main - 1 - (i - left - main))
    )
    bed = np.where((i >= left) & (i < left + main), side, 1 - side).astype(np.int8)
    rel = np.where(mirror != 0, main - 1 - rel, rel)
    return bed, rel.astype(np.int32)


def flat_params(n: int) -> list[tuple[int, int, int, int]]:
    """Every distinct (main, side, spread, mirror) of a flat cycle of n entries."""
    out = []
    for main in range(n, (n + 1) // 2 - 1, -1):
        spreads = (0,) if main == n else (0, 1) if n - main == 1 else (0, 1, 2)
        for side in (FRONT, BACK):
            for spread in spreads:
                for mirror in (0, 1):
                    out.append((main, side, spread, mirror))
    return out


def layout(
    kind: int, n: int, nibble: int, roll: int, main: int, side: int, spread: int, mirror: int
) -> tuple[np.ndarray, np.ndarray]:
    """(bed, rel) of one layout from its parameters."""
    if kind == CIRCULAR:
        b, o = circular_layouts(n, nibble, np.array([roll]))
        return b[0], o[0]
    return flat_layout(n, main, side, spread, mirror)


def aligned(kind: int, n: int, nibble: int, main: int) -> bool:
    """Align(B) = 0 (ch. 6.7.3): a ring without nibble, or a flat row without fold."""
    return (n % 2 == 0 and nibble == 0) if kind == CIRCULAR else main == n


def pair_cost(
    align_a: int,
    align_b: int,
    bed_a: np.ndarray,
    rel_a: np.ndarray,
    bed_b: np.ndarray,
    rel_b: np.ndarray,
) -> tuple[int, int, int]:
    """The cost tuple of eq. 6.21 between two layouts, given the places of their related
    pairs (pair i: (bed_a[i], rel_a[i]) in one layout, (bed_b[i], rel_b[i]) in the other):
    (Align(Bi) + Align(Bj), loops that change bed, loops that change needle once the two
    layouts are translated onto each other as well as can be). Tuples compare
    lexicographically, as the optimisation does."""
    roll = int(np.count_nonzero(bed_a != bed_b))
    d = np.asarray(rel_b, np.int64) - rel_a
    shift = int(d.size - np.bincount(d - d.min()).max()) if d.size else 0
    return align_a + align_b, roll, shift


# ---- the IR ---------------------------------------------------------------------------------


@record
class Schedule:
    """The schedule IR (this module's docstring): each slice's layout and offset, from
    which every cycle entry has its physical needle."""

    slices: Slices
    needles: int
    # per slice
    kind: np.ndarray  # int8: CIRCULAR / FLAT
    nibble: np.ndarray  # int8: circular nibble (index into EVEN_/ODD_NIBBLES); -1 if flat
    roll: np.ndarray  # int32: circular roll; 0 if flat
    main: np.ndarray  # int32: flat main entries; 0 if circular
    side: np.ndarray  # int8: flat main side
    spread: np.ndarray  # int8: flat fold spread (index into SPREADS)
    mirror: np.ndarray  # int8: flat layout laid right to left
    reuse: np.ndarray  # bool: layout taken over from the previous slice (no shaping)
    offset: np.ndarray  # int32: physical needle of relative needle 0
    step: np.ndarray  # int8: 1 full gauge, 2 half gauge
    # per cycle entry (parallel to slices.stitch)
    bed: np.ndarray  # int8: 0 front, 1 back
    rel: np.ndarray  # int32: relative needle within the layout
    needle: np.ndarray  # int32: physical needle
    # alignment records, sorted by slice
    align_slice: np.ndarray  # int32: the slice before which the loop moves
    align_stitch: np.ndarray  # int32: whose loop
    align_bed: np.ndarray  # int8
    align_needle: np.ndarray  # int32
    cost: dict[str, int] = field(default_factory=dict)
    """What the optimisation reached: the cost tuple (align, roll, shift) summed over the
    related slices. The physical loop moves it implies are `loop_moves` (a replay of every
    placement, made for the dump, not for every compile)."""

    @property
    def n_slices(self) -> int:
        return int(self.kind.shape[0])

    @property
    def width(self) -> int:
        """Needles the garment uses: every knitted loop and every held loop moved aside."""
        if not self.needle.size:
            return 0
        return int(max(self.needle.max(), self.align_needle.max(initial=0))) + 1

    def stats(self) -> dict[str, Any]:
        circ = self.kind == CIRCULAR
        n = self.slices.length
        al = np.where(circ, (n % 2 == 0) & (self.nibble == 0), self.main == n)
        return {
            "slices": self.n_slices,
            "entries": int(self.bed.shape[0]),
            "width": self.width,
            "needles": self.needles,
            "circular": int(np.count_nonzero(circ)),
            "flat": int(np.count_nonzero(~circ)),
            "aligned": int(np.count_nonzero(al)),
            "reused": int(np.count_nonzero(self.reuse)),
            "half_gauge": int(np.count_nonzero(self.step == 2)),
            "alignments": int(self.align_slice.shape[0]),
            **self.cost,
        }


def positions(sched: Schedule, k: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(stitches, states, beds, needles) of slice k's cycle: where each EXPECTED stitch's
    loops must be brought before the slice, where each ACTIVE one is knitted and where each
    SUSPENDED loop waits."""
    a = int(sched.slices.start[k])
    b = a + int(sched.slices.length[k])
    return (sched.slices.stitch[a:b], sched.slices.state[a:b], sched.bed[a:b], sched.needle[a:b])


def alignments(sched: Schedule, k: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(stitches, beds, needles) of the held loops to move before slice k (outside its
    cycle), in no particular order."""
    a, b = np.searchsorted(sched.align_slice, [k, k + 1])
    return sched.align_stitch[a:b], sched.align_bed[a:b], sched.align_needle[a:b]


# ---- loops on the bed ---------------------------------------------------------------------------


@record
class Loops:
    """The loops held on the bed outside every cycle for a while: loop `stitch` was last
    represented in slice `src` (at cycle entry `src_entry`: its own entry, ACTIVE or
    SUSPENDED, or the entry of the next wale it will be knitted into) and is next
    represented in slice `cons` > src + 1 (at `cons_entry`); in between it waits."""

    stitch: np.ndarray  # int32
    src: np.ndarray  # int64
    cons: np.ndarray  # int64
    src_entry: np.ndarray  # int64
    cons_entry: np.ndarray  # int64


_CHUNK = 1 << 18
"""Entries of the slices `_represented` takes at once (a million-stitch tube has two
million: its scratch arrays stay a few megabytes this way)."""


def _represented(
    g: StitchGraph, sl: Slices, made: np.ndarray, end: np.ndarray
) -> Iterator[tuple[int, np.ndarray, np.ndarray]]:
    """For each slice k in order: (k, loops, entries) represented in slice k, one entry per
    loop: a stitch's own entry (ACTIVE: made here; SUSPENDED), else the entry of the next
    wale that will take it in (an increase's loop goes into its first next wale, as the
    code generator does, or into the second when the first is not in the cycle). A loop
    lives from the first slice that knits its stitch to the first that knits a next wale of
    it; later appearances (an increase's second next wale) hold no loop. Each slice's own
    loops come first, then those of its stitches' first and their second parents, in the
    order of the slice's entries.

    Computed for many slices at once (up to `_CHUNK` entries): a numpy call per slice cost
    more than the work on a small design's short cycles. "Is the parent's first next wale
    in slice k" is a lookup of (k, stitch) among the chunk's sorted (slice, stitch) keys."""
    n = max(g.n_stitches, 1)
    k0 = 0
    while k0 < sl.n_slices:
        a = int(sl.start[k0])
        k1 = k0 + 1
        while k1 < sl.n_slices and int(sl.start[k1]) + int(sl.length[k1]) - a <= _CHUNK:
            k1 += 1
        b = int(sl.start[k1 - 1]) + int(sl.length[k1 - 1])
        st = sl.stitch[a:b].astype(np.int64)
        state = sl.state[a:b]
        ent = np.arange(a, b, dtype=np.int64)
        ks = np.repeat(np.arange(k0, k1, dtype=np.int64), sl.length[k0:k1])
        keys = np.sort(ks * n + st)
        kid = state != SUSPENDED
        own = ~kid | (state == ACTIVE)
        los, ens, kss, grp = [st[own]], [ent[own]], [ks[own]], [np.zeros(int(own.sum()), np.int8)]
        for j in (0, 1):
            p = g.wale_prev[st, j].astype(np.int64)
            m = kid & (p >= 0)
            q, km = p[m], ks[m]
            first = g.wale_next[q, 0].astype(np.int64)
            want = km * n + np.maximum(first, 0)
            at = np.minimum(np.searchsorted(keys, want), keys.size - 1)
            take = (first == st[m]) | (keys[at] != want)
            los.append(q[take])
            ens.append(ent[m][take])
            kss.append(km[take])
            grp.append(np.full(int(take.sum()), j + 1, np.int8))
        lo, en, kk = np.concatenate(los), np.concatenate(ens), np.concatenate(kss)
        order = np.lexsort((en, np.concatenate(grp), kk))
        lo, en, kk = lo[order], en[order], kk[order]
        ok = (kk >= made[lo]) & (kk <= end[lo])
        lo, en, kk = lo[ok], en[ok], kk[ok]
        bounds = np.searchsorted(kk, np.arange(k0, k1 + 1)).tolist()
        for k in range(k0, k1):
            i, j = bounds[k - k0], bounds[k - k0 + 1]
            yield k, lo[i:j], en[i:j]
        k0 = k1


def _lifetimes(g: StitchGraph, sl: Slices) -> tuple[np.ndarray, np.ndarray]:
    """Per stitch: the slice that makes its loop and the last slice it is on the bed."""
    soe = np.repeat(np.arange(sl.n_slices, dtype=np.int64), sl.length)
    big = np.iinfo(np.int64).max
    made = np.full(g.n_stitches, big, np.int64)
    act = sl.state == ACTIVE
    np.minimum.at(made, sl.stitch[act], soe[act])
    used = np.full(g.n_stitches, big, np.int64)
    for j in (0, 1):
        c = g.wale_next[:, j]
        has = c >= 0
        used[has] = np.minimum(used[has], made[c[has]])
    return made, np.where(used < big, used, made)


def held_loops(g: StitchGraph, sl: Slices) -> Loops:
    """Every hold of every loop (see `Loops`), in one pass over the slices."""
    made, end = _lifetimes(g, sl)
    last = np.full(g.n_stitches, -1, np.int64)
    last_e = np.full(g.n_stitches, -1, np.int64)
    out: list[tuple[np.ndarray, ...]] = []
    for k, lo, en in _represented(g, sl, made, end):
        prev = last[lo]
        gap = (prev >= 0) & (prev < k - 1)
        if gap.any():
            u = lo[gap]
            out.append((u, last[u], np.full(u.shape[0], k, np.int64), last_e[u], en[gap]))
        last[lo] = k
        last_e[lo] = en
    if not out:
        z = np.zeros(0, np.int64)
        return Loops(z.astype(np.int32), z, z, z, z)
    cols = [np.concatenate([o[i] for o in out]) for i in range(5)]
    return Loops(cols[0].astype(np.int32), *cols[1:])


def placements(
    g: StitchGraph, sched: Schedule
) -> Iterator[
    tuple[int, tuple[np.ndarray, np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray, np.ndarray]]
]:
    """For each slice k in order: (k, alignments, represented), each as (loops, beds,
    needles): the held loops that move out of the way before slice k, then every loop
    slice k's cycle stands for, at the place the slice wants it (a loop of a stitch that
    slice k knits first is not on the bed yet). This is the shaping the code generator
    performs before each slice, and what `loop_moves` counts."""
    sl = sched.slices
    made, end = _lifetimes(g, sl)
    for k, rep, en in _represented(g, sl, made, end):
        yield k, alignments(sched, k), (rep, sched.bed[en], sched.needle[en])


def moves(
    g: StitchGraph, sched: Schedule
) -> Iterator[tuple[int, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]]:
    """The loops that change place, replaying `placements`: for each slice k, first for its
    alignments then for its represented loops, (k, loops, from_bed, from_needle, to_bed,
    to_needle) of the loops already on the bed whose place changes."""
    bed = np.full(g.n_stitches, -1, np.int64)
    ndl = np.full(g.n_stitches, -1, np.int64)
    for k, (s_al, b_al, n_al), (rep, b_rep, n_rep) in placements(g, sched):
        for lo, b, n in ((s_al.astype(np.int64), b_al, n_al), (rep, b_rep, n_rep)):
            ch = (bed[lo] >= 0) & ((bed[lo] != b) | (ndl[lo] != n))
            if np.any(ch):
                yield k, lo[ch], bed[lo[ch]], ndl[lo[ch]], b[ch], n[ch]
            bed[lo], ndl[lo] = b, n


def loop_moves(g: StitchGraph, sched: Schedule) -> tuple[int, int]:
    """(roll, shift): how many times a loop changes bed, and changes needle, between its
    successive places on the bed (each slice that represents it, and its alignments)."""
    roll = shift = 0
    for _k, _lo, bf, nf, bt, nt in moves(g, sched):
        roll += int(np.count_nonzero(bf != bt))
        shift += int(np.count_nonzero(nf != nt))
    return roll, shift


def knit_slices(sched: Schedule, n_stitches: int) -> np.ndarray:
    """Per stitch the slice that knits it (its ACTIVE entry; -1 if none)."""
    sl = sched.slices
    out = np.full(n_stitches, -1, np.int64)
    act = sl.state == ACTIVE
    out[sl.stitch[act]] = np.repeat(np.arange(sl.n_slices), sl.length)[act]
    return out


def knit_positions(sched: Schedule, n_stitches: int) -> tuple[np.ndarray, np.ndarray]:
    """(bed, needle) per stitch where it is knitted: its ACTIVE entry (-1 if none; with
    double tracing, the last one)."""
    sl = sched.slices
    bed = np.full(n_stitches, -1, np.int8)
    needle = np.full(n_stitches, -1, np.int32)
    act = sl.state == ACTIVE
    bed[sl.stitch[act]] = sched.bed[act]
    needle[sl.stitch[act]] = sched.needle[act]
    return bed, needle


def carriage_directions(sched: Schedule, stitch: np.ndarray, yarn: np.ndarray) -> np.ndarray:
    """The carriage direction (+1 rightward) at each trace visit (`stitch`, `yarn`) on the
    needles the schedule knits it on. The trace's own directions are the design frame's; a
    layout may lay a ring rotated or a row mirrored, and the carriage follows the needles.

    Along a bed, a visit takes the way the yarn came to it from the previous visit. A visit
    on the other bed (a fold) takes the way along its new bed to the next visit, so each
    bed of a tube is knitted in one pass; but where that would send the carriage back over
    the needle it just left in the same direction (a zigzag across the beds), it takes the
    way the yarn came instead. Positions are front-bed needles at racking 0 (back needle k
    faces front needle k); a yarn that never moves goes rightward."""
    n = stitch.shape[0]
    out = np.ones(n, np.int8)
    if n == 0:
        return out
    bed, needle = knit_positions(sched, int(stitch.max()) + 1)
    order = np.lexsort((np.arange(n), yarn))
    st, yn = stitch[order], yarn[order]
    x, b = needle[st].astype(np.int64), bed[st]
    ar = np.arange(n)
    same_yarn = np.r_[False, yn[1:] == yn[:-1]]
    came = np.zeros(n, np.int64)  # the way from the previous visit of the yarn
    came[1:] = np.sign(x[1:] - x[:-1])
    came[~same_yarn] = 0
    along = same_yarn & np.r_[False, b[1:] == b[:-1]]
    step = np.where(along, came, 0)
    ends = np.r_[~same_yarn[1:], True]
    starts = ~same_yarn
    group_end = np.minimum.accumulate(np.where(ends, ar, n)[::-1])[::-1]
    group_start = np.maximum.accumulate(np.where(starts, ar, 0))
    nxt = np.minimum.accumulate(np.where(step != 0, ar, n)[::-1])[::-1]
    prv = np.maximum.accumulate(np.where(step != 0, ar, -1))
    from_next = np.where(nxt <= group_end, step[np.minimum(nxt, n - 1)], 0)
    from_prev = np.where(prv >= group_start, step[np.maximum(prv, 0)], 0)
    d = np.where(
        step != 0, step, np.where(from_next != 0, from_next, np.where(from_prev != 0, from_prev, 1))
    )
    after = np.r_[step[1:], 0] * ~ends  # the next move, when it is along this visit's bed
    for i in np.flatnonzero(~along & same_yarn).tolist():  # the folds, in order
        nm, arr = int(after[i]), int(came[i])
        if nm and (arr == 0 or nm == arr or int(d[i - 1]) != nm):
            d[i] = nm
        elif arr:
            d[i] = arr
    out[order] = d.astype(np.int8)
    return out


# ---- verifier ---------------------------------------------------------------------------------


def verify(g: StitchGraph, sched: Schedule) -> list[str]:
    """Invariants of a schedule (module docstring); empty = valid."""
    sl = sched.slices
    problems: list[str] = []
    ns, ne = sl.n_slices, sl.stitch.shape[0]
    per_slice = (
        "kind",
        "nibble",
        "roll",
        "main",
        "side",
        "spread",
        "mirror",
        "reuse",
        "offset",
        "step",
    )
    if any(getattr(sched, f).shape != (ns,) for f in per_slice) or any(
        getattr(sched, f).shape != (ne,) for f in ("bed", "rel", "needle")
    ):
        return ["schedule arrays disagree with the slices in length"]
    for k in range(ns):
        a, n = int(sl.start[k]), int(sl.length[k])
        want = layout(
            int(sched.kind[k]),
            n,
            int(sched.nibble[k]),
            int(sched.roll[k]),
            int(sched.main[k]),
            int(sched.side[k]),
            int(sched.spread[k]),
            int(sched.mirror[k]),
        )
        if not (
            np.array_equal(want[0], sched.bed[a : a + n])
            and np.array_equal(want[1], sched.rel[a : a + n])
        ):
            problems.append(f"slice {k}: the layout is not the one its parameters name")
            break
        if bool(sched.kind[k] == CIRCULAR) != bool(sl.circular[k]):
            problems.append(
                f"slice {k}: a {KIND_NAMES[int(sched.kind[k])]} layout for a "
                f"{'ring' if sl.circular[k] else 'flat cycle'}"
            )
            break
        r = sched.rel[a : a + n].astype(np.int64)
        d = np.abs(np.diff(np.r_[r, r[:1]] if sl.circular[k] else r))
        if d.size and d.max() > 1:
            problems.append(f"slice {k}: consecutive entries more than one needle apart")
            break
    soe = np.repeat(np.arange(ns), sl.length)
    step = sched.step[soe].astype(np.int64)
    half = step == 2
    want = sched.offset[soe].astype(np.int64) + sched.rel * step + (sched.bed == BACK) * half
    if np.any(want != sched.needle):
        problems.append("physical needles are not the expansion of the relative ones")
    if np.any(half & (sched.needle % 2 != sched.bed)):
        problems.append("a half-gauge loop is not on its bed's parity (front even, back odd)")
    if ne and (sched.needle.min() < 0 or sched.needle.max() >= sched.needles):
        problems.append(f"a needle is off the bed of {sched.needles}")
    if np.any(np.diff(sched.align_slice) < 0):
        problems.append("alignment records are not sorted by slice")
        return problems
    problems += _verify_occupancy(g, sched)
    return problems


def _verify_occupancy(g: StitchGraph, sched: Schedule) -> list[str]:
    """No two loops on one needle at one time: the entries of each slice, and the loops held
    outside it (at their last place, or where an alignment moved them)."""
    sl = sched.slices
    ns = sl.n_slices
    loops = held_loops(g, sl)
    width = int(max(sched.needles, sched.width, int(sched.align_needle.max(initial=0)) + 1))
    soe = np.repeat(np.arange(ns, dtype=np.int64), sl.length)
    key_e = (soe * 2 + sched.bed) * width + sched.needle
    # expand the holds to (loop, slice) items
    span = (loops.cons - loops.src - 1).astype(np.int64)
    idx = np.repeat(np.arange(span.shape[0]), span)
    first = np.cumsum(span) - span
    row = loops.src[idx] + 1 + (np.arange(idx.shape[0]) - first[idx])
    hs = loops.stitch[idx].astype(np.int64)
    hb = sched.bed[loops.src_entry[idx]].astype(np.int64)
    hn = sched.needle[loops.src_entry[idx]].astype(np.int64)
    problems: list[str] = []
    if sched.align_slice.size:
        rk = sched.align_stitch.astype(np.int64) * (ns + 1) + sched.align_slice
        o = np.argsort(rk, kind="stable")
        rk = rk[o]
        ik = hs * (ns + 1) + row
        found = np.isin(rk, ik)
        if not np.all(found):
            j = o[int(np.flatnonzero(~found)[0])]
            problems.append(
                f"alignment of stitch {int(sched.align_stitch[j])} before slice "
                f"{int(sched.align_slice[j])} moves a loop that is not held there"
            )
        at = np.searchsorted(rk, ik, side="right") - 1
        ok = at >= 0
        atc = np.maximum(at, 0)
        ok &= (rk[atc] // (ns + 1) == hs) & (rk[atc] % (ns + 1) > loops.src[idx])
        hb = np.where(ok, sched.align_bed[o][atc], hb)
        hn = np.where(ok, sched.align_needle[o][atc], hn)
    if np.any((hn < 0) | (hn >= sched.needles)):
        problems.append("a held loop is off the bed")
    # loops stacked on one entry (a decrease's two parents) travel together: count them once
    src = loops.src_entry[idx]
    key_h = (row * 2 + hb) * width + hn
    uniq_h = np.unique(np.stack([key_h, src], 1), axis=0)[:, 0] if key_h.size else key_h
    keys = np.concatenate([key_e, uniq_h])
    u, c = np.unique(keys, return_counts=True)
    if np.any(c > 1):
        bad = int(u[np.argmax(c > 1)])
        k, rest = divmod(bad, 2 * width)
        problems.append(f"slice {k}: two loops on needle {'fb'[rest // width]}{rest % width}")
    return problems


# ---- stable JSON --------------------------------------------------------------------------


def layout_json(sched: Schedule, k: int) -> dict[str, Any]:
    n = int(sched.slices.length[k])
    if sched.kind[k] == CIRCULAR:
        return {
            "kind": "circular",
            "nibble": nibble_name(n, int(sched.nibble[k])),
            "roll": int(sched.roll[k]),
        }
    return {
        "kind": "flat",
        "main": int(sched.main[k]),
        "side": "fb"[int(sched.side[k])],
        "spread": SPREADS[int(sched.spread[k])],
        "mirror": bool(sched.mirror[k]),
    }


def to_json(g: StitchGraph, sched: Schedule) -> dict[str, Any]:
    """The dump of `knitc --emit schedule`: stats first (with the loop moves), then one
    record per slice (its layout, offset and each cycle entry as [stitch, state, needle])
    and the alignments."""
    sl = sched.slices
    out = []
    for k in range(sl.n_slices):
        st, state, bed, needle = positions(sched, k)
        out.append(
            {
                "id": k,
                "node": g.node_names[int(sl.node[k])],
                "layout": layout_json(sched, k),
                "reuse": bool(sched.reuse[k]),
                "offset": int(sched.offset[k]),
                "gauge": int(sched.step[k]),
                "cycle": [
                    [int(s), STATE_NAMES[int(x)][0], f"{'fb'[int(b)]}{int(n)}"]
                    for s, x, b, n in zip(st, state, bed, needle, strict=True)
                ],
            }
        )
    al = [
        {"slice": int(k), "stitch": int(s), "to": f"{'fb'[int(b)]}{int(n)}"}
        for k, s, b, n in zip(
            sched.align_slice, sched.align_stitch, sched.align_bed, sched.align_needle, strict=True
        )
    ]
    roll, shift = loop_moves(g, sched)
    stats = {**sched.stats(), "moves_roll": roll, "moves_shift": shift}
    return {"stats": stats, "slices": out, "alignments": al}
