"""Navigation: go to definition, find references, rename, document and workspace symbols.

Everything starts from the module's `index` ("which name is at this offset?"). Names live
in four namespaces: parameters, nodes, yarns, and definitions (patterns, stitch actions and
shapers share one, as in `frontend.definitions`, and so do the names of an import list).
Parameters, nodes and yarns are a file's own (the yarn `main` exists undeclared, and is
never renamed: it is the design's own yarn); a definition may come from an import, whose
declaration is found in the skeleton (which holds every imported definition with spans
naming its file) or, when the file no longer resolves, by parsing the imported modules
directly. The built-in stitch actions (`knit`, `purl`, ...) are `std.actions`'.

The functions of an `Analysis` here parse other files, so the handlers run them on the
compiler thread. A stale module (the text does not parse) still answers navigation from
the last tree that did, but is never renamed: its spans are in an older text.
"""

from __future__ import annotations

import logging
import os
import re
from collections.abc import Callable, Iterable, Iterator
from pathlib import Path
from typing import TYPE_CHECKING, Any

from lsprotocol import types
from pygls.exceptions import JsonRpcException

from knitc.diagnostics import Diagnostics
from knitc.frontend import ast
from knitc.frontend.fmt import format_expr
from knitc.frontend.names import BUILTIN_ACTIONS
from knitc.frontend.parser import parse_source
from knitc.frontend.skeleton import MAIN_YARN
from knitc.lsp import index as ix
from knitc.lsp.analysis import Analysis
from knitc.lsp.definitions import params_text
from knitc.lsp.locations import STDLIB, location, path_to_uri, source_of
from knitc.lsp.positions import UTF16, Locator
from knitc.records import record
from knitc.source import SourceFile, Span

if TYPE_CHECKING:
    from knitc.lsp.server import KnitServer

log = logging.getLogger("knitc.lsp")

Definition = ast.PatternDef | ast.ActionDef | ast.ShaperDef

SPACES = {
    "param": "param",
    "node": "node",
    "yarn": "yarn",
    "pattern": "def",
    "action": "def",
    "shaper": "def",
    "import": "def",
}
"""The namespace of each index kind: definitions (and import-list names) share one."""

NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_]*\Z")
RESERVED = frozenset({"true", "false", "and", "or", "not", "if", "else", "for", "in"})
"""Words the grammar reserves everywhere (its string keywords), so no name can be one."""
RESERVED_NODES = frozenset({"before", "after"})
"""The targets of the global pattern layers (E210)."""

ACTIONS_MODULE = f"{STDLIB}std/actions.knit"
"""Where the built-in stitch actions, which need no import, are defined."""

MAX_WORKSPACE_FILES = 2000
MAX_WORKSPACE_BYTES = 1 << 20
MAX_WORKSPACE_RESULTS = 1000
SKIP_DIRS = frozenset({".venv", "venv", "node_modules", "__pycache__"})


# ---- what is at the cursor ---------------------------------------------------------------------


@record(frozen=True)
class Target:
    """A name under the cursor: its namespace (`param`, `node`, `yarn`, `def`), name and
    span."""

    space: str
    name: str
    span: Span
    kind: str
    """The index's kind of the item at the cursor (`import` for an import-list name)."""


def target_at(a: Analysis, offset: int) -> Target | None:
    item = a.index.at(offset)
    if item is None or item.kind not in SPACES:
        return None
    return Target(SPACES[item.kind], item.name, item.span, item.kind)


def import_at(a: Analysis, offset: int) -> ast.Import | None:
    """The import whose module path or file string is at `offset` (not its name list)."""
    for imp in a.index.imports:
        first = imp.names[0].span.start if imp.names else imp.span.end
        if imp.span.start + len("import") < offset <= min(first, imp.span.end):
            return imp
    return None


def import_path(imp: ast.Import, importer: str) -> str | None:
    """The path (as spans name files) of the module an import reads."""
    if imp.module is not None:
        return f"{STDLIB}{'/'.join(imp.module)}.knit"
    if imp.path is None or importer.startswith("<"):
        return None
    return os.path.normpath(os.path.join(os.path.dirname(importer), imp.path))


# ---- declarations --------------------------------------------------------------------------------

_parsed: dict[str, tuple[str, ast.Module | None]] = {}
"""Modules parsed here (imports, workspace files), by path, with the text they were parsed
from; touched on the compiler thread only."""


