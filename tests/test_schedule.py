"""Schedule optimisation (thesis ch. 6.7.2-3, 6.8.2): the layout families, the cost tuple,
the reuse shortcut, interface orders from bridges, offsets that never overlap and keep a
gap around a changing block, half-gauge expansion, E601, the code generator's helpers,
`--emit schedule`, and the cost against the fixed node-frame layout knitc used before it had
a scheduler (tests/fixed_layout.py).

Small cases are built by hand: a stitch graph of rings and rows (hints as the shape pass
writes them: ring front 0..h-1 left to right, back right to left) and the slices over it,
one cycle per slice, written in cycle order.
"""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from fixed_layout import layout
from knitc.cli import main
from knitc.diagnostics import Diagnostics
from knitc.driver import compile_source, emit_json
from knitc.scheduling import schedule as ir
from knitc.scheduling.layouts import hub_bridges, valid_orders
from knitc.scheduling.scheduler import schedule
from knitc.scheduling.slices import ACTIVE, Slices
from knitc.shaping.stitch_graph import StitchGraph, empty_pair

ROOT = Path(__file__).resolve().parent.parent
EXAMPLES = sorted((ROOT / "examples").glob("*.knit")) + sorted(
    (ROOT / "examples" / "knitskel").glob("*.knit")
)


# ---- hand-made graphs and slices ----------------------------------------------------------------


class Graph:
    """Courses of a few nodes and the wales between them, built into a StitchGraph."""

    def __init__(self) -> None:
        self.nodes: list[str] = []
        self.courses: list[tuple[int, int, bool, int]] = []  # node, n, circular, gauge
        self.wales: list[tuple[int, int]] = []
        self.n = 0

    def course(self, node: str, n: int, circular: bool = True, gauge: int = 1) -> list[int]:
        if node not in self.nodes:
            self.nodes.append(node)
        self.courses.append((self.nodes.index(node), n, circular, gauge))
        ids = list(range(self.n, self.n + n))
        self.n += n
        return ids

    def wale(self, a: int, b: int) -> None:
        self.wales.append((a, b))

    def build(self) -> StitchGraph:
        n, nc = self.n, len(self.courses)
        node = np.zeros(n, np.int32)
        course = np.zeros(n, np.int32)
        side = np.zeros(n, np.int8)
        needle = np.zeros(n, np.int32)
        cprev = np.full(n, -1, np.int32)
        cnext = np.full(n, -1, np.int32)
        start = np.zeros(nc, np.int32)
        s = 0
        for c, (nd, m, circ, _) in enumerate(self.courses):
            ids = np.arange(s, s + m)
            start[c] = s
            node[ids], course[ids] = nd, c
            if circ:
                h = (m + 1) // 2
                side[ids[h:]] = 1
                needle[ids[:h]] = np.arange(h)
                needle[ids[h:]] = np.arange(m - h)[::-1]
            else:
                needle[ids] = np.arange(m)
            cnext[ids[:-1]], cprev[ids[1:]] = ids[1:], ids[:-1]
            if circ:
                cnext[ids[-1]], cprev[ids[0]] = ids[0], ids[-1]
            s += m
        wp, wn = empty_pair(n), empty_pair(n)
        for a, b in self.wales:
            wn[a, int(wn[a, 0] >= 0)] = b
            wp[b, int(wp[b, 0] >= 0)] = a
        return StitchGraph(
            node_names=list(self.nodes),
            spans=[None],
            node=node,
            course=course,
            side=side,
            needle=needle,
            cprev=cprev,
            cnext=cnext,
            wale_prev=wp,
            wale_next=wn,
            instr=np.zeros(n, np.uint8),
            action=np.full(n, -1, np.int16),
            span=np.zeros(n, np.int32),
            course_start=start,
            course_len=np.array([c[1] for c in self.courses], np.int32),
            course_node=np.array([c[0] for c in self.courses], np.int32),
            course_circular=np.array([c[2] for c in self.courses], bool),
            course_kind=np.zeros(nc, np.int8),
            course_gauge=np.array([c[3] for c in self.courses], np.int8),
        )


