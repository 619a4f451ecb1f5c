"""`knitc lsp`: the language server, on pygls.

The server owns the open documents' analyses and the two ways the pipeline runs for them:

- the **front end** (parse, resolve, shaping; `analysis`) on one compiler thread, a few
  milliseconds after each edit (`FRONT_DELAY` lets a burst of keystrokes settle), its
  diagnostics published at once;
- the **back end** (`backend`: a full compile in a worker process) a moment later
  (`BACK_DELAY`), for the warnings only code generation and its simulation find; a newer
  edit stops it, and its diagnostics replace the front end's when they are for the
  document's current version.

Every feature is a module with a `register(server)` (listed in `FEATURES`), whose
handlers ask `await server.analysis_for(uri)` for the analysis of the document's current
text and call pure functions of it. Compiler code runs only on the compiler thread (the
parser is not reentrant) or in the worker, never on the event loop, which stays free to
answer the editor.
"""

from __future__ import annotations

import asyncio
import importlib
import logging
import os
import tempfile
import traceback
from concurrent.futures import ThreadPoolExecutor
from typing import Any

from lsprotocol import types
from pygls.lsp.server import LanguageServer

from knitc import __version__
from knitc.diagnostics import Diagnostics
from knitc.lsp import settings as st
from knitc.lsp.analysis import WARM_UP, Analysis, analyse
from knitc.lsp.backend import Backend, Job, Outcome
from knitc.lsp.convert import SOURCE, to_lsp
from knitc.lsp.locations import uri_to_path
from knitc.lsp.positions import UTF16
from knitc.source import SourceFile

log = logging.getLogger("knitc.lsp")

FRONT_DELAY = 0.02
"""Seconds an edit waits for the next keystroke before the front end runs."""
BACK_DELAY = 0.1
"""Seconds after the front end's diagnostics before the back end starts."""

FEATURES = (
    "knitc.lsp.hover",
    "knitc.lsp.completion",
    "knitc.lsp.symbols",
    "knitc.lsp.editing",
    "knitc.lsp.quickfix",
)
"""The feature modules, each with a `register(server)`; a missing one is skipped (features
are added one module at a time)."""

PREVIEW = "knitc.preview"


