"""The fuzzers' saved inputs, replayed on every `make test` (deterministic).

tests/fuzz/ holds the fuzz targets (targets.py: what counts as a bug), the grammar-aware
design generator (designs.py) and the runner (`make fuzz`, run.py). This file runs every
target on every saved input of its kind, so a bug a fuzzer once found stays fixed: the
hostile inputs of tests/fuzz/regressions/ (huge numbers, inf and nan, deep nesting,
blow-ups, hostile paths, mutated Knitout and DAT found by `make fuzz`) and the corpus. The
`editor` target (the language server's features at many offsets) runs on the designs the
compiler's do. The parser target also runs on every design of the project (its formatter round trip is a
differential check), and the `design` target on a fixed set of generated designs.
"""

from __future__ import annotations

import random
import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).parent / "fuzz"))

import targets  # noqa: E402

SAVED = [(t, p) for t in ("compile", "editor", "knitout", "dat") for p in targets.inputs(t)]


@pytest.mark.parametrize(("target", "path"), SAVED, ids=[f"{t}:{p.name}" for t, p in SAVED])
def test_saved_inputs(target: str, path: Path) -> None:
    targets.TARGETS[target](path.read_bytes())


PARSED = targets.inputs("parse", project=True)


@pytest.mark.parametrize("path", PARSED, ids=[p.name for p in PARSED])
def test_parse_and_format_round_trip(path: Path) -> None:
    targets.parse(path.read_bytes())


@pytest.mark.parametrize("seed", range(12))
def test_generated_designs(seed: int) -> None:
    import designs

    designs.fuzz_one()(random.Random(seed).randbytes(4000))


def test_a_bug_is_reported_with_its_input(tmp_path, monkeypatch, capsys) -> None:
    import run

    def broken(data: bytes) -> None:
        if b"boom" in data:
            raise targets.Bug("it broke")

    monkeypatch.setitem(targets.TARGETS, "parse", broken)
    (tmp_path / "ok").write_bytes(b"fine")
    (tmp_path / "bad").write_bytes(b"boom")
    assert run.main(["--reproduce", "parse", str(tmp_path / "ok")]) == 0
    assert run.main(["--reproduce", "parse", str(tmp_path / "bad")]) == 1
    assert "BUG in knitc\nit broke" in capsys.readouterr().out


def test_an_internal_error_is_a_bug(monkeypatch) -> None:
    """Exit status 3 (the CLI's internal error) is what every target treats as a bug."""
    import knitc.cli

    def crash(argv: list[str]) -> int:
        return 3

    monkeypatch.setattr(knitc.cli, "main", crash)
    with pytest.raises(targets.Bug, match="exit status 3"):
        targets.knitout(b"knit + f1 3\n")