def parse_file(source: SourceFile) -> ast.Module | None:
    """`source` parsed (once per text), None when it does not parse."""
    cached = _parsed.get(source.path)
    if cached is not None and cached[0] == source.text:
        return cached[1]
    module = parse_source(source, Diagnostics())
    _parsed[source.path] = (source.text, module)
    return module


def sources_of(a: Analysis) -> dict[str, SourceFile]:
    """The texts the compilation read (imports included), this document's last."""
    return {**a.result.diagnostics.sources, a.path: a.source}


def imported_definitions(a: Analysis) -> dict[str, Definition]:
    """Every definition this module can name that is declared in another file, by name."""
    found: dict[str, Definition] = {}
    skel = a.skeleton
    if skel is not None and not a.stale:
        tables: Iterable[dict[str, Any]] = (skel.patterns, skel.actions, skel.shapers)
        for table in tables:
            found.update(table)
    else:
        found.update(_parsed_imports(a))
    for name, d in _builtin_actions(a).items():
        found.setdefault(name, d)
    here = os.path.normpath(a.path)
    return {n: d for n, d in found.items() if os.path.normpath(d.name.span.file) != here}


def _definitions(module: ast.Module) -> dict[str, Definition]:
    return {
        i.name.name: i
        for i in module.items
        if isinstance(i, ast.PatternDef | ast.ActionDef | ast.ShaperDef)
    }


def _parsed_imports(a: Analysis) -> dict[str, Definition]:
    """The definitions of the module's imports read directly (a file that does not resolve
    has no skeleton): one level deep, restricted to the import lists."""
    found: dict[str, Definition] = {}
    sources = sources_of(a)
    for imp in a.index.imports:
        path = import_path(imp, a.path)
        source = source_of(path, sources) if path is not None else None
        module = parse_file(source) if source is not None else None
        if module is None:
            continue
        defs = _definitions(module)
        wanted = {n.name for n in imp.names} if imp.names is not None else set(defs)
        found.update({n: d for n, d in defs.items() if n in wanted})
    return found


def _builtin_actions(a: Analysis) -> dict[str, Definition]:
    source = source_of(ACTIONS_MODULE, sources_of(a))
    module = parse_file(source) if source is not None else None
    if module is None:
        return {}
    return {n: d for n, d in _definitions(module).items() if n in BUILTIN_ACTIONS}


def declaration(a: Analysis, target: Target) -> Span | None:
    """The span of the declared name `target` names: in this file or an imported one."""
    local = local_declaration(a.index, target.space, target.name)
    if local is not None:
        return local.span
    if target.space != "def":
        return None
    d = imported_definitions(a).get(target.name)
    return d.name.span if d is not None else None


def local_declaration(index: ix.Index, space: str, name: str) -> ix.Symbol | None:
    kinds = (space,) if space != "def" else ("pattern", "action", "shaper")
    return next((s for s in index.symbols if s.kind in kinds and s.name == name), None)


def uses(index: ix.Index, space: str, name: str) -> list[ix.Ref]:
    return [r for r in index.refs if SPACES.get(r.kind) == space and r.name == name]


# ---- locations -----------------------------------------------------------------------------------


def span_location(a: Analysis, span: Span, encoding: str) -> types.Location | None:
    """The editor location of a span of this document or of a file it imports."""
    if os.path.normpath(span.file) == os.path.normpath(a.path):
        return types.Location(a.uri, a.locator(encoding).range(span))
    return location(span, sources_of(a), encoding)


def file_start(path: str) -> types.Location | None:
    uri = path_to_uri(path)
    real = Path(path) if not path.startswith("<") else None
    if uri is None or real is not None and not real.is_file():
        return None
    zero = types.Position(0, 0)
    return types.Location(uri, types.Range(zero, zero))


def definition(a: Analysis, offset: int, encoding: str = UTF16) -> list[types.Location]:
    """Where the name at `offset` is declared; an import's module path goes to its file."""
    target = target_at(a, offset)
    if target is None:
        imp = import_at(a, offset)
        path = import_path(imp, a.path) if imp is not None else None
        loc = file_start(path) if path is not None else None
        return [loc] if loc is not None else []
    span = declaration(a, target)
    loc = span_location(a, span, encoding) if span is not None else None
    if loc is None and target.kind == "import":
        loc = _import_list_module(a, target)
    return [loc] if loc is not None else []


