"""The yarn-stack IR: which yarns each stitch holds, and how (thesis ch. 6.9.5, Table 6.1).

A stitch's stack is its *front* yarn, the design yarn that shows on the outside of the
fabric (`knit YARN where ...`; `main` elsewhere), and its *back* yarns, each with a mode:

- ``miss``: the yarn passes behind the stitch (a fair isle float, or an inlay yarn lying
  in the fabric);
- ``tuck``: it tucks on the stitch's new loop (a long float caught to the fabric every
  `tuck_every` needles, or an inlay yarn held every `inlay` stitches); the course above
  knits the tuck in;
- ``knit``: it knits the needle behind the stitch on the other bed (a jacquard backing,
  `codegen.backing`). The front yarn itself may knit behind its stitch (the pique
  backing): Table 6.1's "front-back knit".

A yarn absent from a stitch has no entry (mode *none*). Intarsia and stripes change only
the front yarn: a course of one yarn per stitch has no back yarns.

This is the stage where the layers are unified into per-stitch steps per yarn: code
generation knits each course part (a course cut where the schedule's slices begin) in one
pass per yarn, in a fixed order, the course's own yarn first and the others by number, and
reads from the stacks what each yarn does at each stitch of its pass. What it still
decides itself is what depends on the needles as it finds them: an inlay tuck is skipped
on a needle that already holds two loops (thesis: the real tuck is made "based on the tuck
annotations and its safety considering the needle bed state").

The tucks of a float are placed here, so they depend on the needles the schedule knits
each stitch on: a float is caught on a stitch of its course part knitted before the yarn's
pass (its loop is new), on the bed the float runs along, one at least every `tuck_every`
needles, never beside the yarn's next knit (a tuck there would pull it), and only on a
stitch with a course above to knit it in.

Entries are parallel numpy arrays sorted by (stitch, yarn, inlay); a course part finds its
own with two binary searches and a membership test (`in_part`), whatever order the trace
visits its stitches in.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from knitc import arrays
from knitc.codegen.backing import back_knits
from knitc.records import record
from knitc.scheduling import schedule as sc
from knitc.scheduling.trace import Trace
from knitc.shaping.stitch_graph import StitchGraph, two_bed

MISS, TUCK, KNIT = 1, 2, 3
MODE_NAMES = {MISS: "miss", TUCK: "tuck", KNIT: "knit"}
"""Table 6.1's back modes (*none* is the absence of an entry)."""


