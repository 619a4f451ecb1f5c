"""`knitc lint FILE.k`: knitc's simulation of any Knitout file (`knitc.lint`).

* The hand-broken files of tests/filecheck/lint/ are FileCheck cases (tests/test_filecheck.py
  runs them: the golden output, line, caret and note); here each must report exactly the
  codes its CHECK lines name, and fail exactly when its RUN line expects it to.
* Every shipped design, compiled to Knitout, lints without errors, and with the same
  simulator findings `knitc check` gives the design.
* On a corpus (knitc's outputs, the hand-broken files, the Knitout fixtures) lint's verdict
  (errors or not) is the independent knitout-interpreter's (tests/oracle.py; its hazard
  warnings are not errors), except for the disagreements listed in `DISAGREEMENTS`, each the
  other tool's bug or limitation, with the reason (docs/architecture.md §7, "Lint").
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from knitc.backends.knitout import write_knitout
from knitc.codegen.simulate import CODES
from knitc.driver import compile_file
from knitc.lint import lint_file, lint_text
from oracle import run_oracle

REPO = Path(__file__).resolve().parent.parent
CASES = sorted((REPO / "tests" / "filecheck" / "lint").glob("*.k"))
DESIGNS = sorted((REPO / "examples").glob("*.knit")) + sorted(
    (REPO / "examples" / "knitskel").glob("*.knit")
)
FIXTURES = sorted((REPO / "tests" / "fixtures" / "dat").glob("*.k")) + sorted(
    (REPO / "tests" / "fixtures" / "knitout").glob("*.k")
)
SHOWN = re.compile(r"(?:error|warning)\[([EW]\d{3})\]")
SIMULATOR_CODES = set(CODES.values())

HEADER = (
    ";!knitout-2\n;;Machine: SWG091N2\n;;Gauge: 15\n;;Carriers: 1 2 3 4 5 6 7 8 9 10\n"
    ";;Position: {position}\n"
)

DISAGREEMENTS: dict[str, str] = {
    # knitc lint: errors; the oracle runs them clean
    "lint_racking_half_pitch.k": "oracle bug: it takes any fractional racking for the "
    "all-needle quarter pitch (rack 0.5 runs as 0.25); a Shima racks by whole needles and "
    "quarter pitch only, and the Knitout-to-DAT converter refuses 0.5 (research §1.7, rule 7)",
    "lint_xfer_quarter_pitch.k": "oracle bug: at a quarter-pitch racking it transfers as if at "
    "the whole racking below; f3 and b3 do not face each other at 0.25, and the converter "
    "refuses transfers at quarter pitch (research §1.7, rule 8)",
    "lint_releasehook_other.k": "oracle limitation: `releasehook 4` while the hook holds "
    "carrier 3 only warns (Mismatched_Releasehook_Warning) and releases carrier 3; the "
    "Knitout spec requires the hook to hold the carriers released, and the converter "
    "refuses it (research §1.7, spec-level and rule 4)",
    "lint_out_unused_carrier.k": "oracle limitation: it takes out a carrier that never made "
    "a stitch; the converter refuses `out` of a carrier that has not stitched (research "
    "§1.7, rule 5)",
    "lint_three_carriers.k": "oracle limitation: its machine feeds any number of carriers in "
    "one pass; the SWG091N2 it is built to feeds two, and the converter cannot encode three "
    "(research §1.7, rule 12)",
    # knitc lint: clean; the oracle stops on an error
    "lint_inhook_announced_early.k": "oracle bug: it parks the inserting hook at the next "
    "loop of any carrier after `inhook 4` (carrier 3's rightward row here, so it also "
    "reports the hook's first pass as rightward); the spec parks it at the first stitch of "
    "the hooked carrier (research §1.4, `inhook`)",
    "increase_split.k": "oracle limitation: its grammar has no negative needle numbers (its "
    "runner says so); Knitout allows them, and the converter places the design by "
    "`;;Position:` (research §1.3, §2.2), so only the program's width must fit the bed",
}
"""Corpus files (by name) on which lint's error verdict differs from the oracle's, and why
lint is right."""


def _codes(path: Path) -> set[str]:
    return set(SHOWN.findall(path.read_text(encoding="utf-8")))


# ---- the hand-broken files -------------------------------------------------------------------


@pytest.mark.parametrize("path", CASES, ids=lambda p: p.name)
def test_each_case_reports_the_codes_its_checks_name(path: Path):
    diags = lint_file(str(path))
    assert {d.code for d in diags} == _codes(path), diags.render()
    run = next(line for line in path.read_text().splitlines() if "RUN:" in line)
    assert diags.has_errors == ("not knitc lint" in run)
    for d in diags:  # at a Knitout line of the file; the simulator's name the op
        assert d.span is not None and d.span.file == str(path)
        if d.code in SIMULATOR_CODES:  # (the reader's E91x underline the token at fault)
            assert d.notes and d.notes[0].message.startswith("the operation: `")


def test_every_simulator_code_a_knitout_file_can_reach_has_a_case():
    shown = set().union(*(_codes(p) for p in CASES))
    # E801/E802 are the reader's E916/E915 in a Knitout file; E810 needs a malformed op
    assert SIMULATOR_CODES - shown == {"E801", "E802", "E810"}


def test_a_file_that_cannot_be_read(tmp_path):
    [d] = list(lint_file(str(tmp_path / "missing.k")))
    assert d.code == "E001" and d.is_error
    bad = tmp_path / "latin1.k"
    bad.write_bytes(b";!knitout-2\n; caf\xe9\n")
    assert [d.code for d in lint_file(str(bad))] == ["E001"]


def test_reader_errors_stop_before_the_simulation():
    diags = lint_text(HEADER.format(position="Center") + "knit + f1 3\nfrobnicate\n", "x.k")
    assert [d.code for d in diags] == ["E915", "E911"]  # no E804/E803: not simulated


# ---- where the program sits on the bed -------------------------------------------------------


def _swatch(lo: int, hi: int) -> str:
    """A one-row swatch on f(lo)..f(hi) (tucks, then bound off by drops)."""
    ops = ["inhook 3"] + [f"tuck - f{k} 3" for k in range(hi, lo - 1, -1)]
    ops += ["releasehook 3"] + [f"knit + f{k} 3" for k in range(lo, hi + 1)]
    ops += ["outhook 3"] + [f"drop f{k}" for k in range(lo, hi + 1)]
    return "\n".join(ops) + "\n"


def test_needles_are_placed_as_the_position_header_says():
    # a converter places a Center program by its width: negative needles are fine ...
    text = _swatch(-3, 4)
    diags = lint_text(HEADER.format(position="Center") + text, "c.k")
    assert "E806" not in {d.code for d in diags}
    # ... but Keep keeps its numbers, and f-3..f-1 are off the bed
    diags = lint_text(HEADER.format(position="Keep") + text, "k.k")
    assert [d.message for d in diags if d.code == "E806"][0] == (
        "needle f-1 is outside the bed (0..540) in `tuck - f-1 3`"
    )
    # a program wider than the bed is off it wherever it is placed
    diags = lint_text(HEADER.format(position="Center") + _swatch(-1, 540), "w.k")
    [e] = [d for d in diags if d.code == "E806"]
    assert e.message.startswith("needle f540 is outside the bed (-1..539, where `;;Position:")
    assert e.span is not None and e.span.line == 7  # the first op that uses it


# ---- knitc's own outputs ---------------------------------------------------------------------


def _key(path: Path) -> str:
    return path.stem if path.parent.name == "examples" else f"{path.parent.name}_{path.stem}"


@pytest.fixture(scope="module")
def compiled(tmp_path_factory) -> dict[str, tuple[Path, set[str]]]:
    """Every design's Knitout, with the simulator codes `knitc check` reports for it."""
    out = tmp_path_factory.mktemp("lint-designs")
    found = {}
    for design in DESIGNS:
        r = compile_file(str(design), until="machine")
        assert r.program is not None, r.diagnostics.render()
        path = out / f"{_key(design)}.k"
        path.write_text(write_knitout(r.program), encoding="utf-8")
        found[path.name] = (path, {d.code for d in r.diagnostics} & SIMULATOR_CODES)
    return found