def _import_list_module(a: Analysis, target: Target) -> types.Location | None:
    """An import-list name its module lacks: at least the module it was expected in."""
    for imp in a.index.imports:
        if any(n.span == target.span for n in imp.names or ()):
            path = import_path(imp, a.path)
            return file_start(path) if path is not None else None
    return None


def references(
    a: Analysis, offset: int, include_declaration: bool, encoding: str = UTF16
) -> list[types.Location]:
    """The uses in this file of the name at `offset`, and its declaration if asked for
    (also when that is in an imported file)."""
    target = target_at(a, offset)
    if target is None:
        return []
    spans = [r.span for r in uses(a.index, target.space, target.name)]
    if include_declaration:
        decl = declaration(a, target)
        if decl is not None:
            spans.insert(0, decl)
    out = [span_location(a, s, encoding) for s in spans]
    return [loc for loc in out if loc is not None]


# ---- rename ----------------------------------------------------------------------------------------


class RenameRefused(Exception):
    """Why the name at the cursor cannot be renamed (shown to the designer)."""


def prepare_rename(a: Analysis, offset: int) -> Span | None:
    """The span of the renamable name at `offset`; None where there is no name; raises
    `RenameRefused` for a name that exists but cannot be renamed."""
    target = target_at(a, offset)
    if target is None:
        return None
    _renamable(a, target)
    return target.span


def _renamable(a: Analysis, target: Target) -> Span:
    """The declaration a rename of `target` edits, or `RenameRefused`."""
    if a.stale:
        raise RenameRefused("the file has syntax errors: fix them before renaming")
    what = _describe(target)
    if target.space == "yarn" and target.name == MAIN_YARN:
        raise RenameRefused(f"{what} is the design's own yarn: its name cannot change")
    decl = declaration(a, target)
    if decl is None:
        raise RenameRefused(f"{what} is not declared anywhere, so it cannot be renamed")
    if decl.file.startswith(STDLIB):
        module = decl.file[len(STDLIB) : -len(".knit")].replace("/", ".")
        raise RenameRefused(
            f"{what} is defined in the standard library (`{module}`), which is read-only"
        )
    if decl.file.startswith("<") and os.path.normpath(decl.file) != os.path.normpath(a.path):
        raise RenameRefused(f"{what} is defined in a file that cannot be edited")
    return decl


def _describe(target: Target) -> str:
    return f"`#{target.name}`" if target.space == "param" else f"`{target.name}`"


@record(frozen=True)
class FileEdit:
    """The renamed names of one file: its text (as edited) and the spans to replace."""

    path: str
    source: SourceFile
    spans: list[Span]


def rename(
    a: Analysis,
    offset: int,
    new_name: str,
    encoding: str = UTF16,
    texts: dict[str, str] | None = None,
) -> types.WorkspaceEdit | None:
    """The edits renaming the name at `offset` to `new_name`, in this file and the user
    files it imports; `texts` are the editor's texts of open files (by path), which win
    over the disk. Raises `RenameRefused`."""
    target = target_at(a, offset)
    if target is None:
        raise RenameRefused("there is no parameter, node, yarn or definition name here to rename")
    decl = _renamable(a, target)
    _check_name(a, target, new_name)
    if new_name == target.name:
        return types.WorkspaceEdit(changes={})
    files = _edited_files(a, target, decl, texts or {}, new_name)
    _check_parses(a, files, new_name)
    changes: dict[str, list[types.TextEdit]] = {}
    for f in files:
        uri = a.uri if f.path == os.path.normpath(a.path) else path_to_uri(f.path)
        if uri is None or not f.spans:
            continue
        loc = Locator(f.source, encoding)
        changes[uri] = [types.TextEdit(loc.range(s), new_name) for s in _unique(f.spans)]
    return types.WorkspaceEdit(changes=changes)


def _unique(spans: list[Span]) -> list[Span]:
    seen: dict[tuple[int, int], Span] = {}
    for s in spans:
        seen.setdefault((s.start, s.end), s)
    return sorted(seen.values(), key=lambda s: s.start)