@record
class YarnStacks:
    """Per stitch its front yarn; per back entry its stitch, yarn, mode and whether the
    yarn is laid in (an inlay yarn, `yarn { inlay: N }`) rather than knitted."""

    front: np.ndarray  # int16 per stitch: the design yarn that shows (0: main)
    stitch: np.ndarray  # int32 per entry
    yarn: np.ndarray  # int16 per entry
    mode: np.ndarray  # uint8 per entry: MISS, TUCK or KNIT
    inlay: np.ndarray  # bool per entry
    backed: np.ndarray  # bool per stitch: a back needle knits behind it (some KNIT entry)

    @property
    def n_entries(self) -> int:
        return int(self.stitch.shape[0])

    def stats(self) -> dict[str, Any]:
        fronts = arrays.unique(self.front).tolist() if self.front.size else []
        out: dict[str, Any] = {"stitches": int(self.front.shape[0]), "front_yarns": fronts}
        for m, name in MODE_NAMES.items():
            out[name] = int(np.count_nonzero((self.mode == m) & ~self.inlay))
        out["inlay"] = int(np.count_nonzero(self.inlay))
        return out

    def in_part(self, stitches: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(entry indices, their stitches' places in `stitches`) of the entries on the
        stitches of a course part, in entry order."""
        if self.n_entries == 0 or stitches.size == 0:
            empty = np.zeros(0, np.int64)
            return empty, empty
        lo = int(np.searchsorted(self.stitch, stitches.min(), "left"))
        hi = int(np.searchsorted(self.stitch, stitches.max(), "right"))
        idx = np.arange(lo, hi)
        order = np.argsort(stitches, kind="stable")
        at = np.searchsorted(stitches[order], self.stitch[idx])
        at = np.minimum(at, stitches.size - 1)
        mine = stitches[order][at] == self.stitch[idx]
        return idx[mine], order[at[mine]]


def part_cuts(g: StitchGraph, t: Trace, sched: sc.Schedule) -> tuple[np.ndarray, np.ndarray]:
    """(cuts, course bounds): the visits where a course or one of the schedule's slices
    begins, and where each course begins (with 0 and the end)."""
    course_cuts = np.nonzero(np.diff(g.course[t.stitch]) != 0)[0] + 1
    cuts = arrays.union(course_cuts, sched.slices.visit[1:])
    return cuts, np.r_[0, course_cuts, t.n_visits]


def course_parts(g: StitchGraph, t: Trace, sched: sc.Schedule) -> list[np.ndarray]:
    """The trace's visits cut where a course or one of the schedule's slices begins: the
    parts code generation knits one after another, each in one pass per yarn."""
    cuts, _ = part_cuts(g, t, sched)
    return [p for p in np.split(np.arange(t.n_visits), cuts) if p.size]


def pass_order(base: int, yarns: set[int]) -> list[int]:
    """The order of the yarns' passes over a course part of several: the course's own yarn
    first, then the others by number (what a float may be caught on depends on it)."""
    return [base] + sorted(yarns - {base})


def stack_yarns(
    g: StitchGraph,
    t: Trace,
    sched: sc.Schedule,
    tuck_every: Sequence[int] = (),
    inlay_every: Sequence[int] = (),
) -> YarnStacks:
    """The stacks of every stitch (see the module docstring). `tuck_every[y]` is yarn y's
    float catching distance (0: none), `inlay_every[y]` its inlay tuck spacing (0: not an
    inlay yarn), as the `yarn` declarations set them."""
    n = g.n_stitches
    if t.passes != 1 and (g.colourwork or (g.inlay is not None and bool(g.inlay.any()))):
        raise ValueError("yarn stacks are made from a single-pass trace (each stitch once)")
    front = np.zeros(n, np.int16) if g.yarn is None else g.yarn.astype(np.int16)
    entries: list[tuple[np.ndarray, int, int, bool]] = []  # (stitches, yarn, mode, inlay)
    backed = np.zeros(n, bool)
    jacquard = two_bed(g.backing) if g.backing is not None else None
    colour = g.yarn is not None and (g.colourwork or (jacquard is not None and jacquard.any()))
    laying = g.inlay is not None and bool(g.inlay.any())
    if colour or laying:
        knit_bed, knit_needle = sc.knit_positions(sched, n)
        positions = (  # (as Python values: the float catches look them up one by one)
            list(zip(knit_bed.tolist(), knit_needle.tolist(), strict=True))
            if colour and any(tuck_every)
            else []
        )
        parts = course_parts(g, t, sched)
        if colour:
            backed = _backed(g, jacquard, knit_bed, knit_needle)
            _floats(g, t, parts, positions, jacquard, backed, knit_needle, tuck_every, entries)
        if laying:
            _inlays(g, t, parts, inlay_every, entries)
    return _build(front, entries, backed)


def _backed(
    g: StitchGraph, jacquard: np.ndarray | None, knit_bed: np.ndarray, knit_needle: np.ndarray
) -> np.ndarray:
    """Per stitch: a jacquard stitch of a course whose every wale goes straight on (one
    child, the child's only parent, on the same needle). Only those get a backing loop: the
    back layer is not shaped, so a course before one that decreases, increases or moves
    (and the last one, before the bind-off) closes its loops onto the front a course early
    (`generate._close_backing`): no needle holds more than two loops, and no backing loop
    is in the way of the shaping's transfers."""
    if jacquard is None or not jacquard.any():
        return np.zeros(g.n_stitches, bool)
    kids = g.wale_next
    one = (kids >= 0).sum(axis=1) == 1
    k = np.where(one, kids.max(axis=1), 0)
    straight = (
        one
        & ((g.wale_prev[k] >= 0).sum(axis=1) == 1)
        & (knit_bed[k] == knit_bed)
        & (knit_needle[k] == knit_needle)
    )
    bent = np.bincount(g.course[~straight], minlength=g.n_courses) > 0
    return jacquard & ~bent[g.course]


def region_yarns(g: StitchGraph) -> dict[int, list[int]]:
    """Per node with jacquard stitches: the yarns of those stitches, ascending (every one
    makes a pass in each of the node's jacquard courses)."""
    assert g.yarn is not None and g.backing is not None
    jacquard = two_bed(g.backing)
    return {
        node: arrays.unique(g.yarn[jacquard & (g.node == node)]).tolist()
        for node in arrays.unique(g.node[jacquard]).tolist()
    }


def _floats(
    g: StitchGraph,
    t: Trace,
    parts: list[np.ndarray],
    positions: list[tuple[int, int]],
    jacquard: np.ndarray | None,
    backed: np.ndarray,
    knit_needle: np.ndarray,
    tuck_every: Sequence[int],
    entries: list[tuple[np.ndarray, int, int, bool]],
) -> None:
    """The back yarns of every course part of several yarns (fair isle) or of a jacquard
    course: the yarns of the part and, in a jacquard course, of its region, each in its
    pass order (the course's yarn first, then by number), with what it does behind each
    stitch it does not show on."""
    assert g.yarn is not None
    course_yarn = g.course_yarn()
    intarsia = course_yarn == len(g.yarn_names)
    jacquard_course = np.zeros(g.n_courses, bool)
    regions: dict[int, list[int]] = {}
    if jacquard is not None and jacquard.any():  # (`two_bed(g.backing)`)
        jacquard_course[g.course[jacquard]] = True
        regions = region_yarns(g)
    in_region = g.node_courses()
    for part in parts:
        stitches = t.stitch[part]
        course = int(g.course[stitches[0]])
        ys = g.yarn[stitches]
        if intarsia[course]:
            continue  # (an intarsia course's stack is its front yarn alone)
        base = int(course_yarn[course])
        if not jacquard_course[course] and not bool((ys != base).any()):
            continue
        yarns = set(ys.tolist())
        region: list[int] = []
        backs: np.ndarray | None = None
        if jacquard_course[course]:
            assert g.backing is not None
            region = regions[int(g.course_node[course])]
            yarns |= set(region)
            backs = back_knits(
                np.where(backed[stitches], g.backing[stitches], 0),
                ys,
                knit_needle[stitches] // g.course_gauge[course],  # (columns, half gauge too)
                np.full(len(stitches), int(in_region[course])),
                region,
            )
        done = np.zeros(len(stitches), bool)  # knitted in this part's earlier passes
        for y in pass_order(base, yarns):
            sel = ys == y
            if backs is not None and y in region:
                knits = backs[region.index(y)]
                entries.append((stitches[knits], y, KNIT, False))
                entries.append((stitches[~knits & ~sel], y, MISS, False))
            elif y != base or bool((~sel).any()):
                every = tuck_every[y] if y < len(tuck_every) else 0
                tucks = (
                    _float_tucks(g, stitches, sel, done, every, positions)
                    if every > 0
                    else np.zeros(0, np.int64)
                )
                behind = ~sel
                behind[tucks] = False
                entries.append((stitches[tucks], y, TUCK, False))
                entries.append((stitches[behind], y, MISS, False))
            done |= sel


def _float_tucks(
    g: StitchGraph,
    stitches: np.ndarray,
    sel: np.ndarray,
    done: np.ndarray,
    every: int,
    positions: list[tuple[int, int]],
) -> np.ndarray:
    """Indices into `stitches` (a course part in pass order) where a fair isle yarn,
    knitting its stitches `sel`, catches its floats: one at least every `every` needles
    along each float between two of its knits, on a stitch knitted already in the part
    (`done`: its loop is new; the tuck rides on it and the course above knits it in), on
    the bed the float runs along, with a course above, and not beside the yarn's next
    knit."""
    at = np.nonzero(sel)[0].tolist()
    out: list[int] = []
    for i, j in zip(at, at[1:], strict=False):
        if j - i - 1 < every:
            continue
        bed, last = positions[int(stitches[i])]
        ahead = positions[int(stitches[j])][1]
        for k in range(i + 1, j):
            s = int(stitches[k])
            b, x = positions[s]
            if (
                abs(x - last) >= every
                and done[k]
                and b == bed
                and g.wale_next[s, 0] >= 0
                and abs(ahead - x) > 1
            ):
                out.append(k)
                last = x
    return np.asarray(out, np.int64)


def _inlays(
    g: StitchGraph,
    t: Trace,
    parts: list[np.ndarray],
    inlay_every: Sequence[int],
    entries: list[tuple[np.ndarray, int, int, bool]],
) -> None:
    """Each inlay yarn behind the stitches it is laid over, tucking on every n-th of them
    counted along the course (so a course knitted in parts keeps the spacing), on a stitch
    with a stitch above that is no decrease (the tuck would go onto its neighbour's loops
    with it)."""
    assert g.inlay is not None
    for part in parts:
        stitches = t.stitch[part]
        laid = g.inlay[stitches]
        start = int(g.course_start[g.course[stitches[0]]])
        for y in sorted(set(laid.tolist()) - {0}):
            n = inlay_every[y] if y < len(inlay_every) and inlay_every[y] > 0 else 1
            mine = stitches[laid == y]
            kid = g.wale_next[mine, 0]
            tuck = ((mine - start) % n == 0) & (kid >= 0)
            tuck &= g.wale_prev[np.where(kid >= 0, kid, 0), 1] < 0
            entries.append((mine[tuck], y, TUCK, True))
            entries.append((mine[~tuck], y, MISS, True))


def _build(
    front: np.ndarray, entries: list[tuple[np.ndarray, int, int, bool]], backed: np.ndarray
) -> YarnStacks:
    """The IR from the entries, sorted by (stitch, yarn, inlay)."""
    parts = [e for e in entries if e[0].size]
    if not parts:
        z = np.zeros(0, np.int64)
        return YarnStacks(
            front,
            z.astype(np.int32),
            z.astype(np.int16),
            z.astype(np.uint8),
            z.astype(bool),
            backed,
        )
    stitch = np.concatenate([e[0] for e in parts]).astype(np.int32)
    yarn = np.concatenate([np.full(e[0].size, e[1], np.int16) for e in parts])
    mode = np.concatenate([np.full(e[0].size, e[2], np.uint8) for e in parts])
    inlay = np.concatenate([np.full(e[0].size, e[3], bool) for e in parts])
    order = np.lexsort((inlay, yarn, stitch))
    return YarnStacks(front, stitch[order], yarn[order], mode[order], inlay[order], backed)


def verify(g: StitchGraph, y: YarnStacks) -> list[str]:
    """The stacks' invariants: one front yarn per stitch, of the design's; entries sorted
    and unique per (stitch, yarn, inlay); a back yarn that shows on the stitch only as the
    pique's front-back knit; knits only behind two-bed backed stitches, and every backed
    stitch knitted behind; tucks only on stitches with a course above."""
    out: list[str] = []
    n = g.n_stitches
    names = max(len(g.yarn_names), 1)
    if y.front.shape != (n,) or y.backed.shape != (n,):
        return [f"stacks for {y.front.shape[0]} stitches, graph has {n}"]
    if g.yarn is not None and not (y.front == g.yarn).all():
        out.append("a front yarn that is not the stitch's yarn")
    if y.n_entries and (int(y.yarn.min()) < 0 or int(y.yarn.max()) >= names):
        out.append("a back yarn outside the design's yarns")
        return out
    if y.n_entries == 0:
        if y.backed.any():
            out.append("a backed stitch with no back knit")
        return out
    if int(y.stitch.min()) < 0 or int(y.stitch.max()) >= n:
        out.append("an entry on no stitch")
        return out
    key = (y.stitch.astype(np.int64) * names + y.yarn) * 2 + y.inlay
    if (np.diff(key) <= 0).any():
        out.append("entries not sorted, or two for one stitch, yarn and kind")
    if not np.isin(y.mode, list(MODE_NAMES)).all():
        out.append("an entry of an unknown mode")
    shows = (y.yarn == y.front[y.stitch]) & ~y.inlay
    if (shows & (y.mode != KNIT)).any():
        out.append("a stitch's front yarn floats or tucks behind it")
    knit = y.mode == KNIT
    if (knit & (y.inlay | ~y.backed[y.stitch])).any():
        out.append("a back knit behind a stitch with no backing")
    has_knit = np.zeros(n, bool)
    has_knit[y.stitch[knit]] = True
    if (y.backed & ~has_knit).any():
        out.append("a backed stitch with no back knit")
    tucks = y.stitch[y.mode == TUCK]
    if (g.wale_next[tucks, 0] < 0).any():
        out.append("a tuck on a stitch with no course above to knit it in")
    return out


def to_json(g: StitchGraph, y: YarnStacks) -> dict[str, Any]:
    """The dump of `knitc --emit yarn-stack`: stats, the yarn names, then every stitch
    whose stack is more than its front yarn (its back yarns and their modes); a stitch
    knitted by its front yarn alone is left out, the graph dump has its yarn."""
    names = list(g.yarn_names) or ["main"]
    stacks = []
    i = 0
    while i < y.n_entries:
        s = int(y.stitch[i])
        back = []
        while i < y.n_entries and int(y.stitch[i]) == s:
            item: dict[str, Any] = {
                "yarn": names[int(y.yarn[i])],
                "mode": MODE_NAMES[int(y.mode[i])],
            }
            if y.inlay[i]:
                item["inlay"] = True
            back.append(item)
            i += 1
        stacks.append({"stitch": s, "front": names[int(y.front[s])], "back": back})
    stats = y.stats()
    stats["front_yarns"] = [names[i] for i in stats["front_yarns"]]
    return {"stats": stats, "yarns": names, "stacks": stacks}