def make_slices(
    g: StitchGraph,
    cycles: list[list[int]],
    circular: list[bool],
    gauge: list[int] | None = None,
    states: list[list[int]] | None = None,
) -> Slices:
    """Slices with the given cycles (all ACTIVE unless `states` says otherwise)."""
    k = len(cycles)
    length = np.array([len(c) for c in cycles], np.int32)
    start = np.concatenate([[0], np.cumsum(length)[:-1]]).astype(np.int64)
    stitch = np.concatenate([np.array(c, np.int32) for c in cycles])
    state = (
        np.concatenate([np.array(s, np.uint8) for s in states])
        if states
        else np.full(stitch.shape[0], ACTIVE, np.uint8)
    )
    visits = np.array(
        [
            int(np.count_nonzero(state[a : a + n] == ACTIVE))
            for a, n in zip(start, length, strict=True)
        ],
        np.int32,
    )
    return Slices(
        node=np.array([int(g.node[c[0]]) for c in cycles], np.int32),
        yarn=np.zeros(k, np.int16),
        dir=np.ones(k, np.int8),
        fresh=np.ones(k, bool),
        circular=np.array(circular, bool),
        visit=np.concatenate([[0], np.cumsum(visits)[:-1]]).astype(np.int64),
        visits=visits,
        start=start,
        length=length,
        shaping=np.zeros(k, np.int32),
        limit=np.full(k, 4, np.int32),
        cast_on=np.zeros(k, bool),
        cast_off=np.zeros(k, bool),
        gauge=np.array(gauge or [1] * k, np.int8),
        derived_from=np.full(k, -1, np.int64),
        stitch=stitch,
        state=state,
    )


def run(g: StitchGraph, s: Slices, needles: int = 200, **kw) -> ir.Schedule:
    diags = Diagnostics()
    sched = schedule(g, s, needles=needles, diags=diags, **kw)
    assert sched is not None, diags.render()
    assert ir.verify(g, sched) == []
    return sched


def places(sched: ir.Schedule, k: int) -> dict[int, tuple[int, int]]:
    st, _, bed, needle = ir.positions(sched, k)
    return {int(s): (int(b), int(n)) for s, b, n in zip(st, bed, needle, strict=True)}


def ring_wales(G: Graph, a: list[int], b: list[int]) -> None:
    for x, y in zip(a, b, strict=True):
        G.wale(x, y)


# ---- layout families (ch. 6.7.2) ----------------------------------------------------------------


@pytest.mark.parametrize("n", range(2, 12))
def test_circular_layouts_are_5n_for_even_and_4n_for_odd(n):
    seen = set()
    for nib in range(ir.n_nibbles(n)):
        bed, rel = ir.circular_layouts(n, nib, np.arange(n))
        seen |= {(tuple(b), tuple(r)) for b, r in zip(bed.tolist(), rel.tolist(), strict=True)}
    assert len(seen) == (5 * n if n % 2 == 0 else 4 * n)


def _slack_ok(rel: np.ndarray, ring: bool) -> bool:
    r = np.r_[rel, rel[:1]] if ring else rel
    return bool(np.all(np.abs(np.diff(r)) <= 1))


@pytest.mark.parametrize("n", range(1, 13))
def test_every_layout_satisfies_the_slack_constraint(n):
    for nib in range(ir.n_nibbles(n)):
        beds, rels = ir.circular_layouts(n, nib, np.arange(n))
        for b, r in zip(beds, rels, strict=True):
            assert _slack_ok(r, True) and r.min() == 0
            assert len(set(zip(b.tolist(), r.tolist(), strict=True))) == n
    for p in ir.flat_params(n):
        b, r = ir.flat_layout(n, *p)
        assert _slack_ok(r, False) and r.min() == 0
        assert len(set(zip(b.tolist(), r.tolist(), strict=True))) == n


@pytest.mark.parametrize("n", [1, 2, 5, 9, 16])
def test_flat_layouts_lays_out_every_shape_at_once_as_one_by_one(n):
    params = ir.flat_params(n)
    beds, rels = ir.flat_layouts(n, np.array(params))
    assert beds.shape == rels.shape == (len(params), n)
    for p, b, r in zip(params, beds, rels, strict=True):
        one_b, one_r = ir.flat_layout(n, *p)
        assert b.tolist() == one_b.tolist() and r.tolist() == one_r.tolist()


