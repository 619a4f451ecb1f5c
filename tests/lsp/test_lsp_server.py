"""The server as a whole: settings from the editor, the preview command, a back end that a
newer edit stops, cancelled requests, and staying responsive on a huge design."""

from __future__ import annotations

import asyncio
import time
from pathlib import Path

import pytest
from lsp_session import Session
from lsprotocol import types

ROOT = Path(__file__).resolve().parents[2]
PARAM = "param w = 8\ntube body {\n  length: 10\n  width: #w\n}\n"
HUGE = "tube big {\n  length: 500\n  width: 1000\n}\n"
"""A million stitches: legal, too big to shape while typing (`analysis.FAST_STITCHES`)."""


def codes(diags) -> list[str]:
    return [str(d.code) for d in diags]


@pytest.mark.lsp_settings({"knitc": {"defines": {"w": "0"}}})
async def test_defines_from_the_initialization_options(session: Session):
    uri = session.open("p.knit", PARAM)
    (d,) = await session.diagnostics(uri, lambda d: len(d) > 0)
    assert d.code == "E313" and "width" in d.message


async def test_defines_from_a_configuration_change(session: Session):
    uri = session.open("p.knit", PARAM)
    assert len(await session.diagnostics(uri)) == 0
    session.client.workspace_did_change_configuration(
        types.DidChangeConfigurationParams(settings={"knitc": {"defines": ["w=0"]}})
    )
    (d,) = await session.diagnostics(uri, lambda d: len(d) > 0)
    assert d.code == "E313"


@pytest.mark.lsp_settings({"knitc": {"maxStitches": 100}})
async def test_the_stitch_budget_setting(session: Session):
    uri = session.open("p.knit", PARAM)
    (d,) = await session.diagnostics(uri, lambda d: len(d) > 0)
    assert d.code == "E512" and "100" in d.message


@pytest.mark.lsp_settings({"knitc": {"defines": [3], "maxStitches": "many"}})
async def test_bad_settings_are_reported_and_dropped(session: Session):
    uri = session.open("p.knit", PARAM)
    assert len(await session.diagnostics(uri)) == 0
    shown = [m.message for m in session.client.log_messages + _shown(session)]
    assert any("knitc.defines" in m for m in shown)
    assert any("knitc.maxStitches" in m for m in shown)


def _shown(session: Session) -> list[types.ShowMessageParams]:
    return list(getattr(session.client, "messages", []))


@pytest.mark.lsp_settings({"knitc": {"include": ["shared"]}})
async def test_include_folders_from_the_settings(session: Session):
    shared = session.workspace / "shared"
    shared.mkdir()
    (shared / "lace.knit").write_text("pattern lace() {\n  set K\n}\n")
    design = 'import "../shared/lace.knit"\ntube a { length: 10 width: 8 }\n'
    uri = session.open("designs/d.knit", design)
    assert len(await session.diagnostics(uri)) == 0


async def test_preview_writes_the_viewers_page(session: Session):
    uri = session.open("tube.knit", (ROOT / "examples/tube.knit").read_text())
    await session.diagnostics(uri)
    got = await session.client.workspace_execute_command_async(
        types.ExecuteCommandParams(command="knitc.preview", arguments=[uri])
    )
    assert got is not None and got["uri"].startswith("file:")
    page = Path(got["path"]).read_text(encoding="utf-8")
    assert page.startswith("<!DOCTYPE html>") or "<html" in page[:200]
    assert "tube.knit" in page


async def test_preview_of_a_broken_design_is_null(session: Session):
    uri = session.open("bad.knit", "tube a {\n")
    got = await session.client.workspace_execute_command_async(
        types.ExecuteCommandParams(command="knitc.preview", arguments=[uri])
    )
    assert got is None


