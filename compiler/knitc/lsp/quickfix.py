"""Quick fixes for knitc's diagnostics.

Four mistakes have one obvious repair, which the diagnostic's hint already names:

- a misspelt name, whose hint says ``did you mean `X`?`` (every resolver check that
  suggests a close match): replace the name by `X`. The diagnostic's range is not always
  just the name (`#nam` includes the `#`, `@nod.width` the property, an unknown stdlib
  module the whole `import`), so the word replaced is the one in the range closest to `X`;
- an unknown pattern, action or shaper that a standard-library module defines: import it
  from there, in that module's existing `import std.X (…)` list or a new import after the
  others;
- reverse stitches (or an action) that need the facing needles free, on a full-gauge
  tube, whose hint asks for `gauge: half`: set it on the node the statement patterns (or
  in `machine`, for a global layer);
- an unknown yarn (`knit blue`, E228): declare it, `yarn blue { carrier: N }` on the
  lowest carrier no yarn asks for, after the other yarns (or the machine block, or the
  imports and parameters).
"""

from __future__ import annotations

import difflib
import re
from typing import Any

from lsprotocol import types

from knitc.frontend import ast
from knitc.frontend import skeleton as sk
from knitc.lsp.analysis import Analysis
from knitc.lsp.convert import SOURCE
from knitc.lsp.definitions import stdlib_providers
from knitc.lsp.server import KnitServer
from knitc.records import record

_DID_YOU_MEAN = re.compile(r"did you mean `([^`]+)`\?")
_UNKNOWN = {"E217": "action", "E218": "pattern"}
"""Codes of an unknown definition's use, and the kind each names."""
_SHAPER_VALUE = "E312"
"""`shaper: x` naming no shaper (among other bad choices)."""
_GAUGE_HINT = "`gauge: half`"
_UNKNOWN_YARN = "E228"


@record(frozen=True)
class Fix:
    """A quick fix in code-point offsets of the document's text."""

    title: str
    edits: tuple[tuple[int, int, str], ...]
    preferred: bool = False


def hint_of(d: types.Diagnostic) -> str:
    """The hint the server attached (`data`), else the message's `hint:` paragraph."""
    data: Any = d.data
    if isinstance(data, dict) and isinstance(data.get("hint"), str):
        return str(data["hint"])
    _, sep, hint = d.message.partition("\nhint: ")
    return hint.split("\n")[0] if sep else ""


# ---- did you mean -----------------------------------------------------------------------------

_PIECE = re.compile(r"[^\s.#@()\[\],:{}=]+")
_DOTTED = re.compile(r"[^\s#@()\[\],:{}=]+")


def rename_fix(text: str, start: int, end: int, hint: str) -> Fix | None:
    """Replace the misspelt word in `text[start:end]` by the hint's suggestion."""
    m = _DID_YOU_MEAN.search(hint)
    if m is None:
        return None
    want = m.group(1)
    word = _closest_word(text, start, end, want)
    if word is None:
        return None
    s, e = word
    if text[s:e] == want:
        return None
    return Fix(f"Change to `{want}`", ((s, e, want),), preferred=True)


def _closest_word(text: str, start: int, end: int, want: str) -> tuple[int, int] | None:
    """The word of the range most like `want` (sigils aside); at an empty range, the word
    that starts there."""
    if end <= start:
        end = start
        while end < len(text) and (text[end].isalnum() or text[end] == "_"):
            end += 1
    piece = _DOTTED if "." in want else _PIECE
    bare = want.lstrip("#@")
    best: tuple[float, int, int] | None = None
    for m in piece.finditer(text, start, end):
        score = difflib.SequenceMatcher(None, m.group(), bare).ratio()
        if best is None or score > best[0]:
            best = (score, m.start(), m.end())
    return None if best is None else (best[1], best[2])


# ---- imports from the standard library ---------------------------------------------------------


def import_fixes(
    a: Analysis,
    d_code: str,
    start: int,
    end: int,
    exports: dict[str, tuple[tuple[str, str], ...]],
) -> list[Fix]:
    """Import an unknown pattern, action or shaper from the stdlib modules defining it."""
    module = a.module
    if module is None or a.stale:
        return []
    kind = _UNKNOWN.get(d_code)
    if d_code == _SHAPER_VALUE and _is_shaper_value(module, start):
        kind = "shaper"
    if kind is None:
        return []
    m = re.match(
        r"[A-Za-z_]\w*", a.text[start : max(end, start + 1)] if start < len(a.text) else ""
    )
    if m is None:
        return []
    name = m.group()
    fixes = []
    for dotted, what in exports.get(name, ()):
        if what == kind:
            edit = _import_edit(a.text, module, dotted, name)
            if edit is not None:
                fixes.append(Fix(f"Import `{name}` from {dotted}", (edit,)))
    return fixes


