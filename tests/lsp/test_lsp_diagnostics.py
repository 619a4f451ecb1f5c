"""Diagnostics while the designer types: the front end's at once, the back end's after a
full compile, both with the CLI's codes, messages, hints and related places."""

from __future__ import annotations

from lsp_session import Session
from lsprotocol import types

TUBE = "tube body {\n  length: 10\n  width: 8\n}\n"


def codes(diags) -> list[str]:
    return [str(d.code) for d in diags]


async def test_a_clean_design_has_no_diagnostics(session: Session):
    uri = session.open("tube.knit", TUBE)
    diags = await session.diagnostics(uri)
    assert len(diags) == 0


async def test_a_syntax_error_is_located_with_its_code_and_hint(session: Session):
    uri = session.open("bad.knit", "tube body {\n  length: 10\n  width: \n}\n")
    diags = await session.diagnostics(uri, lambda d: len(d) > 0)
    (d,) = diags
    assert d.code == "E101" or str(d.code).startswith("E1")
    assert d.severity == types.DiagnosticSeverity.Error
    assert d.source == "knitc"
    assert d.range.start.line == 3
