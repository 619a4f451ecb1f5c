"""Yarn tracing: stitch graph → traced yarn (thesis ch. 6.6).

Two tracers produce the same IR:

- `trace_courses`, the default: the shape pass already lays every course out in yarn
  order and appends courses in knitting order, so the yarn path is the stitch ids in
  order (but for an intarsia round, visited from a wall, `_Locals`); what remains is
  deciding which yarn knits each course (a course continues a yarn whose last stitch is
  next to its first, else a new yarn starts), the carriage direction, and tucks where
  short rows turn. Linear and vectorised per course.
- `trace_rules`, the rule-based procedure of Narayanan et al. used by the thesis (R1 start
  yarn, R2 next row, R3 continue, R4 tuck and turn, R5 end short row, R6 end yarn), with
  single or double tracing (`passes=2`: every stitch visited twice, which lets one carrier
  knit any short-row structure). Its R7/R8 (local yarns for intarsia) are hooks: `yarn_of`
  may assign a stitch to another yarn, which then starts and ends where its stitches do.
  The default tracer has R7 itself, for intarsia courses (`_Locals`).
  It works on any stitch graph, including ones not made by the shape pass.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np

from knitc.scheduling import trace as tr
from knitc.shaping.stitch_graph import COURSE_KINDS, StitchGraph

_TURNING = (COURSE_KINDS.index("short_row"), COURSE_KINDS.index("continuity"))


def trace_courses(g: StitchGraph, carry_up: Sequence[int] = ()) -> tr.Trace:
    """Single-pass tracing in knitting order (see the module docstring). With stripes
    (`StitchGraph.yarn`), `carry_up[y]` is how many courses yarn y may rest at the side
    (`_trace_stripes`)."""
    if g.colourwork:
        return _trace_stripes(g, carry_up)
    n = g.n_stitches
    yarn = np.zeros(n, np.int16)
    flags = np.zeros(n, np.uint8)
    last_of: list[int] = []  # yarn -> its last stitch
    joins: list[tuple[int, int]] = []  # (first stitch of a course, previous stitch of its yarn)
    for c in range(g.n_courses):
        ids = g.course_ids(c)
        if ids.size == 0:
            continue
        first = int(ids[0])
        chosen = -1
        jump = False
        for y in range(len(last_of) - 1, -1, -1):  # most recent yarn first
            if tr.neighbours(g, last_of[y], first):
                chosen = y
                break
        if chosen < 0:
            for y in range(len(last_of) - 1, -1, -1):
                if tr.near(g, last_of[y], first):
                    chosen, jump = y, True
                    break
        if chosen < 0:
            chosen = len(last_of)
            last_of.append(-1)
        else:
            if jump:
                flags[first] |= tr.JUMP
            if g.course_kind[c] in _TURNING and not g.course_circular[c]:
                joins.append((first, last_of[chosen]))
        yarn[ids] = chosen
        last_of[chosen] = int(ids[-1])
    stitch = np.arange(n, dtype=np.int32)
    dirs = tr.carriage_dirs(g, stitch, yarn)
    for first, prev in joins:  # short rows turn on the same bed: tuck (ch. 5.4)
        if g.side[first] == g.side[prev] and dirs[first] != dirs[prev]:
            flags[first] |= tr.TUCK_PREV
    tr.start_end_flags(yarn, flags)
    return tr.Trace(stitch, yarn, dirs, flags, passes=1, method="courses")


def _trace_stripes(g: StitchGraph, carry_up: Sequence[int]) -> tr.Trace:
    """`trace_courses` for a striped design: a course continues a strand (a length of yarn
    on one carrier) of its own yarn. The strand that knitted the course below goes on as
    usual; one that rested while other yarns knitted is carried up the side (CARRY) when
    the course starts at the edge where it stopped and it rested at most `carry_up`
    courses (`trace.carried`). Otherwise a new strand of that yarn starts.

    An intarsia course (`StitchGraph.intarsia_courses`) is traced region by region
    (`_intarsia_course`): the strand of the course below is *pending*, resting at the
    side, while each region's local yarn knits its run."""
    n = g.n_stitches
    assert g.yarn is not None
    design = g.course_yarn()
    intarsia = design == len(g.yarn_names)
    yarn = np.zeros(n, np.int16)  # per stitch (one visit each): its strand
    flags = np.zeros(n, np.uint8)  # per stitch: its visit's flags
    last_of: list[int] = []  # strand -> its last stitch
    of_yarn: list[int] = []  # strand -> the design's yarn it is (-1: a region's local yarn)
    joins: list[tuple[int, int]] = []
    visits: list[np.ndarray] = []  # per course, its stitches in visiting order
    local = _Locals(g, last_of, of_yarn) if intarsia.any() else None
    for c in range(g.n_courses):
        ids = g.course_ids(c)
        if ids.size == 0:
            continue
        if intarsia[c]:
            assert local is not None
            visits.append(local.course(c, yarn, flags))
            continue
        visits.append(ids)
        first = int(ids[0])
        want = int(design[c])
        chosen, flag = -1, 0
        for y in range(len(last_of) - 1, -1, -1):  # most recent strand first
            if of_yarn[y] != want:
                continue
            a = last_of[y]
            ca = int(g.course[a])
            if not _rested(g, design, ca, c, want):  # as `trace_courses` continues a yarn
                if tr.neighbours(g, a, first):
                    chosen, flag = y, 0
                    break
                if tr.near(g, a, first):
                    chosen, flag = y, tr.JUMP
                    break
            # (rested: the courses knitted since, in knitting order, whatever their node)
            elif c - ca - 1 <= _at(carry_up, want) and tr.carried(g, a, first) >= 0:
                chosen, flag = y, tr.CARRY
                break
        if chosen < 0:
            chosen = len(last_of)
            last_of.append(-1)
            of_yarn.append(want)
        else:
            flags[first] |= flag
            if flag != tr.CARRY and g.course_kind[c] in _TURNING and not g.course_circular[c]:
                joins.append((first, last_of[chosen]))
        yarn[ids] = chosen
        last_of[chosen] = int(ids[-1])
    stitch = np.concatenate(visits).astype(np.int32) if visits else np.zeros(0, np.int32)
    strands = yarn[stitch]
    dirs = tr.carriage_dirs(g, stitch, tr.sweeps(g, stitch, strands))
    dir_of = np.zeros(n, np.int8)
    dir_of[stitch] = dirs
    for first, prev in joins:
        if g.side[first] == g.side[prev] and dir_of[first] != dir_of[prev]:
            flags[first] |= tr.TUCK_PREV
    out = flags[stitch]
    tr.start_end_flags(strands, out)
    return tr.Trace(stitch, strands, dirs, out, passes=1, method="courses")


