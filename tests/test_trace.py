"""Yarn tracing (stitch graph → trace IR, thesis ch. 6.6): both tracers on every example.

`trace_courses` (the driver's tracer, one visit per stitch) and `trace_rules` (R1-R6, with
`passes=1` or `passes=2`) run on every design in `examples/` and `examples/knitskel/`; each
trace must pass `trace.verify` and the independent checks below. Then the numbers the
original reports for the knitskel ports (yarns, tucks), the `--emit trace` dump, and
hand-corrupted traces that the verifier must reject.

The last section holds regression tests for the tracing bugs these tests found (carriage
directions, tucks, far JUMPs, the R7/R8 hook, a closed start), fixed in c2df2e1 and bfe996e.
"""

from __future__ import annotations

import json
from functools import cache
from pathlib import Path

import numpy as np
import pytest

from knitc.cli import main
from knitc.driver import compile_file, compile_source
from knitc.scheduling import trace as tr
from knitc.scheduling.tracing import trace_courses, trace_rules
from knitc.shaping import stitch_graph as sg

ROOT = Path(__file__).resolve().parent.parent
KNITSKEL = ROOT / "examples" / "knitskel"
FIXTURES = Path(__file__).resolve().parent / "fixtures" / "knitskel"
EXAMPLES = sorted((ROOT / "examples").glob("*.knit")) + sorted(KNITSKEL.glob("*.knit"))
IDS = [str(p.relative_to(ROOT / "examples")) for p in EXAMPLES]

TRACERS = {
    "courses": trace_courses,
    "rules1": lambda g: trace_rules(g, passes=1),
    "rules2": lambda g: trace_rules(g, passes=2),
}


@cache
def graph(path: str) -> sg.StitchGraph:
    r = compile_file(path, until="stitch-graph")
    assert r.ok, r.diagnostics.render()
    return r.graph


@cache
def traced(path: str, tracer: str) -> tr.Trace:
    return TRACERS[tracer](graph(path))


def knitskel(name: str) -> str:
    return str(KNITSKEL / f"{name}.knit")


def fixture(name: str) -> dict:
    return json.loads((FIXTURES / f"{name}.json").read_text(encoding="utf-8"))


# ---- independent checks (the verifier's rules, written again) ---------------------------------


def yarn_visits(t: tr.Trace, y: int) -> np.ndarray:
    return np.nonzero(t.yarn == y)[0]


def neighbours(g: sg.StitchGraph, a: int, b: int) -> bool:
    return a == b or b in (g.cnext[a], g.cprev[a]) or b in g.wale_next[a] or b in g.wale_prev[a]


def near(g: sg.StitchGraph, a: int, b: int) -> bool:
    """What a JUMP may bridge (scheduling/trace.py, scheduling/tracing.py): an adjacent needle of the same
    node, or one diagonal step onto the next course (a spiral)."""
    if g.node[a] == g.node[b] and abs(int(g.needle[a]) - int(g.needle[b])) <= 1:
        return True
    for nb in (g.cnext[a], g.cprev[a]):
        if nb >= 0 and b in g.wale_next[nb]:
            return True
    return any(ch >= 0 and b in (g.cnext[ch], g.cprev[ch]) for ch in g.wale_next[a])


