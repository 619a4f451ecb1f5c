"""Slicing (traced yarn → bed slices, thesis ch. 6.7.1): small designs whose slices are
worked out by hand, every example, the `slice_shaping` machine property, `--emit slices`,
and hand-broken slicings that `scheduling.slices.verify` must reject.

Cycles are written as in the thesis's figures: a stitch id and its state's initial,
`7a` active, `7e` expected, `7s` suspended, in cycle order (flat: left to right; rings:
front left to right, then back right to left).
"""

from __future__ import annotations

import json
from functools import cache
from pathlib import Path

import numpy as np
import pytest

import test_stitch_graph
from knitc.cli import main
from knitc.driver import compile_file, compile_source, emit_json
from knitc.scheduling import slices as sl
from knitc.scheduling.slicing import slice_trace
from knitc.scheduling.tracing import trace_rules
from knitc.shaping.stitch_graph import COURSE_KINDS

ROOT = Path(__file__).resolve().parent.parent
EXAMPLES = sorted((ROOT / "examples").glob("*.knit")) + sorted(
    (ROOT / "examples" / "knitskel").glob("*.knit")
)
IDS = [str(p.relative_to(ROOT / "examples")) for p in EXAMPLES]


@cache
def sliced(text: str):
    r = compile_source(text, "t.knit", until="slices")
    assert r.ok, r.diagnostics.render()
    assert sl.verify(r.graph, r.trace, r.slices) == []
    return r.graph, r.trace, r.slices


def cycle(s: sl.Slices, k: int) -> str:
    st, state = s.cycle(k)
    return " ".join(f"{int(a)}{'aes'[[1, 0, 2][int(b)]]}" for a, b in zip(st, state))


def cycles(s: sl.Slices) -> list[str]:
    return [cycle(s, k) for k in range(s.n_slices)]


# ---- hand-worked designs ---------------------------------------------------------------------


def test_flat_sheet_one_slice_per_course():
    g, t, s = sliced("sheet s { length: 3  width: 4 }")
    # courses run right to left every other row, but cycles always read left to right
    assert cycles(s) == ["0a 1a 2a 3a", "7a 6a 5a 4a", "8a 9a 10a 11a"]
    assert s.fresh.tolist() == [True, False, False]
    assert s.derived_from.tolist() == [-1, 0, 1]
    assert s.dir.tolist() == [1, -1, 1]
    assert s.cast_on.tolist() == [True, False, False]
    assert s.cast_off.tolist() == [False, False, True]
    assert not s.circular.any() and s.limit.tolist() == [2, 2, 2]
    assert s.visit.tolist() == [0, 4, 8] and s.visits.tolist() == [4, 4, 4]


def test_tube_slices_are_half_rings():
    # one carriage direction per slice: each round is a front pass and a back pass; the
    # cycle is always the whole ring, the half not knitted yet EXPECTED
    g, t, s = sliced("tube s { length: 3  width: 3 }")
    assert cycles(s) == [
        "0a 1a 2a 3e 4e 5e",
        "6e 7e 8e 3a 4a 5a",
        "6a 7a 8a 9e 10e 11e",
        "12e 13e 14e 9a 10a 11a",
        "12a 13a 14a 15e 16e 17e",
        # the last course's front half ends, but its loops wait on the bed, SUSPENDED,
        # for the course's cast-off, which comes once its back half is knitted
        "12s 13s 14s 15a 16a 17a",
    ]
    assert s.fresh.tolist() == [True] + [False] * 5
    assert s.dir.tolist() == [1, -1] * 3
    assert s.circular.tolist() == [True] * 6  # the last round stays a ring
    assert s.limit.tolist() == [4] * 6
    assert s.cast_on.tolist() == [True, True, False, False, False, False]
    assert s.cast_off.tolist() == [False, False, False, False, True, True]


