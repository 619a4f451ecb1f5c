"""Diagnostics: errors and warnings that point at the designer's source.

Passes never raise on bad input; they add `Diagnostic`s to a `Diagnostics` collection and
carry on where they can, so one run reports every independent mistake. The CLI renders them
compiler-style (``path:line:col: error[E301]: message``, the source line, a caret, notes and
hints); the language server will turn the same objects into LSP diagnostics.

Codes are stable identifiers (tests pin them, users search for them): E1xx syntax, E2xx names
and imports, E3xx types and values, E4xx parameters and cycles, E5xx skeleton topology;
Wxxx warnings.
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator
from dataclasses import field
from enum import Enum

from knitc.records import record
from knitc.source import SourceFile, Span


class Severity(Enum):
    ERROR = "error"
    WARNING = "warning"


@record(frozen=True)
class Note:
    """Extra context: a secondary location ("defined here") or a plain remark."""

    message: str
    span: Span | None = None


@record(frozen=True)
class Diagnostic:
    severity: Severity
    code: str
    message: str
    span: Span | None
    notes: tuple[Note, ...] = ()
    hint: str | None = None

    @property
    def is_error(self) -> bool:
        return self.severity is Severity.ERROR


@record
class Diagnostics:
    """An ordered collection of diagnostics, plus the sources needed to render them."""

    items: list[Diagnostic] = field(default_factory=list)
    sources: dict[str, SourceFile] = field(default_factory=dict)

    def add_source(self, source: SourceFile) -> None:
        self.sources[source.path] = source

    def error(
        self,
        code: str,
        message: str,
        span: Span | None,
        *,
        notes: Iterable[Note] = (),
        hint: str | None = None,
    ) -> Diagnostic:
        d = Diagnostic(Severity.ERROR, code, message, span, tuple(notes), hint)
        self.items.append(d)
        return d

    def warning(
        self,
        code: str,
        message: str,
        span: Span | None,
        *,
        notes: Iterable[Note] = (),
        hint: str | None = None,
    ) -> Diagnostic:
        d = Diagnostic(Severity.WARNING, code, message, span, tuple(notes), hint)
        self.items.append(d)
        return d

    def extend(self, other: Diagnostics) -> None:
        self.items.extend(other.items)
        self.sources.update(other.sources)

    def __iter__(self) -> Iterator[Diagnostic]:
        return iter(self.items)

    def __len__(self) -> int:
        return len(self.items)

    @property
    def error_count(self) -> int:
        return sum(1 for d in self.items if d.is_error)

    @property
    def warning_count(self) -> int:
        return sum(1 for d in self.items if not d.is_error)

    @property
    def has_errors(self) -> bool:
        return any(d.is_error for d in self.items)

    def promote_warnings(self) -> None:
        """`-W error`: every warning becomes an error with the same code."""
        self.items = [
            Diagnostic(Severity.ERROR, d.code, d.message, d.span, d.notes, d.hint)
            if not d.is_error
            else d
            for d in self.items
        ]

    def sorted(self) -> list[Diagnostic]:
        """Stable, source-ordered list (by file, then position, then insertion)."""

        def key(item: tuple[int, Diagnostic]) -> tuple[object, ...]:
            i, d = item
            if d.span is None:
                return ("", 0, 0, i)
            return (d.span.file, d.span.line, d.span.column, i)

        return [d for _, d in sorted(enumerate(self.items), key=key)]

    def render(self) -> str:
        return "".join(render(d, self.sources) for d in self.sorted())


def _excerpt(span: Span, sources: dict[str, SourceFile], gutter: int) -> list[str]:
    source = sources.get(span.file)
    if source is None:
        return []
    text = source.line_text(span.line)
    if not text and span.line > 1 and span.column == 1:
        # An error at the very end of the file reads better on the last real line.
        return []
    pad = " " * gutter
    expanded = text.expandtabs(1)
    start = max(span.column - 1, 0)
    if span.end_line == span.line:
        width = max(span.end_column - span.column, 1)
    else:
        width = max(len(expanded) - start, 1)
    shown, start, width = _clip(expanded, start, width)
    caret = " " * start + "^" * width
    return [f"{span.line:>{gutter}} | {shown}\n", f"{pad} | {caret}\n"]


EXCERPT_WIDTH = 100
"""Most characters of a source line a diagnostic prints: a 40 KB line (a minified or
generated design, or a hostile one) would otherwise be echoed whole, with a caret as long."""


def _clip(line: str, start: int, width: int) -> tuple[str, int, int]:
    """`line` cut to about `EXCERPT_WIDTH` characters around the caret at `start` (of
    `width`), with `…` where text was left out; and the caret's start and width in it."""
    if len(line) <= EXCERPT_WIDTH:
        return line, start, width
    context = EXCERPT_WIDTH // 4
    lo = max(0, min(start - context, len(line) - EXCERPT_WIDTH))
    hi = min(len(line), lo + EXCERPT_WIDTH)
    shown = line[lo:hi]
    caret_start = start - lo
    caret_width = max(min(width, hi - start), 1)
    if lo > 0:
        shown, caret_start = "…" + shown, caret_start + 1
    if hi < len(line):
        shown += "…"
    return shown, caret_start, caret_width


def at_designer(
    span: Span, note: str = "written here, in the applied pattern"
) -> tuple[Span, list[Note]]:
    """Where to report a finding about code expanded from the designer's line: at that line
    (the outermost span of the chain), with a note at each definition it expanded through.
    (`render` prints a chained span the other way, innermost first and "while expanding"
    each parent: for errors inside a definition rather than about its use.)"""
    outer, *inner = span.chain()
    return outer, [Note(note, s) for s in inner]


def render(d: Diagnostic, sources: dict[str, SourceFile]) -> str:
    """Render one diagnostic in the compiler style the CLI prints."""
    where = f"{d.span}: " if d.span is not None else "knitc: "
    lines = [f"{where}{d.severity.value}[{d.code}]: {d.message}\n"]
    gutter = max(len(str(d.span.line)) if d.span else 1, 2)
    if d.span is not None:
        lines += _excerpt(d.span, sources, gutter)
    pad = " " * gutter
    for note in d.notes:
        if note.span is not None:
            lines.append(f"{pad} = note: {note.span}: {note.message}\n")
        else:
            lines.append(f"{pad} = note: {note.message}\n")
    parent = d.span.parent if d.span is not None else None
    while parent is not None:
        lines.append(f"{pad} = note: {parent}: while expanding this\n")
        parent = parent.parent
    if d.hint:
        lines.append(f"{pad} = hint: {d.hint}\n")
    return "".join(lines)