def _check_name(a: Analysis, target: Target, new: str) -> None:
    if not NAME.match(new):
        raise RenameRefused(
            f"`{new}` is not a name: a name is a letter or `_`, then letters, digits or `_`"
        )
    if new in RESERVED:
        raise RenameRefused(f"`{new}` is a reserved word and cannot be a name")
    if target.space == "node" and new in RESERVED_NODES:
        raise RenameRefused(f"`{new}` is reserved for the global pattern layers (E210)")
    if new == target.name:
        return
    if _taken(a, target.space, new):
        kind = {"param": "parameter", "node": "node", "yarn": "yarn", "def": "definition"}[
            target.space
        ]
        shown = f"#{new}" if target.space == "param" else new
        raise RenameRefused(f"there is already a {kind} named `{shown}`")


def _taken(a: Analysis, space: str, name: str) -> bool:
    """Whether `name` already names something of `space`: `main` always names a yarn."""
    if local_declaration(a.index, space, name) is not None:
        return True
    if space == "yarn":
        return name == MAIN_YARN
    return space == "def" and name in imported_definitions(a)


def _edited_files(
    a: Analysis, target: Target, decl: Span, texts: dict[str, str], new: str
) -> list[FileEdit]:
    """This file's and, for a definition declared in an imported file, every imported user
    file's uses and declaration (a file that declares the name itself is left alone).
    Refuses a new name one of those files already defines."""
    here = os.path.normpath(a.path)
    home = os.path.normpath(decl.file)
    own = uses(a.index, target.space, target.name)
    spans = [r.span for r in own]
    local = local_declaration(a.index, target.space, target.name)
    if local is not None:
        spans.append(local.span)
    files = [FileEdit(here, a.source, spans)]
    if home == here or target.space != "def":
        return files
    for path, source, module in _user_imports(a, texts):
        index = ix.build(module)
        if local_declaration(index, "def", new) is not None:
            raise RenameRefused(f"`{os.path.basename(path)}` already defines `{new}`")
        declared = local_declaration(index, "def", target.name)
        if declared is not None and path != home:
            continue
        found = [r.span for r in uses(index, "def", target.name)]
        if declared is not None:
            found.append(declared.span)
        files.append(FileEdit(path, source, found))
    return files


def _user_imports(
    a: Analysis, texts: dict[str, str]
) -> Iterator[tuple[str, SourceFile, ast.Module]]:
    """The user files this module imports, directly or not, parsed from their current text."""
    sources = sources_of(a)
    seen = {os.path.normpath(a.path)}
    todo = [(a.path, imp) for imp in a.index.imports]
    while todo:
        importer, imp = todo.pop(0)
        path = import_path(imp, importer) if imp.module is None else None
        if path is None or path in seen:
            continue
        seen.add(path)
        source = _current_source(path, texts, sources)
        module = parse_file(source) if source is not None else None
        if source is None or module is None:
            continue
        yield path, source, module
        todo.extend((path, i) for i in module.items if isinstance(i, ast.Import))


def _current_source(
    path: str, texts: dict[str, str], sources: dict[str, SourceFile]
) -> SourceFile | None:
    """A file's text as the editor has it (open and perhaps unsaved), else as on disk."""
    if path in texts:
        return SourceFile(path, texts[path])
    try:
        return SourceFile(path, Path(path).read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError):
        return source_of(path, sources)


def _check_parses(a: Analysis, files: list[FileEdit], new: str) -> None:
    """Refuse a name the grammar would read as something else where it is written."""
    for f in files:
        text = f.source.text
        for s in sorted(_unique(f.spans), key=lambda s: -s.start):
            text = text[: s.start] + new + text[s.end :]
        if parse_source(SourceFile(f.path, text), Diagnostics()) is None:
            raise RenameRefused(f"`{new}` cannot be a name there: the file would not parse")


# ---- document symbols -------------------------------------------------------------------------------

K = types.SymbolKind
DEF_SYMBOLS = {"pattern": K.Function, "action": K.Function, "shaper": K.Function}
INDEX_SYMBOLS = {"param": K.Constant, "node": K.Class, "yarn": K.Object, **DEF_SYMBOLS}
DETAIL_CHARS = 60


def _short(text: str) -> str:
    """One line of at most `DETAIL_CHARS` characters (a grid or profile can be long)."""
    line = " ".join(text.split())
    return line if len(line) <= DETAIL_CHARS else line[: DETAIL_CHARS - 1] + "…"


