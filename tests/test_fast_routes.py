"""The fast routes of `knitc k2dat` held to the general ones they short-cut, on every Knitout
file of the test suite and the examples' own: `knitout_to_dat` (bare records straight to a
DAT) against `parse_knitout` + `to_dat` + `encode`, and the row encoder against the numpy
raster (`pack(render())`); the simulator's fast path against its general handlers; and code
generation's action-pass short cuts (`generate.FAST_PASSES`) against every stitch as an
Action, op for op. A fast route may decline (None: the caller takes the general one), never
differ."""

from __future__ import annotations

from functools import cache
from pathlib import Path

import pytest
from hypothesis import HealthCheck, assume, event, given, settings
from hypothesis import strategies as st

from knitc.backends.dat_format import DatError, _encode_rows, encode, pack, render
from knitc.backends.dat_write import DatWriteError, to_dat
from knitc.backends.knitout import write_knitout
from knitc.backends.knitout_read import KnitoutError, knitout_to_dat, parse_knitout
from knitc.codegen.bed import Pos, Unsupported
from knitc.codegen.machine import Machine, MachineProgram, Needle
from knitc.driver import compile_file, compile_source
from test_stdlib_patterns import CASES, NO_PURL, SHAPES
from test_transfers import Problem, make_bed

REPO = Path(__file__).resolve().parent.parent
FILES = sorted(p for p in (REPO / "tests").rglob("*.k") if "fuzz" not in p.parts)
DESIGNS = ["tube", "sheet", "sock", "knitskel/wristband2"]


@cache
def example_knitout(name: str) -> str:
    r = compile_file(str(REPO / "examples" / f"{name}.knit"), until="machine")
    assert r.program is not None
    return write_knitout(r.program)


def general(text: str) -> bytes | None:
    try:
        return encode(to_dat(parse_knitout(text, "t.k")))
    except (KnitoutError, DatWriteError, DatError, ValueError):
        return None


def check(text: str) -> None:
    warnings: list[KnitoutError] = []
    fast = knitout_to_dat(text, "t.k", warnings=warnings)
    if fast is not None:
        assert fast == general(text)


@pytest.mark.parametrize("path", FILES, ids=lambda p: str(p.relative_to(REPO / "tests")))
def test_straight_to_dat_is_the_general_route(path: Path) -> None:
    check(path.read_text(encoding="utf-8", errors="replace"))


@pytest.mark.parametrize("name", DESIGNS)
def test_straight_to_dat_on_the_examples(name: str) -> None:
    text = example_knitout(name)
    fast = knitout_to_dat(text, "t.k", warnings=[])
    assert fast is not None and fast == general(text)


@pytest.mark.parametrize("name", DESIGNS)
def test_row_encoder_is_the_raster(name: str) -> None:
    image = to_dat(parse_knitout(example_knitout(name), "t.k"))
    rows = _encode_rows(image)
    assert rows is not None and rows == pack(render(image))  # (plain designs: never declined)


# ---- the simulator's fast path ------------------------------------------------------------


def _run(prog, fast: bool, **options):
    from knitc.codegen.simulate import Simulator

    sim = Simulator(prog, **options)
    sim.fast_path = fast
    findings = sim.run()
    end = (
        dict(sim.loops),
        sim.active,
        sim.hook,
        sim.racking,
        dict(sim.last_touch),
        dict(sim.last_use),
        dict(sim.anchor),
        dict(sim.missed),
        sim.loop_at,
        sim.loop_front,
        sim.loop_prev,
        sim.loop_prev_d,
        sim.loop_next,
        sim.loop_next_d,
        sim.loop_more,
        sim.on_needle,
        sim.last_loop,
        # (the open knitting pass: which needles it knitted, its span, where it is)
        sim._pass_key,
        sim._pass_pos,
        sim._pass_span,
        sim._pass_touched,
        sim._passes,
    )
    return [(f.kind, f.severity, f.message, f.op, f.stitch) for f in findings], end