def _is_shaper_value(module: ast.Module, offset: int) -> bool:
    """Is `offset` in the value of a `shaper:` property (not another choice's)?"""
    return any(
        isinstance(n, ast.Prop)
        and n.name.name == "shaper"
        and n.value.span.start <= offset < n.value.span.end
        for n in module.walk()
    )


def _import_edit(
    text: str, module: ast.Module, dotted: str, name: str
) -> tuple[int, int, str] | None:
    imports = [i for i in module.items if isinstance(i, ast.Import)]
    path = tuple(dotted.split("."))
    for imp in imports:
        if imp.module == path and imp.names is not None:
            if any(n.name == name for n in imp.names):
                return None
            at = imp.names[-1].span.end
            return (at, at, f", {name}")
    line = f"import {dotted} ({name})"
    if imports:
        at = _line_end(text, imports[-1].span.end)
        return (at, at, "\n" + line)
    first = module.items[0].span.start if module.items else len(text)
    at = _line_start(text, first)
    return (at, at, line + "\n\n")


def _line_end(text: str, offset: int) -> int:
    """The end of the line `offset` is on (before its newline): after a trailing comment."""
    nl = text.find("\n", offset)
    return len(text) if nl < 0 else nl


def _line_start(text: str, offset: int) -> int:
    return text.rfind("\n", 0, offset) + 1


# ---- half gauge --------------------------------------------------------------------------------


def gauge_fix(a: Analysis, start: int) -> Fix | None:
    """`gauge: half` on the node the statement at `start` is in or patterns, else in the
    `machine` block."""
    module = a.module
    if module is None or a.stale:
        return None
    item = next((i for i in module.items if i.span.start <= start < i.span.end), None)
    nodes = {i.name.name: i for i in module.items if isinstance(i, ast.NodeDecl)}
    node: ast.NodeDecl | ast.MachineDecl | None = None
    if isinstance(item, ast.NodeDecl):
        node = item
    elif isinstance(item, ast.PatternLayer):
        node = nodes.get(item.target.name)
    if node is None:
        node = next((i for i in module.items if isinstance(i, ast.MachineDecl)), None)
        if node is None:
            return _new_machine(a.text, module)
    where = f"`{node.name.name}`" if isinstance(node, ast.NodeDecl) else "`machine`"
    edit = _set_gauge(a.text, node)
    return None if edit is None else Fix(f"Knit {where} in half gauge", (edit,), True)


def _set_gauge(text: str, decl: ast.NodeDecl | ast.MachineDecl) -> tuple[int, int, str] | None:
    """The edit that makes the block say `gauge: half`."""
    for p in decl.props:
        if p.name.name == "gauge":
            if isinstance(p.value, ast.Name) and p.value.id == "half":
                return None
            return (p.value.span.start, p.value.span.end, "half")
    if decl.props:
        last = decl.props[-1]
        close = decl.span.end - 1
        if _one_line(text, decl.span.start, close):
            return (last.span.end, last.span.end, ", gauge: half")
        indent = _indent(text, last.span.start)
        at = _line_end(text, last.span.end)
        if close < at:  # `}` on the last property's line: it moves to a line of its own
            between = text[last.span.end : close]
            outer = _indent(text, decl.span.start)
            if between.strip():  # a comment: keep it where it is
                return (close, close, f"\n{indent}gauge: half\n{outer}")
            return (last.span.end, close, f"\n{indent}gauge: half\n{outer}")
        return (at, at, f"\n{indent}gauge: half")
    brace = text.rfind("{", decl.span.start, decl.span.end)
    return (brace + 1, decl.span.end - 1, " gauge: half ")


def _one_line(text: str, start: int, end: int) -> bool:
    return "\n" not in text[start:end]


def _indent(text: str, offset: int) -> str:
    line = text[_line_start(text, offset) : offset]
    return line[: len(line) - len(line.lstrip())]


def _new_machine(text: str, module: ast.Module) -> Fix:
    """A `machine { gauge: half }` after the imports (a design with no machine block)."""
    imports = [i for i in module.items if isinstance(i, ast.Import)]
    if imports:
        at = _line_end(text, imports[-1].span.end)
        edit = (at, at, "\n\nmachine { gauge: half }")
    else:
        first = module.items[0].span.start if module.items else 0
        at = _line_start(text, first)
        edit = (at, at, "machine { gauge: half }\n\n")
    return Fix("Knit the design in half gauge", (edit,), True)


# ---- yarns ------------------------------------------------------------------------------------

CARRIERS = range(1, 11)
"""The carriers a yarn may ask for (`YARN_PROPS["carrier"]`)."""