class KnitServer(LanguageServer):
    def __init__(self) -> None:
        super().__init__(
            "knitc", __version__, text_document_sync_kind=types.TextDocumentSyncKind.Incremental
        )
        self.settings = st.Settings()
        self.analyses: dict[str, Analysis] = {}
        self.compiler = ThreadPoolExecutor(max_workers=1, thread_name_prefix="knitc-front")
        self.backend = Backend(self._backend_done)
        self.back_diagnostics: dict[str, tuple[int | None, list[types.Diagnostic]]] = {}
        """Per document: the version of its last back-end compile and the diagnostics only
        the back end found (shown again, until the next one, after edits elsewhere)."""
        self._timers: dict[str, asyncio.TimerHandle] = {}
        self._refreshing: dict[str, asyncio.Task[None]] = {}
        self._inflight: dict[
            str, tuple[tuple[int | None, st.Settings], asyncio.Future[Analysis]]
        ] = {}
        """Per document: the analysis running now, and the (version, settings) it is of."""
        self._previews: dict[int, asyncio.Future[Outcome]] = {}
        self._preview_dir: str | None = None
        self.front_delay = FRONT_DELAY
        self.back_delay = BACK_DELAY
        self.root: str | None = None
        self._event_loop: asyncio.AbstractEventLoop | None = None

    # -- what features use
    @property
    def encoding(self) -> str:
        """The position encoding agreed with the client (UTF-16 unless negotiated)."""
        if not self._workspace_ready():
            return UTF16
        enc = self.workspace.position_encoding
        return str(getattr(enc, "value", enc) or UTF16)

    def _workspace_ready(self) -> bool:
        try:
            self.workspace  # noqa: B018 - raises before `initialize`
        except RuntimeError:
            return False
        return True

    async def analysis_for(self, uri: str) -> Analysis | None:
        """The analysis of the document's current text (made now if the last is older);
        None for a document the editor has not opened."""
        doc = self.workspace.text_documents.get(uri)
        if doc is None:
            return None
        current = self.analyses.get(uri)
        if (
            current is not None
            and current.version == doc.version
            and current.settings == self.settings
        ):
            return current
        return await self._analyse(uri)

    async def run_compiler(self, fn: Any, *args: Any) -> Any:
        """Run `fn(*args)` on the compiler thread (anything that parses or compiles)."""
        return await asyncio.get_running_loop().run_in_executor(self.compiler, fn, *args)

    async def run_safely(self, fn: Any, *args: Any) -> Any:
        """`run_compiler(fn, *args)`, or None (logged with its traceback) when it fails: a
        feature never answers an odd position or a half-written file with an error, and a
        bug in one shows in the server's log, not as a broken request."""
        try:
            return await self.run_compiler(fn, *args)
        except Exception:
            log.exception("%s failed", getattr(fn, "__name__", fn))
            return None

    # -- the front end
    async def _analyse(self, uri: str) -> Analysis | None:
        """Analyse the document's current text, or wait for the analysis of it already
        running (a refresh and a request arriving together share one)."""
        doc = self.workspace.text_documents.get(uri)
        if doc is None:
            return None
        key = (doc.version, self.settings)
        running = self._inflight.get(uri)
        if running is None or running[0] != key:
            task = asyncio.ensure_future(self._analyse_text(uri, doc.version, doc.source))
            running = self._inflight[uri] = (key, task)
        # shield: a cancelled request must not cancel the analysis others wait for
        return await asyncio.shield(running[1])

    async def _analyse_text(self, uri: str, version: int | None, text: str) -> Analysis:
        previous = self.analyses.get(uri)
        settings = self.settings
        path = uri_to_path(uri)
        try:
            a: Analysis = await self.run_compiler(
                analyse, uri, version, path, text, settings, previous
            )
        except Exception:  # a bug in knitc: say so in the document, keep serving
            a = _failed(uri, version, path, text, settings, previous)
        stored = self.analyses.get(uri)
        if uri in self.workspace.text_documents and (
            stored is None or stored.version is None or (a.version or 0) >= stored.version
        ):
            self.analyses[uri] = a
        running = self._inflight.get(uri)
        if running is not None and running[0] == (version, settings):
            del self._inflight[uri]
        return a

    def schedule(self, uri: str, delay: float | None = None) -> None:
        """(Re)start the wait before `uri` is analysed: the debounce of edits."""
        loop = self._event_loop = asyncio.get_running_loop()
        timer = self._timers.pop(uri, None)
        if timer is not None:
            timer.cancel()
        self._timers[uri] = loop.call_later(
            self.front_delay if delay is None else delay, self._start_refresh, uri
        )

    def _start_refresh(self, uri: str) -> None:
        self._timers.pop(uri, None)
        task = self._refreshing.get(uri)
        if task is not None and not task.done():
            task.cancel()  # an older refresh still waiting for its turn
        self._refreshing[uri] = asyncio.ensure_future(self._refresh(uri))

    async def _refresh(self, uri: str) -> None:
        a = await self.analysis_for(uri)
        if a is None or not self._current(uri, a.version):
            return
        self._publish(uri, a)
        if a.result.ok or not a.shaped:
            await asyncio.sleep(self.back_delay)
            if self._current(uri, a.version):
                self.backend.submit(Job((uri, "check"), a.version, a.path, a.text, a.settings))

    def _current(self, uri: str, version: int | None) -> bool:
        doc = self.workspace.text_documents.get(uri)
        return doc is not None and doc.version == version

    def _publish(self, uri: str, a: Analysis) -> None:
        diags = to_lsp(a.diagnostics, a.source, self.encoding)
        back = self.back_diagnostics.get(uri)
        if back is not None and back[0] != a.version and a.result.ok:
            diags += _still_valid(back[1], diags, a.source)
        self.text_document_publish_diagnostics(
            types.PublishDiagnosticsParams(uri=uri, diagnostics=diags, version=a.version)
        )

    # -- the back end
    def _backend_done(self, outcome: Outcome) -> None:
        """Called on the backend's thread: continue on the event loop."""
        loop = self._event_loop
        if loop is not None and not loop.is_closed():
            loop.call_soon_threadsafe(self._backend_finished, outcome)

    def _backend_finished(self, outcome: Outcome) -> None:
        job = outcome.job
        uri, kind = job.key
        if kind == "preview":
            fut = self._previews.pop(job.id, None)
            if fut is not None and not fut.done():
                fut.set_result(outcome)
            return
        if outcome.status == "cancelled":
            self.window_log_message(
                types.LogMessageParams(
                    types.MessageType.Log,
                    f"knitc: stopped the back end of version {job.version} (a newer edit)",
                )
            )
            return
        if not self._current(uri, job.version):
            return
        source = SourceFile(job.path, job.text)
        if outcome.status == "failed" or outcome.diagnostics is None:
            self.window_log_message(
                types.LogMessageParams(types.MessageType.Error, f"knitc: {outcome.detail}")
            )
            diags = _internal(outcome.detail)
            a = self.analyses.get(uri)
            front = to_lsp(a.diagnostics, a.source, self.encoding) if a is not None else []
            all_diags = front + diags
        else:
            all_diags = to_lsp(outcome.diagnostics, source, self.encoding)
            self.window_log_message(
                types.LogMessageParams(
                    types.MessageType.Log,
                    f"knitc: back end of version {job.version}: {len(all_diags)} "
                    f"diagnostics in {outcome.seconds:.2f} s",
                )
            )
        now = self.analyses.get(uri)
        found_by_front: set[tuple[object, ...]] = (
            {_key(d) for d in to_lsp(now.diagnostics, now.source, self.encoding)}
            if now is not None and now.version == job.version
            else set()
        )
        self.back_diagnostics[uri] = (
            job.version,
            [d for d in all_diags if _key(d) not in found_by_front],
        )
        self.text_document_publish_diagnostics(
            types.PublishDiagnosticsParams(uri=uri, diagnostics=all_diags, version=job.version)
        )

    async def preview(self, uri: str) -> dict[str, str] | None:
        """Write the viewer's page for the document; where it is, or None."""
        a = await self.analysis_for(uri)
        if a is None:
            return None
        if self._preview_dir is None:
            self._preview_dir = tempfile.mkdtemp(prefix="knitc-preview-")
        name = os.path.splitext(os.path.basename(a.path.strip("<>")))[0] or "design"
        out = os.path.join(self._preview_dir, f"{name}.html")
        job = self.backend.submit(Job((uri, "preview"), a.version, a.path, a.text, a.settings, out))
        fut: asyncio.Future[Outcome] = asyncio.get_running_loop().create_future()
        self._previews[job.id] = fut
        try:
            outcome = await fut
        except asyncio.CancelledError:  # the editor cancelled the request: stop the job
            self._previews.pop(job.id, None)
            self.backend.stop(job)
            raise
        if outcome.status != "done" or not outcome.detail:
            return None
        from pygls import uris

        return {"uri": uris.from_fs_path(outcome.detail) or "", "path": outcome.detail}

    # -- settings
    def configure(self, value: Any) -> None:
        self.settings = st.from_json(value, self.root)
        for problem in self.settings.problems:
            self.window_show_message(
                types.ShowMessageParams(types.MessageType.Warning, f"knitc: {problem}")
            )


