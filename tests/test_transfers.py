"""The shaping transfer planner (`knitc.codegen.transfers.move`) on a bare bed.

Every test puts loops of known stitches on a `Bed`, asks `move` for a set of moves, and
replays the emitted ops with `replay` below, which follows every loop by identity: each
loop must end on its target, no transfer may put a loop on a needle that holds a loop of
another stitch unless both end there (a decrease), every racking stays within the limit,
transfers are aligned at the racking of the moment, the program ends at racking 0, no
loop crosses a carrier's rest position (except the loop the carrier's yarn holds) and a
carrier is never moved while a loop is on a slider. knitc's own simulation must find no
error, and a few programs also go through the independent oracle (tests/oracle.py).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from types import SimpleNamespace

import numpy as np
import pytest

from knitc.backends.knitout import write_knitout
from knitc.codegen.bed import Bed, Pos, Unsupported
from knitc.codegen.machine import Machine, MachineProgram, aligned
from knitc.codegen.simulate import simulate
from knitc.codegen.transfers import Park, _windings, move, plan
from oracle import assert_clean, run_oracle_on_text

CARRIER = 3


# ---- harness ------------------------------------------------------------------------------------


@dataclass
class Problem:
    """Loops on the bed (needle -> stitch), where each must go, and the bed's set-up."""

    start: dict[Pos, int]
    target: dict[int, Pos]
    max_rack: int = 4
    needles: int = 80
    course: dict[int, int] = field(default_factory=dict)
    """Course (and node) of a stitch (default 0); loops of another one are other pieces."""
    circular: bool = True
    """Whether the courses are tubes (their loops may rotate around the beds)."""

    def moves(self) -> list[tuple[int, Pos, Pos]]:
        where = {s: p for p, s in self.start.items()}
        return [(s, where[s], t) for s, t in self.target.items() if where[s] != t]


def make_bed(pb: Problem, carrier_at: float | None = None) -> Bed:
    """A bed holding the loops of `pb`, made by tucks of carrier 3 (so the program is one
    the independent machine accepts); the carrier is left at `carrier_at` if given."""
    n = max(pb.start.values()) + 1
    course = np.array([pb.course.get(s, 0) for s in range(n)])
    g = SimpleNamespace(
        spans=[None],
        span=np.zeros(n, np.int32),
        course=course,
        node=course,
        course_circular=np.full(course.max() + 1, pb.circular),
    )
    bed = Bed(g, MachineProgram(Machine(needles=pb.needles)), pb.max_rack)  # type: ignore[arg-type]
    bed.prog.inhook((CARRIER,))
    order = sorted(pb.start.items(), key=lambda it: (-it[0][1], it[0][0]))
    for i, (pos, s) in enumerate(order):
        bed.stitch_op("tuck", -1, pos, s, CARRIER)
        if i == 0:
            bed.prog.releasehook((CARRIER,))
    if carrier_at is not None and carrier_at != bed.carrier_at[CARRIER]:
        here = bed.carrier_at[CARRIER]
        d = 1 if carrier_at > here else -1
        bed.stitch_op("miss", d, ("f", int(carrier_at - 0.5 * d)), -1, CARRIER)
    return bed


def finish(bed: Bed) -> None:
    for pos in sorted(p for p, k in bed.loops.items() if k):
        bed.drop(pos, -1)
    bed.prog.outhook((CARRIER,))