def check_trace(g: sg.StitchGraph, t: tr.Trace) -> list[str]:
    """Everything a trace promises, checked visit by visit."""
    out = []
    n = g.n_stitches
    if t.n_visits != t.passes * n:
        out.append(f"{t.n_visits} visits for {n} stitches x {t.passes}")
    counts = np.bincount(t.stitch, minlength=n)
    if np.any(counts != t.passes):
        out.append("a stitch is not visited `passes` times")
    first = np.full(n, -1)
    last = np.full(n, -1)
    for i, s in enumerate(t.stitch):
        if first[s] < 0:
            first[s] = i
        last[s] = i
    for s in range(n):
        for p in g.wale_prev[s]:
            if p >= 0 and first[s] < last[p]:
                out.append(f"stitch {s} visited before its previous wale {int(p)} is finished")
                break
    if set(np.unique(t.yarn)) != set(range(t.n_yarns)):
        out.append("yarn ids are not 0..n-1")
    if not set(np.unique(t.dir)) <= {-1, 1}:
        out.append("a direction is not +-1")
    if np.any(t.flags & ~np.uint8(127)):
        out.append("unknown flag bits")
    for y in range(t.n_yarns):
        idx = yarn_visits(t, y)
        fl = t.flags[idx]
        if not fl[0] & tr.START or np.count_nonzero(fl & tr.START) != 1:
            out.append(f"yarn {y}: START is not exactly on its first visit")
        if not fl[-1] & tr.END or np.count_nonzero(fl & tr.END) != 1:
            out.append(f"yarn {y}: END is not exactly on its last visit")
        st = t.stitch[idx]
        for k in range(1, len(idx)):
            a, b = int(st[k - 1]), int(st[k])
            if fl[k] & tr.CARRY:
                if tr.carried(g, a, b) < 0:
                    out.append(f"yarn {y}: carried {a} -> {b} from another edge")
                    break
            elif fl[k] & tr.SHIFT:
                if not tr.shifted(g, a, b):
                    out.append(f"yarn {y}: shifted {a} -> {b} beyond its course and the next")
                    break
            elif not neighbours(g, a, b) and not fl[k] & tr.JUMP:
                out.append(f"yarn {y}: unflagged jump {a} -> {b}")
                break
    return out


def far_jumps(g: sg.StitchGraph, t: tr.Trace) -> list[tuple[int, int]]:
    """JUMP-flagged steps that bridge more than the IR allows."""
    bad = []
    for y in range(t.n_yarns):
        idx = yarn_visits(t, y)
        for i, j in zip(idx[:-1], idx[1:]):
            a, b = int(t.stitch[i]), int(t.stitch[j])
            if t.flags[j] & tr.JUMP and not (neighbours(g, a, b) or near(g, a, b)):
                bad.append((a, b))
    return bad


def direction_errors(g: sg.StitchGraph, t: tr.Trace) -> list[int]:
    """Visits whose `dir` disagrees with the needle step from the yarn's previous visit, for
    steps between two stitches of one course on one bed."""
    bad = []
    for y in range(t.n_yarns):
        idx = yarn_visits(t, y)
        a, b = t.stitch[idx[:-1]], t.stitch[idx[1:]]
        same = (
            (g.course[a] == g.course[b]) & (g.side[a] == g.side[b]) & (g.needle[a] != g.needle[b])
        )
        step = np.sign(g.needle[b].astype(np.int64) - g.needle[a].astype(np.int64))
        bad += [int(v) for v in idx[1:][same & (step != t.dir[idx[1:]])]]
    return bad


# ---- every tracer on every example --------------------------------------------------------------


@pytest.mark.parametrize("tracer", list(TRACERS))
@pytest.mark.parametrize("path", EXAMPLES, ids=IDS)
def test_tracer_on_example(path, tracer):
    g = graph(str(path))
    t = traced(str(path), tracer)
    assert tr.verify(g, t) == []
    assert check_trace(g, t) == []
    passes = 2 if tracer == "rules2" else 1
    assert t.passes == passes and t.n_visits == passes * g.n_stitches
    assert np.all(np.bincount(t.stitch, minlength=g.n_stitches) == passes)
    assert t.method == ("courses" if tracer == "courses" else "rules")
    st = t.stats()
    assert np.count_nonzero(t.flags & tr.START) == st["yarns"] == t.n_yarns >= 1
    assert np.count_nonzero(t.flags & tr.END) == st["yarns"]


