"""Source files and spans.

Every AST node, IR record and diagnostic points back at the text the designer wrote, so a
warning about a needle in the machine program can still name the DSL line that caused it.
Spans keep both offsets (for editors, which count in code points) and 1-based line/column
pairs (for humans); `parent` chains a span to the place that expanded it, e.g. the `apply`
of a stdlib pattern whose body raised the error ("while expanding ...").
"""

from __future__ import annotations

import bisect
import re
from dataclasses import field

from knitc.records import record


@record(frozen=True, slots=True)
class Span:
    """A half-open range of one source file: [start, end) in code points."""

    file: str
    line: int
    column: int
    end_line: int
    end_column: int
    start: int = 0
    end: int = 0
    parent: Span | None = field(default=None, compare=False)
    """Where this span was expanded from (an import or a pattern application)."""

    def __str__(self) -> str:
        return f"{self.file}:{self.line}:{self.column}"

    def with_parent(self, parent: Span | None) -> Span:
        return Span(
            self.file,
            self.line,
            self.column,
            self.end_line,
            self.end_column,
            self.start,
            self.end,
            parent,
        )

    def chain(self) -> tuple[Span, ...]:
        """The spans this one was expanded from and itself, outermost (the designer's line)
        first, each without its parent."""
        out: list[Span] = []
        s: Span | None = self
        while s is not None:
            out.append(s.with_parent(None))
            s = s.parent
        return tuple(reversed(out))

    @staticmethod
    def expanded(spans: tuple[Span, ...]) -> Span:
        """The innermost of `spans` (outermost first) with the others as its parents."""
        chained: Span | None = None
        for s in spans:
            chained = s.with_parent(chained)
        assert chained is not None
        return chained

    def to_json(self) -> list[object]:
        """Compact, stable form for IR dumps: [file, line, col, end_line, end_col]."""
        return [self.file, self.line, self.column, self.end_line, self.end_column]


UNKNOWN_SPAN = Span("<unknown>", 1, 1, 1, 1)


_NEWLINE = re.compile("\n")


@record(frozen=True)
class SourceFile:
    """The text of one input, with a line index for span construction and rendering."""

    path: str
    text: str
    _line_starts: tuple[int, ...] = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        # (the regex scan runs in C: a character loop cost ~50 ms on a 2 MB Knitout file)
        starts = (0, *(m.end() for m in _NEWLINE.finditer(self.text)))
        object.__setattr__(self, "_line_starts", starts)

    def line_text(self, line: int) -> str:
        """The text of 1-based `line`, without its newline ('' past the end)."""
        if line < 1 or line > len(self._line_starts):
            return ""
        start = self._line_starts[line - 1]
        end = self.text.find("\n", start)
        return self.text[start:] if end < 0 else self.text[start:end]

    @property
    def line_count(self) -> int:
        """How many lines the text has (a final newline starts an empty last line)."""
        return len(self._line_starts)

    def line_start(self, line: int) -> int:
        """The code-point offset where 1-based `line` starts (clamped to the text)."""
        return self._line_starts[max(1, min(line, len(self._line_starts))) - 1]

    def position(self, offset: int) -> tuple[int, int]:
        """1-based (line, column) of a code-point offset."""
        offset = max(0, min(offset, len(self.text)))
        line = bisect.bisect_right(self._line_starts, offset)
        return line, offset - self._line_starts[line - 1] + 1

    def span(self, start: int, end: int) -> Span:
        line, col = self.position(start)
        end_line, end_col = self.position(end)
        return Span(self.path, line, col, end_line, end_col, start, end)