class _Locals:
    """The local yarns of intarsia regions (thesis ch. 6.9.6, rule R7): a region's first
    run starts a new strand, which goes on through the region's runs of later courses and
    ends after its last; the strand of the course below is pending meanwhile (it is no
    candidate for a region, and `_rested` sees it rest)."""

    def __init__(self, g: StitchGraph, last_of: list[int], of_yarn: list[int]) -> None:
        from knitc.shaping.intarsia import regions

        self.g, self.last_of, self.of_yarn = g, last_of, of_yarn
        self.region = regions(g)
        self.in_node = g.node_courses()
        self.strand: dict[int, int] = {}  # region -> its local yarn

    def course(self, c: int, yarn: np.ndarray, flags: np.ndarray) -> np.ndarray:
        """Trace intarsia course `c` (strands into `yarn`, flags into `flags`, per stitch)
        and return its stitches in visiting order. A flat course is visited in course
        order; a round starts at a wall and goes around one way on its node's even courses
        and back the other way on its odd ones (or the other way round where only that
        continues its first run's yarn), so each region's yarn goes back and forth over
        its own stitches. The last visit of every run but a flat course's last is
        flagged JOIN (its yarn tucks on the next run's first needle)."""
        g = self.g
        ids = g.course_ids(c)
        reg = self.region[ids]
        circular = bool(g.course_circular[c])
        if circular:
            walls = np.nonzero(reg != np.roll(reg, 1))[0]
            if walls.size:
                ids, reg = np.roll(ids, -int(walls[0])), np.roll(reg, -int(walls[0]))
            ways = [(ids, reg), (ids[::-1], reg[::-1])]
            if self.in_node[c] % 2:
                ways.reverse()
            # (the other way round when only it continues the first run's yarn: a band
            # that goes on into the next tube, whose course count starts again)
            ids, reg = next((w for w in ways if self._continues(*w)), ways[0])
        runs = np.split(np.arange(ids.size), np.nonzero(np.diff(reg) != 0)[0] + 1)
        for k, run in enumerate(runs):
            first, last = int(ids[run[0]]), int(ids[run[-1]])
            r = int(reg[run[0]])
            strand = self.strand.get(r, -1)
            flag = 0
            if strand >= 0:
                a = self.last_of[strand]
                if tr.neighbours(g, a, first):
                    flag = 0
                elif tr.near(g, a, first):
                    flag = tr.JUMP
                elif tr.shifted(g, a, first):
                    flag = tr.SHIFT
                else:
                    strand = -1  # (no way to carry it there: a new local yarn)
            if strand < 0:  # R7: start a local yarn for the region
                strand = self.strand[r] = len(self.last_of)
                self.last_of.append(-1)
                self.of_yarn.append(-1)
            flags[first] |= flag
            yarn[ids[run]] = strand
            self.last_of[strand] = last
            if len(runs) > 1 and (k + 1 < len(runs) or circular):
                flags[last] |= tr.JOIN
        return ids

    def _continues(self, ids: np.ndarray, reg: np.ndarray) -> bool:
        """Whether the first run of a round visited as `ids` goes on from where its
        region's yarn stopped (or starts the region)."""
        strand = self.strand.get(int(reg[0]), -1)
        if strand < 0:
            return True
        a, b = self.last_of[strand], int(ids[0])
        return tr.neighbours(self.g, a, b) or tr.near(self.g, a, b) or tr.shifted(self.g, a, b)


