"""Property tests of schedule optimisation over generated garments.

The programs come from `programs()` in test_props_resolve.py and go through the filters of
test_props_shape.py (`compile_graph`), as in test_props_codegen.py. Every garment is traced
(the driver's `trace_courses`, or `trace_rules` with one or two passes), sliced with a drawn
shaping limit and scheduled on a wide machine; the schedule must hold, checked here from
scratch with Python sets rather than with `scheduling.schedule.verify` alone:

* every layout satisfies the slack constraint (consecutive cycle entries at most one
  relative needle apart, around the ring for circular cycles) and puts no two entries of a
  cycle on one needle;
* every needle is on the bed, and half-gauge fronts are on even needles, backs on odd;
* no two loops on the bed at the same time share a needle: replaying the slices, the loops
  of each cycle are where the cycle puts them and every other live loop is where it was
  last (or where an alignment record moved it);
* every ACTIVE stitch is placed;
* and `scheduling.schedule.verify` agrees (finds nothing).

A narrow machine must give E601 rather than an overlap or a crash, and only when the
schedule really needs more needles than the machine has (the width E601 reports fits).
"""

from __future__ import annotations

from hypothesis import event, given, settings
from hypothesis import strategies as st

from knitc.diagnostics import Diagnostics
from knitc.driver import compile_source
from knitc.scheduling import schedule as ir
from knitc.scheduling.scheduler import schedule
from knitc.scheduling.slices import ACTIVE, EXPECTED, SUSPENDED
from knitc.scheduling.slicing import slice_trace
from knitc.scheduling.tracing import trace_courses, trace_rules
from test_props_resolve import programs
from test_props_shape import SETTINGS, compile_graph

TRACERS = {
    "courses": trace_courses,
    "rules1": lambda g: trace_rules(g, passes=1),
    "rules2": lambda g: trace_rules(g, passes=2),
}


def replay_occupancy(g, sl, sched) -> list[str]:
    """Walk the slices with Python dicts: where every live loop is at every slice."""
    problems = []
    made: dict[int, int] = {}
    for k in range(sl.n_slices):
        st, state = sl.cycle(k)
        for s, x in zip(st.tolist(), state.tolist(), strict=True):
            if x == ACTIVE:
                made.setdefault(s, k)
    dies = {}
    for s, k in made.items():
        kids = [int(c) for c in g.wale_next[s] if c >= 0 and int(c) in made]
        dies[s] = min((made[c] for c in kids), default=k)
    where: dict[int, tuple[int, int]] = {}  # live loop -> (bed, needle)
    for k in range(sl.n_slices):
        st, state, bed, needle = ir.positions(sched, k)
        for s, b, n in zip(*ir.alignments(sched, k), strict=True):
            assert int(s) in where, f"slice {k}: alignment of a loop not on the bed"
            where[int(s)] = (int(b), int(n))
        taken: dict[tuple[int, int], int] = {}
        here = set()
        for s, x, b, n in zip(
            st.tolist(), state.tolist(), bed.tolist(), needle.tolist(), strict=True
        ):
            if (b, n) in taken:
                problems.append(f"slice {k}: entries {taken[(b, n)]} and {s} share a needle")
            taken[(b, n)] = s
            loops = [s] if x in (ACTIVE, SUSPENDED) else []
            if x in (EXPECTED, ACTIVE):
                ps = [int(p) for p in g.wale_prev[s] if p >= 0]
                # an increase's loop goes into its first next wale when both are here
                loops += [
                    p
                    for p in ps
                    if g.wale_next[p, 0] == s or int(g.wale_next[p, 0]) not in set(st.tolist())
                ]
            for p in loops:
                if p in made and made[p] <= k <= dies[p]:
                    here.add(p)
                    if x != ACTIVE or p == s:
                        where[p] = (b, n)
        held: dict[tuple[int, int], int] = {}
        for p, pos in where.items():
            if p in here or not (made[p] < k <= dies[p]):
                continue
            if pos in taken:
                problems.append(f"slice {k}: held loop {p} on the needle of entry {taken[pos]}")
            if pos in held and not set(g.wale_next[p]) & set(g.wale_next[held[pos]]) - {-1}:
                problems.append(f"slice {k}: held loops {held[pos]} and {p} share a needle")
            held[pos] = p
        for p in [p for p in where if dies[p] <= k]:
            del where[p]
    return problems


def check_schedule(g, sl, sched) -> None:
    for k in range(sl.n_slices):
        st, state, bed, needle = ir.positions(sched, k)
        a = int(sl.start[k])
        rel = sched.rel[a : a + st.shape[0]].tolist()
        ring = rel + rel[:1] if sl.circular[k] else rel
        assert all(abs(x - y) <= 1 for x, y in zip(ring, ring[1:], strict=False)), k
        places = list(zip(bed.tolist(), needle.tolist(), strict=True))
        assert len(set(places)) == len(places), k
        assert all(0 <= n < sched.needles for _, n in places), k
        if sched.step[k] == 2:
            assert all(n % 2 == b for b, n in places), k
        assert all(
            0 <= n < sched.needles for n, x in zip(needle, state, strict=True) if x == ACTIVE
        )
    assert replay_occupancy(g, sl, sched) == []
    assert ir.verify(g, sched) == []