def test_ring_shapes_leave_out_their_corners():
    # N = 6, no nibble: 3 front left to right, 3 back right to left, facing each other
    bed, rel = ir.circular_shape(6, 0)
    assert bed.tolist() == [0, 0, 0, 1, 1, 1] and rel.tolist() == [0, 1, 2, 2, 1, 0]
    bed, rel = ir.circular_shape(6, 1)  # FL+FR: the front is short at both ends
    assert bed.tolist() == [0, 0, 1, 1, 1, 1] and rel.tolist() == [1, 2, 3, 2, 1, 0]
    bed, rel = ir.circular_shape(5, 3)  # BR: the back misses its right corner
    assert bed.tolist() == [0, 0, 0, 1, 1] and rel.tolist() == [0, 1, 2, 1, 0]
    # roll r puts the first entry in slot r
    bed, rel = ir.circular_layouts(6, 0, np.array([2]))
    assert (int(bed[0, 0]), int(rel[0, 0])) == (0, 2)
    assert ir.aligned(ir.CIRCULAR, 6, 0, 0) and not ir.aligned(ir.CIRCULAR, 5, 0, 0)


def test_flat_layouts_cover_the_row_the_single_fold_and_the_c_shape():
    bed, rel = ir.flat_layout(6, 6, 0, 0, 0)  # the plain row
    assert bed.tolist() == [0] * 6 and rel.tolist() == [0, 1, 2, 3, 4, 5]
    bed, rel = ir.flat_layout(6, 4, 0, 0, 0)  # single fold: two entries under the left end
    assert bed.tolist() == [1, 1, 0, 0, 0, 0] and rel.tolist() == [1, 0, 0, 1, 2, 3]
    bed, rel = ir.flat_layout(7, 4, 1, 2, 0)  # C-shape on the back, folds at both ends
    assert bed.tolist() == [0, 1, 1, 1, 1, 0, 0] and rel.tolist() == [0, 0, 1, 2, 3, 3, 2]
    bed, rel = ir.flat_layout(4, 4, 1, 0, 1)  # mirrored: right to left
    assert rel.tolist() == [3, 2, 1, 0]
    assert (6, 0, 0, 0) in ir.flat_params(6) and (3, 1, 2, 1) in ir.flat_params(6)
    assert all(m >= 3 for m, *_ in ir.flat_params(6))


# ---- the cost tuple (eq. 6.21) -------------------------------------------------------------------


def test_cost_tuple_on_hand_made_pairs():
    b0, r0 = ir.circular_layouts(8, 0, np.array([0]))
    b1, r1 = ir.circular_layouts(8, 0, np.array([1]))
    b0, r0, b1, r1 = b0[0], r0[0], b1[0], r1[0]
    assert ir.pair_cost(0, 0, b0, r0, b0, r0) == (0, 0, 0)
    assert ir.pair_cost(0, 0, b0, r0, b0, r0 + 3) == (0, 0, 0)  # a translation is free
    # rolled by one: the two corner loops change bed; at the best translation (one needle
    # either way) three loops keep their offset, five move
    assert ir.pair_cost(0, 0, b0, r0, b1, r1) == (0, 2, 5)
    bn, rn = ir.circular_layouts(8, 1, np.array([0]))
    al, ro, sh = ir.pair_cost(0, 1, b0, r0, bn[0], rn[0])
    assert al == 1 and (al, ro, sh) > (0, 2, 5)  # lexicographic: alignment first


# ---- within a node: the reuse shortcut ---------------------------------------------------------


def test_plain_courses_reuse_their_layout_even_when_the_cycle_is_rotated():
    G = Graph()
    c0, c1, c2 = G.course("t", 8), G.course("t", 8), G.course("t", 8)
    ring_wales(G, c0, c1)
    ring_wales(G, c1, c2)
    g = G.build()
    rot = c2[3:] + c2[:3]  # the third cycle starts three entries later
    s = make_slices(g, [c0, c1, rot], [True] * 3)
    sched = run(g, s)
    assert sched.reuse.tolist() == [False, True, True]
    assert sched.roll[2] == (sched.roll[1] + 3) % 8
    assert sched.cost["align"] == 0 and sched.cost["roll"] == sched.cost["shift"] == 0
    assert ir.loop_moves(g, sched) == (0, 0)
    p1, p2 = places(sched, 1), places(sched, 2)
    assert all(p2[c2[i]] == p1[c1[i]] for i in range(8))