def _expr(e: ast.Node) -> str:
    try:
        return _short(format_expr(e))
    except TypeError:
        return ""


def _itf(ref: ast.ItfRef) -> str:
    index = f"[{format_expr(ref.index)}]" if ref.index is not None else ""
    return f"{ref.node.name}.{ref.path.name}{index}"


class _Outline:
    """Builds `DocumentSymbol`s of one module with one locator."""

    def __init__(self, locator: Locator) -> None:
        self.loc = locator

    def symbol(
        self,
        name: str,
        kind: types.SymbolKind,
        whole: Span,
        selection: Span,
        detail: str | None = None,
        children: list[types.DocumentSymbol] | None = None,
    ) -> types.DocumentSymbol:
        rng = self.loc.range(whole)
        sel = self.loc.range(selection)
        if not _inside(sel, rng):
            sel = rng
        return types.DocumentSymbol(
            name=name or "?",
            kind=kind,
            range=rng,
            selection_range=sel,
            detail=detail,
            children=children,
        )

    def props(self, props: Iterable[ast.Prop]) -> list[types.DocumentSymbol]:
        return [
            self.symbol(p.name.name, K.Property, p.span, p.name.span, _expr(p.value)) for p in props
        ]

    def item(self, item: ast.Node) -> types.DocumentSymbol | None:
        handler = _ITEMS.get(type(item))
        return handler(self, item) if handler is not None else None

    def group(
        self, name: str, kind: types.SymbolKind, members: list[types.DocumentSymbol]
    ) -> types.DocumentSymbol:
        rng = types.Range(members[0].range.start, members[-1].range.end)
        return types.DocumentSymbol(
            name=name, kind=kind, range=rng, selection_range=members[0].range, children=members
        )


def _inside(inner: types.Range, outer: types.Range) -> bool:
    def key(p: types.Position) -> tuple[int, int]:
        return (p.line, p.character)

    return key(outer.start) <= key(inner.start) and key(inner.end) <= key(outer.end)


def _import(o: _Outline, i: ast.Import) -> types.DocumentSymbol:
    name = ".".join(i.module) if i.module is not None else f'"{i.path}"'
    detail = "(" + ", ".join(n.name for n in i.names) + ")" if i.names is not None else None
    return o.symbol(name, K.Module, i.span, i.span, detail)


def _param(o: _Outline, p: ast.ParamDecl) -> types.DocumentSymbol:
    return o.symbol(p.name.name, K.Constant, p.span, p.name.span, _expr(p.value))


def _machine(o: _Outline, m: ast.MachineDecl) -> types.DocumentSymbol:
    return o.symbol("machine", K.Namespace, m.span, m.span, None, o.props(m.props))


def _node(o: _Outline, n: ast.NodeDecl) -> types.DocumentSymbol:
    return o.symbol(n.name.name, K.Class, n.span, n.name.span, n.kind, o.props(n.props))


def _yarn(o: _Outline, y: ast.YarnDecl) -> types.DocumentSymbol:
    return o.symbol(y.name.name, K.Object, y.span, y.name.span, "yarn", o.props(y.props))


def _layer(o: _Outline, p: ast.PatternLayer) -> types.DocumentSymbol:
    return o.symbol(f"pattern {p.target.name}", K.Event, p.span, p.target.span, "pattern layer")


def _pattern(o: _Outline, d: ast.PatternDef) -> types.DocumentSymbol:
    return o.symbol(d.name.name, K.Function, d.span, d.name.span, _signature("pattern", d.params))


def _shaper(o: _Outline, d: ast.ShaperDef) -> types.DocumentSymbol:
    return o.symbol(d.name.name, K.Function, d.span, d.name.span, _signature("shaper", d.params))


def _action(o: _Outline, d: ast.ActionDef) -> types.DocumentSymbol:
    props = [i for i in d.items if isinstance(i, ast.Prop)]
    return o.symbol(d.name.name, K.Function, d.span, d.name.span, "action", o.props(props))


def _signature(kind: str, params: tuple[ast.ParamDef, ...]) -> str:
    return f"{kind}({params_text(params)})"


def _connect(o: _Outline, c: ast.Connect) -> types.DocumentSymbol:
    return o.symbol(f"{_itf(c.a)} -> {_itf(c.b)}", K.Interface, c.span, c.a.span)