@pytest.mark.parametrize("path", EXAMPLES, ids=IDS)
def test_trace_courses_visits_in_id_order_and_jumps_are_near(path):
    """Course by course in id order, one yarn a course; an intarsia course has a yarn per
    region (R7), and a round of one is visited from a wall, one way or back."""
    g = graph(str(path))
    t = traced(str(path), "courses")
    band = g.intarsia_courses()
    at = 0
    for c in range(g.n_courses):
        ids = g.course_ids(c).tolist()
        got = t.stitch[at : at + len(ids)].tolist()
        at += len(ids)
        if not band[c]:
            assert got == ids
            assert len(set(t.yarn[g.course_ids(c)])) == 1
        elif not g.course_circular[c]:
            assert got == ids and len(set(t.yarn[g.course_ids(c)])) > 1
        else:
            k = ids.index(got[0])
            turned = ids[k:] + ids[:k]
            assert got in (turned, turned[:1] + turned[1:][::-1]), c
    assert far_jumps(g, t) == []


@pytest.mark.parametrize("path", EXAMPLES[:3], ids=IDS[:3])
def test_driver_trace_is_trace_courses(path):
    r = compile_file(str(path), until="trace")
    assert r.stage_reached == "trace"
    t = trace_courses(r.graph)
    for field in ("stitch", "yarn", "dir", "flags"):
        assert np.array_equal(getattr(r.trace, field), getattr(t, field))


def test_passes_must_be_one_or_two():
    g = graph(knitskel("wristband"))
    with pytest.raises(ValueError):
        trace_rules(g, passes=3)


# ---- the numbers of the knitskel ports ---------------------------------------------------------

YARNS_TODAY = {
    "sweatpants": 2,
    "sock": 1,
    "sock_flat": 1,
    "wristband": 3,
    "glove": 7,
    "split_unfolded_4x": 5,
    "wristband2": 3,
}
"""`trace_courses` yarn counts today. The original (fixtures): sweatpants 2, sock 1,
sock_flat 1, glove 5, split_unfolded_4x 4, and with the ports' stand-in nodes wristband 3,
wristband2 3. The differences:
- glove: the yarn of the last branch into each merge (index finger, thumb) ends there and a
  new one starts on the split's continuity course, where the original runs on;
- split_unfolded_4x: the tube's yarn knits all four branch courses (jumping between
  strips), then each strip starts its own yarn; the original continues into strip 0 only.
(wristband2 had 4 until c2df2e1: its closed start got a yarn of its own.)"""


@pytest.mark.parametrize("name", list(YARNS_TODAY))
def test_knitskel_yarns(name):
    t = traced(knitskel(name), "courses")
    assert t.n_yarns == YARNS_TODAY[name]
    if name in ("sweatpants", "sock", "sock_flat"):
        assert t.n_yarns == fixture(name)["yarn_starts"] == len(fixture(name)["yarns"])


def test_sweatpants_yarns_match_the_original():
    g, t = graph(knitskel("sweatpants")), traced(knitskel("sweatpants"), "courses")
    assert (
        [len(yarn_visits(t, y)) for y in range(t.n_yarns)]
        == [y["stitches"] for y in fixture("sweatpants")["yarns"]]
        == [5352, 2952]
    )
    legs = {
        y: {g.node_names[int(g.node[s])] for s in t.stitch[yarn_visits(t, y)]} for y in range(2)
    }
    assert legs == {0: {"waist", "split", "leg1"}, 1: {"split", "leg2"}}


@pytest.mark.parametrize("name", ["sock", "sock_flat"])
def test_sock_tucks(name):
    t = traced(knitskel(name), "courses")
    assert t.stats()["tucks"] == 16 == fixture(name)["trace"]["tucks"]
    assert t.n_yarns == 1


@pytest.mark.parametrize("path", EXAMPLES, ids=IDS)
def test_trace_courses_tucks_only_where_short_rows_turn(path):
    g, t = graph(str(path)), traced(str(path), "courses")
    kinds = {sg.COURSE_KINDS.index("short_row"), sg.COURSE_KINDS.index("continuity")}
    tucked = t.stitch[(t.flags & tr.TUCK_PREV) != 0]
    assert all(int(g.course_kind[g.course[s]]) in kinds for s in tucked)
    joints = bool(np.any(g.course_kind == sg.COURSE_KINDS.index("short_row")))
    assert (len(tucked) > 0) == joints
    if path.name == "sock.knit" and path.parent.name == "examples":
        assert len(tucked) == 11  # one per turn between its 12 short rows