def replay(
    prog: MachineProgram,
    start: int,
    loops: dict[Pos, set[int]],
    target: dict[int, Pos],
    max_rack: int,
) -> None:
    """Follow every loop through ops[start:] and assert the planner's invariants."""
    loops = {p: set(s) for p, s in loops.items() if s}
    rack = 0
    carriers: dict[int, float] = {}
    anchor: dict[int, Pos] = {}
    for op in prog.ops[:start]:
        if op.kind in ("tuck", "knit", "miss"):
            carriers[op.carriers[0]] = op.needle.index + 0.5 * op.dir
        if op.kind in ("tuck", "knit"):
            anchor[op.carriers[0]] = (op.needle.bed, op.needle.index)
        if op.kind == "rack":
            rack = op.value
    assert rack == 0
    for op in prog.ops[start:]:
        if op.kind == "rack":
            assert abs(op.value) <= max_rack, f"racking {op.value} beyond {max_rack}"
            rack = op.value
        elif op.kind == "miss":
            on_sliders = [p for p, s in loops.items() if s and p[0] in ("fs", "bs")]
            assert not on_sliders, f"carrier moved while loops are on sliders {on_sliders}"
            carriers[op.carriers[0]] = op.needle.index + 0.5 * op.dir
        elif op.kind == "xfer":
            a = (op.needle.bed, op.needle.index)
            b = (op.needle2.bed, op.needle2.index)
            assert aligned(op.needle, op.needle2, rack), f"{op} misaligned at racking {rack}"
            moving = loops.pop(a, set())
            assert moving, f"{op} moves no loop"
            there = loops.get(b, set())
            if there:
                assert all(target[s] == b for s in moving | there), (
                    f"{op} puts stitches {sorted(moving)} on {b} holding {sorted(there)}"
                )
            for c, x in carriers.items():
                if min(a[1], b[1]) < x < max(a[1], b[1]):
                    assert anchor.get(c) == a, f"{op} crosses carrier {c} at {x}"
            for c, n in anchor.items():
                if n == a:
                    anchor[c] = b
            loops[b] = there | moving
        else:
            raise AssertionError(f"unexpected op {op}")
    assert rack == 0, "the plan must end at racking 0"
    where = {s: p for p, ss in loops.items() for s in ss}
    for s, t in target.items():
        assert where.get(s) == t, f"stitch {s} ends on {where.get(s)}, not {t}"


@dataclass
class Done:
    """A checked move: the bed (its program finished: loops dropped, carrier out), the ops
    the move emitted, and the loops it left on each needle."""

    bed: Bed
    moved: list
    held: dict[Pos, int]

    def ops(self, kind: str) -> list:
        return [op for op in self.moved if op.kind == kind]

    def racks(self) -> list:
        return [op.value for op in self.ops("rack")]


def run(pb: Problem, carrier_at: float | None = None, **kw) -> Done:
    """Set up, move, check with `replay` and knitc's simulation."""
    bed = make_bed(pb, carrier_at)
    start = len(bed.prog.ops)
    loops = {p: {s} for p, s in pb.start.items()}
    move(bed, pb.moves(), **kw)
    target = {s: pb.target.get(s, p) for p, s in pb.start.items()}
    replay(bed.prog, start, loops, target, pb.max_rack)
    assert {s: bed.where[s] for s in target} == target  # the bed model agrees
    assert bed.rack == 0
    done = Done(bed, bed.prog.ops[start:], {p: k for p, k in bed.loops.items() if k})
    finish(bed)
    assert [f for f in simulate(bed.prog, max_loops=3) if f.is_error] == []
    return done


def tube(front: list[int], back: list[int], first: int = 0) -> dict[Pos, int]:
    """A counter-clockwise cycle: front needles left to right, then back right to left."""
    pos = [("f", n) for n in front] + [("b", n) for n in back]
    return {p: first + i for i, p in enumerate(pos)}


def cycle_target(start: dict[Pos, int], slots: list[Pos], k: int) -> dict[int, Pos]:
    """Loop i of the cycle (by stitch id) goes to slot (i + k) mod n: a rotation by k."""
    ids = sorted(start.values())
    return {s: slots[(i + k) % len(slots)] for i, s in enumerate(ids)}


# ---- same-bed shifts ----------------------------------------------------------------------------


def test_a_shift_within_the_racking_limit_is_one_round():
    pb = Problem(tube(list(range(10, 16)), []), {})
    pb.target = {s: ("f", p[1] + 3) for p, s in pb.start.items()}
    done = run(pb)
    assert done.racks() == [3, 0]
    assert all(op.needle2.bed in ("bs", "f") for op in done.ops("xfer"))  # full gauge: sliders