def test_decrease_suspends_then_merges():
    # 8 -> 4: every stitch of course 0 decreases. Two merges fill slice 1 (limit 2), so
    # stitches 0-3 stay SUSPENDED on their needles until slice 2 merges them; there 8 and
    # 9, which end, wait too, for the cast-off at the end of their course.
    g, t, s = sliced("sheet s { length: 2  width: [0: 8, 1: 4] }")
    assert cycles(s) == ["0a 1a 2a 3a 4a 5a 6a 7a", "0s 1s 2s 3s 9a 8a", "11a 10a 9s 8s"]
    assert s.shaping.tolist() == [0, 2, 2]
    dec = sl.decreasing(g)
    st, state = s.cycle(1)
    assert dec[st[state == sl.SUSPENDED]].all()
    # each merge replaced its two suspended parents
    for m in (8, 9, 10, 11):
        assert sorted(g.wale_prev[m]) in ([0, 1], [2, 3], [4, 5], [6, 7])
    assert sorted(g.wale_prev[10].tolist() + g.wale_prev[11].tolist()) == [0, 1, 2, 3]


def test_closed_tube_merges_front_and_back():
    # a closed top collapses the back onto the front: the front's last loops wait
    # SUSPENDED while the back is knitted, then both merge
    g, t, s = sliced("tube t { length: 3  width: 3 }\nt.top closed")
    assert cycles(s)[3:] == ["6s 7s 8s 9a 10a 11a", "12a 13a 14a"]
    # a collapse closing is a fold, not shaping: it does not count towards the limit
    assert s.shaping.tolist()[-1] == 0 and s.cast_off.tolist()[-1]
    # the merges leave the last cycle on the front bed: a flat cycle, cut with the
    # tubular limit it opened with
    assert not s.circular[-1] and s.limit[-1] == 4


def test_a_collapse_closing_is_not_cut_by_the_shaping_limit():
    # 6 front+back merges, more than the tubular limit of 4: still one slice, because a
    # fold moves loops straight across the beds (a cut would leave half the closing waiting)
    g, t, s = sliced("tube t { length: 2  width: 6 }\nt.top closed")
    st, state = s.cycle(s.n_slices - 1)
    assert (state == sl.ACTIVE).sum() == 6 and (state == sl.SUSPENDED).sum() == 0
    assert (sl.stitch_shaping(g)[st] == 0).all()
    # a real decrease of a tube still counts
    g, t, s = sliced("tube t { length: 2  width: [0: 8, 1: 4], shaper: sides }")
    assert s.shaping.sum() == 8


def test_a_gauge_change_is_not_cut_by_the_shaping_limit():
    # 10 half-gauge stitches spread 1:2 onto 20 full-gauge ones: ten increases, but no loop
    # stretches, so the course is one slice (per direction), not five
    g, t, s = sliced(
        "sheet a { length: 2  width: 10  gauge: half }\n"
        "sheet b { length: 2  width: 20 }\na.top -> b.bottom"
    )
    spread = [c for c in range(g.n_courses) if g.course_gauge[c] == 1][0]
    ids = set(g.course_ids(spread).tolist())
    holding = [
        k
        for k in range(s.n_slices)
        if ids
        & set(
            s.stitch[s.start[k] : s.start[k] + s.length[k]][
                s.state[s.start[k] : s.start[k] + s.length[k]] == sl.ACTIVE
            ].tolist()
        )
    ]
    assert len(holding) == 1 and s.shaping[holding[0]] == 0
    assert ((g.wale_next[list(ids)] >= 0).sum(1) <= 1).all()  # the spread is in the parents


def test_increase_children_are_expected_in_order():
    g, t, s = sliced("tube t { length: 2  width: [0: 3, 1: 4] }")
    assert sorted(g.wale_next[1].tolist()) == [7, 8]  # stitch 1 increases
    assert cycles(s)[:2] == ["0a 1a 2a 3e 4e 5e", "6e 7e 8e 9e 3a 4a 5a"]
    assert s.shaping.tolist()[:2] == [1, 1]  # 1 on the front, 4 on the back
    assert g.needle[7] < g.needle[8]  # the two children, left to right