def test_sock_tucks_are_on_every_short_row_turn():
    """Which stitches are tucks: every short row after the first starts with one, where the
    yarn turns."""
    g, t = graph(knitskel("sock")), traced(knitskel("sock"), "courses")
    heel = g.node_names.index("heel")
    rows = [
        c
        for c in range(g.n_courses)
        if g.course_node[c] == heel and sg.COURSE_KINDS[int(g.course_kind[c])] == "short_row"
    ]
    starts = [int(g.course_start[c]) for c in rows]
    for s in starts[1:]:
        assert t.flags[s] & tr.TUCK_PREV


def test_sock_tucks_where_the_original_puts_them():
    g, t = graph(knitskel("sock")), traced(knitskel("sock"), "courses")
    heel = g.node_names.index("heel")
    courses = [c for c in range(g.n_courses) if g.course_node[c] == heel]
    kinds = [sg.COURSE_KINDS[int(g.course_kind[c])] for c in courses]
    first_row = courses[kinds.index("short_row")]
    cont = courses[kinds.index("continuity")]
    assert not t.flags[int(g.course_start[first_row])] & tr.TUCK_PREV
    assert t.flags[int(g.course_start[cont])] & tr.TUCK_PREV


def test_sweatpants_has_two_yarns_with_every_tracer():
    for tracer in TRACERS:
        assert traced(knitskel("sweatpants"), tracer).n_yarns == 2


# ---- the JSON dump --------------------------------------------------------------------------------


def test_emit_trace_json(capsys):
    path = knitskel("sock")
    assert main(["--emit", "trace", path]) == 0
    text = capsys.readouterr().out
    assert text.startswith('{\n "stats": {\n  "visits": ')
    obj = json.loads(text)
    assert list(obj) == ["stats", "yarns", "visits"]
    assert list(obj["stats"])[:3] == ["visits", "yarns", "tucks"]
    assert obj["stats"]["visits"] == 1490 and obj["stats"]["yarns"] == 1
    assert obj["stats"]["tucks"] == 16
    assert len(obj["visits"]) == 1490 and len(obj["yarns"]) == 1
    assert obj["yarns"][0] == {
        "yarn": 0,
        "visits": 1490,
        "first": 0,
        "last": 1489,
        "nodes": ["bottom", "heel", "main"],
    }
    assert obj["visits"][0]["flags"] == ["start"] and obj["visits"][-1]["flags"] == ["end"]
    assert sum("tuck" in v["flags"] for v in obj["visits"]) == 16
    # deterministic
    assert main(["--emit", "trace", path]) == 0
    assert capsys.readouterr().out == text


# ---- the verifier rejects corrupted traces -------------------------------------------------------


def _copy(t: tr.Trace) -> tr.Trace:
    return tr.Trace(
        t.stitch.copy(),
        t.yarn.copy(),
        t.dir.copy(),
        t.flags.copy(),
        passes=t.passes,
        method=t.method,
    )


@pytest.fixture(scope="module")
def tube():
    g = compile_source("tube t { length: 4  width: 3 }\n", "t.knit", until="stitch-graph").graph
    t = trace_courses(g)
    assert tr.verify(g, t) == []
    return g, t


def test_verifier_catches_a_stitch_before_its_parent(tube):
    g, t = tube
    bad = _copy(t)
    child = int(g.wale_next[2, 0])  # stitch 2's wale child, one course later
    bad.stitch[2], bad.stitch[child] = child, 2
    problems = tr.verify(g, bad)
    assert any(f"stitch {child} is knitted before its previous wale 2" in p for p in problems)
    assert check_trace(g, bad)


def test_verifier_catches_a_dropped_visit(tube):
    g, t = tube
    keep = np.arange(t.n_visits) != 7
    bad = tr.Trace(t.stitch[keep], t.yarn[keep], t.dir[keep], t.flags[keep])
    assert tr.verify(g, bad) == ["stitch 7 is visited 0 times, not 1"]