@pytest.mark.parametrize("dist", [5, 9, 13, 26])
def test_shifts_beyond_the_racking_limit_go_in_rounds(dist):
    pb = Problem(tube(list(range(4, 12)), []), {}, needles=60)
    pb.target = {s: ("f", p[1] + dist) for p, s in pb.start.items()}
    done = run(pb)
    assert max(abs(r) for r in done.racks()) <= 4
    assert len([r for r in done.racks() if r]) == -(-dist // 4)  # one racking per round


def test_a_flat_decrease_stacks_the_edge_loops_on_their_partners():
    # 8 loops, 2 decreases at each edge: loops 0,1 -> f12, 2 -> f13 ... 6,7 -> f17
    start = tube(list(range(10, 18)), [])
    goal = [12, 12, 13, 14, 15, 16, 17, 17]
    pb = Problem(start, {s: ("f", goal[s]) for s in range(8)})
    done = run(pb)
    assert done.held[("f", 12)] == 2 and done.held[("f", 17)] == 2


def test_a_decrease_onto_an_unmoving_loop():
    start = tube(list(range(10, 16)), [])
    pb = Problem(start, {0: ("f", 11)})  # only loop 0 moves, onto loop 1
    done = run(pb)
    assert done.held[("f", 11)] == 2
    assert len(done.ops("xfer")) == 2


def test_a_loop_never_passes_an_unmoving_loop_of_its_bed():
    start = tube([10, 11, 12], [])
    pb = Problem(start, {0: ("f", 14)}, circular=False)  # it would pass loops 1 and 2
    bed = make_bed(pb)
    with pytest.raises(Unsupported, match="stitch 0"):
        move(bed, pb.moves())


def test_loops_of_another_piece_bound_the_free_range():
    start = tube([10, 11, 12], [])
    start[("f", 20)] = 3  # another piece (course 1)
    pb = Problem(start, {0: ("f", 14), 1: ("f", 15), 2: ("f", 16)}, course={3: 1})
    run(pb)
    pb.target = {0: ("f", 18), 1: ("f", 19), 2: ("f", 21)}
    with pytest.raises(Unsupported):
        move(make_bed(pb), pb.moves())


def test_a_free_range_keeps_the_loops_inside_it():
    start = tube(list(range(20, 26)), list(range(25, 19, -1)))
    pb = Problem(start, cycle_target(start, list(start), 2))
    done = run(pb, free=(18, 27))
    used = {n.index for op in done.ops("xfer") for n in (op.needle, op.needle2)}
    assert min(used) >= 18 and max(used) <= 27
    with pytest.raises(Unsupported, match="free needles"):
        move(make_bed(pb), pb.moves(), free=(21, 30))


# ---- bed changes --------------------------------------------------------------------------------


@pytest.mark.parametrize("dist", [6, 9, 14, 20])
def test_cross_bed_moves_beyond_the_racking_limit(dist):
    # a flat piece on the front whose loops go to the back, `dist` needles to the left
    pb = Problem(tube(list(range(30, 36)), []), {}, needles=90)
    pb.target = {s: ("b", p[1] - dist) for p, s in pb.start.items()}
    done = run(pb)
    assert max(abs(r) for r in done.racks()) <= 4


def test_a_fold_rolls_loops_around_the_corner():
    # wristband's merge: two flat pieces side by side become a tube, the right one folding
    # under the left one (its far end goes farthest)
    left = {("f", n): 9 - (n - 2) for n in range(2, 12)}  # stitch 9 on f2 .. stitch 0 on f11
    right = {("f", n): 10 + (n - 15) for n in range(15, 25)}  # stitch 10 on f15 .. 19 on f24
    target = {s: ("f", p[1] + 2) for p, s in left.items()}
    target.update({10 + i: ("b", 13 - i) for i in range(10)})
    pb = Problem({**left, **right}, target)
    done = run(pb)
    assert all(abs(r) <= 4 for r in done.racks())


@pytest.mark.parametrize("half", [False, True])
def test_loops_travel_under_unmoving_loops_on_the_other_bed(half):
    # the left piece stays; the right one folds under it, its loops passing beneath the
    # left piece's loops on the back bed
    step = 2 if half else 1
    left = {("f", 2 + step * i): 9 - i for i in range(10)}
    right = {("f", 2 + step * (12 + i)): 10 + i for i in range(10)}
    target = {10 + i: ("b", 2 + step * (9 - i) + (1 if half else 0)) for i in range(10)}
    done = run(Problem({**left, **right}, target))
    assert done.held == {**{p: 1 for p in left}, **{t: 1 for t in target.values()}}
    if half:
        assert all(op.needle2.bed in ("f", "b") for op in done.ops("xfer"))


@pytest.mark.parametrize("k", [1, 2, 3, -1, -2])
def test_a_tube_rotation_rolls_k_loops_around_each_end(k):
    start = tube(list(range(20, 30)), list(range(29, 19, -1)))
    pb = Problem(start, cycle_target(start, list(start), k))
    done = run(pb)
    # k loops changed bed at each end
    changed = [s for p, s in start.items() if pb.target[s][0] != p[0]]
    assert len(changed) == 2 * abs(k)
    assert done.bed.rack == 0


def test_a_corner_decrease_onto_the_other_bed():
    start = tube(list(range(20, 26)), list(range(25, 19, -1)))
    pb = Problem(start, {5: ("b", 25), 11: ("f", 20)})  # the two corner loops stack
    done = run(pb)
    assert done.held[("b", 25)] == 2 and done.held[("f", 20)] == 2
    assert len(done.ops("xfer")) == 2  # directly, at racking 0


def test_windings_pick_the_nearer_end():
    # a tube's first front loop going to the back: around the left end, not the right one
    start = tube(list(range(20, 26)), list(range(25, 19, -1)))
    cycle = [(p, p) for p in start]
    cycle[0] = (("f", 20), ("b", 19))
    w = _windings(cycle)
    assert w[0] == -1 and all(x == 0 for x in w[1:])  # front loop, roll -1: the left end


def test_rib_like_moves_go_straight_across():
    start = tube(list(range(10, 18)), [])
    pb = Problem(start, {1: ("b", 11), 3: ("b", 13), 5: ("b", 15)})  # every other loop back
    done = run(pb)
    assert done.racks() == []  # all at racking 0
    assert len(done.ops("xfer")) == 3


# ---- gauges -------------------------------------------------------------------------------------


def test_half_gauge_parks_on_the_free_hooks():
    start = tube(list(range(10, 30, 2)), list(range(29, 9, -2)))
    pb = Problem(start, {})
    pb.target = {s: (p[0], p[1] + 6) for p, s in start.items()}
    done = run(pb)
    beds = {n.bed for op in done.ops("xfer") for n in (op.needle, op.needle2)}
    assert beds == {"f", "b"}  # no slider
    assert all(r % 2 == 0 for r in done.racks())


def test_full_gauge_parks_on_the_sliders():
    start = tube(list(range(10, 20)), list(range(19, 9, -1)))
    pb = Problem(start, {s: (p[0], p[1] + 6) for p, s in start.items()})
    done = run(pb)
    assert {op.needle2.bed for op in done.ops("xfer")} >= {"fs", "bs"}
    # the same flat problem in half gauge uses hooks, forced full gauge uses sliders
    flat = Problem(tube(list(range(10, 20, 2)), []), {})
    flat.target = {s: ("f", p[1] + 4) for p, s in flat.start.items()}
    assert "bs" not in {op.needle2.bed for op in run(flat).ops("xfer")}
    assert "bs" in {op.needle2.bed for op in run(flat, gauge=1).ops("xfer")}


def test_half_gauge_tube_rotation():
    start = tube(list(range(20, 40, 2)), list(range(39, 19, -2)))
    pb = Problem(start, cycle_target(start, list(start), 2))
    done = run(pb)
    assert "bs" not in {op.needle2.bed for op in done.ops("xfer")}


# ---- carriers -----------------------------------------------------------------------------------


def test_a_carrier_inside_the_shaping_range_is_parked_first():
    # an increase at the right edge: the loops move right across the carrier's position
    start = tube(list(range(10, 16)), [])
    pb = Problem(start, {s: ("f", p[1] + 2) for p, s in start.items()})
    done = run(pb, carrier_at=12.5)
    [park] = done.ops("miss")
    assert park.needle.index + 0.5 * park.dir > 17 or park.needle.index + 0.5 * park.dir < 10
    assert done.bed.carrier_at[CARRIER] == park.needle.index + 0.5 * park.dir


def test_a_carrier_outside_the_moves_stays():
    start = tube(list(range(10, 16)), [])
    pb = Problem(start, {s: ("f", p[1] + 2) for p, s in start.items()})
    bed = make_bed(pb)  # the cast-on ends at the left, carrier at 9.5
    n = len(bed.prog.ops)
    move(bed, pb.moves())
    assert not [op for op in bed.prog.ops[n:] if op.kind == "miss"]


def test_the_loop_holding_the_yarn_may_cross_its_carrier():
    # the yarn's own loop (the last tucked one, f10, carrier at 9.5) moves left past it
    start = tube(list(range(10, 16)), [])
    pb = Problem(start, {0: ("f", 8)})  # stitch 0 is on f10: tucked last
    bed = make_bed(pb)
    assert bed.carrier_at[CARRIER] == 9.5
    steps = plan(bed, pb.moves())
    assert not [s for s in steps if isinstance(s, Park)]
    run(pb)


def test_an_out_carrier_is_no_barrier():
    start = tube(list(range(10, 16)), [])
    pb = Problem(start, {s: ("f", p[1] + 2) for p, s in start.items()})
    bed = make_bed(pb, carrier_at=12.5)
    bed.prog.outhook((CARRIER,))
    assert not [s for s in plan(bed, pb.moves()) if isinstance(s, Park)]


# ---- what cannot be done ------------------------------------------------------------------------


def test_stacked_loops_cannot_be_split():
    pb = Problem(tube([10, 11], []), {})
    bed = make_bed(pb)
    bed.xfer(("f", 10), ("b", 10), 0)
    bed.xfer(("b", 10), ("f", 11), 0)  # both loops on f11
    with pytest.raises(Unsupported, match="split"):
        move(bed, [(0, ("f", 11), ("f", 13)), (1, ("f", 11), ("f", 14))])


def test_a_target_off_the_bed():
    pb = Problem(tube([1, 2], []), {0: ("f", -2)})
    with pytest.raises(Unsupported, match="not a hook"):
        move(make_bed(pb), pb.moves())


def test_no_room_to_roll_around_the_end():
    # a full-gauge tube filling the free range cannot rotate: no needle beyond its corner
    start = tube(list(range(0, 6)), list(range(5, -1, -1)))
    pb = Problem(start, cycle_target(start, list(start), 1), needles=6)
    with pytest.raises(Unsupported, match="roll"):
        move(make_bed(pb), pb.moves())


def test_plan_leaves_the_bed_alone():
    pb = Problem(tube(list(range(10, 16)), []), {0: ("f", 8)})
    bed = make_bed(pb)
    n = len(bed.prog.ops)
    assert plan(bed, pb.moves())
    assert len(bed.prog.ops) == n and bed.where[0] == ("f", 10)


# ---- the independent machine --------------------------------------------------------------------


def test_plans_run_clean_on_the_independent_machine():
    texts = []
    left = {("f", n): 9 - (n - 2) for n in range(2, 12)}
    right = {("f", n): 10 + (n - 15) for n in range(15, 25)}
    fold = {s: ("f", p[1] + 2) for p, s in left.items()}
    fold.update({10 + i: ("b", 13 - i) for i in range(10)})
    t = tube(list(range(20, 30)), list(range(29, 19, -1)))
    h = tube(list(range(20, 40, 2)), list(range(39, 19, -2)))
    flat = tube(list(range(10, 18)), [])
    for pb, carrier in [
        (Problem({**left, **right}, fold), None),
        (Problem(t, cycle_target(t, list(t), 2)), None),
        (Problem(h, cycle_target(h, list(h), -2)), None),
        (Problem(flat, {s: ("f", p[1] + 2) for p, s in flat.items()}), 13.5),
        (Problem(flat, {s: ("b", p[1] - 9) for p, s in flat.items()}), None),
    ]:
        texts.append(write_knitout(run(pb, carrier_at=carrier).bed.prog))
    for report in run_oracle_on_text(texts):
        assert_clean(report)
