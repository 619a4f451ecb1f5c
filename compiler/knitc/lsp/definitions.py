"""How the server shows a definition (pattern, action, shaper): its call signature and its
documentation (the `//` lines right above it), and what each standard-library module
exports. Hover, completion, the outline and the import quick fix all show these, so they
read the same everywhere."""

from __future__ import annotations

from functools import lru_cache

from knitc.diagnostics import Diagnostics
from knitc.frontend import ast
from knitc.frontend.fmt import format_expr
from knitc.records import record
from knitc.source import SourceFile

KINDS: dict[type, str] = {
    ast.PatternDef: "pattern",
    ast.ActionDef: "action",
    ast.ShaperDef: "shaper",
}
"""The definition node types and the word that declares each."""


def params_text(params: tuple[ast.ParamDef, ...]) -> str:
    """`k = 1, p = 1`: a definition's parameters as written (defaults formatted)."""
    return ", ".join(
        p.name.name if p.default is None else f"{p.name.name} = {_expr(p.default)}" for p in params
    )


def signature(d: ast.Node) -> str:
    """`rib(k = 1, p = 1)`, `zigzag(M, N)` or `purl_flat`: how a definition is called."""
    name = str(getattr(getattr(d, "name", None), "name", "?"))
    params = getattr(d, "params", None)
    return name if params is None else f"{name}({params_text(params)})"


def _expr(e: ast.Node) -> str:
    try:
        return format_expr(e)
    except Exception:  # a formatter gap must not cost a signature
        return "…"


def doc_comment(source: SourceFile, line: int) -> str:
    """The `//` lines right above 1-based `line` of `source`: a definition's documentation
    (the standard library's convention)."""
    lines: list[str] = []
    at = min(line, source.line_count) - 1
    while at >= 1:
        text = source.line_text(at).strip()
        if not text.startswith("//"):
            break
        lines.append(text[2:].removeprefix(" "))
        at -= 1
    return "\n".join(reversed(lines)).strip()


@record(frozen=True)
class Export:
    """A pattern, action or shaper of a standard-library module."""

    kind: str
    name: str
    signature: str
    doc: str
    module: str
    """The module's short name (`stitches` for `std.stitches`)."""


def stdlib_modules() -> list[str]:
    """The short names of the standard library's modules (`stitches`, `motifs`, …)."""
    from knitc.resources import stdlib_root

    try:
        std = stdlib_root().joinpath("std")
        return sorted(
            e.name[: -len(".knit")]
            for e in std.iterdir()
            if e.name.endswith(".knit") and e.is_file()
        )
    except OSError:
        return []


@lru_cache(maxsize=32)
def stdlib_exports(module: str) -> tuple[Export, ...]:
    """What `import std.<module>` brings, parsed once (on the compiler thread: the parser
    is not reentrant)."""
    from knitc.frontend.parser import parse_source
    from knitc.resources import stdlib_module

    try:
        text = stdlib_module(f"std.{module}").read_text(encoding="utf-8")
    except (OSError, ValueError):
        return ()
    source = SourceFile(f"<stdlib>/std/{module}.knit", text)
    parsed = parse_source(source, Diagnostics())
    if parsed is None:
        return ()
    return tuple(
        Export(
            KINDS[type(item)],
            item.name.name,
            signature(item),
            doc_comment(source, item.span.line),
            module,
        )
        for item in parsed.items
        if isinstance(item, ast.PatternDef | ast.ActionDef | ast.ShaperDef)
    )


def stdlib_providers() -> dict[str, tuple[tuple[str, str], ...]]:
    """Each standard-library definition's name -> ((`std.module`, kind), …): where an
    unknown name could be imported from."""
    out: dict[str, list[tuple[str, str]]] = {}
    for module in stdlib_modules():
        for e in stdlib_exports(module):
            out.setdefault(e.name, []).append((f"std.{module}", e.kind))
    return {k: tuple(v) for k, v in out.items()}