def yarn_fix(a: Analysis, start: int, end: int, preferred: bool) -> Fix | None:
    """Declare the unknown yarn of `knit NAME` at `start`..`end` (the name)."""
    module = a.module
    if module is None or a.stale:
        return None
    m = re.fullmatch(r"[A-Za-z_]\w*", a.text[start:end])
    if m is None or m.group() == sk.MAIN_YARN:
        return None
    name = m.group()
    carrier = next((c for c in CARRIERS if c not in _asked_carriers(a, module)), None)
    decl = f"yarn {name} {{ carrier: {carrier} }}" if carrier else f"yarn {name} {{}}"
    items = module.items
    yarns = [i for i in items if isinstance(i, ast.YarnDecl)]
    machine = [i for i in items if isinstance(i, ast.MachineDecl)]
    header = [i for i in items if isinstance(i, ast.Import | ast.ParamDecl)]
    if yarns:
        at = _line_end(a.text, yarns[-1].span.end)
        edit = (at, at, "\n" + decl)
    elif machine or header:
        at = _line_end(a.text, (machine or header)[-1].span.end)
        edit = (at, at, "\n\n" + decl)
    else:
        at = _line_start(a.text, items[0].span.start if items else 0)
        edit = (at, at, decl + "\n\n")
    return Fix(f"Declare yarn `{name}`", (edit,), preferred)


def _asked_carriers(a: Analysis, module: ast.Module) -> set[int]:
    """The carriers the design's yarns ask for, `main`'s included: as resolved, else as
    written (a design that does not resolve)."""
    skel = a.skeleton
    if skel is not None:
        return {y.carrier for y in skel.yarns.values() if y.carrier is not None}
    asked = {sk.MACHINE_PROPS["carriers"].default[0]}  # `main`'s, unless it declares one
    for item in module.items:
        if not isinstance(item, ast.YarnDecl):
            continue
        for p in item.props:
            if p.name.name == "carrier" and isinstance(p.value, ast.Number):
                if item.name.name == sk.MAIN_YARN:
                    asked.discard(sk.MACHINE_PROPS["carriers"].default[0])
                asked.add(int(p.value.value))
    return asked


# ---- the handler -------------------------------------------------------------------------------


def fixes_for(
    a: Analysis,
    d: types.Diagnostic,
    exports: dict[str, tuple[tuple[str, str], ...]],
    encoding: str,
) -> list[Fix]:
    """Every quick fix for one diagnostic of `a`'s document."""
    if d.source != SOURCE:
        return []
    loc = a.locator(encoding)
    start, end = loc.offset(d.range.start), loc.offset(d.range.end)
    hint, code = hint_of(d), str(d.code or "")
    fixes: list[Fix] = []
    rename = rename_fix(a.text, start, end, hint)
    if rename is not None:
        fixes.append(rename)
    fixes += import_fixes(a, code, start, end, exports)
    if _GAUGE_HINT in hint:
        gauge = gauge_fix(a, start)
        if gauge is not None:
            fixes.append(gauge)
    if code == _UNKNOWN_YARN:
        yarn = yarn_fix(a, start, end, preferred=rename is None)
        if yarn is not None:
            fixes.append(yarn)
    return fixes


def code_actions(
    a: Analysis,
    diagnostics: list[types.Diagnostic],
    exports: dict[str, tuple[tuple[str, str], ...]],
    encoding: str,
) -> list[types.CodeAction]:
    loc = a.locator(encoding)
    out = []
    for d in diagnostics:
        for fix in fixes_for(a, d, exports, encoding):
            edits = [types.TextEdit(loc.offsets_range(s, e), new) for s, e, new in fix.edits]
            out.append(
                types.CodeAction(
                    title=fix.title,
                    kind=types.CodeActionKind.QuickFix,
                    diagnostics=[d],
                    is_preferred=fix.preferred or None,
                    edit=types.WorkspaceEdit(changes={a.uri: edits}),
                )
            )
    return out


def register(server: KnitServer) -> None:
    options = types.CodeActionOptions(code_action_kinds=[types.CodeActionKind.QuickFix])

    @server.feature(types.TEXT_DOCUMENT_CODE_ACTION, options)
    async def code_action(
        ls: KnitServer, params: types.CodeActionParams
    ) -> list[types.CodeAction] | None:
        a = await ls.analysis_for(params.text_document.uri)
        if a is None:
            return None
        only = params.context.only
        if only and not any(str(k).startswith(types.CodeActionKind.QuickFix) for k in only):
            return []
        exports = await ls.run_safely(stdlib_providers) or {}
        return (
            await ls.run_safely(
                code_actions, a, list(params.context.diagnostics), exports, ls.encoding
            )
            or []
        )