SIM_OPTIONS = [{}, {"limit_per_kind": 1}, {"max_loops": 1, "max_float": 2}, {"placed": True}]


def _readable(path: Path) -> bool:
    try:
        parse_knitout(path.read_text(encoding="utf-8", errors="replace"), "t.k")
    except (KnitoutError, ValueError):
        return False  # (a hostile fixture: the reader refuses it, nothing to simulate)
    return True


PROGRAMS = [p for p in FILES if _readable(p)]


@pytest.mark.parametrize("options", SIM_OPTIONS, ids=str)
@pytest.mark.parametrize("path", PROGRAMS, ids=lambda p: str(p.relative_to(REPO / "tests")))
def test_simulator_fast_path_is_the_general_handlers(path: Path, options: dict) -> None:
    prog = parse_knitout(path.read_text(encoding="utf-8", errors="replace"), "t.k")
    assert _run(prog, True, **options) == _run(prog, False, **options)


@pytest.mark.parametrize("name", DESIGNS)
def test_simulator_fast_path_on_the_examples(name: str) -> None:
    prog = parse_knitout(example_knitout(name), "t.k")
    assert _run(prog, True, verified=True) == _run(prog, False, verified=True)


@st.composite
def _passes(draw) -> MachineProgram:
    """A random program of knitting passes: a cast-on, then passes of knits (and now and
    then a tuck, miss, drop or transfer) over runs of needles with gaps, turning back or
    not, on one bed or from bed to bed, at a racking, sometimes against the direction or
    on a needle twice: what the simulator's plain-knit runs must simulate exactly as op by
    op."""
    prog = MachineProgram(Machine(needles=30, max_misses=draw(st.integers(1, 6))))
    c = draw(st.sampled_from([(3,), (3,), (4,)]))
    prog.inhook(c)
    lo = draw(st.integers(0, 20))
    width = draw(st.integers(2, 30 - lo))
    for k in reversed(range(lo, lo + width)):  # a tube's cast-on over [lo, lo + width)
        prog.tuck(-1, Needle("f", k), c)
    prog.releasehook(c)
    for k in range(lo, lo + width):
        prog.tuck(1, Needle("b", k), c)
    for k in reversed(range(lo, lo + width)):  # (the first knit of a cast-on loop: W808)
        prog.knit(-1, Needle("f", k), c)
    for k in range(lo, lo + width):
        prog.knit(1, Needle("b", k), c)
    for _ in range(draw(st.integers(1, 10))):
        d = draw(st.sampled_from([1, -1]))
        bed = draw(st.sampled_from(["f", "f", "b"]))
        plain = draw(st.booleans())  # (knits only: a run from end to end)
        rib = plain and draw(st.integers(0, 2))  # (... going from bed to bed, as a rib's)
        if draw(st.booleans()):
            prog.rack(draw(st.integers(-1, 1)))
        if plain:  # (a needle here and there left out)
            needles = [k for k in range(lo, lo + width) if draw(st.integers(0, 9))]
        else:
            needles = draw(st.lists(st.integers(max(lo - 2, 0), min(lo + width + 2, 29))))
        if plain or draw(st.integers(0, 3)):
            needles = sorted(set(needles), reverse=d < 0)
        for k in needles:
            kind = draw(st.sampled_from(["knit"] * 8 + ["tuck", "tuck", "miss", "drop", "xfer"]))
            other = (k // rib) % 2 if rib else not plain and not draw(st.integers(0, 5))
            n = Needle("fb".replace(bed, "") if other else bed, k)
            kind = "knit" if plain else kind
            if kind == "xfer":
                r = int(prog.racking)
                prog.xfer(n, n.opposite(k - r if n.bed == "f" else k + r))
            elif kind == "drop":
                prog.drop(n)
            else:
                getattr(prog, kind)(d, n, c)
    return prog


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(prog=_passes(), options=st.sampled_from([*SIM_OPTIONS[:3], {"max_float": 1}]))
def test_simulator_fast_path_on_random_passes(prog: MachineProgram, options: dict) -> None:
    for verified in (False, True):
        assert _run(prog, True, verified=verified, **options) == _run(
            prog, False, verified=verified, **options
        )


def _tube(width: int = 10) -> MachineProgram:
    """A cast-on of `width` needles on both beds, each knitted once (W808 done with)."""
    prog = MachineProgram(Machine(needles=30, max_misses=2))
    prog.inhook(3)
    for k in reversed(range(width)):
        prog.tuck(-1, Needle("f", k), 3)
    prog.releasehook(3)
    for k in range(width):
        prog.tuck(1, Needle("b", k), 3)
    for k in reversed(range(width)):
        prog.knit(-1, Needle("f", k), 3)
    for k in range(width):
        prog.knit(1, Needle("b", k), 3)
    return prog


def _knits(prog: MachineProgram, d: int, bed: str, ks) -> MachineProgram:
    for k in ks:
        prog.knit(d, Needle(bed, k), 3)
    return prog


def _rib(racking: int, knits: list[tuple[int, int]]) -> MachineProgram:
    """A pass of knits going + from bed to bed at `racking`: (front?, needle) each, a needle
    now and then met twice or behind the pass's position (where a run must stop)."""
    prog = _tube()
    prog.rack(racking)
    for front, k in knits:
        prog.knit(1, Needle("f" if front else "b", k), 3)
    return prog


def _cast_on_inside() -> MachineProgram:
    prog = _tube()
    prog.drop("f5")
    prog.tuck(-1, "f5", 3)
    return _knits(prog, -1, "f", reversed(range(10)))


def _dropped(needle: str) -> MachineProgram:
    prog = _tube()
    prog.drop(needle)
    return prog


def _missed_inside() -> MachineProgram:
    prog = _tube()
    for d in (-1, 1, -1, 1):  # f4 missed by four passes (max_misses 2)
        _knits(prog, d, "f", [k for k in range(10)[::d] if k != 4])
    return _knits(prog, -1, "f", reversed(range(10)))


@pytest.mark.parametrize(
    "prog",
    [
        _cast_on_inside(),
        _missed_inside(),
        _knits(_tube(), -1, "f", [9, 8, 7, 3, 2, 1, 0]),  # a long float in the run
        _knits(_knits(_tube(), -1, "f", [9, 8, 7, 6]), -1, "f", [5, 4, 3, 2, 1]),  # (one pass)
        _knits(_dropped("f5"), -1, "f", reversed(range(10))),  # an empty needle
        _knits(_tube(), 1, "b", [0, 1, 2, 3, 4, 5, 6, 7, 8, 9]),
        _rib(0, [(1, 0), (1, 1), (1, 2), (1, 3), (0, 3), (1, 4), (1, 5), (0, 5), (0, 6)]),
        _rib(0, [(1, 0), (1, 1), (1, 2), (0, 2), (1, 2), (1, 3), (1, 4), (1, 5), (1, 6)]),
        _rib(-1, [(1, 0), (0, 1), (1, 1), (0, 2), (1, 2), (0, 3), (1, 3), (1, 4), (1, 5)]),
        _rib(-1, [(1, 0), (1, 1), (1, 2), (0, 2), (0, 3), (1, 3), (1, 4), (1, 5), (1, 6)]),
        _rib(1, [(1, 0), (0, 0), (1, 1), (0, 1), (1, 2), (0, 2), (0, 3), (1, 4), (0, 5)]),
    ],
    ids=[
        *("cast-on", "missed", "float", "two-runs", "empty", "back"),
        *("rib", "rib-twice", "rib-1", "rib-1-back", "rib+1"),
    ],
)
def test_simulator_knit_runs_stop_where_a_knit_needs_a_look(prog: MachineProgram) -> None:
    """A plain-knit run (`Simulator._knit_run`) stops before the knit whose needle needs the
    op-by-op way (a cast-on loop, a loop missed too often, a long float, an empty needle)."""
    for options in ({}, {"max_float": 2}):
        assert _run(prog, True, verified=True, **options) == _run(
            prog, False, verified=True, **options
        )


# ---- code generation: the action pass's short cuts against its general route ---------------

LACE = """import std.stitches (cable, eyelets)
sheet s { length: 30  width: 40 }
pattern s {
  apply eyelets() where wales(0.05:0.5)
  apply cable(2, 8) where wales(0.5:0.95)
}
"""
ACTIONS = """action rev { split_by_side: true
  pre { xfer(needle, opposite) }
  main { knit(dir, opposite, carriers) }
  post { xfer(opposite, needle) }
}
action lean {
  pre { xfer(needle, opposite) }
  main { miss(dir, needle, carriers)  knit(dir, opposite, carriers) }
  post { xfer(opposite, needle) }
}
tube t { length: 8  width: [0: 4, 1: 8]  gauge: half }
sheet s { length: 6  width: 6 }
t.top -> s.bottom
pattern t { use rev where courses(1:end) }
pattern s { use lean where select(1:2:end, 1) }
"""
CODEGEN = [f"examples/{n}.knit" for n in ("tube", "sheet", "sock", "sweater", "glove")] + [
    f"examples/knitskel/{n}.knit" for n in ("glove", "sweatpants", "wristband2", "sock_flat")
]


def _ops(text: str, path: str, fast: bool, monkeypatch: pytest.MonkeyPatch) -> list:
    from knitc.codegen import generate, transfers

    monkeypatch.setattr(generate, "FAST_PASSES", fast)
    monkeypatch.setattr(transfers, "FAST_ALONG_BED", fast)
    r = compile_source(text, path, until="machine")
    assert r.program is not None and not r.diagnostics.has_errors, r.diagnostics.render()
    return list(r.program.ops)


def _same_ops(text: str, path: str, monkeypatch: pytest.MonkeyPatch) -> None:
    fast, general = _ops(text, path, True, monkeypatch), _ops(text, path, False, monkeypatch)
    assert len(fast) == len(general)
    for i, (a, b) in enumerate(zip(fast, general, strict=True)):
        assert a == b and a.span == b.span, f"op {i}: {a} != {b}"


@pytest.mark.parametrize("name", CODEGEN)
def test_action_pass_short_cuts_on_the_examples(name: str, monkeypatch) -> None:
    path = REPO / name
    _same_ops(path.read_text(encoding="utf-8"), str(path), monkeypatch)


@pytest.mark.parametrize("text", [LACE, ACTIONS], ids=["lace", "actions"])
def test_action_pass_short_cuts_with_actions(text: str, monkeypatch) -> None:
    _same_ops(text, "t.knit", monkeypatch)


@pytest.mark.parametrize("module, name, shape", CASES)
def test_action_pass_short_cuts_on_every_stdlib_pattern(module, name, shape, monkeypatch):
    call = NO_PURL[module][name] if shape == "full-gauge tube" else f"{name}()"
    src = (
        f"import {module} ({name})\n" + SHAPES[shape].format() + f"\npattern s {{ apply {call} }}\n"
    )
    _same_ops(src, "t.knit", monkeypatch)


# ---- the transfer planner's short cut for one loop along its bed ----------------------------


@st.composite
def along_bed(draw) -> tuple[Problem, float | None, tuple[int, Pos, Pos]]:
    """A bed of loops (either gauge, pieces, a loop on a slider now and then) and one move
    of a loop, mostly a few needles along its bed (the bind-off's move), sometimes across
    a loop, to the other bed, or too far: the short cut must decline what it cannot plan."""
    half = draw(st.booleans())
    needles = draw(st.sets(st.integers(0, 30), min_size=1, max_size=14))
    start: dict[Pos, int] = {}
    for n in sorted(needles):
        bed = draw(
            st.sampled_from(["f", "b", "f", "b", "fs"] if draw(st.booleans()) else ["f", "b"])
        )
        if half and bed in ("f", "b") and draw(st.integers(0, 9)):
            n = 2 * (n // 2) + (bed == "b")  # keep the half-gauge parity, mostly
        start.setdefault((bed, n), len(start))
    hooks = [p for p in start if p[0] in ("f", "b")]
    assume(hooks)
    src = draw(st.sampled_from(hooks))
    dst_bed = src[0] if draw(st.integers(0, 5)) else ("b" if src[0] == "f" else "f")
    dst = (dst_bed, min(39, max(0, src[1] + draw(st.integers(-6, 6)))))
    assume(dst != src)
    pb = Problem(
        start,
        {},
        max_rack=draw(st.sampled_from([1, 2, 3, 4])),
        needles=40,
        course={s: draw(st.integers(0, 1)) for s in start.values()},
        circular=draw(st.booleans()),
    )
    carrier = draw(st.none() | st.integers(-1, 40).map(lambda x: x + 0.5))
    return pb, carrier, (start[src], src, dst)


def _plan(pb: Problem, carrier: float | None, m, fast: bool, monkeypatch) -> object:
    from knitc.codegen import transfers

    monkeypatch.setattr(transfers, "FAST_ALONG_BED", fast)
    bed = make_bed(pb, carrier_at=carrier)
    try:
        return transfers.plan(bed, [m])
    except Unsupported as exc:
        return str(exc)


def _short_cut(pb: Problem, carrier: float | None, m) -> bool:
    """Whether `plan` takes `_along_bed`'s short cut for the case (it does not decline)."""
    from knitc.codegen import transfers

    bed = make_bed(pb, carrier_at=carrier)
    return bool(m[1] != m[2] and bed.loops.get(m[1], 0)) and (
        transfers._along_bed(bed, *m) is not None
    )


@settings(max_examples=600, deadline=None, suppress_health_check=list(HealthCheck))
@given(along_bed())
def test_one_loop_along_its_bed_is_planned_as_the_planner_does(case) -> None:
    pb, carrier, m = case
    event("short cut" if _short_cut(pb, carrier, m) else "declined")
    with pytest.MonkeyPatch.context() as mp:
        assert _plan(pb, carrier, m, True, mp) == _plan(pb, carrier, m, False, mp)


def test_the_short_cut_plans_a_good_share_of_those_moves() -> None:
    """The comparison above is worth something only if the short cut often answers."""
    taken = []

    @settings(max_examples=300, deadline=None, suppress_health_check=list(HealthCheck))
    @given(along_bed())
    def count(case) -> None:
        taken.append(_short_cut(*case))

    count()
    assert sum(taken) >= len(taken) // 10, f"{sum(taken)} of {len(taken)}"


def test_a_bind_off_move_onto_its_neighbour_takes_the_short_cut() -> None:
    # half gauge: the loop of f2 goes onto f4, which keeps its own (a stack), through b2
    pb = Problem({("f", 0): 0, ("f", 2): 1, ("f", 4): 2, ("b", 5): 3}, {}, needles=40)
    assert _short_cut(pb, None, (1, ("f", 2), ("f", 4)))
    with pytest.MonkeyPatch.context() as mp:
        steps = _plan(pb, None, (1, ("f", 2), ("f", 4)), True, mp)
        assert steps == _plan(pb, None, (1, ("f", 2), ("f", 4)), False, mp)
    from knitc.codegen.transfers import Xfer

    assert steps == [Xfer(("f", 2), ("b", 2), 1, 0), Xfer(("b", 2), ("f", 4), 1, 2)]