async def test_a_newer_edit_stops_the_back_end(session: Session):
    sweater = (ROOT / "examples/sweater.knit").read_text()
    uri = session.open("sweater.knit", sweater)
    await session.diagnostics(uri, version=1)  # the front end's; the back end starts soon
    await asyncio.sleep(0.4)
    session.replace_all(uri, sweater.replace("param body_len = ", "param body_len = 2 + "))
    await session.diagnostics(uri, lambda d: "W803" in codes(d))
    logs = [m.message for m in session.client.log_messages]
    assert any("stopped the back end of version 1" in m for m in logs), logs
    assert not any("back end of version 1:" in m for m in logs)


async def test_a_huge_design_stays_responsive(session: Session):
    uri = session.open("huge.knit", HUGE)
    assert len(await session.diagnostics(uri, version=1)) == 0
    start = time.monotonic()
    symbols = await session.client.text_document_document_symbol_async(
        types.DocumentSymbolParams(types.TextDocumentIdentifier(uri))
    )
    folds = await session.client.text_document_folding_range_async(
        types.FoldingRangeParams(types.TextDocumentIdentifier(uri))
    )
    assert time.monotonic() - start < 2.0
    assert symbols is not None and folds is not None
    # Making it small stops the long compile (killed when it does not stop by itself).
    session.replace_all(uri, "tube big {\n  length: 5\n  width: 0\n}\n")
    (d,) = await session.diagnostics(uri, lambda d: len(d) > 0, timeout=20)
    assert d.code == "E313"


BIG = (
    "tube big {\n  length: 300\n  width: 245\n}\npattern big {\n"
    + "".join(f"  set P where noise({2 + k}, threshold = 0.5, seed = {k})\n" for k in range(12))
    + "}\n"
)
"""147,000 stitches and twelve noise layers: shaped while typing (just under
`analysis.FAST_STITCHES`), so its front end keeps the compiler thread busy for about half a
second, ten times the test's wait even on a loaded machine (one `set` statement took
0.08 s once shaping got faster, and the hover was sometimes answered before its
cancellation arrived)."""


async def test_a_cancelled_request_is_answered_as_cancelled(session: Session):
    uri = session.open("big.knit", BIG)
    await session.diagnostics(uri)
    session.replace_all(uri, BIG.replace("300", "299"))  # the compiler thread is busy now
    protocol = session.client.protocol
    request = asyncio.ensure_future(
        protocol.send_request_async(
            types.TEXT_DOCUMENT_HOVER,
            types.HoverParams(types.TextDocumentIdentifier(uri), types.Position(0, 6)),
            msg_id="hover-1",
        )
    )
    await asyncio.sleep(0.05)  # sent, and waiting for the busy compiler thread
    protocol.notify(types.CANCEL_REQUEST, types.CancelParams(id="hover-1"))
    with pytest.raises(Exception, match="(?i)cancel"):
        await asyncio.wait_for(request, 20)
    # The server is still there and answers the next request.
    symbols = await session.client.text_document_document_symbol_async(
        types.DocumentSymbolParams(types.TextDocumentIdentifier(uri))
    )
    assert symbols is not None


async def test_shutting_down_with_a_request_running(session: Session):
    uri = session.open("huge.knit", HUGE)
    await session.diagnostics(uri)
    running = asyncio.ensure_future(
        session.client.protocol.send_request_async(
            types.WORKSPACE_EXECUTE_COMMAND,
            types.ExecuteCommandParams(command="knitc.preview", arguments=[uri]),
        )
    )
    await asyncio.sleep(0.3)
    assert not running.done()
    # The fixture's shutdown must succeed (pygls alone fails it: server.py's shutdown).


async def test_untitled_documents(session: Session):
    uri = "untitled:Untitled-1"
    session.versions[uri] = 1
    session.client.text_document_did_open(
        types.DidOpenTextDocumentParams(types.TextDocumentItem(uri, "knit", 1, "tube a {\n"))
    )
    (d,) = await session.diagnostics(uri, lambda d: len(d) > 0)
    assert str(d.code).startswith("E1")