@pytest.mark.parametrize(
    "text",
    [
        "tube t { length: 30, width: 12 }",
        "sheet s { type: flat, length: 30, width: 12 }",
        "tube t { length: 20, width: 9, gauge: half }",
    ],
)
def test_plain_tube_and_sheet_have_no_roll_and_no_shift(text):
    r = compile_source(text, "t.knit", until="schedule")
    assert r.ok, r.diagnostics.render()
    sched = r.schedule
    assert sched.cost == {"align": 0, "roll": 0, "shift": 0}
    assert ir.loop_moves(r.graph, sched) == (0, 0)
    # every slice as long as the one before it takes its layout over (the last one is
    # shorter: the cast-off stitches have no next wales to bring in)
    n = r.slices.length
    same = (n[1:] == n[:-1]) & ~r.slices.fresh[1:]
    assert same.sum() >= r.slices.n_slices - 3 and np.all(sched.reuse[1:][same])
    assert len(set(sched.offset.tolist())) == 1


def test_a_gauge_change_keeps_the_layout_in_place():
    # wristband2 changes gauge twice (full -> half -> full, equal needle spans): each course
    # pairs with the one across the change loop for loop on its own bed, so no ring rolls
    # and the garment stays on the 50 needles the original used (plus the left margin); it
    # used to slide 6-7 needles at each change and take 78
    path = Path(__file__).resolve().parent.parent / "examples" / "knitskel" / "wristband2.knit"
    r = compile_source(path.read_text(), str(path), until="schedule")
    assert r.ok, r.diagnostics.render()
    sched = r.schedule
    assert sched.width <= 52
    assert ir.loop_moves(r.graph, sched)[0] == 0
    gauges = r.graph.course_gauge[r.graph.course[sched.slices.stitch[sched.slices.start]]]
    change = np.flatnonzero(np.diff(gauges.astype(int)) != 0)
    assert change.size >= 3
    for k in change.tolist():  # the slices on both sides of each change sit at one offset
        assert sched.offset[k] == sched.offset[k + 1]


def test_a_shaping_slice_moves_only_the_loops_it_must():
    r = compile_source(
        "tube t { length: 12, width: [0: 8, 1: 11], shaper: sides }", "t.knit", until="schedule"
    )
    assert r.ok, r.diagnostics.render()
    sched = r.schedule
    increases = int(((r.graph.wale_next >= 0).sum(1) == 2).sum())
    assert increases == 6
    # a fold increase grows the ring by one corner: a nibble, or two moved loops at most
    roll, shift = ir.loop_moves(r.graph, sched)
    assert roll == 0 and shift <= 2 * increases


# ---- between nodes: bridges and orders --------------------------------------------------------


def test_bridges_order_three_branches_with_the_middle_one_between():
    orders = valid_orders([0, 1, 2], {frozenset((0, 1)), frozenset((1, 2))})
    assert orders == {(0, 1, 2), (2, 1, 0)}
    assert valid_orders([0, 1], {frozenset((0, 1))}) == {(0, 1), (1, 0)}
    # a ring of bridges (an unfolded split) allows no line: no pruning
    assert (
        valid_orders([0, 1, 2], {frozenset((0, 1)), frozenset((1, 2)), frozenset((2, 0))}) is None
    )


def _merge(n_branches: int, w: int = 4):
    """Tubes of 2w stitches knitted one after the other, merged into one ring whose front
    holds their fronts left to right and whose back their backs right to left."""
    G = Graph()
    branches = [G.course(f"b{i}", 2 * w) for i in range(n_branches)]
    base = G.course("base", 2 * w * n_branches)
    fronts = [b[:w] for b in branches]
    backs = [b[w:] for b in branches]
    base_front = base[: w * n_branches]
    base_back = base[w * n_branches :]
    ring_wales(G, [x for f in fronts for x in f], base_front)
    ring_wales(G, [x for b in backs[::-1] for x in b], base_back)
    g = G.build()
    s = make_slices(g, branches + [base], [True] * (n_branches + 1))
    return g, s, branches, base


def test_a_two_to_one_merge_puts_the_branches_in_the_order_of_the_merged_ring():
    g, s, (a, b), base = _merge(2)
    sched = run(g, s)
    pa, pb = places(sched, 0), places(sched, 1)
    assert max(n for _, n in pa.values()) < min(n for _, n in pb.values())
    assert ir.loop_moves(g, sched) == (0, 0)
    # the bridges of the merged ring: the two course neighbours across each bed
    lab = np.array([0] * 4 + [1] * 4 + [1] * 4 + [0] * 4)
    other = np.array(a[:4] + b[:4] + b[4:] + a[4:])
    nodes, bridges = hub_bridges(g, True, (lab, other))
    assert nodes == [0, 1] and bridges == {frozenset((0, 1))}


