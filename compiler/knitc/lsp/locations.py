"""Which document a span is in, as the editor names it.

Spans name files by path: the design's own, a user import's (`import "parts/lace.knit"`),
or a standard-library module's, `<stdlib>/std/stitches.knit`, which is a real file for the
editor to open wherever the package is installed as files (a wheel or an editable
install), and has no address when it is not (a zipped install).
"""

from __future__ import annotations

import os
from pathlib import Path

from lsprotocol import types
from pygls import uris

from knitc.lsp.positions import UTF16, Locator
from knitc.source import SourceFile, Span

STDLIB = "<stdlib>/"


def uri_to_path(uri: str) -> str:
    """The path spans use for the document at `uri` (`<uri>` when it is not a file)."""
    path = uris.to_fs_path(uri) if uri.startswith("file:") else None
    return path if path else f"<{uri}>"


def path_to_uri(path: str) -> str | None:
    """The URI of the file a span names; None for text that is no file."""
    if path.startswith(STDLIB):
        real = stdlib_file(path)
        return uris.from_fs_path(str(real)) if real is not None else None
    if path.startswith("<"):
        inner = path[1:-1]
        return inner if ":" in inner else None
    return uris.from_fs_path(os.path.abspath(path))


def stdlib_file(path: str) -> Path | None:
    """The file on disk of a `<stdlib>/…` span, if the standard library is files."""
    from knitc.resources import stdlib_root

    root = stdlib_root()
    if not isinstance(root, Path):
        return None
    real = root.joinpath(*path[len(STDLIB) :].split("/"))
    return real if real.is_file() else None


def source_of(path: str, sources: dict[str, SourceFile]) -> SourceFile | None:
    """The text of the file a span names: from the compilation, else read from disk."""
    if path in sources:
        return sources[path]
    real: Path | None = stdlib_file(path) if path.startswith(STDLIB) else Path(path)
    if real is None or path.startswith("<") and not path.startswith(STDLIB):
        return None
    try:
        return SourceFile(path, real.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError):
        return None


def location(
    span: Span, sources: dict[str, SourceFile], encoding: str = UTF16
) -> types.Location | None:
    """The editor location of `span`; None when its file has no address."""
    uri = path_to_uri(span.file)
    source = source_of(span.file, sources)
    if uri is None or source is None:
        return None
    return types.Location(uri, Locator(source, encoding).range(span))
