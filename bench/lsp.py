"""The language server's latency, measured the way an editor sees it: the real `knitc lsp`
process over stdio, a client that sends edits and waits for what comes back.

- glove: time from an edit (`didChange`) to the diagnostics of that version: the front
  end (parse, resolve, shaping) with a warm parser and standard library. Target: 100 ms.
- hover and completion on the glove, per request.
- sweater: time from an edit to the back end's diagnostics of that version (a full compile
  in the worker process, the W803 float warning among them). Target: 2 s.

`python bench/lsp.py` prints the JSON; bench/run.py puts it in bench/results.json.
"""

from __future__ import annotations

import asyncio
import json
import statistics
import sys
import time
from pathlib import Path

from lsprotocol import types
from pygls.lsp.client import LanguageClient

REPO = Path(__file__).resolve().parent.parent
EDITS = 30
BACK_EDITS = 6


class _Client:
    def __init__(self) -> None:
        self.client = LanguageClient("knitc-bench", "1")
        self.client.feature(types.WINDOW_LOG_MESSAGE)(lambda params: None)
        self.published: dict[tuple[str, int | None], list[tuple[float, list[str]]]] = {}
        self.event = asyncio.Event()

        @self.client.feature(types.TEXT_DOCUMENT_PUBLISH_DIAGNOSTICS)
        def _published(params: types.PublishDiagnosticsParams) -> None:
            codes = [str(d.code) for d in params.diagnostics]
            key = (params.uri, params.version)
            self.published.setdefault(key, []).append((time.perf_counter(), codes))
            self.event.set()

    async def wait(self, uri: str, version: int, nth: int = 1) -> float:
        """When the `nth` publication of `version` arrived (the server publishes the front
        end's diagnostics, then, when it runs, the back end's)."""
        while True:
            got = self.published.get((uri, version), [])
            if len(got) >= nth:
                return got[nth - 1][0]
            self.event.clear()
            await asyncio.wait_for(self.event.wait(), 60)


def _ms(values: list[float]) -> dict[str, float]:
    values = sorted(v * 1000 for v in values)
    return {
        "median_ms": round(statistics.median(values), 1),
        "p90_ms": round(values[int(0.9 * (len(values) - 1))], 1),
        "max_ms": round(values[-1], 1),
        "n": len(values),
    }


async def measure() -> dict[str, object]:
    c = _Client()
    started = time.perf_counter()
    await c.client.start_io(sys.executable, "-m", "knitc.lsp")
    await c.client.initialize_async(
        types.InitializeParams(
            capabilities=types.ClientCapabilities(), root_uri=(REPO / "examples").as_uri()
        )
    )
    c.client.initialized(types.InitializedParams())
    out: dict[str, object] = {}

    glove = (REPO / "examples/glove.knit").read_text(encoding="utf-8")
    uri = (REPO / "examples/glove.knit").as_uri()
    c.client.text_document_did_open(
        types.DidOpenTextDocumentParams(types.TextDocumentItem(uri, "knit", 1, glove))
    )
    first = await c.wait(uri, 1)
    out["start_to_first_diagnostics_s"] = round(first - started, 3)
    line = next(i for i, t in enumerate(glove.splitlines()) if t.startswith("param finger_len"))
    col = glove.splitlines()[line].index("22")
    times = []
    for i in range(EDITS):
        await asyncio.sleep(0.05)
        version = i + 2
        sent = time.perf_counter()
        c.client.text_document_did_change(
            types.DidChangeTextDocumentParams(
                types.VersionedTextDocumentIdentifier(version=version, uri=uri),
                [
                    types.TextDocumentContentChangePartial(
                        range=types.Range(
                            types.Position(line, col), types.Position(line, col + 2)
                        ),
                        text="23" if i % 2 == 0 else "22",
                    )
                ],
            )
        )
        times.append(await c.wait(uri, version) - sent)
    out["glove_edit_to_diagnostics"] = _ms(times)

    pos = types.Position(line + 20, 8)
    for name, request in (
        (
            "glove_hover",
            lambda: c.client.text_document_hover_async(
                types.HoverParams(types.TextDocumentIdentifier(uri), pos)
            ),
        ),
        (
            "glove_completion",
            lambda: c.client.text_document_completion_async(
                types.CompletionParams(types.TextDocumentIdentifier(uri), pos)
            ),
        ),
    ):
        times = []
        for _ in range(EDITS):
            sent = time.perf_counter()
            await request()
            times.append(time.perf_counter() - sent)
        out[name] = _ms(times)

    sweater = (REPO / "examples/sweater.knit").read_text(encoding="utf-8")
    suri = (REPO / "examples/sweater.knit").as_uri()
    c.client.text_document_did_open(
        types.DidOpenTextDocumentParams(types.TextDocumentItem(suri, "knit", 1, sweater))
    )
    await c.wait(suri, 1, nth=2)
    times = []
    for i in range(BACK_EDITS):
        version = i + 2
        text = sweater if i % 2 else sweater.replace("\n", "\n ", 1)  # an edit that changes nothing
        sent = time.perf_counter()
        c.client.text_document_did_change(
            types.DidChangeTextDocumentParams(
                types.VersionedTextDocumentIdentifier(version=version, uri=suri),
                [types.TextDocumentContentChangeWholeDocument(text=text)],
            )
        )
        times.append(await c.wait(suri, version, nth=2) - sent)
        assert "W803" in c.published[(suri, version)][1][1], "the back end's float warning"
    out["sweater_edit_to_back_end_diagnostics"] = _ms(times)
    await c.client.shutdown_async(None)
    c.client.exit(None)
    await c.client.stop()
    return out


def main() -> int:
    print(json.dumps(asyncio.run(measure()), indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
