"""Small designs given as text, compiled for the tests that hold them to the independent
machine and the DAT writer (the colourwork tests: stripes, jacquard, intarsia, plating)."""

from __future__ import annotations

from fabric import assert_knits_as_designed
from knitc.backends.dat_format import decode, encode, rows
from knitc.backends.dat_write import to_dat
from knitc.driver import Result, compile_source


def compiled(text: str, name: str, *, clean: bool = False) -> Result:
    """`text` compiled to a machine program, which it must reach without an error (nor a
    warning, with `clean`)."""
    r = compile_source(text, f"{name}.knit", until="machine")
    assert r.program is not None and not r.diagnostics.has_errors, r.diagnostics.render()
    if clean:
        assert not r.diagnostics.warning_count, (name, r.diagnostics.render())
    return r


def assert_round_trips_through_dat(r: Result) -> None:
    """The program's DAT decodes to the rows it was encoded from."""
    assert r.program is not None
    image = to_dat(r.program)
    assert rows(decode(encode(image))) == rows(image)


def assert_random_designs_knit(texts: list[str], prefix: str) -> None:
    """Random designs, each compiled (an error is the test's failure, shown with the
    text), then all held to the independent machine and the fabric check in one oracle
    process."""
    results = []
    for i, text in enumerate(texts):
        r = compile_source(text, f"{prefix}{i}.knit", until="machine")
        assert r.program is not None, text + r.diagnostics.render()
        results.append(r)
    assert_knits_as_designed(results, names=[f"design {i}:\n{t}" for i, t in enumerate(texts)])