def _rested(g: StitchGraph, design: np.ndarray, ca: int, c: int, want: int) -> bool:
    """Whether a yarn that knitted course `ca` rested, while another yarn knitted a
    course of the same node as `ca` or `c` in between, before course `c`."""
    nodes = (g.course_node[ca], g.course_node[c])
    return any(design[k] != want and g.course_node[k] in nodes for k in range(ca + 1, c))


DEFAULT_CARRY_UP = 8
"""`carry_up` for a yarn the caller gave none for (the `yarn` property's default,
`skeleton.YARN_PROPS`, which the driver always passes)."""


def _at(values: Sequence[int], i: int) -> int:
    """values[i], or the default carry when the caller gave none for yarn i."""
    return values[i] if i < len(values) else DEFAULT_CARRY_UP


def trace_rules(
    g: StitchGraph, passes: int = 2, yarn_of: Callable[[int], int] | None = None
) -> tr.Trace:
    """Rule-based tracing (R1–R6) with `passes` visits per stitch (see module docstring)."""
    if passes not in (1, 2):
        raise ValueError("passes must be 1 or 2")
    n = g.n_stitches
    visits = np.zeros(n, np.int8)
    # pending[c]: wale edges into course c whose parent is not finished yet
    pending = np.zeros(g.n_courses, np.int64)
    for k in (0, 1):
        p = g.wale_prev[:, k]
        np.add.at(pending, g.course[p >= 0], 1)
    done_in_course = np.zeros(g.n_courses, np.int64)
    out_stitch: list[int] = []
    out_yarn: list[int] = []
    out_flags: list[int] = []
    next_course = 0  # lowest course that may still hold unfinished stitches

    def ready(s: int) -> bool:
        return pending[g.course[s]] == 0 and visits[s] < passes

    def knit(s: int, yarn: int, flag: int = 0) -> None:
        visits[s] += 1
        out_stitch.append(s)
        out_yarn.append(yarn)
        out_flags.append(flag)
        if visits[s] == passes:
            done_in_course[g.course[s]] += 1
            for child in g.wale_next[s]:
                if child >= 0:
                    pending[g.course[child]] -= 1

    def along(s: int, o: int) -> int:
        return int(g.cnext[s] if o > 0 else g.cprev[s])

    def orient(t: int) -> int:
        """Orientation (+1 along course order) for entering stitch t."""
        nx, pv = int(g.cnext[t]), int(g.cprev[t])
        if nx >= 0 and visits[nx] < passes:
            return 1
        if pv >= 0 and visits[pv] < passes:
            return -1
        return 1

    yarn = -1
    cur, o = -1, 1
    remaining = n * passes
    while remaining > 0:
        if cur < 0:  # R1: start a yarn at the first unfinished stitch of a ready course
            while (
                next_course < g.n_courses
                and done_in_course[next_course] == g.course_len[next_course]
            ):
                next_course += 1
            start = -1
            for c in range(next_course, g.n_courses):
                if pending[c] or done_in_course[c] == g.course_len[c]:
                    continue
                ids = g.course_ids(c)
                open_ids = ids[visits[ids] < passes]
                ends = [int(s) for s in open_ids if g.cprev[s] < 0 or g.cnext[s] < 0]
                start = ends[0] if ends else int(open_ids[0])
                break
            if start < 0:
                raise AssertionError("tracing is stuck: no ready stitch")
            yarn += 1
            if out_stitch and out_yarn[-1] == yarn - 1:
                out_flags[-1] |= tr.END
            o = orient(start)
            knit(start, yarn, tr.START)
            remaining -= 1
            cur = start
            continue
        nxt, flag = -1, 0
        # R2: next row, once the current stitch is finished and a course above is ready
        if visits[cur] == passes:
            ahead = along(cur, o)
            if ahead >= 0 and visits[ahead] == passes:
                for child in g.wale_next[ahead]:
                    if child >= 0 and ready(int(child)):
                        nxt = int(child)
                        break
            if nxt < 0:
                for child in g.wale_next[cur]:
                    if child >= 0 and ready(int(child)):
                        nxt = int(child)
                        flag = 0 if g.course_circular[g.course[nxt]] else tr.TUCK_PREV
                        break
            if nxt >= 0:
                o = orient(nxt)
        # R3: continue along the course
        if nxt < 0:
            ahead = along(cur, o)
            if ahead >= 0 and ready(ahead):
                nxt = ahead
        # R4: tuck and turn at the end of a row that still needs tracing
        if nxt < 0 and visits[cur] < passes and along(cur, o) < 0:
            o = -o
            nxt, flag = cur, tr.TUCK_PREV
        # R5: end of a short row: continue beyond it in an earlier row
        if nxt < 0:
            s = cur
            for _ in range(4):
                parent = int(g.wale_prev[s, 0])
                if parent < 0:
                    break
                for cand in (along(parent, o), along(parent, -o)):
                    if cand >= 0 and ready(cand):
                        nxt = cand
                        break
                if nxt >= 0:
                    o = orient(nxt)
                    break
                s = parent
        # R6: end the yarn
        if nxt < 0:
            out_flags[-1] |= tr.END
            cur = -1
            continue
        if not tr.neighbours(g, cur, nxt):
            if not tr.near(g, cur, nxt):  # too far to carry the yarn: end it (R6)
                cur = -1
                continue
            flag |= tr.JUMP
        y = yarn if yarn_of is None else yarn_of(nxt)
        knit(nxt, y, flag)
        remaining -= 1
        cur = nxt
    if out_flags:
        out_flags[-1] |= tr.END
    stitch = np.asarray(out_stitch, np.int32)
    yarns = np.asarray(out_yarn, np.int16)
    flags = np.asarray(out_flags, np.uint8)
    tr.start_end_flags(yarns, flags)
    return tr.Trace(
        stitch, yarns, tr.carriage_dirs(g, stitch, yarns), flags, passes=passes, method="rules"
    )