def _itf_stmt(o: _Outline, s: ast.ItfStmt) -> types.DocumentSymbol:
    state = f" {s.state}" if s.state else ""
    closing = f"({s.closing.name})" if s.closing is not None else ""
    children = o.props(s.props) if s.props else None
    return o.symbol(
        f"{_itf(s.itf)}{state}{closing}", K.Interface, s.span, s.itf.span, None, children
    )


def _start(o: _Outline, s: ast.Start) -> types.DocumentSymbol:
    return o.symbol(f"start {_itf(s.itf)}", K.Event, s.span, s.itf.span)


_ITEMS: dict[type, Callable[[_Outline, Any], types.DocumentSymbol]] = {
    ast.Import: _import,
    ast.ParamDecl: _param,
    ast.MachineDecl: _machine,
    ast.YarnDecl: _yarn,
    ast.NodeDecl: _node,
    ast.PatternLayer: _layer,
    ast.PatternDef: _pattern,
    ast.ShaperDef: _shaper,
    ast.ActionDef: _action,
    ast.Start: _start,
    ast.ItfStmt: _itf_stmt,
}

GROUPS = {ast.Connect: "connections"}
"""Items shown as one group (a garment has many connections, each one line)."""


def document_symbols(a: Analysis, encoding: str = UTF16) -> list[types.DocumentSymbol]:
    """The outline of the document, in source order; connections as one group at the first."""
    if a.module is None:
        return []
    o = _Outline(a.locator(encoding))
    out: list[types.DocumentSymbol] = []
    connections: list[types.DocumentSymbol] = []
    where = -1
    for item in a.module.items:
        if isinstance(item, ast.Connect):
            where = len(out) if where < 0 else where
            connections.append(_connect(o, item))
            continue
        sym = o.item(item)
        if sym is not None:
            out.append(sym)
    if connections:
        out.insert(where, o.group(GROUPS[ast.Connect], K.Namespace, connections))
    return out


# ---- workspace symbols ------------------------------------------------------------------------------


@record(frozen=True)
class Indexed:
    """A file's text and index, for workspace symbols."""

    uri: str
    source: SourceFile
    index: ix.Index


_disk: dict[str, tuple[int, int, Indexed | None]] = {}
"""Workspace files by path, with the mtime and size they were indexed at."""


def workspace_files(root: str, skip: set[str]) -> list[Indexed]:
    """The `.knit` files under `root` (not hidden, not in `SKIP_DIRS`, at most
    `MAX_WORKSPACE_FILES` of at most `MAX_WORKSPACE_BYTES`), except the paths in `skip`."""
    out: list[Indexed] = []
    for path in _knit_files(root):
        if os.path.normpath(path) in skip:
            continue
        found = _indexed(path)
        if found is not None:
            out.append(found)
    return out


def _knit_files(root: str) -> Iterator[str]:
    count = 0
    for folder, dirs, names in os.walk(root):
        dirs[:] = sorted(d for d in dirs if not d.startswith(".") and d not in SKIP_DIRS)
        for name in sorted(names):
            if name.endswith(".knit") and not name.startswith("."):
                count += 1
                if count > MAX_WORKSPACE_FILES:
                    return
                yield os.path.join(folder, name)


def _indexed(path: str) -> Indexed | None:
    try:
        st = os.stat(path)
    except OSError:
        return None
    cached = _disk.get(path)
    if cached is not None and cached[:2] == (st.st_mtime_ns, st.st_size):
        return cached[2]
    found: Indexed | None = None
    if st.st_size <= MAX_WORKSPACE_BYTES:
        try:
            source = SourceFile(path, Path(path).read_text(encoding="utf-8"))
        except (OSError, UnicodeDecodeError):
            source = None
        module = parse_file(source) if source is not None else None
        uri = path_to_uri(path)
        if source is not None and module is not None and uri is not None:
            found = Indexed(uri, source, ix.build(module))
    _disk[path] = (st.st_mtime_ns, st.st_size, found)
    return found