def test_every_design_lints_clean_as_knitc_check_reports_it(compiled):
    assert len(compiled) >= 12
    for name, (path, check) in compiled.items():
        diags = lint_file(str(path))
        assert not diags.has_errors, name + "\n" + diags.render()
        assert {d.code for d in diags} == check, name + "\n" + diags.render()


# ---- agreement with the independent machine -------------------------------------------------


def test_error_verdicts_agree_with_the_oracle(compiled):
    corpus = [path for path, _ in compiled.values()] + CASES + FIXTURES
    names = [p.name for p in corpus]
    assert len(set(names)) == len(names)
    reports = run_oracle(corpus, timeout=300)
    agree, disagree = [], {}
    for path, report in zip(corpus, reports):
        mine = lint_file(str(path)).has_errors
        theirs = bool(report.problem_kinds() - {"hazard"})
        if mine == theirs:
            agree.append(path.name)
        else:
            disagree[path.name] = f"lint {'errors' if mine else 'clean'}; " + report.describe()
    unexplained = {n: why for n, why in disagree.items() if n not in DISAGREEMENTS}
    assert not unexplained, "\n\n".join(f"{n}: {why}" for n, why in unexplained.items())
    stale = sorted(set(DISAGREEMENTS) - set(disagree))
    assert not stale, f"listed as disagreeing but agree now: {stale}"
    assert len(agree) >= 40  # the corpus is mostly agreement, errors and clean alike