def test_short_row_joint_slices_hold_the_whole_ring():
    g, t, s = sliced(
        "tube a { length: 2  width: 6 }\njoint j { rows: 3  width: 4 }\n"
        "tube b { length: 2  width: 6 }\na.top -> j.bottom\nj.top -> b.bottom"
    )
    j = g.node_names.index("j")
    ks = np.flatnonzero(s.node == j)
    first = int(ks[0])
    assert s.fresh[first] and not s.fresh[ks[1:]].any()
    # the joint's first own stitch is in a short row: its fresh slice is the ring as the
    # yarn finds it, the first short row plus the continuity stitches of the other columns
    st, state = s.cycle(first)
    kinds = {COURSE_KINDS[int(g.course_kind[g.course[x]])] for x in st}
    assert kinds == {"short_row", "continuity"}
    assert set(g.node[st]) == {j}
    assert cycle(s, first) == "24a 25a 26a 27a 28a 38e 39e 40e 41e 42e 43e 44e"
    # every slice of the joint holds one stitch per column of the 12-stitch ring
    for k in ks:
        assert s.length[k] == 12
    # a short row that continues in the same direction as a wale child is cut (37 is 36's
    # next wale), then the continuity course turns round the back
    assert cycles(s)[6:9] == [
        "45e 33a 34a 35a 36a 38e 39e 40e 41e 42e 43e 44e",
        "45e 46e 47e 48e 37a 38a 39e 40e 41e 42e 43e 44e",
        "45e 46e 47e 48e 49e 50e 39a 40a 41a 42a 43a 44a",
    ]


# the same small split and merge as the stitch-graph tests
SPLIT, MERGE = test_stitch_graph.SPLIT, test_stitch_graph.MERGE


def test_split_branches_open_fresh_slices():
    g, t, s = sliced(SPLIT)
    # the trunk's last slice already expects both branches' first stitches
    assert cycle(s, 3) == "16e 17e 20e 21e 12a 13a 14a 15a"
    fork = g.node_names.index("fork")
    ks = np.flatnonzero(s.node == fork)
    assert s.fresh[ks].tolist() == [True, False, True, False]
    assert s.yarn[ks].tolist() == [0, 0, 1, 1]  # the second branch has its own yarn
    assert [cycle(s, int(k)) for k in ks] == [
        "16a 17a 18e 19e",
        "24e 25e 18a 19a",
        "20a 21a 22e 23e",
        "28e 29e 22a 23a",
    ]


def test_merge_opens_on_the_first_branch_then_on_the_base():
    g, t, s = sliced(MERGE)
    fork = g.node_names.index("fork")
    ks = np.flatnonzero(s.node == fork)
    assert [cycle(s, int(k)) for k in ks] == [
        "18e 19e 16a 17e",  # the continuity course over the left branch's ring
        "18e 19e 24e 17a",
        "18a 19a 24e 25e",
        # the base reaches the right branch: fresh, with the knitted 18 and 19 replaced by
        # their next wales in the trunk
        "26e 27e 20a 21a 22e 23e 24e 25e",
        "26e 27e 28e 29e 22a 23a 24a 25a",
    ]
    assert s.fresh[ks].tolist() == [True, False, False, True, False]
    assert g.wale_next[18, 0] == 26 and g.wale_next[19, 0] == 27


# ---- the shaping limit -------------------------------------------------------------------

WIDEN = "sheet s { length: 2  width: [0: 4, 1: 8] }"


def test_machine_slice_shaping_cuts_more_slices():
    _, _, default = sliced(WIDEN)
    g, t, one = sliced("machine { slice_shaping: 1 }\n" + WIDEN)
    assert one.n_slices > default.n_slices
    assert (one.limit == 1).all() and (default.limit == 2).all()
    assert (one.shaping <= 1).all() and int(one.shaping.sum()) == int(default.shaping.sum())
    assert cycles(one)[:4] == [
        "0a 1e 2e 3e",
        "11e 10e 1a 2e 3e",
        "11e 10e 9e 8e 2a 3e",
        "11e 10e 9e 8e 7e 6e 3a",
    ]
    _, _, many = sliced("machine { slice_shaping: 1000 }\n" + WIDEN)
    assert many.n_slices < default.n_slices and (many.limit == 1000).all()


def test_one_stitch_may_exceed_the_limit():
    # a stitch that is both a merge and an increase shapes 2: with limit 1 it still gets
    # a slice of its own, which the verifier accepts for a one-visit slice only
    g, t, s = sliced(
        "sheet s { length: 3  width: [0: 8, 0.5: 4, 1: 8] }\nmachine { slice_shaping: 1 }"
    )
    shp = sl.stitch_shaping(g)
    assert (shp == 2).any()
    big = s.shaping > s.limit
    assert big.any() and (s.visits[big] == 1).all()
    assert (shp[s.stitch[s.state == sl.ACTIVE]] <= 2).all()


# ---- every example ---------------------------------------------------------------------------