def test_a_three_to_one_merge_keeps_the_middle_branch_in_the_middle():
    g, s, branches, _ = _merge(3)
    sched = run(g, s)
    lo = [min(n for _, n in places(sched, k).values()) for k in range(3)]
    hi = [max(n for _, n in places(sched, k).values()) for k in range(3)]
    assert hi[0] < lo[1] and hi[1] < lo[2] or hi[2] < lo[1] and hi[1] < lo[0]
    assert ir.loop_moves(g, sched) == (0, 0)


# ---- offsets --------------------------------------------------------------------------------


def test_held_branches_never_overlap_the_knitted_one():
    g, s, branches, base = _merge(3)
    sched = run(g, s)
    # while branch 2 is knitted, branches 0 and 1 wait on the bed: all distinct needles
    held = {n for k in (0, 1) for n in places(sched, k).values()}
    assert not held & set(places(sched, 2).values())


def _two_pieces():
    """Two independent tubes knitted turn about; the first grows by two at its left fold."""
    G = Graph()
    x0, y0 = G.course("x", 8), G.course("y", 8)
    x1, y1 = G.course("x", 10), G.course("y", 8)
    # x: the front-left and back-left stitches split in two
    G.wale(x0[0], x1[0])
    G.wale(x0[0], x1[1])
    for i in range(1, 4):
        G.wale(x0[i], x1[i + 1])
    for i in range(4, 7):
        G.wale(x0[i], x1[i + 1])
    G.wale(x0[7], x1[8])
    G.wale(x0[7], x1[9])
    ring_wales(G, y0, y1)
    g = G.build()
    x1_cycle = x1
    s = make_slices(g, [x0, y0, x1_cycle, y1], [True] * 4)
    return g, s


@pytest.mark.parametrize("gap", [1, 2])
def test_a_changing_block_keeps_a_gap_from_an_unrelated_held_block(gap):
    g, s = _two_pieces()
    sched = run(g, s, gap=gap)
    grown = [n for _, n in places(sched, 2).values()]
    held = [n for _, n in places(sched, 1).values()]  # y waits while x grows
    assert ir.alignments(sched, 2)[0].size == 0
    dist = min(abs(a - b) for a in grown for b in held)
    assert dist >= gap + 1


def test_blocks_fit_the_bed_or_fail_with_e601():
    g, s = _two_pieces()
    diags = Diagnostics()
    # x grows to 5 needles per bed, y takes 4 and one needle stays free between them,
    # after the 2 needles of margin: 12 needles
    assert run(g, s, needles=12).width == 12
    assert schedule(g, s, needles=11, diags=diags) is None
    assert [d.code for d in diags] == ["E601"]
    assert diags.items[0].message == "the garment needs 12 needles but the machine has 11"


def test_e601_from_the_driver():
    r = compile_source(
        "machine { needles: 30 }\ntube t { length: 3, width: 40 }", "t.knit", until="schedule"
    )
    assert [d.code for d in r.diagnostics if d.is_error] == ["E601"]
    assert r.schedule is None


# ---- half gauge (ch. 6.8.2) ----------------------------------------------------------------


def test_half_gauge_puts_fronts_on_even_and_backs_on_odd_needles_facing_empty_ones():
    r = compile_source(
        "tube h { length: 6, width: 5, gauge: half }\n"
        "tube f { length: 4, width: 5 }\nh.top -> f.bottom",
        "t.knit",
        until="schedule",
    )
    assert r.ok, r.diagnostics.render()
    sched, s = r.schedule, r.slices
    assert set(sched.step.tolist()) == {1, 2}
    for k in range(s.n_slices):
        _, _, bed, needle = ir.positions(sched, k)
        if sched.step[k] == 2:
            assert np.all(needle % 2 == bed)
            taken = set(zip(bed.tolist(), needle.tolist(), strict=True))
            assert not any((1 - b, n) in taken for b, n in taken)
            assert np.array_equal(
                needle, sched.offset[k] + 2 * sched.rel[s.start[k] : s.start[k] + s.length[k]] + bed
            )


