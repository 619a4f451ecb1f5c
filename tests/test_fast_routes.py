"""The fast routes of `knitc k2dat` held to the general ones they short-cut, on every Knitout
file of the test suite and the examples' own: `knitout_to_dat` (bare records straight to a
DAT) against `parse_knitout` + `to_dat` + `encode`, and the row encoder against the numpy
raster (`pack(render())`). A fast route may decline (None: the caller takes the general
one), never differ."""

from __future__ import annotations

from functools import cache
from pathlib import Path

import pytest

from knitc.backends.dat_format import DatError, _encode_rows, encode, pack, render
from knitc.backends.dat_write import DatWriteError, to_dat
from knitc.backends.knitout import write_knitout
from knitc.backends.knitout_read import KnitoutError, knitout_to_dat, parse_knitout
from knitc.driver import compile_file

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
    end = (dict(sim.loops), sim.active, sim.hook, sim.racking, sim.loop_at, sim.loop_prev)
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
