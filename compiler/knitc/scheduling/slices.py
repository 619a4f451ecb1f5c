"""The bed-slice IR: the trace cut into local snapshots of the needle bed (thesis ch. 6.7.1).

A slice is one step of time for code generation: a run of consecutive trace visits (its
*active* stitches, knitted by one yarn in one direction) together with the cycle of
stitches on the bed around them in their region (at an interface it reaches into the
next node's first course), each in one of three states:

- EXPECTED: a stitch whose previous wales' loops are on the bed, waiting to be knitted;
- ACTIVE: knitted in this slice (exactly the slice's visits);
- SUSPENDED: a stitch already knitted whose loop stays on its needle, held: a decreasing
  stitch until the stitch it merges into is knitted, a stitch whose next wales are in
  another gauge until the slice of that gauge takes it (`waiting`), and a stitch that ends
  until its course is cast off (`derive`).

Slices are stored as parallel numpy arrays (one row per slice) plus one flat array of
cycle entries (`stitch`, `state`), where slice k owns entries `start[k] : start[k] +
length[k]`, in counter-clockwise order (flat cycles left to right; rings front left to
right, then back right to left). Slice k's active visits are trace visits `visit[k] :
visit[k] + visits[k]`; slices tile the trace in order.

A slice is *fresh* (the first of a region: its cycle is built from the stitch graph) or
*derived* from an earlier slice of the same node, `derived_from[k]`, by `derive` and then
merges: a merge puts the decrease stitch in place of its two SUSPENDED parents (at the
first of them in cycle order) and makes it ACTIVE.

Counting shaping: a stitch with two next wales is one increase, a stitch with two
previous wales one decrease (the merge), so each shaping event counts once, in the slice
that knits its splitting or merged stitch (`stitch_shaping`); folds (a flat course opening
into a tube or a tube collapsing into a flat course) and gauge changes do not count.

A slice is `circular` when its cycle lies on both beds (a ring), else a flat cycle laid
left to right.

Invariants (`verify`): every trace visit is active in exactly one slice; a slice has one
yarn, one direction, one node and one gauge, and its active stitches share their cast-on
needs (no previous wale) and cast-off needs (no next wale), recorded in `cast_on` /
`cast_off`; no two wale-connected stitches and no stitch twice in one cycle; `shaping`
counts the active increases and decreases and stays within `limit` (a one-visit slice may
exceed it: it cannot be cut further); every entry is on the bed when its slice starts
(previous wales finished; EXPECTED entries not finished, SUSPENDED ones finished
decreasing stitches); cycles are exactly `fresh_cycle` of the first visit (fresh slices)
or `derive` of their source (derived ones), plus the slice's activations and merges.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from knitc.records import record
from knitc.scheduling.trace import Trace
from knitc.shaping.stitch_graph import COURSE_KINDS, StitchGraph

EXPECTED, ACTIVE, SUSPENDED = 0, 1, 2
STATE_NAMES = ("expected", "active", "suspended")


@record
class Slices:
    """The bed-slice IR (this module's docstring): per-slice arrays, then the flat cycle
    entries every slice owns a run of."""

    # per slice
    node: np.ndarray  # int32: the node every active stitch belongs to
    yarn: np.ndarray  # int16: the yarn knitting the active stitches
    dir: np.ndarray  # int8: carriage direction of the active visits (+1 / -1)
    fresh: np.ndarray  # bool: a fresh slice (first of a region) rather than a derived one
    circular: np.ndarray  # bool: the cycle lies on both beds: a ring
    visit: np.ndarray  # int64: first active trace visit
    visits: np.ndarray  # int32: number of active visits
    start: np.ndarray  # int64: first cycle entry
    length: np.ndarray  # int32: cycle entries
    shaping: np.ndarray  # int32: increases + decreases among the active stitches
    limit: np.ndarray  # int32: the shaping limit the slice was cut with (from its cycle as
    # it opened: a ring's limit even if merges leave it on one bed)
    cast_on: np.ndarray  # bool: the active stitches need a cast-on (no previous wale)
    cast_off: np.ndarray  # bool: the active stitches need a cast-off (no next wale)
    gauge: np.ndarray  # int8: course gauge of the active stitches (1 full, 2 half)
    derived_from: np.ndarray  # int64: the slice this one was derived from; -1 if fresh
    # per cycle entry
    stitch: np.ndarray  # int32
    state: np.ndarray  # uint8: EXPECTED / ACTIVE / SUSPENDED

    @property
    def n_slices(self) -> int:
        return int(self.node.shape[0])

    def cycle(self, k: int) -> tuple[np.ndarray, np.ndarray]:
        """(stitches, states) of slice k, in cycle order."""
        a = int(self.start[k])
        b = a + int(self.length[k])
        return self.stitch[a:b], self.state[a:b]

    def stats(self) -> dict[str, Any]:
        counts = np.bincount(self.state, minlength=3) if self.state.size else np.zeros(3, int)
        return {
            "slices": self.n_slices,
            "fresh": int(np.count_nonzero(self.fresh)),
            "entries": int(self.stitch.shape[0]),
            **{STATE_NAMES[i]: int(counts[i]) for i in range(3)},
            "shaping": int(self.shaping.sum()) if self.n_slices else 0,
        }


# ---- stitch properties the slicing rules use (shared by the pass and the verifier) ----------


def stitch_shaping(g: StitchGraph) -> np.ndarray:
    """Per stitch: 1 for an increase (two next wales), 1 for a decrease (two previous
    wales), so each shaping event counts once (int8; 2 for a stitch that is both).

    Folds are not shaping: a flat course opening into a tube (each stitch's two children on
    the two beds) or a tube closing into a flat course (each stitch merging a front and a
    back loop, a collapse closing) moves every loop straight across the beds, nothing
    stretches along a bed; nor is the 1:2 spread (or 2:1 gather) of a gauge change, where
    half-gauge loops meet full-gauge ones needle for needle. Cutting such a course into limited slices would leave half a
    closing waiting while the ring it belongs to is already zipped, which no layout of a
    ring can describe."""
    n_next = (g.wale_next >= 0).sum(1)
    n_prev = (g.wale_prev >= 0).sum(1)
    inc, dec = n_next == 2, n_prev == 2
    circ = g.course_circular[g.course]
    k0, k1 = np.maximum(g.wale_next[:, 0], 0), np.maximum(g.wale_next[:, 1], 0)
    opening = inc & ~circ & circ[k0] & (g.side[k0] != g.side[k1])
    p0, p1 = np.maximum(g.wale_prev[:, 0], 0), np.maximum(g.wale_prev[:, 1], 0)
    closing = dec & ~circ & circ[p0] & (g.side[p0] != g.side[p1])
    # a gauge change spreads loops 1:2 (or gathers them 2:1) without stretching either
    gauge = g.course_gauge[g.course]
    spread = inc & (gauge[k0] != gauge)
    gather = dec & (gauge[p0] != gauge)
    return (inc & ~opening & ~spread).astype(np.int8) + (dec & ~closing & ~gather).astype(np.int8)


def decreasing(g: StitchGraph) -> np.ndarray:
    """Per stitch: a single next wale, and that stitch has two previous wales (ch. 6.7.1,
    footnote 3): its loop waits, SUSPENDED, until the merge is knitted."""
    n_next = (g.wale_next >= 0).sum(1)
    child = g.wale_next.max(1)  # the one next wale where there is exactly one
    out = np.zeros(g.n_stitches, bool)
    one = n_next == 1
    out[one] = (g.wale_prev[child[one]] >= 0).sum(1) == 2
    return out


def waiting(g: StitchGraph) -> np.ndarray:
    """Per stitch: whether its loop waits SUSPENDED once knitted, instead of giving way to
    its next wales in the cycle: a decreasing stitch (`decreasing`), and a stitch whose next
    wales are in a course of another gauge. A cycle mixing the two gauges would lay the
    finer loops out in the coarser spacing (or the other way round); so the loops of the
    last course before a gauge change stay as they are, and the other gauge's slice starts
    fresh from them. (A fresh cycle is always of its own stitch's gauge: there only
    `decreasing` stitches wait.)"""
    out = decreasing(g)
    kid = g.wale_next.max(1)
    has = kid >= 0
    gauge = g.course_gauge[g.course]
    out[has] |= gauge[kid[has]] != gauge[has]
    return out


def ccw_courses(g: StitchGraph) -> np.ndarray:
    """Per course: whether its yarn order runs counter-clockwise (left to right on the
    front bed, right to left on the back). Decided by the majority of steps between course
    neighbours on one bed; a course without such a step counts as counter-clockwise."""
    ids = np.arange(g.n_stitches)
    j = g.cnext
    ok = j >= 0
    jj = np.where(ok, j, 0)
    ok &= (g.side[jj] == g.side) & (g.needle[jj] != g.needle)
    step = np.sign(g.needle[jj].astype(np.int64) - g.needle) * (1 - 2 * g.side.astype(np.int64))
    votes = np.bincount(g.course[ids[ok]], weights=step[ok], minlength=g.n_courses)
    return votes >= 0


def ccw_kids(g: StitchGraph, ccw: np.ndarray | None = None) -> np.ndarray:
    """Per stitch its next wales, packed to the front and in counter-clockwise order (the
    order they take in a derived cycle). Two children of an increase are course neighbours;
    their course's orientation decides which comes first."""
    if ccw is None:
        ccw = ccw_courses(g)
    k = g.wale_next.copy()
    swap_pack = (k[:, 0] < 0) & (k[:, 1] >= 0)
    k[swap_pack] = k[swap_pack][:, ::-1]
    two = np.flatnonzero(k[:, 1] >= 0)
    a, b = k[two, 0], k[two, 1]
    forward = ccw[g.course[a]]
    a_first = np.where(
        g.cnext[a] == b, forward, np.where(g.cnext[b] == a, ~forward, (a < b) == forward)
    )
    # A fold (a flat course closing a tube: collapse) gives each stitch one child on each
    # bed; the child on the parent's own bed comes first, the other one goes round the back.
    fold = g.side[a] != g.side[b]
    a_first = np.where(fold, g.side[a] == g.side[two], a_first)
    k[two] = np.where(a_first[:, None], np.stack([a, b], 1), np.stack([b, a], 1))
    return k


def folds(g: StitchGraph, kids: np.ndarray) -> np.ndarray:
    """Per stitch: its two next wales are on different beds (see `ccw_kids`)."""
    out = np.zeros(g.n_stitches, bool)
    two = np.flatnonzero(kids[:, 1] >= 0)
    out[two] = g.side[kids[two, 0]] != g.side[kids[two, 1]]
    return out


def course_cycle(g: StitchGraph, c: int, ccw: np.ndarray) -> np.ndarray:
    """The stitches of course c in cycle order: counter-clockwise, and a ring starting at
    its leftmost front stitch (front left to right, then back right to left). A flat course
    on both beds (a zigzag closing, whose yarn alternates front and back needles) lies on
    the bed as the ring it closes, so its cycle is that ring's order."""
    ids = g.course_ids(c)
    sides = g.side[ids]
    if (
        not g.course_circular[c]
        and 0 < int(sides.sum()) < ids.size
        and np.count_nonzero(np.diff(sides)) > 1
    ):
        front, back = ids[sides == 0], ids[sides == 1]
        return np.concatenate(
            [
                front[np.argsort(g.needle[front], kind="stable")],
                back[np.argsort(-g.needle[back], kind="stable")],
            ]
        )
    if not ccw[c]:
        ids = ids[::-1]
    if g.course_circular[c]:
        front = np.flatnonzero(g.side[ids] == 0)
        if front.size and front.size < ids.size:
            first = front[np.argmin(g.needle[ids[front]])]
            ids = np.roll(ids, -int(first))
    return ids


def derive(
    kids: np.ndarray,
    dec: np.ndarray,
    st: np.ndarray,
    state: np.ndarray,
    done: np.ndarray,
    passes: int,
    fold: np.ndarray | None = None,
    course: np.ndarray | None = None,
    holding: int = -1,
) -> tuple[np.ndarray, np.ndarray]:
    """The cycle derived from (st, state), thesis ch. 6.7.1 "Slice Derivation":
    EXPECTED entries stay; decreasing stitches, ACTIVE or SUSPENDED, become SUSPENDED;
    other ACTIVE stitches are replaced by their 0, 1 or 2 next wales (in `kids` order) as
    EXPECTED. `done[s]`: visits stitch s has had so far, out of `passes`. Two refinements
    keep the cycle true to the bed: an ACTIVE stitch with a visit still to come (double
    tracing) stays EXPECTED, and a stitch to be EXPECTED that is already finished (knitted
    by another region of an interleaved trace) is dropped. Entries of any other state value
    are dropped (the pass's scratch marks). A folding stitch (`fold`, see `folds`) keeps its
    first child in place and sends the second to the end of the cycle, in reverse order of
    the parents: a flat course opening into a tube becomes a ring, front then back.

    A finished stitch with no next wale of course `holding` (`course[s]`: the course whose
    visits the new slice continues) stays SUSPENDED: its loop is on its needle until the
    course is cast off, at its end, so later slices of the course must leave it room; in a
    slice of another course it is gone."""
    fin = done[st] >= passes
    act = state == ACTIVE
    k = kids[st]
    ending = (k[:, 0] < 0) & (k[:, 1] < 0)
    held = np.zeros(st.shape[0], bool) if course is None else ending & fin & (course[st] == holding)
    stay = ((state == EXPECTED) & ~fin) | (act & ~fin)
    susp = ((state == SUSPENDED) & (~ending | held)) | (act & fin & (dec[st] | held))
    repl = act & fin & ~dec[st] & ~held
    cand = np.stack([np.where(repl, k[:, 0], st), np.where(repl, k[:, 1], -1)], 1)
    cstate = np.stack(
        [np.where(susp, SUSPENDED, EXPECTED), np.full(st.shape[0], EXPECTED)], 1
    ).astype(np.uint8)
    open_kid = (k >= 0) & (done[np.maximum(k, 0)] < passes)
    valid = np.stack([stay | susp | (repl & open_kid[:, 0]), repl & open_kid[:, 1]], 1)
    if fold is not None and (repl & fold[st]).any():
        back = repl & fold[st] & valid[:, 1]
        valid[:, 1] &= ~back
        tail_st, tail_state = cand[back, 1][::-1], cstate[back, 1][::-1]
    else:
        tail_st = tail_state = np.zeros(0, np.int32)
    flat = valid.ravel()
    return (
        np.concatenate([cand.ravel()[flat], tail_st]).astype(np.int32),
        np.concatenate([cstate.ravel()[flat], tail_state]).astype(np.uint8),
    )


def fresh_cycle(
    g: StitchGraph,
    ccw: np.ndarray,
    kids: np.ndarray,
    dec: np.ndarray,
    s: int,
    done: np.ndarray,
    passes: int,
    fold: np.ndarray | None = None,
    holding: int = -1,
) -> tuple[np.ndarray, np.ndarray]:
    """The cycle a fresh slice opened on stitch s starts from: the course of s (for a short
    row or continuity stitch, the course of its previous wale: those are not rows of the
    bed) as the yarn finds it, i.e. `derive` of that course with every stitch ACTIVE.
    Unfinished stitches stay EXPECTED; finished ones give way to their next wales, or stay
    SUSPENDED if decreasing. A course nobody has knitted yet is simply all EXPECTED."""
    c = int(g.course[s])
    p = int(g.wale_prev[s].max())
    if COURSE_KINDS[int(g.course_kind[c])] in ("short_row", "continuity") and p >= 0:
        c = int(g.course[p])
    st = course_cycle(g, c, ccw)
    return derive(
        kids, dec, st, np.full(st.shape[0], ACTIVE, np.uint8), done, passes, fold, g.course, holding
    )


def holding_course(g: StitchGraph, t: Trace, v: int) -> int:
    """The course a slice opening at visit `v` continues (its ending loops are still on the
    needles, `derive`), or -1 when visit v starts a run of its course."""
    c = int(g.course[t.stitch[v]])
    return c if v > 0 and int(g.course[t.stitch[v - 1]]) == c else -1


# ---- verifier ---------------------------------------------------------------------------------


def verify(g: StitchGraph, t: Trace, sl: Slices) -> list[str]:
    """Invariants of a slicing of trace `t` over graph `g` (module docstring); empty = valid."""
    problems: list[str] = []
    k = sl.n_slices
    if k == 0:
        return [] if t.n_visits == 0 else ["no slices for a non-empty trace"]
    fields = (
        "node",
        "yarn",
        "dir",
        "fresh",
        "circular",
        "visit",
        "visits",
        "start",
        "length",
        "shaping",
        "limit",
        "cast_on",
        "cast_off",
        "gauge",
        "derived_from",
    )
    if any(getattr(sl, f).shape != (k,) for f in fields) or sl.state.shape != sl.stitch.shape:
        return ["slice arrays disagree in length"]
    ends = sl.visit + sl.visits
    if sl.visit[0] != 0 or ends[-1] != t.n_visits or np.any(sl.visit[1:] != ends[:-1]):
        problems.append("slices do not tile the trace visits in order")
        return problems
    if np.any(sl.visits <= 0):
        problems.append(f"slice {int(np.nonzero(sl.visits <= 0)[0][0])} has no active visit")
        return problems
    cends = sl.start + sl.length
    if sl.start[0] != 0 or cends[-1] != sl.stitch.shape[0] or np.any(sl.start[1:] != cends[:-1]):
        problems.append("cycle entries do not tile the entry array")
        return problems
    n = g.n_stitches
    if sl.stitch.size and (sl.stitch.min() < 0 or sl.stitch.max() >= n):
        return ["a cycle entry is not a stitch of the graph"]
    if np.any(sl.state > SUSPENDED):
        return ["a cycle entry has an unknown state"]
    if np.any(sl.length <= 0):
        return [f"slice {int(np.nonzero(sl.length <= 0)[0][0])} has an empty cycle"]
    slice_of_visit = np.repeat(np.arange(k), sl.visits)
    slice_of_entry = np.repeat(np.arange(k), sl.length)
    back = g.side[sl.stitch] == 1
    on_back = np.add.reduceat(back.astype(np.int64), sl.start)
    ring = (on_back > 0) & (on_back < sl.length)
    if np.any(ring != sl.circular):
        problems.append(
            f"slice {int(np.nonzero(ring != sl.circular)[0][0])} is marked "
            "circular but its cycle is not on both beds, or the other way round"
        )
    vs = t.stitch
    n_prev = (g.wale_prev >= 0).sum(1)
    n_next = (g.wale_next >= 0).sum(1)
    per_visit = (
        ("yarn", t.yarn, sl.yarn),
        ("direction", t.dir, sl.dir),
        ("node", g.node[vs], sl.node),
        ("gauge", g.course_gauge[g.course[vs]], sl.gauge),
        ("cast-on need", n_prev[vs] == 0, sl.cast_on),
        ("cast-off need", n_next[vs] == 0, sl.cast_off),
    )
    for name, arr, per in per_visit:
        bad = arr != per[slice_of_visit]
        if np.any(bad):
            v = int(np.nonzero(bad)[0][0])
            problems.append(f"visit {v} has another {name} than its slice {int(slice_of_visit[v])}")
    key_all = slice_of_entry.astype(np.int64) * (n + 1) + sl.stitch
    srt = np.sort(key_all)
    if np.any(srt[1:] == srt[:-1]):
        problems.append("a cycle holds a stitch twice")
    # every active visit appears as an ACTIVE entry of its slice, and nothing else is ACTIVE
    act = sl.state == ACTIVE
    got = np.sort(key_all[act])
    want = np.sort(slice_of_visit.astype(np.int64) * (n + 1) + vs)
    if not np.array_equal(got, want):
        problems.append("the ACTIVE entries of the slices are not exactly their visits")
    # no two wale-connected stitches in one slice
    for j in (0, 1):
        p = g.wale_prev[sl.stitch, j]
        has = p >= 0
        key = slice_of_entry[has].astype(np.int64) * (n + 1) + p[has]
        if key.size and np.any(srt[np.minimum(np.searchsorted(srt, key), srt.size - 1)] == key):
            problems.append("a slice holds two wale-connected stitches")
            break
    shp = np.bincount(slice_of_visit, weights=stitch_shaping(g)[vs], minlength=k)
    if np.any(shp != sl.shaping):
        problems.append(f"slice {int(np.nonzero(shp != sl.shaping)[0][0])} miscounts its shaping")
    over = (sl.shaping > sl.limit) & (sl.visits > 1)
    if np.any(over):
        problems.append(f"slice {int(np.nonzero(over)[0][0])} shapes more than its limit")
    if not sl.fresh[0]:
        problems.append("the first slice is not fresh")
    if problems:
        return problems
    problems += _verify_cycles(g, t, sl)
    return problems


def _verify_cycles(g: StitchGraph, t: Trace, sl: Slices) -> list[str]:
    """Slice by slice in trace order: entries are on the bed at the slice's start, cycles
    follow `fresh_cycle` or `derive` plus merges, and derivation stays within a node."""
    n = g.n_stitches
    done = np.zeros(n, np.int32)  # visits so far
    ccw = ccw_courses(g)
    kids, dec, merging = ccw_kids(g, ccw), waiting(g), decreasing(g)
    fold = folds(g, kids)
    last_of_node: dict[int, int] = {}
    for k in range(sl.n_slices):
        st, state = sl.cycle(k)
        where = f"slice {k}"
        p = g.wale_prev[st]
        if np.any((p >= 0) & (done[np.maximum(p, 0)] < t.passes)):
            return [f"{where} holds a stitch whose previous wale is not finished"]
        if np.any(done[st[state == EXPECTED]] >= t.passes):
            return [f"{where} expects a stitch that is already finished"]
        sus = st[state == SUSPENDED]
        holding = holding_course(g, t, int(sl.visit[k]))
        ending = (g.wale_next[sus] < 0).all(1) & (g.course[sus] == holding)
        if np.any((done[sus] < t.passes) | ~(dec[sus] | ending)):
            return [f"{where} suspends a stitch that is not a finished waiting stitch"]
        src = int(sl.derived_from[k])
        if sl.fresh[k] != (src < 0):
            return [f"{where} is fresh and derived at once, or neither"]
        if src >= 0:
            if src != last_of_node.get(int(sl.node[k]), -1):
                return [f"{where} is not derived from the last slice of its node"]
            base = derive(kids, dec, *sl.cycle(src), done, t.passes, fold, g.course, holding)
            what = f"the cycle derived from slice {src}"
        else:
            base = fresh_cycle(
                g, ccw, kids, merging, int(t.stitch[sl.visit[k]]), done, t.passes, fold, holding
            )
            what = "the fresh cycle of its first stitch"
        problem = _check_cycle(g, *base, st, state)
        if problem:
            return [f"{where} {problem.format(what)}"]
        last_of_node[int(sl.node[k])] = k
        a = int(sl.visit[k])
        np.add.at(done, t.stitch[a : a + int(sl.visits[k])], 1)
    return []


def _check_cycle(
    g: StitchGraph, dst: np.ndarray, dstate: np.ndarray, st: np.ndarray, state: np.ndarray
) -> str | None:
    """None if (st, state) is the base cycle (dst, dstate) with the slice's activations and
    merges applied; else a message with `{}` for the base's name."""
    dst, dstate = dst.copy(), dstate.copy()
    keep = np.ones(dst.shape[0], bool)
    extra = st[(state == ACTIVE) & ~np.isin(st, dst)]
    if extra.size:
        order = np.argsort(dst, kind="stable")
        ordered = dst[order]
        for m in extra:
            par = g.wale_prev[m]
            if np.any(par < 0):
                return f"activates stitch {int(m)}, which {{}} does not hold"
            i = np.minimum(np.searchsorted(ordered, par), dst.shape[0] - 1)
            if np.any(ordered[i] != par):
                return f"merges stitch {int(m)} whose parents are not in {{}}"
            lo, hi = sorted(int(x) for x in order[i])
            if dstate[lo] != SUSPENDED or dstate[hi] != SUSPENDED or not keep[lo] or not keep[hi]:
                return f"merges stitch {int(m)} whose parents are not both suspended"
            dst[lo], dstate[lo], keep[hi] = m, ACTIVE, False
    dst, dstate = dst[keep], dstate[keep]
    if not np.array_equal(dst, st):
        return "does not hold {}"
    was = np.where(state == ACTIVE, np.where(dstate == ACTIVE, ACTIVE, EXPECTED), state)
    if not np.array_equal(was, dstate):
        return "changes states that {} does not explain"
    return None


def to_json(g: StitchGraph, sl: Slices) -> dict[str, Any]:
    """The dump of `knitc --emit slices`: stats first, then one record per slice."""
    out = []
    for k in range(sl.n_slices):
        st, state = sl.cycle(k)
        out.append(
            {
                "id": k,
                "node": g.node_names[int(sl.node[k])],
                "yarn": int(sl.yarn[k]),
                "dir": int(sl.dir[k]),
                "fresh": bool(sl.fresh[k]),
                "derived_from": int(sl.derived_from[k]),
                "circular": bool(sl.circular[k]),
                "gauge": int(sl.gauge[k]),
                "cast_on": bool(sl.cast_on[k]),
                "cast_off": bool(sl.cast_off[k]),
                "visits": [int(sl.visit[k]), int(sl.visits[k])],
                "shaping": int(sl.shaping[k]),
                "limit": int(sl.limit[k]),
                "cycle": [[int(s), STATE_NAMES[int(x)][0]] for s, x in zip(st, state, strict=True)],
            }
        )
    return {"stats": sl.stats(), "slices": out}
