"""Diagnostics while the designer types: the front end's at once, the back end's after a
full compile, both with the CLI's codes, messages, hints and related places; edits that
break and repair a file; positions on lines with text outside ASCII."""

from __future__ import annotations

import asyncio
from pathlib import Path

from lsp_session import Session
from lsprotocol import types

ROOT = Path(__file__).resolve().parents[2]
TUBE = "tube body {\n  length: 10\n  width: 8\n}\n"


def codes(diags) -> list[str]:
    return [str(d.code) for d in diags]


async def test_a_clean_design_has_no_diagnostics(session: Session):
    uri = session.open("tube.knit", TUBE)
    assert len(await session.diagnostics(uri)) == 0


async def test_a_syntax_error_is_located_with_its_code_and_hint(session: Session):
    uri = session.open("bad.knit", "tube body {\n  length: 10\n  width: \n}\n")
    (d,) = await session.diagnostics(uri, lambda d: len(d) > 0)
    assert str(d.code).startswith("E1")
    assert d.severity == types.DiagnosticSeverity.Error
    assert d.source == "knitc"
    assert d.range.start.line == 3


async def test_breaking_and_repairing_a_file(session: Session):
    uri = session.open("t.knit", TUBE)
    assert len(await session.diagnostics(uri)) == 0
    session.edit(uri, (2, 9), (2, 10), "")  # `width: 8` -> `width: `
    assert codes(await session.diagnostics(uri, lambda d: len(d) > 0))[0].startswith("E1")
    session.edit(uri, (2, 9), (2, 9), "1")  # `width: 1`
    session.edit(uri, (2, 10), (2, 10), "2")  # `width: 12`
    assert len(await session.diagnostics(uri, lambda d: len(d) == 0)) == 0
    session.edit(uri, (1, 10), (1, 12), "0")  # `length: 0`
    (d,) = await session.diagnostics(uri, lambda d: len(d) > 0)
    assert d.code == "E313" and "length" in d.message
    assert d.range.start == types.Position(1, 10)


async def test_positions_count_utf16_units(session: Session):
    text = 'machine { model: "🧶é", needles: 0 }\ntube a { length: 10 width: 8 }\n'
    uri = session.open("u.knit", text)
    (d,) = await session.diagnostics(uri, lambda d: len(d) > 0)
    assert d.code == "E313"
    # `needles` is code point 23 but UTF-16 unit 24: the yarn emoji is two units.
    line = text.splitlines()[0]
    col = line.index("0 }")
    assert d.range.start == types.Position(0, col + 1)
    assert d.range.end == types.Position(0, col + 2)


async def test_utf8_clients_get_utf8_positions(neovim_session: Session):
    # Neovim offers utf-8 and utf-16 and pygls picks utf-8 when both are offered.
    text = 'machine { model: "🧶é", needles: 0 }\ntube a { length: 10 width: 8 }\n'
    uri = neovim_session.open("u.knit", text)
    (d,) = await neovim_session.diagnostics(uri, lambda d: len(d) > 0)
    line = text.splitlines()[0]
    units = {"utf-8": len(line[: line.index("0 }")].encode()), "utf-16": line.index("0 }") + 1}
    assert d.range.start.character in units.values()


async def test_hints_notes_and_the_stdlib_place_of_an_applied_pattern(session: Session):
    uri = session.open("glove.knit", (ROOT / "examples/glove.knit").read_text())
    diags = await session.diagnostics(uri, lambda d: "W708" in codes(d))
    (d,) = [d for d in diags if d.code == "W708"]
    assert d.severity == types.DiagnosticSeverity.Warning
    assert "hint: " in d.message and d.data == {"hint": d.message.split("hint: ", 1)[1]}
    assert d.range.start.line == 102  # the designer's `apply eyelets() …`
    assert d.related_information
    assert any(r.location.uri.endswith("std/stitches.knit") for r in d.related_information)


async def test_back_end_warnings_arrive_after_the_front_end(session: Session):
    text = (ROOT / "examples/sweater.knit").read_text()
    uri = session.open("sweater.knit", text)
    diags = await session.diagnostics(uri, lambda d: "W803" in codes(d))
    (d,) = [d for d in diags if d.code == "W803"]
    underarm = text.splitlines().index(next(x for x in text.splitlines() if "split underarm" in x))
    assert "floats" in d.message and d.range.start.line == underarm


async def test_back_end_errors_too(session: Session):
    uri = session.open("n.knit", "machine { needles: 20 }\ntube a { length: 4 width: 30 }\n")
    (d,) = await session.diagnostics(uri, lambda d: len(d) > 0)
    assert d.code == "E601" and d.range.start.line == 1


async def test_a_missing_import_is_an_error_at_the_import(session: Session):
    uri = session.open("m.knit", 'import "nope.knit"\ntube a { length: 10 width: 8 }\n')
    (d,) = await session.diagnostics(uri, lambda d: len(d) > 0)
    assert d.code == "E203" and d.range.start.line == 0


async def test_an_imported_file_with_its_own_error(session: Session):
    (session.workspace / "parts").mkdir()
    (session.workspace / "parts/lace.knit").write_text("pattern lace() {\n  set FR2 where\n}\n")
    uri = session.open("d.knit", 'import "parts/lace.knit"\ntube a { length: 10 width: 8 }\n')
    diags = await session.diagnostics(uri, lambda d: len(d) > 0)
    assert all(d.source == "knitc" for d in diags)
    related = [r.location.uri for d in diags for r in d.related_information or ()]
    assert any(u.endswith("parts/lace.knit") for u in related) or any(
        "lace.knit" in d.message for d in diags
    )


async def test_closing_a_document_clears_its_diagnostics(session: Session):
    uri = session.open("bad.knit", "tube a {\n")
    await session.diagnostics(uri, lambda d: len(d) > 0)
    session.client.text_document_did_close(
        types.DidCloseTextDocumentParams(types.TextDocumentIdentifier(uri))
    )
    await session.diagnostics(uri, lambda d: len(d) == 0, closed=True)


async def test_a_fixed_warning_does_not_linger(session: Session):
    # W708 is the front end's; after the back end has run, deleting its cause must clear it
    # at once (only the back end's own findings are kept while it runs again).
    text = (ROOT / "examples/tube.knit").read_text()
    uri = session.open("tube.knit", text)
    await session.diagnostics(uri, lambda d: "W708" in codes(d))
    await asyncio.sleep(1.5)  # the back end of version 1 has published
    session.replace_all(uri, text.replace("  apply tuck_stitch() where courses(0.45:0.55)\n", ""))
    first = await session.diagnostics(uri)
    assert "W708" not in codes(first)
