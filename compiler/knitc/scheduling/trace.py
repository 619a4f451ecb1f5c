"""The traced-yarn IR: the order in which yarns visit stitches (thesis ch. 6.6).

One row per visit, as parallel numpy arrays: the stitch, the yarn (a logical yarn; the
scheduler assigns carriers), the direction the carriage moves on that stitch (+1 towards
higher needles, -1 towards lower), and flags. A trace made by double tracing visits each
stitch twice (`passes == 2`); single-pass tracing visits each stitch once.

Flags:
- START / END: first and last visit of a yarn;
- TUCK_PREV: tuck before this visit (the yarn turned: short-row ends, ch. 5.4 and 6.6);
- JUMP: the previous visit is neither a course nor a wale neighbour, but an adjacent needle
  of the same node (a ring closing across beds, or a continuity course meeting its next
  course); anything farther starts a new yarn instead;
- CARRY: the yarn rested at the side while other yarns knitted stripes, and is carried up
  the edge to this visit, which starts a course at the end where the yarn stopped
  (`carried`);
- SHIFT: an intarsia region's local yarn goes on to its region's next run, which does not
  start next to where it stopped (a wall that moved between courses, or a region with two
  runs in a course): it floats along its own course or the one below to this visit, in
  the region's node;
- JOIN: after this visit, the last of a run of an intarsia region, the yarn tucks on the
  first needle of the next run of the course (another region's) before it turns back: the
  tuck join that links the regions across their wall (thesis ch. 6.9.6).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from knitc.records import record
from knitc.shaping.stitch_graph import StitchGraph

START, END, TUCK_PREV, JUMP, CARRY, SHIFT, JOIN = 1, 2, 4, 8, 16, 32, 64
FLAG_NAMES = {
    START: "start",
    END: "end",
    TUCK_PREV: "tuck",
    JUMP: "jump",
    CARRY: "carry",
    SHIFT: "shift",
    JOIN: "join",
}


@record
class Trace:
    """The traced-yarn IR (this module's docstring): one row per visit, `passes` visits
    per stitch, and the tracing `method` that made it, which code generation checks."""

    stitch: np.ndarray  # int32
    yarn: np.ndarray  # int16
    dir: np.ndarray  # int8
    flags: np.ndarray  # uint8
    passes: int = 1
    method: str = "courses"

    @property
    def n_visits(self) -> int:
        return int(self.stitch.shape[0])

    @property
    def n_yarns(self) -> int:
        return int(self.yarn.max()) + 1 if self.n_visits else 0

    def stats(self) -> dict[str, Any]:
        return {
            "visits": self.n_visits,
            "yarns": self.n_yarns,
            "tucks": int(np.count_nonzero(self.flags & TUCK_PREV)),
            "jumps": int(np.count_nonzero(self.flags & JUMP)),
            "passes": self.passes,
            "method": self.method,
        }


def _neighbours(g: StitchGraph, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Whether visits a[i] -> b[i] move to a course or wale neighbour (or stay)."""
    same = a == b
    course = (g.cnext[a] == b) | (g.cprev[a] == b)
    wale = (
        (g.wale_next[a, 0] == b)
        | (g.wale_next[a, 1] == b)
        | (g.wale_prev[a, 0] == b)
        | (g.wale_prev[a, 1] == b)
    )
    return same | course | wale


def neighbours(g: StitchGraph, a: int, b: int) -> bool:
    """Stitch b is stitch a, or its course or wale neighbour: a step that needs no
    justification (the scalar form of the check `verify` makes over whole arrays)."""
    return bool(
        a == b or g.cnext[a] == b or g.cprev[a] == b or b in g.wale_next[a] or b in g.wale_prev[a]
    )


def near(g: StitchGraph, a: int, b: int) -> bool:
    """A justified one-step jump from stitch a to b: a diagonal onto the next course (a
    spiral, or a wale child of a course neighbour), or the adjacent needle of the same bed
    in the same node."""
    for nb in (g.cnext[a], g.cprev[a]):
        if nb >= 0 and b in g.wale_next[nb]:
            return True
    for ch in g.wale_next[a]:
        if ch >= 0 and (g.cnext[ch] == b or g.cprev[ch] == b):
            return True
    return bool(
        g.node[a] == g.node[b]
        and g.side[a] == g.side[b]
        and abs(int(g.needle[a]) - int(g.needle[b])) <= 1
    )


def shifted(g: StitchGraph, a: int, b: int) -> bool:
    """A justified SHIFT from stitch a to b: b is in a's node, on a's course or on a course
    whose stitch b sits above a stitch of a's course (the yarn floats along that course)."""
    if g.node[a] != g.node[b]:
        return False
    if g.course[a] == g.course[b]:
        return True
    parent = int(g.wale_prev[b, 0])
    return parent >= 0 and g.course[parent] == g.course[a]


def carried(g: StitchGraph, a: int, b: int) -> int:
    """How many courses a yarn rests when it is carried up the side from stitch a, the last
    of a course, to stitch b, the first of a later one (-1: not a carry). b must start at
    the fabric's edge where a stopped: down its wale to a's course, b lands on a or next to
    it (or, after a round of a tube, next to where that round began). The wale may cross
    into another node (a brim into a body)."""
    ca, cb = int(g.course[a]), int(g.course[b])
    circular = bool(g.course_circular[ca])
    if cb <= ca or (not circular and g.cnext[a] >= 0):
        return -1
    if b != int(g.course_start[cb]) and (g.course_circular[cb] or g.cprev[b] >= 0):
        return -1
    x, steps = b, 0
    while int(g.course[x]) > ca:
        x = int(g.wale_prev[x, 0])
        steps += 1
        if x < 0:
            return -1
    if int(g.course[x]) != ca:
        return -1
    first = int(g.course_start[ca])
    if x == a or neighbours(g, a, x) or (circular and (x == first or neighbours(g, first, x))):
        return steps - 1
    return -1


def sweeps(g: StitchGraph, stitch: np.ndarray, yarn: np.ndarray) -> np.ndarray:
    """Per visit, the group whose steps set each other's carriage direction
    (`carriage_dirs`): its strand's, except that the visits of an intarsia course are one
    group of their own. The course's runs, one per region's local yarn, are knitted in one
    sweep of the carriage, so a run of a single stitch goes the course's way, not the way
    its yarn goes on the next course."""
    band = g.intarsia_courses()
    if yarn.size == 0 or not band.any():
        return yarn
    on = band[g.course[stitch]]
    return np.where(on, int(yarn.max()) + 1 + g.course[stitch], yarn).astype(np.int64)


def carriage_dirs(g: StitchGraph, stitch: np.ndarray, yarn: np.ndarray) -> np.ndarray:
    """The carriage direction at each visit (+1 towards higher needles): the step that
    brought the yarn to it from its previous visit on the same bed. A visit reached across
    beds (or a yarn's first) takes the direction of the yarn's next step on one bed, and a
    yarn that never steps along a bed goes rightward."""
    n = stitch.shape[0]
    d = np.zeros(n, np.int8)
    if n == 0:
        return d
    order = np.lexsort((np.arange(n), yarn))
    st, yn = stitch[order], yarn[order]
    ar = np.arange(n)
    step = np.zeros(n, np.int64)
    same = (yn[1:] == yn[:-1]) & (g.side[st[1:]] == g.side[st[:-1]])
    dn = g.needle[st[1:]].astype(np.int64) - g.needle[st[:-1]]
    step[1:] = np.where(same, np.sign(dn), 0)
    ends = np.r_[yn[1:] != yn[:-1], True]
    group_end = np.minimum.accumulate(np.where(ends, ar, n)[::-1])[::-1]
    starts = np.r_[True, yn[1:] != yn[:-1]]
    group_start = np.maximum.accumulate(np.where(starts, ar, 0))
    nxt = np.minimum.accumulate(np.where(step != 0, ar, n)[::-1])[::-1]
    prv = np.maximum.accumulate(np.where(step != 0, ar, -1))
    from_next = np.where(nxt <= group_end, step[np.minimum(nxt, n - 1)], 0)
    from_prev = np.where(prv >= group_start, step[np.maximum(prv, 0)], 0)
    out = np.where(
        step != 0, step, np.where(from_next != 0, from_next, np.where(from_prev != 0, from_prev, 1))
    )
    d[order] = out.astype(np.int8)
    return d


def start_end_flags(yarn: np.ndarray, flags: np.ndarray) -> None:
    """Set START on each yarn's first visit and END on its last (in place)."""
    n = yarn.shape[0]
    if n == 0:
        return
    flags &= ~np.uint8(START | END)
    _, first = np.unique(yarn, return_index=True)
    _, last_rev = np.unique(yarn[::-1], return_index=True)
    flags[first] |= START
    flags[n - 1 - last_rev] |= END


def verify(g: StitchGraph, t: Trace) -> list[str]:
    """Invariants of a trace over its stitch graph; empty = valid."""
    problems: list[str] = []
    n = g.n_stitches
    counts = np.bincount(t.stitch, minlength=n) if t.n_visits else np.zeros(n, np.int64)
    if np.any(counts != t.passes):
        bad = int(np.nonzero(counts != t.passes)[0][0])
        problems.append(f"stitch {bad} is visited {int(counts[bad])} times, not {t.passes}")
        return problems
    # the last visit of every stitch comes after the last visits of its previous wales
    last = np.zeros(n, np.int64)
    last[t.stitch] = np.arange(t.n_visits)
    first = np.full(n, t.n_visits, np.int64)
    np.minimum.at(first, t.stitch, np.arange(t.n_visits))
    for k in (0, 1):
        p = g.wale_prev[:, k]
        has = p >= 0
        early = first[has] < last[p[has]]
        if np.any(early):
            s = int(np.nonzero(has)[0][early][0])
            problems.append(
                f"stitch {s} is knitted before its previous wale {int(p[s])} is finished"
            )
            break
    # consecutive visits of one yarn: neighbours, or a flagged jump
    if t.n_visits > 1:
        order = np.lexsort((np.arange(t.n_visits), t.yarn))  # each yarn's visits in order
        st, fl, yn = t.stitch[order], t.flags[order], t.yarn[order]
        a, b = st[:-1], st[1:]
        same_yarn = yn[:-1] == yn[1:]
        jump = (fl[1:] & JUMP) != 0
        carry = (fl[1:] & CARRY) != 0
        shift = (fl[1:] & SHIFT) != 0
        ok = _neighbours(g, a, b) | jump | carry | shift
        bad = same_yarn & ~ok
        if np.any(bad):
            i = int(np.nonzero(bad)[0][0])
            problems.append(
                f"yarn {int(yn[i])} jumps from stitch {int(a[i])} to {int(b[i])} "
                "without a justification"
            )
        for i in np.nonzero(same_yarn & jump)[0][:10000]:
            if not near(g, int(a[i]), int(b[i])):
                problems.append(
                    f"yarn {int(yn[i])} jumps from stitch {int(a[i])} to "
                    f"{int(b[i])}, which is not a neighbouring needle"
                )
                break
        for i in np.nonzero(same_yarn & shift)[0][:10000]:
            if not shifted(g, int(a[i]), int(b[i])):
                problems.append(
                    f"yarn {int(yn[i])} shifts from stitch {int(a[i])} to {int(b[i])}, "
                    "which is not on its course or the next one of its node"
                )
                break
        for i in np.nonzero(same_yarn & carry)[0][:10000]:
            if carried(g, int(a[i]), int(b[i])) < 0:
                problems.append(
                    f"yarn {int(yn[i])} is carried from stitch {int(a[i])} to "
                    f"{int(b[i])}, which does not start at the edge where it stopped"
                )
                break
    problems += _verify_intarsia_flags(g, t)
    starts = np.count_nonzero(t.flags & START)
    if starts != t.n_yarns:
        problems.append(f"{starts} yarn starts for {t.n_yarns} yarns")
    return problems


def _verify_intarsia_flags(g: StitchGraph, t: Trace) -> list[str]:
    """SHIFT and JOIN only in intarsia courses; a JOIN ends a run: the next visit is of the
    same course and another yarn, or, after a round's last visit, the round's first is."""
    flagged = np.nonzero(t.flags & (SHIFT | JOIN))[0]
    if flagged.size == 0:
        return []
    band = g.intarsia_courses()
    course = g.course[t.stitch]
    if not band[course[flagged]].all():
        return ["a SHIFT or JOIN outside an intarsia course"]
    for i in np.nonzero(t.flags & JOIN)[0].tolist():
        c = int(course[i])
        j = i + 1
        if j == t.n_visits or course[j] != c:  # a course's last visit: a round's wrap
            if not g.course_circular[c]:
                return [f"visit {i} joins past the end of flat course {c}"]
            j = i - int(np.count_nonzero(course[: i + 1] == c)) + 1  # the round's first
        if t.yarn[j] == t.yarn[i]:
            return [f"visit {i} joins onto its own yarn's run"]
    return []


def to_json(g: StitchGraph, t: Trace) -> dict[str, Any]:
    """The dump of `knitc --emit trace`: stats first, then yarns and visits."""
    visits = []
    for i in range(t.n_visits):
        f = int(t.flags[i])
        visits.append(
            {
                "stitch": int(t.stitch[i]),
                "yarn": int(t.yarn[i]),
                "dir": int(t.dir[i]),
                "flags": [name for bit, name in FLAG_NAMES.items() if f & bit],
            }
        )
    yarns = []
    for y in range(t.n_yarns):
        idx = np.nonzero(t.yarn == y)[0]
        yarns.append(
            {
                "yarn": y,
                "visits": int(idx.size),
                "first": int(t.stitch[idx[0]]),
                "last": int(t.stitch[idx[-1]]),
                "nodes": sorted({g.node_names[int(g.node[s])] for s in t.stitch[idx]}),
            }
        )
    return {"stats": t.stats(), "yarns": yarns, "visits": visits}