def workspace_symbols(
    query: str, files: Iterable[Indexed], encoding: str = UTF16
) -> list[types.SymbolInformation]:
    """Declarations whose name contains `query` (any case), over `files`."""
    want = query.lower()
    out: list[types.SymbolInformation] = []
    for f in files:
        loc = Locator(f.source, encoding)
        container = os.path.basename(f.source.path.strip("<>"))
        for s in f.index.symbols:
            if want in s.name.lower():
                out.append(
                    types.SymbolInformation(
                        name=s.name,
                        kind=INDEX_SYMBOLS[s.kind],
                        location=types.Location(f.uri, loc.range(s.span)),
                        container_name=container,
                    )
                )
                if len(out) >= MAX_WORKSPACE_RESULTS:
                    return out
    return out


def open_files(analyses: Iterable[Analysis]) -> list[Indexed]:
    return [Indexed(a.uri, a.source, a.index) for a in analyses]


# ---- the handlers --------------------------------------------------------------------------------


def _refused(problem: RenameRefused) -> JsonRpcException:
    return JsonRpcException(str(problem), code=int(types.LSPErrorCodes.RequestFailed))


def register(server: KnitServer) -> None:
    """Add the navigation handlers to the server."""

    @server.feature(types.TEXT_DOCUMENT_DEFINITION)
    async def goto_definition(
        ls: KnitServer, params: types.DefinitionParams
    ) -> list[types.Location] | None:
        a = await ls.analysis_for(params.text_document.uri)
        if a is None:
            return None
        offset = a.locator(ls.encoding).offset(params.position)
        return await ls.run_safely(definition, a, offset, ls.encoding) or None

    @server.feature(types.TEXT_DOCUMENT_REFERENCES)
    async def find_references(
        ls: KnitServer, params: types.ReferenceParams
    ) -> list[types.Location] | None:
        a = await ls.analysis_for(params.text_document.uri)
        if a is None:
            return None
        offset = a.locator(ls.encoding).offset(params.position)
        include = params.context.include_declaration
        return await ls.run_safely(references, a, offset, include, ls.encoding)

    @server.feature(types.TEXT_DOCUMENT_PREPARE_RENAME)
    async def prepare(ls: KnitServer, params: types.PrepareRenameParams) -> types.Range | None:
        a = await ls.analysis_for(params.text_document.uri)
        if a is None:
            return None
        offset = a.locator(ls.encoding).offset(params.position)
        try:
            span = await ls.run_compiler(prepare_rename, a, offset)
        except RenameRefused as problem:
            raise _refused(problem) from None
        except Exception:
            log.exception("prepareRename failed")
            return None
        return a.locator(ls.encoding).range(span) if span is not None else None

    @server.feature(types.TEXT_DOCUMENT_RENAME, types.RenameOptions(prepare_provider=True))
    async def do_rename(ls: KnitServer, params: types.RenameParams) -> types.WorkspaceEdit | None:
        a = await ls.analysis_for(params.text_document.uri)
        if a is None:
            return None
        offset = a.locator(ls.encoding).offset(params.position)
        texts = _open_texts(ls)
        try:
            edit: types.WorkspaceEdit | None = await ls.run_compiler(
                rename, a, offset, params.new_name, ls.encoding, texts
            )
        except RenameRefused as problem:
            raise _refused(problem) from None
        except Exception:
            log.exception("rename failed")
            return None
        return edit

    @server.feature(types.TEXT_DOCUMENT_DOCUMENT_SYMBOL)
    async def outline(
        ls: KnitServer, params: types.DocumentSymbolParams
    ) -> list[types.DocumentSymbol] | None:
        a = await ls.analysis_for(params.text_document.uri)
        if a is None:
            return None
        return await ls.run_safely(document_symbols, a, ls.encoding)

    @server.feature(types.WORKSPACE_SYMBOL)
    async def find_symbols(
        ls: KnitServer, params: types.WorkspaceSymbolParams
    ) -> list[types.SymbolInformation] | None:
        found = [await ls.analysis_for(uri) for uri in list(ls.workspace.text_documents)]
        analyses = [a for a in found if a is not None]
        files = open_files(analyses)
        if ls.root:
            skip = {os.path.normpath(a.path) for a in analyses}
            files += await ls.run_safely(workspace_files, ls.root, skip) or []
        return workspace_symbols(params.query, files, ls.encoding)


def _open_texts(ls: KnitServer) -> dict[str, str]:
    """The editor's text of each open file, by the path spans use."""
    from knitc.lsp.locations import uri_to_path

    return {
        os.path.normpath(uri_to_path(uri)): doc.source
        for uri, doc in ls.workspace.text_documents.items()
    }
