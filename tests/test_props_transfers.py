"""Property tests of the transfer planner on random order-preserving transfer problems.

A problem is a cycle of loops on the bed (a tube, or a flat piece on the front bed) and a
target of the same cycle order: counter-clockwise front and back needles, loops possibly
stacked two to a needle (decreases), a tube possibly rotated by a few stitches (rolls), a
flat piece possibly folded around its right end, in full or half gauge, with the carrier
anywhere. With free needles around it every such problem has a plan, and `move` must find
one that `test_transfers.replay` accepts: every loop on its target, no loop ever on a
needle holding a loop of another stitch unless both end there, every racking within the
limit, racking 0 at the end, no loop across a carrier's position. A sample of the plans
also runs through the independent oracle.
"""

from __future__ import annotations

from hypothesis import HealthCheck, assume, event, given, settings
from hypothesis import strategies as st

from knitc.backends.knitout import write_knitout
from oracle import assert_clean, run_oracle_on_text
from test_transfers import Problem, run

SETTINGS = settings(
    max_examples=250,
    deadline=None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much],
)
NEEDLES = 120


def _needles(draw, count: int, first: int, step: int, gaps: int) -> list[int]:
    """`count` increasing needles from `first`, `step` apart times a gap of 1..gaps."""
    out = [first]
    for _ in range(count - 1):
        out.append(out[-1] + step * draw(st.integers(1, gaps)))
    return out


@st.composite
def problems(draw) -> tuple[Problem, float | None]:
    max_rack = draw(st.sampled_from([2, 3, 4, 4, 4]))
    half = draw(st.booleans())
    step = 2 if half else 1
    closed = draw(st.booleans())
    nf = draw(st.integers(1, 8))
    nb = draw(st.integers(1, 8)) if closed else 0
    base = 40
    front = _needles(draw, nf, base, step, 2)
    back = _needles(draw, nb, base + (1 if half else 0), step, 2) if nb else []
    start = [("f", n) for n in front] + [("b", n) for n in reversed(back)]
    n = len(start)
    # the target: front slots then back slots, each taking one or two consecutive loops
    sizes = []
    left = n
    while left:
        k = draw(st.integers(1, min(2, left)))
        sizes.append(k)
        left -= k
    slots = len(sizes)
    if closed:
        p = draw(st.integers(1, slots))
    else:
        p = draw(st.integers(max(1, slots - 3), slots))  # the last few may fold to the back
    q = slots - p
    shift = draw(st.integers(-12, 12))
    tf = _needles(draw, p, base + step * shift, step, 2)
    tb = _needles(draw, q, base + step * shift + (1 if half else 0), step, 2) if q else []
    slot_pos = [("f", x) for x in tf] + [("b", x) for x in reversed(tb)]
    order = [i for i, k in enumerate(sizes) for _ in range(k)]
    k = draw(st.integers(-3, 3)) if closed else 0
    target = {s: slot_pos[order[(s + k) % n]] for s in range(n)}
    pb = Problem(
        {pos: s for s, pos in enumerate(start)},
        target,
        max_rack=max_rack,
        needles=NEEDLES,
        circular=closed,
    )
    assume(pb.moves())
    carrier = None
    if draw(st.booleans()):
        lo = min(min(front), min(tf)) - 2
        hi = max(max(front + back), max(tf + tb)) + 2
        carrier = draw(st.integers(lo, hi)) + 0.5
    event("tube" if closed else "flat")
    event("half gauge" if half else "full gauge")
    if any(target[s][0] != start[s][0] for s in range(n)):
        event("bed changes")
    if len(sizes) < n:
        event("decreases")
    return pb, carrier


@SETTINGS
@given(problems())
def test_random_order_preserving_problems_are_planned(problem):
    pb, carrier = problem
    if run(pb, carrier_at=carrier).ops("miss"):
        event("carrier parked")


def test_a_sample_of_random_plans_runs_clean_on_the_independent_machine():
    texts: list[str] = []

    @settings(SETTINGS, max_examples=40)
    @given(problems())
    def collect(problem):
        pb, carrier = problem
        done = run(pb, carrier_at=carrier)
        if len(texts) < 12:
            texts.append(write_knitout(done.bed.prog))

    collect()
    assert len(texts) == 12
    for report in run_oracle_on_text(texts):
        assert_clean(report)
