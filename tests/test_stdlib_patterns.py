"""Every stitch pattern of `std.stitches`, applied to a flat sheet and to a half-gauge tube
(and, when it needs no purl, to a full-gauge tube), compiles to Knitout that runs clean on
the independent machine. The list of patterns is read from the stdlib itself, so a new
pattern is covered the day it is added."""

from __future__ import annotations

import numpy as np
import pytest

from knitc.backends.knitout import write_knitout
from knitc.driver import compile_source
from knitc.ir.stitch_graph import INSTRUCTIONS
from oracle import assert_clean, run_oracle_on_text

SHAPES = {
    "sheet": "sheet s {{ length: 26  width: 24 }}",
    "half-gauge tube": "tube s {{ length: 26  width: 12  gauge: half }}",
    "full-gauge tube": "tube s {{ length: 26  width: 12 }}",
}
NO_PURL = {"tuck_stitch": "tuck_stitch()", "eyelets": "eyelets()", "cable": "cable(2, 6, 0)"}
"""Patterns (with arguments) that write no purl, so they work on full-gauge tubes too."""


def stdlib_patterns() -> list[str]:
    r = compile_source("import std.stitches\n", "t.knit", until="skeleton")
    assert not r.diagnostics.has_errors, r.diagnostics.render()
    return sorted(r.skeleton.patterns)


CASES = [(name, shape) for name in stdlib_patterns() for shape in ("sheet", "half-gauge tube")]
CASES += [(name, "full-gauge tube") for name in NO_PURL]


def compile_case(name: str, shape: str):
    call = NO_PURL[name] if shape == "full-gauge tube" else f"{name}()"
    src = (f"import std.stitches ({name})\n" + SHAPES[shape].format() + "\n"
           f"pattern s {{ apply {call} }}\n")
    r = compile_source(src, "t.knit", until="machine")
    assert not r.diagnostics.has_errors, r.diagnostics.render()
    return r


def test_the_stdlib_has_the_common_patterns():
    assert {"rib", "seed", "garter", "basket", "eyelets", "cable", "tuck_stitch"} \
        <= set(stdlib_patterns())


@pytest.mark.parametrize("name, shape", CASES)
def test_each_pattern_keeps_its_instructions(name, shape):
    """Nothing the pattern writes is refused on an unshaped piece, except on its last
    course (where moves, crosses and tucks have no next course)."""
    r = compile_case(name, shape)
    g = r.graph
    assert (g.instr != 0).any(), "the pattern wrote nothing"
    refused = [d for d in r.diagnostics if d.code in ("W708", "W709")]
    assert all("last course" in d.message for d in refused), [d.message for d in refused]
    assert not [d for d in r.diagnostics if d.code == "W603"]
    written = {INSTRUCTIONS[i] for i in np.unique(g.instr)}
    ops = {o.kind for o in r.program}
    if written & {"FR1", "FL1", "XR+", "XL-"}:
        assert "xfer" in ops and "rack" in ops  # carried with racking


def test_every_pattern_runs_clean_on_the_independent_machine():
    texts = [write_knitout(compile_case(name, shape).program) for name, shape in CASES]
    for report in run_oracle_on_text(texts):
        assert_clean(report)