# ---- the code generator's helpers ------------------------------------------------------------


def test_positions_and_alignments_are_what_the_code_generator_reads():
    g, s, branches, base = _merge(2)
    sched = run(g, s)
    st, state, bed, needle = ir.positions(sched, 2)
    assert st.tolist() == base and np.all(state == ACTIVE)
    assert bed.dtype == np.int8 and needle.min() >= 0
    # branch 0 waits on the bed while branch 1 is knitted (slice 1): move one of its loops
    # out of the way by hand and read it back
    far = int(sched.width) + 5
    moved = replace(
        sched,
        align_slice=np.array([1], np.int32),
        align_stitch=np.array([branches[0][0]], np.int32),
        align_bed=np.array([0], np.int8),
        align_needle=np.array([far], np.int32),
    )
    got = ir.alignments(moved, 1)
    assert [x.tolist() for x in got] == [[branches[0][0]], [0], [far]]
    assert all(a.size == 0 for a in ir.alignments(moved, 0))
    assert ir.verify(g, moved) == []
    # onto a needle of the branch being knitted: two loops on one needle
    clash = replace(
        moved,
        align_needle=np.array([int(ir.positions(sched, 1)[3][0])], np.int32),
        align_bed=np.array([int(ir.positions(sched, 1)[2][0])], np.int8),
    )
    assert any("two loops" in p for p in ir.verify(g, clash))
    # a loop that is not waiting then (branch 1 is in the cycle of slice 1)
    wrong = replace(moved, align_stitch=np.array([branches[1][0]], np.int32))
    assert any("not held" in p for p in ir.verify(g, wrong))


def test_the_verifier_rejects_broken_schedules():
    g, s, _, _ = _merge(2)
    sched = run(g, s)
    n = sched.needle.copy()
    n[1] = n[0]
    assert any("two loops" in p or "expansion" in p for p in ir.verify(g, replace(sched, needle=n)))
    r = sched.rel.copy()
    r[0] += 3
    assert any("parameters" in p for p in ir.verify(g, replace(sched, rel=r)))
    assert any("off the bed" in p for p in ir.verify(g, replace(sched, needles=3)))


# ---- JSON -------------------------------------------------------------------------------------


def test_emit_schedule_is_stable_with_stats_first(tmp_path, capsys):
    path = ROOT / "examples" / "sock.knit"
    outs = []
    for i in range(2):
        out = tmp_path / f"s{i}.json"
        assert main(["--emit", "schedule", "-o", str(out), str(path)]) == 0
        outs.append(out.read_text())
    assert outs[0] == outs[1]
    data = json.loads(outs[0])
    assert list(data) == ["stats", "slices", "alignments"]
    assert list(data["stats"])[:3] == ["slices", "entries", "width"]
    first = data["slices"][0]
    assert set(first) >= {"id", "node", "layout", "offset", "gauge", "cycle"}
    assert first["cycle"][0][2][0] in "fb"
    r = compile_source(path.read_text(), str(path), until="schedule")
    assert emit_json(r, "schedule") == outs[0]


# ---- against the fixed layout -------------------------------------------------------------------


def fixed_layout_moves(g: StitchGraph, needles: int) -> tuple[int, int]:
    """Loop moves of the fixed layout: every loop goes from its stitch's needle to that of
    its first next wale."""
    lay = layout(g, needles, Diagnostics())
    c = g.wale_next[:, 0]
    has = c >= 0
    return (
        int(np.count_nonzero(lay.bed[has] != lay.bed[c[has]])),
        int(np.count_nonzero(lay.needle[has] != lay.needle[c[has]])),
    )


@pytest.mark.parametrize("path", EXAMPLES, ids=lambda p: str(p.relative_to(ROOT / "examples")))
def test_schedule_moves_no_more_loops_than_the_fixed_layout(path):
    r = compile_source(path.read_text(), str(path), until="schedule")
    assert r.schedule is not None, r.diagnostics.render()
    roll, shift = fixed_layout_moves(r.graph, r.skeleton.machine.needles)
    moved_roll, moved_shift = ir.loop_moves(r.graph, r.schedule)
    assert moved_roll + moved_shift <= roll + shift
    stats = json.loads(emit_json(r, "schedule"))["stats"]  # (the dump counts them too)
    assert (stats["moves_roll"], stats["moves_shift"]) == (moved_roll, moved_shift)