@pytest.mark.parametrize("path", EXAMPLES, ids=IDS)
def test_examples_slice_validly(path):
    r = compile_file(str(path), until="slices")
    assert r.ok, r.diagnostics.render()
    g, s = r.graph, r.slices
    assert sl.verify(g, r.trace, s) == []
    st = s.stats()
    assert st["active"] == r.trace.n_visits == g.n_stitches
    # the yarn's first slice in every node is fresh; derived slices stay in their node
    src = s.derived_from[~s.fresh]
    assert (s.node[src] == s.node[~s.fresh]).all() and (src < np.flatnonzero(~s.fresh)).all()
    # the rule-based tracer, single and double, slices validly too
    for passes in (1, 2):
        t2 = trace_rules(g, passes=passes)
        assert sl.verify(g, t2, slice_trace(g, t2)) == []


# ---- --emit slices ---------------------------------------------------------------------------


def test_emit_slices_json(tmp_path, capsys):
    src = tmp_path / "t.knit"
    src.write_text("tube s { length: 3  width: 3 }\n", encoding="utf-8")
    assert main(["--emit", "slices", str(src)]) == 0
    out = capsys.readouterr().out
    assert main(["--emit", "slices", str(src)]) == 0
    assert capsys.readouterr().out == out  # deterministic
    data = json.loads(out)
    assert list(data) == ["stats", "slices"]
    assert data["stats"] == {
        "slices": 6,
        "fresh": 1,
        "entries": 36,
        "expected": 15,
        "active": 18,
        "suspended": 3,
        "shaping": 0,
    }
    first = data["slices"][0]
    assert list(first)[:2] == ["id", "node"]
    assert first["cycle"] == [[0, "a"], [1, "a"], [2, "a"], [3, "e"], [4, "e"], [5, "e"]]
    assert first["fresh"] and first["derived_from"] == -1 and first["cast_on"]
    assert [d["visits"] for d in data["slices"]] == [[v, 3] for v in range(0, 18, 3)]
    r = compile_file(str(src), until="slices")
    assert emit_json(r, "slices") == out


# ---- the verifier rejects broken slicings ---------------------------------------------------


@pytest.fixture(scope="module")
def shaped():
    """A tube that widens and is closed at the top: fresh, derived, increases, suspended
    stitches and merges."""
    return sliced("tube t { length: 4  width: [0: 3, 1: 5] }\nt.top closed")


def _copy(s):
    return {f: getattr(s, f).copy() for f in s.__dataclass_fields__}


def _entries(s, k: int, state: int) -> np.ndarray:
    """Indices (into the flat entry arrays) of slice k's entries in `state`, in cycle order."""
    return int(s.start[k]) + np.flatnonzero(s.cycle(k)[1] == state)


def test_verifier_accepts_the_fixture(shaped):
    g, t, s = shaped
    assert (s.state == sl.SUSPENDED).any() and (s.shaping > 0).any()
    assert sl.verify(g, t, s) == []


def _expect(g, t, broken, word):
    problems = sl.verify(g, t, broken)
    assert problems, "the verifier accepted a broken slicing"
    assert any(word in p for p in problems), problems


def test_verifier_rejects_untiled_visits(shaped):
    g, t, s = shaped
    a = _copy(s)
    a["visits"][0] -= 1
    _expect(g, t, sl.Slices(**a), "tile")


def test_verifier_rejects_another_yarn_or_direction(shaped):
    g, t, s = shaped
    a = _copy(s)
    a["yarn"][2] = 5
    _expect(g, t, sl.Slices(**a), "yarn")
    a = _copy(s)
    a["dir"][2] = -a["dir"][2]
    _expect(g, t, sl.Slices(**a), "direction")


def test_verifier_rejects_mixed_cast_needs(shaped):
    g, t, s = shaped
    a = _copy(s)
    a["cast_on"][0] = False
    _expect(g, t, sl.Slices(**a), "cast-on")
    a = _copy(s)
    a["cast_off"][-1] = False
    _expect(g, t, sl.Slices(**a), "cast-off")


def test_verifier_rejects_lost_or_extra_active_entries(shaped):
    g, t, s = shaped
    a = _copy(s)
    a["state"][np.flatnonzero(a["state"] == sl.ACTIVE)[0]] = sl.EXPECTED
    _expect(g, t, sl.Slices(**a), "ACTIVE")
    a = _copy(s)
    a["state"][np.flatnonzero(a["state"] == sl.EXPECTED)[0]] = sl.ACTIVE
    _expect(g, t, sl.Slices(**a), "ACTIVE")


