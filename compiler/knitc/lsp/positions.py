"""Positions between knitc's spans and the editor's.

knitc counts in code points (Lark's offsets, `Span.column`); an LSP client counts in the
code units of the position encoding the two agreed on at start-up, UTF-16 unless both
prefer another. The two agree on ASCII and drift apart on the first character outside it
(`é` is one UTF-16 unit but two UTF-8 bytes, `🧶` two UTF-16 units), so every position
crossing the boundary goes through here, with the text of the line it is on.
"""

from __future__ import annotations

from lsprotocol import types

from knitc.source import SourceFile, Span

UTF8, UTF16, UTF32 = "utf-8", "utf-16", "utf-32"


def units(text: str, encoding: str) -> int:
    """How many code units `text` is in `encoding`."""
    if encoding == UTF32:
        return len(text)
    if encoding == UTF8:
        return len(text.encode("utf-8", "surrogatepass"))
    return len(text.encode("utf-16-le", "surrogatepass")) // 2


def column_to_units(line: str, column: int, encoding: str) -> int:
    """The client's character index of 0-based code-point `column` on `line`."""
    return units(line[:column], encoding) if encoding != UTF32 else min(column, len(line))


def units_to_column(line: str, character: int, encoding: str) -> int:
    """The 0-based code-point column at client character index `character` on `line` (the
    end of the line when it is past it; the character's start inside a surrogate pair)."""
    if encoding == UTF32:
        return max(0, min(character, len(line)))
    seen = 0
    for i, ch in enumerate(line):
        seen += units(ch, encoding)
        if seen > character:
            return i
    return len(line)


class Locator:
    """Positions in one source text, for one client encoding."""

    def __init__(self, source: SourceFile, encoding: str = UTF16) -> None:
        self.source = source
        self.encoding = encoding

    def position(self, offset: int) -> types.Position:
        """The client position of code-point `offset`."""
        line, col = self.source.position(offset)
        text = self.source.line_text(line)
        return types.Position(line - 1, column_to_units(text, col - 1, self.encoding))

    def offset(self, position: types.Position) -> int:
        """The code-point offset of a client position (clamped into the text)."""
        line = position.line + 1
        if line > self.source.line_count:
            return len(self.source.text)
        text = self.source.line_text(line)
        start = self.source.line_start(line)
        return start + units_to_column(text, position.character, self.encoding)

    def range(self, span: Span) -> types.Range:
        """The client range of a span of this text (by its line and column, which every span
        has, also the ones made without offsets)."""
        return types.Range(
            self._at(span.line, span.column), self._at(span.end_line, span.end_column)
        )

    def offsets_range(self, start: int, end: int) -> types.Range:
        return types.Range(self.position(start), self.position(end))

    def _at(self, line: int, column: int) -> types.Position:
        line = max(1, line)
        text = self.source.line_text(line)
        return types.Position(line - 1, column_to_units(text, max(column - 1, 0), self.encoding))