def test_verifier_catches_a_double_pass_missing_a_visit(tube):
    g, _ = tube
    t = trace_rules(g, passes=2)
    assert tr.verify(g, t) == []
    i = int(np.nonzero(t.stitch == 5)[0][0])
    keep = np.arange(t.n_visits) != i
    bad = tr.Trace(t.stitch[keep], t.yarn[keep], t.dir[keep], t.flags[keep], passes=2)
    assert tr.verify(g, bad) == ["stitch 5 is visited 1 times, not 2"]


def test_verifier_catches_an_unflagged_jump(tube):
    g, t = tube
    bad = _copy(t)
    # knit the first course 0, 2, 1, 3, ...: 0 -> 2 skips a stitch without a JUMP flag
    bad.stitch[1], bad.stitch[2] = 2, 1
    problems = tr.verify(g, bad)
    assert any("yarn 0 jumps from stitch 0 to 2 without a justification" in p for p in problems)
    # a JUMP flag justifies only a step to a neighbouring needle: 0 -> 2 skips one
    bad.flags[1] |= tr.JUMP
    assert any(
        "from stitch 0 to 2, which is not a neighbouring needle" in p for p in tr.verify(g, bad)
    )


def test_verifier_catches_a_cleared_jump_flag(tube):
    g, t = tube
    jumps = np.nonzero(t.flags & tr.JUMP)[0]
    assert jumps.size  # the tube's spiral: back 0 -> front 0 of the next course
    bad = _copy(t)
    bad.flags[jumps[0]] &= ~np.uint8(tr.JUMP)
    assert any("without a justification" in p for p in tr.verify(g, bad))


def test_verifier_catches_missing_yarn_starts(tube):
    g, t = tube
    bad = _copy(t)
    bad.flags[0] &= ~np.uint8(tr.START)
    assert tr.verify(g, bad) == ["0 yarn starts for 1 yarns"]
    bad = _copy(t)
    bad.yarn[6:] = 1  # a second yarn from course 1 on, without its START
    assert "1 yarn starts for 2 yarns" in tr.verify(g, bad)


# ---- regressions: bugs these tests found --------------------------------------------------------


def test_trace_rules_direction_on_flat_courses():
    g = graph(str(ROOT / "examples" / "sheet.knit"))
    assert direction_errors(g, trace_rules(g, passes=1)) == []


def test_trace_courses_direction_on_a_course_crossing_beds():
    g = graph(knitskel("sock"))
    assert direction_errors(g, traced(knitskel("sock"), "courses")) == []


@pytest.mark.parametrize("tracer", list(TRACERS))
@pytest.mark.parametrize("path", EXAMPLES, ids=IDS)
def test_directions_follow_the_needles_and_jumps_are_near(path, tracer):
    """Every tracer, every example: `dir` is the needle step along a bed, and a JUMP
    bridges at most a neighbouring needle or a spiral's diagonal."""
    g, t = graph(str(path)), traced(str(path), tracer)
    assert direction_errors(g, t) == []
    assert far_jumps(g, t) == []


def test_trace_rules_jumps_are_near():
    g = graph(str(ROOT / "examples" / "sock.knit"))
    assert far_jumps(g, trace_rules(g, passes=1)) == []


def test_trace_rules_yarn_of_hook_starts_and_ends_yarns():
    g = compile_source(
        "sheet s { type: flat  length: 4  width: 6 }\n", "t.knit", until="stitch-graph"
    ).graph
    t = trace_rules(g, passes=1, yarn_of=lambda s: 1 if g.needle[s] >= 3 else 0)
    assert t.n_yarns == 2
    assert tr.verify(g, t) == []


def test_closed_start_keeps_one_yarn():
    """Regression (fixed in c2df2e1): the collapsed first course used to end away from the
    tube's first stitch, so a second yarn started."""
    g = compile_source(
        "tube a { length: 3  width: 3 }\nstart a.bottom\na.bottom closed\n",
        "t.knit",
        until="stitch-graph",
    ).graph
    t = trace_courses(g)
    assert t.n_yarns == 1 and tr.verify(g, t) == [] and check_trace(g, t) == []
