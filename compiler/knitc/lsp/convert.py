"""knitc's diagnostics as LSP diagnostics for one document.

The same `Diagnostic` objects the CLI renders: code, message and hint (the hint is the
message's second paragraph, since LSP has no field for it, and also in `data`, where the
quick fixes read it), notes with a place as related information, the "while expanding"
chain too. A diagnostic is shown in the document at the outermost span of its chain that
is in this document (the designer's line for an error inside an applied stdlib pattern);
one about another file only (an imported file's own syntax error) is shown at the top of
this document, pointing there.
"""

from __future__ import annotations

from lsprotocol import types

from knitc.diagnostics import Diagnostic, Diagnostics
from knitc.lsp.locations import location
from knitc.lsp.positions import UTF16, Locator
from knitc.source import SourceFile, Span

SOURCE = "knitc"


def to_lsp(diags: Diagnostics, source: SourceFile, encoding: str = UTF16) -> list[types.Diagnostic]:
    """The diagnostics to show in the document whose text is `source`, in source order."""
    here = Locator(source, encoding)
    sources = {**diags.sources, source.path: source}
    return [_one(d, source.path, here, sources, encoding) for d in diags.sorted()]


def _one(
    d: Diagnostic,
    path: str,
    here: Locator,
    sources: dict[str, SourceFile],
    encoding: str,
) -> types.Diagnostic:
    related: list[types.DiagnosticRelatedInformation] = []
    message = d.message
    anchor: Span | None = None
    if d.span is not None:
        chain = d.span.chain()
        anchor = next((s for s in chain if s.file == path), None)
        for s in chain:
            if s is not anchor and s != anchor:
                loc = location(s, sources, encoding)
                what = "the error is here" if s is chain[-1] else "while expanding this"
                if loc is not None:
                    related.append(types.DiagnosticRelatedInformation(loc, what))
                elif s is chain[-1]:
                    message += f"\n(at {s})"
    for note in d.notes:
        loc = location(note.span, sources, encoding) if note.span is not None else None
        if loc is not None:
            related.append(types.DiagnosticRelatedInformation(loc, note.message))
        else:
            message += f"\nnote: {note.message}"
    if d.hint:
        message += f"\nhint: {d.hint}"
    where = (
        here.range(anchor)
        if anchor is not None
        else types.Range(types.Position(0, 0), types.Position(0, 0))
    )
    return types.Diagnostic(
        range=where,
        message=message,
        severity=types.DiagnosticSeverity.Error if d.is_error else types.DiagnosticSeverity.Warning,
        code=d.code,
        source=SOURCE,
        related_information=related or None,
        data={"hint": d.hint} if d.hint else None,
    )
