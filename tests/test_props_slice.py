"""Property tests of slicing over generated garments.

The programs come from `programs()` in test_props_resolve.py and go through the filters of
test_props_shape.py (`compile_graph`), as in test_props_codegen.py. For every garment and
every tracer (the driver's `trace_courses`, and `trace_rules` with one and two passes):

* `scheduling.slices.verify` finds nothing;
* the thesis's constraints hold, checked here from scratch, slice by slice, with Python
  sets: (1) one yarn, (2) no two wale-connected stitches, (3) one cast-on and one cast-off
  need, (4) one direction, (5) increases + decreases within the limit (or a single visit);
  and every visit is active in exactly one slice;
* the vectorised pass gives exactly the slices of `reference_slices` below, a
  visit-by-visit transcription of the rules (ch. 6.7.1) with lists and no numpy tricks.

The shaping limit is drawn too, so small limits (many cuts) are covered. 40 examples
(three tracers and a pure-Python reference each) keep the test near ten seconds.
"""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from knitc.scheduling import slices as sl
from knitc.scheduling.slicing import slice_trace
from knitc.scheduling.trace import Trace
from knitc.scheduling.tracing import trace_courses, trace_rules
from knitc.shaping.stitch_graph import COURSE_KINDS, StitchGraph
from test_props_resolve import programs
from test_props_shape import SETTINGS, compile_graph

E, A, S = sl.EXPECTED, sl.ACTIVE, sl.SUSPENDED


# ---- a plain transcription of the slicing rules ----------------------------------------------


def shaping_rule(g: StitchGraph) -> list[int]:
    """Increases + decreases per stitch, folds (a flat course opening into a tube or a tube
    collapsing into a flat course) and gauge changes excluded, written out on lists."""
    nexts = [[int(k) for k in row if k >= 0] for row in g.wale_next]
    prevs = [[int(p) for p in row if p >= 0] for row in g.wale_prev]
    circ = [bool(g.course_circular[int(g.course[s])]) for s in range(g.n_stitches)]

    gauge = [int(g.course_gauge[int(g.course[s])]) for s in range(g.n_stitches)]

    def fold(s: int, two: list[int]) -> bool:
        return (
            not circ[s] and circ[two[0]] and int(g.side[two[0]]) != int(g.side[two[1]])
        ) or gauge[two[0]] != gauge[s]

    return [
        int(len(nexts[s]) == 2 and not fold(s, nexts[s]))
        + int(len(prevs[s]) == 2 and not fold(s, prevs[s]))
        for s in range(g.n_stitches)
    ]


def reference_slices(g: StitchGraph, t: Trace, flat: int, tube: int) -> list[dict]:
    """The slicing rules one visit at a time, on Python lists (see slice.py's docstring)."""
    ccw = sl.ccw_courses(g)
    kids = [[int(k) for k in row if k >= 0] for row in sl.ccw_kids(g, ccw)]
    prevs = [[int(p) for p in row if p >= 0] for row in g.wale_prev]
    dec = [len(kids[s]) == 1 and len(prevs[kids[s][0]]) == 2 for s in range(g.n_stitches)]
    gauge = [int(g.course_gauge[int(g.course[s])]) for s in range(g.n_stitches)]
    # a derived cycle stays in one gauge: a loop whose next wales are in the other gauge
    # waits; a fresh cycle is built in its own stitch's gauge, where only decreases wait
    waits = [dec[s] or any(gauge[k] != gauge[s] for k in kids[s]) for s in range(g.n_stitches)]
    shaping = shaping_rule(g)
    done = [0] * g.n_stitches

    def finished(s: int) -> bool:
        return done[s] >= t.passes

    fold = [
        len(kids[s]) == 2 and g.side[kids[s][0]] != g.side[kids[s][1]] for s in range(g.n_stitches)
    ]

    holding = [-1]  # the course the slice being opened continues: its ends stay on the bed

    def held(s: int) -> bool:
        return not kids[s] and finished(s) and int(g.course[s]) == holding[0]

    def derive(cyc: list[list[int]], fresh: bool = False) -> list[list[int]]:
        out, round_the_back = [], []
        for s, state in cyc:
            if state == E or (state == A and not finished(s)):
                if not finished(s):
                    out.append([s, E])
            elif state == S and not kids[s]:
                if held(s):
                    out.append([s, S])
            elif state == S or (dec[s] if fresh else waits[s]) or held(s):
                out.append([s, S])
            elif fold[s]:  # one child in place, the other round the back of the ring
                out += [[k, E] for k in kids[s][:1] if not finished(k)]
                round_the_back += [[k, E] for k in kids[s][1:] if not finished(k)]
            else:
                out += [[k, E] for k in kids[s] if not finished(k)]
        return out + round_the_back[::-1]

    def fresh(s: int) -> list[list[int]]:
        c = int(g.course[s])
        if COURSE_KINDS[int(g.course_kind[c])] in ("short_row", "continuity") and prevs[s]:
            c = int(g.course[max(prevs[s])])
        return derive([[int(x), A] for x in sl.course_cycle(g, c, ccw)], fresh=True)

    def take(sli: dict, s: int, check_limit: bool) -> bool:
        if check_limit and sli["shaping"] + shaping[s] > sli["limit"]:
            return False
        cyc, entry = sli["cycle"], sli["entry"]
        if s in entry and entry[s][1] == E:
            entry[s][1] = A
        else:
            if len(prevs[s]) != 2:
                return False
            at = [i for i, (x, state) in enumerate(cyc) if x in prevs[s] and state == S]
            if len(at) != 2:
                return False
            cyc[at[0]] = entry[s] = [s, A]
            del cyc[at[1]]
        sli["shaping"] += shaping[s]
        sli["visits"] += 1
        return True

    def opened(cyc, v, src) -> dict:
        sides = {int(g.side[x]) for x, _ in cyc}
        return {
            "cycle": cyc,
            "entry": {x: e for e in cyc for x in e[:1]},
            "key": key(v),
            "visit": v,
            "visits": 0,
            "shaping": 0,
            "limit": tube if sides == {0, 1} else flat,
            "derived_from": src,
        }

    def key(v: int) -> tuple:
        s = int(t.stitch[v])
        c = int(g.course[s])
        return (
            int(g.node[s]),
            int(t.yarn[v]),
            int(t.dir[v]),
            int(g.course_gauge[c]),
            not prevs[s],
            not kids[s],
        )

    out: list[dict] = []
    last_of_node: dict[int, int] = {}
    for v in range(t.n_visits):
        s = int(t.stitch[v])
        if out and out[-1]["key"] == key(v) and take(out[-1], s, True):
            done[s] += 1
            continue
        node = int(g.node[s])
        new = None
        same = v > 0 and int(g.course[int(t.stitch[v - 1])]) == int(g.course[s])
        holding[0] = int(g.course[s]) if same else -1
        if node in last_of_node:
            src = last_of_node[node]
            cand = opened(derive([list(e) for e in out[src]["cycle"]]), v, src)
            if take(cand, s, False):
                new = cand
        if new is None:
            new = opened(fresh(s), v, -1)
            assert take(new, s, False)
        out.append(new)
        last_of_node[node] = len(out) - 1
        done[s] += 1
    return out