@settings(SETTINGS, max_examples=40)
@given(programs(), st.sampled_from(sorted(TRACERS)), st.sampled_from([None, 1, 3]))
def test_generated_garments_get_a_valid_schedule(prog, tracer, limit):
    _, g = compile_graph(prog)
    t = TRACERS[tracer](g)
    limits = {} if limit is None else {"flat_limit": limit, "tube_limit": limit}
    sl = slice_trace(g, t, **limits)
    diags = Diagnostics()
    sched = schedule(g, sl, needles=2000, diags=diags)
    assert sched is not None, diags.render()
    event(f"alignments: {'some' if sched.align_slice.size else 'none'}")
    check_schedule(g, sl, sched)


def represented_one(g, sl, k, made, end):
    """Slice k's represented loops and their entries, computed for that slice alone with
    Python sets: the definition `schedule._represented` computes for many slices at once."""
    st, state = sl.cycle(k)
    a = int(sl.start[k])
    here = set(st.tolist())
    own, parents = [], {0: [], 1: []}
    for i, (s, x) in enumerate(zip(st.tolist(), state.tolist(), strict=True)):
        if x in (SUSPENDED, ACTIVE):  # a loop of its own (made here, or waiting)
            own.append((s, a + i))
        if x == SUSPENDED:  # (an EXPECTED or ACTIVE stitch takes in its parents' loops)
            continue
        for j in (0, 1):
            p = int(g.wale_prev[s, j])
            if p >= 0:
                first = int(g.wale_next[p, 0])
                if first == s or max(first, 0) not in here:
                    parents[j].append((p, a + i))
    pairs = [(lo, en) for lo, en in own + parents[0] + parents[1] if made[lo] <= k <= end[lo]]
    return [lo for lo, _ in pairs], [en for _, en in pairs]


@settings(SETTINGS, max_examples=25)
@given(programs(), st.sampled_from(sorted(TRACERS)), st.sampled_from([1, 5, 1 << 18]))
def test_represented_loops_are_each_slices_own(prog, tracer, chunk):
    """`_represented` (many slices per numpy call, `chunk` entries at a time) gives each
    slice the loops and entries its definition does, slice by slice."""
    _, g = compile_graph(prog)
    sl = slice_trace(g, TRACERS[tracer](g))
    made, end = ir._lifetimes(g, sl)
    old, ir._CHUNK = ir._CHUNK, chunk
    try:
        got = [(k, lo.tolist(), en.tolist()) for k, lo, en in ir._represented(g, sl, made, end)]
    finally:
        ir._CHUNK = old
    assert [k for k, _, _ in got] == list(range(sl.n_slices))
    for k, lo, en in got:
        assert (lo, en) == represented_one(g, sl, k, made.tolist(), end.tolist())


def _narrow_machine(g) -> str:
    sl = slice_trace(g, trace_courses(g))
    diags = Diagnostics()
    sched = schedule(g, sl, needles=12, diags=diags)
    if sched is not None:
        check_schedule(g, sl, sched)
        return "fits"
    assert [d.code for d in diags if d.is_error] == ["E601"]
    # the width it reports is what a wider machine gets, and more than this one has
    need = int(diags.items[0].message.split()[3])
    assert need > 12
    wide = schedule(g, sl, needles=need, diags=Diagnostics())
    assert wide is not None and wide.width == need
    check_schedule(g, sl, wide)
    return "E601"


@settings(SETTINGS, max_examples=15)
@given(programs())
def test_a_narrow_machine_is_an_error_not_an_overlap(prog):
    _, g = compile_graph(prog)
    event(_narrow_machine(g))


def test_the_width_e601_asks_for_is_enough():
    # Found by hypothesis (seed 129874845360850946832588695163947462292): greedy placement
    # met the bed's right end at 32 and 33 needles although an unbounded bed packs the
    # garment into 32.
    src = """
sheet n1 { length: 1  type: flat  width: [0: 2, 1: 2] }
sheet n2 { length: 1  type: flat  width: [0: 4, 1: 4] }
sheet n3 { length: 4  type: cylinder  width: [0: 2, 1: 9] }
n2.top -> n3.bottom
joint n4 { rows: 1 }
n3.top -> n4.bottom
split n5 { degree: 2  folded: false }
n4.top -> n5.branches[1]
sheet n6 { length: 1  type: cylinder  width: 7  gauge: half }
n5.branches[0] -> n6.bottom
start n6.top
"""
    r = compile_source(src, "t.knit", until="stitch-graph")
    assert r.graph is not None, r.diagnostics.render()
    assert _narrow_machine(r.graph) == "E601"
