"""What every language-server test does: open a document, edit it, wait for the
diagnostics of a version (`Session`, over a pytest-lsp client)."""

from __future__ import annotations

import asyncio
from collections.abc import Callable, Sequence
from pathlib import Path

from lsprotocol import types
from pytest_lsp import LanguageClient

TIMEOUT = 30.0
"""Seconds a test waits for what the server should send (a back-end compile of the
sweater takes about 2 s; CI machines are slower and busy)."""


class Session:
    def __init__(self, client: LanguageClient, workspace: Path) -> None:
        self.client = client
        self.workspace = workspace
        self.versions: dict[str, int] = {}

    def uri(self, name: str) -> str:
        return (self.workspace / name).as_uri()

    def open(self, name: str, text: str, *, write: bool = True) -> str:
        """Open `name` (in the test's workspace folder) with `text`; its URI."""
        path = self.workspace / name
        if write:
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_text(text, encoding="utf-8")
        uri = path.as_uri()
        self.versions[uri] = 1
        self.client.text_document_did_open(
            types.DidOpenTextDocumentParams(
                types.TextDocumentItem(uri=uri, language_id="knit", version=1, text=text)
            )
        )
        return uri

    def replace_all(self, uri: str, text: str) -> int:
        """Send the whole new text as one change; the new version."""
        return self.change(uri, [types.TextDocumentContentChangeWholeDocument(text=text)])

    def edit(self, uri: str, start: tuple[int, int], end: tuple[int, int], text: str) -> int:
        """Replace the range (line, character)–(line, character) with `text`."""
        rng = types.Range(types.Position(*start), types.Position(*end))
        return self.change(uri, [types.TextDocumentContentChangePartial(range=rng, text=text)])

    def change(self, uri: str, changes: Sequence[types.TextDocumentContentChangeEvent]) -> int:
        self.versions[uri] += 1
        self.client.text_document_did_change(
            types.DidChangeTextDocumentParams(
                types.VersionedTextDocumentIdentifier(uri=uri, version=self.versions[uri]),
                list(changes),
            )
        )
        return self.versions[uri]

    async def diagnostics(
        self,
        uri: str,
        until: Callable[[Sequence[types.Diagnostic]], bool] = lambda d: True,
        version: int | None = None,
        timeout: float = TIMEOUT,
        closed: bool = False,
    ) -> Sequence[types.Diagnostic]:
        """The diagnostics of `uri` once a publication for `version` (default: the
        document's current one; `closed`: the one without a version that closing sends)
        satisfies `until`."""
        want = None if closed else self.versions.get(uri) if version is None else version
        loop = asyncio.get_running_loop()
        deadline = loop.time() + timeout
        while True:
            got = self.client.diagnostics.get(uri)
            if got is not None and self.published.get(uri) == want and until(got):
                return got
            if loop.time() > deadline:
                raise AssertionError(
                    f"no diagnostics of version {want} satisfying the test within {timeout} s; "
                    f"last: version {self.published.get(uri)}: {got}"
                )
            await asyncio.sleep(0.01)

    @property
    def published(self) -> dict[str, int | None]:
        """The version of each document's last publication."""
        return published_versions(self.client)


def published_versions(client: LanguageClient) -> dict[str, int | None]:
    return client.__dict__.setdefault("_knitc_versions", {})


def track_versions(client: LanguageClient) -> None:
    """Remember the version each publication was for (pytest-lsp keeps only the list)."""
    seen = published_versions(client)

    def published(params: types.PublishDiagnosticsParams) -> None:
        seen[params.uri] = params.version
        client.diagnostics[params.uri] = params.diagnostics

    client.protocol.fm._features.pop(types.TEXT_DOCUMENT_PUBLISH_DIAGNOSTICS, None)
    client.feature(types.TEXT_DOCUMENT_PUBLISH_DIAGNOSTICS)(published)
