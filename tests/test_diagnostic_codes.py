"""Every diagnostic code knitc can produce has a golden case, and the reference lists it.

The codes are read from the compiler's source (every `"E123"` / `"W123"` literal); a golden
case is an expected diagnostic in `tests/golden/diagnostics/*.expected` or a FileCheck
line in `tests/filecheck/` (`error[E123]`). A new code without a case fails here.
"""

from __future__ import annotations

import re
from pathlib import Path

ROOT = Path(__file__).parent.parent
CODE = re.compile(r"[\"']([EW]\d{3})[\"']")
SHOWN = re.compile(r"(?:error|warning)\[([EW]\d{3})\]")

WITHOUT_GOLDEN_CASE: dict[str, str] = {
    "E000": "not a diagnostic: the resolver's `_Silent` marker for an evaluation that failed "
    "on an error already reported, never printed (golden 110_param_cycle and "
    "112_param_self_reference go through it and show each mistake once)",
    "E531": "defensive: a shaper's mapping the checks before it (E318, E319) let through; the "
    "only input that reached it, a pattern's name as `shaper:`, is now E312 at the property "
    "(golden 223); tests/test_shapers.py covers MappingError",
    "E317": "the resolver reports an assignment to a context name (`needle = ...`) as E222 "
    "before any action runs, so the interpreter's own check cannot fire; "
    "tests/test_interp.py::test_constants_are_readable_not_assignable",
    # knitc's simulation (codegen/simulate.py) runs on what code generation made, which is
    # clean by construction, and, through `knitc lint`, on any Knitout file: the cases of
    # tests/filecheck/lint/ cover its codes but these, which the Knitout reader stops first.
    "E801": "simulator: `knitc lint` reports a misaligned transfer as the reader's E916 "
    "(tests/filecheck/lint/lint_misaligned_xfer.k); tests/test_simulate.py::test_misaligned_xfer",
    "E802": "simulator: `knitc lint` reports a carrier used while out as the reader's E915 "
    "(tests/filecheck/lint/lint_carrier_not_in.k); tests/test_simulate.py::test_carrier_not_in",
    "E810": "simulator, a malformed op (the machine verifier fails first, an internal error; "
    "the Knitout reader makes only well-formed ops): "
    "tests/test_simulate.py::test_malformed_ops_are_reported_and_skipped",
}
"""Codes no input can produce through the CLI, each with the reason (and where it is tested
instead)."""


def compiler_codes() -> set[str]:
    codes: set[str] = set()
    for path in (ROOT / "compiler" / "knitc").rglob("*.py"):
        codes |= set(CODE.findall(path.read_text()))
    return codes


def golden_codes() -> set[str]:
    seen: set[str] = set()
    for path in (ROOT / "tests" / "golden").rglob("*.expected"):
        seen |= set(SHOWN.findall(path.read_text()))
    for path in (ROOT / "tests" / "filecheck").rglob("*"):
        if path.is_file():
            seen |= set(SHOWN.findall(path.read_text()))
    return seen


def test_every_code_has_a_golden_case():
    missing = sorted(compiler_codes() - golden_codes() - set(WITHOUT_GOLDEN_CASE))
    assert not missing, f"codes without a golden case: {', '.join(missing)}"


def test_the_exceptions_are_real_codes_without_a_case():
    stale = sorted(set(WITHOUT_GOLDEN_CASE) - (compiler_codes() - golden_codes()))
    assert not stale, f"listed as without a golden case but not: {', '.join(stale)}"