def test_verifier_rejects_wale_connected_stitches(shaped):
    g, t, s = shaped
    a = _copy(s)
    # slice 1's first EXPECTED entry (a child of slice 0's front) replaced by the next
    # course's stitch above it: two wale-connected stitches in one slice
    k = 1
    i = int(_entries(s, k, sl.ACTIVE)[0])
    a["stitch"][int(s.start[k])] = g.wale_next[a["stitch"][i], 0]
    _expect(g, t, sl.Slices(**a), "wale-connected")


def test_verifier_rejects_a_wrong_circular_flag(shaped):
    g, t, s = shaped
    a = _copy(s)
    a["circular"][0] = False
    _expect(g, t, sl.Slices(**a), "circular")


def test_verifier_rejects_a_stitch_twice(shaped):
    g, t, s = shaped
    a = _copy(s)
    a["stitch"][1] = a["stitch"][0]
    _expect(g, t, sl.Slices(**a), "twice")


def test_verifier_rejects_too_much_shaping(shaped):
    g, t, s = shaped
    k = int(np.flatnonzero((s.shaping > 0) & (s.visits > 1))[0])
    a = _copy(s)
    a["limit"][k] = int(s.shaping[k]) - 1
    _expect(g, t, sl.Slices(**a), "limit")
    a = _copy(s)
    a["shaping"][k] -= 1
    _expect(g, t, sl.Slices(**a), "miscounts")


def test_verifier_rejects_a_wrong_derivation(shaped):
    g, t, s = shaped
    k = 2  # derived; swap two EXPECTED entries: not the order derivation gives
    i, j = (int(x) for x in _entries(s, k, sl.EXPECTED)[:2])
    a = _copy(s)
    a["stitch"][[i, j]] = a["stitch"][[j, i]]
    _expect(g, t, sl.Slices(**a), "derived")
    a = _copy(s)
    a["derived_from"][k] = 0  # not the node's last slice
    _expect(g, t, sl.Slices(**a), "last slice of its node")
    a = _copy(s)
    a["fresh"][k] = True
    _expect(g, t, sl.Slices(**a), "fresh")


def test_verifier_rejects_a_wrong_fresh_cycle(shaped):
    g, t, s = shaped
    assert cycle(s, 0) == "0a 1a 2a 3e 4e 5e"
    a = _copy(s)
    a["stitch"][[3, 5]] = a["stitch"][[5, 3]]  # the back bed read the wrong way round
    _expect(g, t, sl.Slices(**a), "fresh cycle")


def test_verifier_rejects_a_suspended_stitch_that_does_not_decrease(shaped):
    g, t, s = shaped
    a = _copy(s)
    k = 1
    i = int(_entries(s, k, sl.EXPECTED)[0])
    a["state"][i] = sl.SUSPENDED
    _expect(g, t, sl.Slices(**a), "suspends")


def test_verifier_rejects_an_expected_stitch_already_knitted(shaped):
    g, t, s = shaped
    a = _copy(s)
    # put slice 0's first (knitted) stitch back into slice 3 in place of an EXPECTED entry
    # (its next wale, 6, is not in slice 3)
    k = 3
    i = int(_entries(s, k, sl.EXPECTED)[-1])
    a["stitch"][i] = s.stitch[0]
    _expect(g, t, sl.Slices(**a), "finished")


def test_verifier_rejects_a_merge_of_unsuspended_parents(shaped):
    g, t, s = shaped
    k = s.n_slices - 1  # the closing course: merges of 14-17 (suspended) with 18-21
    src = int(s.derived_from[k])
    st, state = s.cycle(src)
    assert cycle(s, src) == "14s 15s 16s 17s 18a 19a 20a 21a"
    a = _copy(s)
    # the source slice forgets that 14-17 were suspended: they become EXPECTED, which
    # they cannot be (knitted already), and the merges lose their suspended parents
    a["state"][int(s.start[src]) + np.flatnonzero(state == sl.SUSPENDED)] = sl.EXPECTED
    _expect(g, t, sl.Slices(**a), "finished")
    # a merge placed where its parents were not: the cycle is not the derived one
    a = _copy(s)
    a["stitch"][int(s.start[k]) : int(s.start[k]) + 2] = [23, 22]
    _expect(g, t, sl.Slices(**a), "derived")