def _key(d: types.Diagnostic) -> tuple[object, ...]:
    r = d.range
    return (d.code, d.message, r.start.line, r.start.character, r.end.line, r.end.character)


def _still_valid(
    old: list[types.Diagnostic], new: list[types.Diagnostic], source: SourceFile
) -> list[types.Diagnostic]:
    """The back end's diagnostics of an earlier version worth keeping until the next back end
    result: those the front end did not find itself, on lines that exist (no flicker of every
    warning while the designer types elsewhere)."""
    have = {(d.code, d.message) for d in new}
    return [
        d for d in old if (d.code, d.message) not in have and d.range.end.line < source.line_count
    ]


def _internal(detail: str) -> list[types.Diagnostic]:
    last = detail.strip().splitlines()[-1] if detail.strip() else "unknown"
    return [
        types.Diagnostic(
            range=types.Range(types.Position(0, 0), types.Position(0, 0)),
            message=f"internal error in knitc (a bug, not your design): {last}\n"
            "the server log has the details; please report it with this file",
            severity=types.DiagnosticSeverity.Error,
            code="internal-error",
            source=SOURCE,
        )
    ]


def _failed(
    uri: str,
    version: int | None,
    path: str,
    text: str,
    settings: st.Settings,
    previous: Analysis | None,
) -> Analysis:
    """The analysis of a text the front end crashed on: no IRs, one internal error."""
    from knitc import driver

    detail = traceback.format_exc(limit=8)
    log.error("front end failed on %s:\n%s", uri, detail)
    diags = Diagnostics()
    diags.error(
        "internal-error", f"internal error in knitc: {detail.strip().splitlines()[-1]}", None
    )
    result = driver.Result(diags, path=path, text=text)
    module = previous.module if previous is not None else None
    return Analysis(uri, version, path, SourceFile(path, text), settings, result, module, True)


