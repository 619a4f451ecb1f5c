"""The `editor` fuzz target: the language server's features on any text, as a designer's
editor would ask for them while typing.

The front end's analysis of the text (a stale module when it does not parse, as the
server keeps), then every feature at a spread of offsets — the text's start and end, every
sixteenth of it, after each `.`, `#`, `@`, `:` and `{` — plus the whole-document features.
A bug is any exception (a rename may refuse, saying why: that is its answer),
a position outside the document, a semantic-token stream with a negative step, or
formatting whose result does not parse or changes the module.
"""

from __future__ import annotations

from lsprotocol import types
from pygls.exceptions import JsonRpcException

from knitc.diagnostics import Diagnostics
from knitc.frontend.parser import parse_source
from knitc.lsp import completion, editing, hover, quickfix, symbols
from knitc.lsp.analysis import Analysis, analyse
from knitc.lsp.convert import to_lsp
from knitc.lsp.definitions import stdlib_providers
from knitc.lsp.settings import Settings
from knitc.source import SourceFile

MAX_STITCHES = 20_000
"""As the compiling targets: a large design is slow, not wrong."""
PATH = "/fuzz/editor.knit"
MARKS = ".#@:{"


class Bug(Exception):
    pass


def offsets(text: str) -> list[int]:
    n = len(text)
    spread = {0, n, *(n * i // 16 for i in range(16))}
    marks = [i + 1 for i, ch in enumerate(text) if ch in MARKS][:64]
    return sorted(spread | set(marks))


def editor(data: bytes) -> None:
    text = data.decode("utf-8", "replace")
    settings = Settings(max_stitches=MAX_STITCHES)
    # A stale module, as while typing: the text up to its last closing brace analysed first.
    cut = text[: text.rfind("}") + 1]
    previous = analyse("file:///fuzz/editor.knit", 1, PATH, cut, settings) if cut else None
    a = analyse("file:///fuzz/editor.knit", 2, PATH, text, settings, previous)
    lines = a.source.line_count
    for enc in ("utf-16", "utf-8"):
        for d in to_lsp(a.diagnostics, a.source, enc):
            _inside(d.range, lines, "a diagnostic")
    for offset in offsets(text):
        _at(a, offset)
    _whole(a, lines)


def _at(a: Analysis, offset: int) -> None:
    hover.hover_at(a, offset, {"w": "3"})
    ans = completion.answer(a, offset)
    for item in completion.to_lsp(ans, a).items:
        edit = item.text_edit
        if isinstance(edit, types.TextEdit):
            _inside(edit.range, a.source.line_count, f"completion `{item.label}`")
    symbols.definition(a, offset)
    symbols.references(a, offset, True)
    try:
        if symbols.prepare_rename(a, offset) is not None:
            symbols.rename(a, offset, "renamed_x")
    except (symbols.RenameRefused, JsonRpcException):
        pass  # a refusal, with its reason, is the answer


def _whole(a: Analysis, lines: int) -> None:
    symbols.document_symbols(a)
    data = editing.encode(a, editing.semantic_tokens(a, editing.lex(a.text)))
    if len(data) % 5 or any(v < 0 for v in data):
        raise Bug(f"semantic tokens with a negative step or a broken stream: {data[:20]}")
    for r in editing.folding_ranges(a):
        if not 0 <= r.start_line <= r.end_line < lines:
            raise Bug(f"folding range {r} outside the document's {lines} lines")
    hover.inlay_hints(a, 0, len(a.text))
    quickfix.code_actions(a, to_lsp(a.diagnostics, a.source), stdlib_providers(), "utf-16")
    edits = editing.format_edits(a.text, PATH)
    if edits and a.result.module is not None:
        new = a.text
        for e in sorted(edits, key=lambda e: e.start, reverse=True):
            new = new[: e.start] + e.text + new[e.end :]
        again = parse_source(SourceFile(PATH, new), Diagnostics())
        if again != a.result.module:
            raise Bug("formatting changed the module (or broke it)")
    editing.range_format_edits(a.text, 0, max(lines // 2, 0), PATH)


def _inside(r: types.Range, lines: int, what: str) -> None:
    for p in (r.start, r.end):
        if not 0 <= p.line <= lines or p.character < 0:
            raise Bug(f"{what} at {p}, outside the document's {lines} lines")