# ---- the constraints, from scratch ------------------------------------------------------------


def check_constraints(g: StitchGraph, t: Trace, s: sl.Slices) -> None:
    prevs = [[int(p) for p in row if p >= 0] for row in g.wale_prev]
    nexts = [[int(p) for p in row if p >= 0] for row in g.wale_next]
    rule = shaping_rule(g)
    stitch, yarn, dirs = t.stitch.tolist(), t.yarn.tolist(), t.dir.tolist()
    seen: list[int] = []
    for k in range(s.n_slices):
        a, b = int(s.visit[k]), int(s.visit[k] + s.visits[k])
        vis = stitch[a:b]
        seen += range(a, b)
        st, state = (x.tolist() for x in s.cycle(k))
        assert len(set(st)) == len(st)
        active = sorted(x for x, y in zip(st, state) if y == A)
        assert active == sorted(vis)  # every visit is active in its slice, nothing else
        assert len(set(yarn[a:b])) == 1  # (1)
        assert not set(st) & {p for x in st for p in prevs[x]}  # (2)
        assert len({not prevs[x] for x in vis}) == 1  # (3)
        assert len({not nexts[x] for x in vis}) == 1
        assert len(set(dirs[a:b])) == 1  # (4)
        shaping = sum(rule[x] for x in vis)
        assert shaping == s.shaping[k]
        assert shaping <= s.limit[k] or len(vis) == 1  # (5)
    assert seen == list(range(t.n_visits))


def check_against_reference(g: StitchGraph, t: Trace, s: sl.Slices, flat: int, tube: int) -> None:
    ref = reference_slices(g, t, flat, tube)
    assert s.n_slices == len(ref)
    for k, r in enumerate(ref):
        st, state = s.cycle(k)
        assert [[int(x), int(y)] for x, y in zip(st, state)] == r["cycle"], k
        assert (int(s.visit[k]), int(s.visits[k])) == (r["visit"], r["visits"])
        assert (int(s.shaping[k]), int(s.limit[k])) == (r["shaping"], r["limit"])
        assert int(s.derived_from[k]) == r["derived_from"]
        assert bool(s.circular[k]) == ({int(g.side[x]) for x, _ in r["cycle"]} == {0, 1})


TRACERS = {
    "courses": trace_courses,
    "rules1": lambda g: trace_rules(g, passes=1),
    "rules2": lambda g: trace_rules(g, passes=2),
}


@settings(SETTINGS, max_examples=40)
@given(programs(), st.sampled_from([None, 1, 3]))
def test_generated_garments_slice_validly(prog, limit):
    _, g = compile_graph(prog)
    limits = {} if limit is None else {"flat_limit": limit, "tube_limit": limit}
    flat, tube = (2, 4) if limit is None else (limit, limit)
    for name, tracer in TRACERS.items():
        t = tracer(g)
        s = slice_trace(g, t, **limits)
        assert sl.verify(g, t, s) == [], name
        check_constraints(g, t, s)
        check_against_reference(g, t, s, flat, tube)
        assert np.array_equal(np.sort(s.stitch[s.state == A]), np.sort(t.stitch))