def create_server() -> KnitServer:
    """The server with every feature registered."""
    server = KnitServer()

    @server.feature(types.INITIALIZE)
    def initialize(ls: KnitServer, params: types.InitializeParams) -> None:
        from pygls import uris

        if params.root_uri:
            ls.root = uris.to_fs_path(params.root_uri)
        ls.configure(params.initialization_options)

    @server.feature(types.INITIALIZED)
    async def initialized(ls: KnitServer, params: types.InitializedParams) -> None:
        ls._event_loop = asyncio.get_running_loop()
        ls.backend.start()
        await ls.run_compiler(analyse, "warm-up:", None, "<warm-up>", WARM_UP, st.Settings(), None)

    @server.feature(types.WORKSPACE_DID_CHANGE_CONFIGURATION)
    def did_change_configuration(
        ls: KnitServer, params: types.DidChangeConfigurationParams
    ) -> None:
        if params.settings is None:
            return
        ls.configure(params.settings)
        for uri in list(ls.workspace.text_documents):
            ls.schedule(uri, 0)

    @server.feature(types.TEXT_DOCUMENT_DID_OPEN)
    def did_open(ls: KnitServer, params: types.DidOpenTextDocumentParams) -> None:
        ls.schedule(params.text_document.uri, 0)

    @server.feature(types.TEXT_DOCUMENT_DID_CHANGE)
    def did_change(ls: KnitServer, params: types.DidChangeTextDocumentParams) -> None:
        ls.schedule(params.text_document.uri)

    @server.feature(types.TEXT_DOCUMENT_DID_SAVE)
    def did_save(ls: KnitServer, params: types.DidSaveTextDocumentParams) -> None:
        # An imported file may have changed on disk: analyse the other documents again.
        for uri in list(ls.workspace.text_documents):
            if uri != params.text_document.uri and ls.analyses.pop(uri, None) is not None:
                ls.schedule(uri, 0)

    @server.feature(types.TEXT_DOCUMENT_DID_CLOSE)
    def did_close(ls: KnitServer, params: types.DidCloseTextDocumentParams) -> None:
        uri = params.text_document.uri
        ls.analyses.pop(uri, None)
        ls.back_diagnostics.pop(uri, None)
        ls.backend.discard(uri)
        ls.text_document_publish_diagnostics(
            types.PublishDiagnosticsParams(uri=uri, diagnostics=[])
        )

    @server.feature(types.SHUTDOWN)
    def shutdown(ls: KnitServer, params: Any) -> None:
        ls.backend.close()
        # pygls 2.1 cancels the requests still running after this handler while iterating
        # over the dict their cancellation removes them from (a RuntimeError that fails the
        # shutdown): cancel them here, over a copy, so that it finds them all done.
        current = ls.protocol.msg_id
        for msg_id, future in list(ls.protocol._request_futures.items()):
            if msg_id != current and not future.done():
                future.cancel()

    @server.command(PREVIEW)
    async def preview(ls: KnitServer, uri: str) -> dict[str, str] | None:
        return await ls.preview(uri)

    for name in FEATURES:
        try:
            module = importlib.import_module(name)
        except ModuleNotFoundError as exc:
            if exc.name != name:
                raise
            continue
        module.register(server)
    return server
