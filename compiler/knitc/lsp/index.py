"""The names of one module: where each is declared and every place it is used.

Navigation (definition, references, rename, symbols), hover and completion all start from
"what is at this offset?": a `Symbol` (a declaration's name) or a `Ref` (a use). Names have
six kinds with one namespace each: design parameters (`param p`, used as `#p`), nodes
(`tube body`, used in interfaces `body.top`, layers `pattern body {…}` and references
`@body.length`), yarns (`yarn red {…}`, used in `knit red where …`; `main`, the design's
own yarn, may be used without a declaration), and the definitions a module declares or
imports: patterns (`apply p(…)`), stitch actions (`use a`) and shapers (`shaper: s`, a word
that is not one of the built-in shapers). A node is also named inside the strings of the
queries `shape("node")` and `itf("node.top")`. The names of an import list (`import
std.stitches (rib)`) are `Ref`s of kind `import`: which kind of definition each is, only
the imported module knows. Locals of a body (`let`, `for`, pattern and shaper parameters)
are not indexed.
"""

from __future__ import annotations

import bisect
from dataclasses import field

from knitc.frontend import ast
from knitc.frontend.skeleton import SHAPERS
from knitc.records import record
from knitc.source import Span

KINDS = ("param", "node", "yarn", "pattern", "action", "shaper")

NODE_QUERIES = ("shape", "itf")
"""Pattern queries whose string argument starts with a node's name."""


@record(frozen=True)
class Symbol:
    """A declaration in this module."""

    kind: str
    name: str
    span: Span
    """The declared name."""
    decl: ast.Node
    """The whole declaration (its span is the symbol's extent)."""


@record(frozen=True)
class Ref:
    """A use of a name (which may be declared here, imported, or nowhere)."""

    kind: str
    name: str
    span: Span
    """The name itself: without the `#` of a parameter or the `@` of a property reference."""


@record
class Index:
    symbols: list[Symbol] = field(default_factory=list)
    refs: list[Ref] = field(default_factory=list)
    imports: list[ast.Import] = field(default_factory=list)
    _starts: list[int] = field(default_factory=list, repr=False)
    _sorted: list[Symbol | Ref] = field(default_factory=list, repr=False)

    def declared(self, kind: str, name: str) -> Symbol | None:
        """This module's declaration of `name` (the first, if declared twice)."""
        return next((s for s in self.symbols if s.kind == kind and s.name == name), None)

    def uses(self, kind: str, name: str) -> list[Ref]:
        return [r for r in self.refs if r.kind == kind and r.name == name]

    def at(self, offset: int) -> Symbol | Ref | None:
        """The name at code-point `offset` (its end counts: the cursor just after a word)."""
        i = bisect.bisect_right(self._starts, offset) - 1
        for item in self._sorted[max(i - 1, 0) : i + 1][::-1]:
            if item.span.start <= offset <= item.span.end:
                return item
        return None


def _name_span(token: Span, skip: int, length: int) -> Span:
    """The part of a token's span `skip` code points in, `length` long (one line)."""
    return Span(
        token.file,
        token.line,
        token.column + skip,
        token.line,
        token.column + skip + length,
        token.start + skip,
        token.start + skip + length,
    )


def build(module: ast.Module) -> Index:
    index = Index()
    for item in module.items:
        _declare(index, item)
    for item in module.items:
        if isinstance(item, ast.Import):
            index.imports.append(item)
            for n in item.names or ():
                index.refs.append(Ref("import", n.name, n.span))
            continue
        if isinstance(item, ast.PatternLayer) and item.target.name not in ("before", "after"):
            index.refs.append(Ref("node", item.target.name, item.target.span))
        for node in item.walk():
            _use(index, node)
    items: list[Symbol | Ref] = [*index.symbols, *index.refs]
    items.sort(key=lambda x: x.span.start)
    index._sorted = items
    index._starts = [x.span.start for x in items]
    return index


def _declare(index: Index, item: ast.Node) -> None:
    kind = {
        ast.ParamDecl: "param",
        ast.NodeDecl: "node",
        ast.YarnDecl: "yarn",
        ast.PatternDef: "pattern",
        ast.ActionDef: "action",
        ast.ShaperDef: "shaper",
    }.get(type(item))
    if kind is not None:
        name: ast.Ident = item.name  # type: ignore[attr-defined]
        index.symbols.append(Symbol(kind, name.name, name.span, item))


def _use(index: Index, node: ast.Node) -> None:
    if isinstance(node, ast.ParamRef):
        index.refs.append(Ref("param", node.name, _name_span(node.span, 1, len(node.name))))
    elif isinstance(node, ast.PropRef) and node.node is not None:
        index.refs.append(Ref("node", node.node, _name_span(node.span, 1, len(node.node))))
    elif isinstance(node, ast.ItfRef):
        index.refs.append(Ref("node", node.node.name, node.node.span))
    elif isinstance(node, ast.ApplyStmt):
        index.refs.append(Ref("pattern", node.pattern.name, node.pattern.span))
    elif isinstance(node, ast.UseStmt):
        index.refs.append(Ref("action", node.action.name, node.action.span))
    elif isinstance(node, ast.KnitStmt):
        index.refs.append(Ref("yarn", node.yarn.name, node.yarn.span))
    elif isinstance(node, ast.NodeDecl):
        _shaper_use(index, node)
    elif isinstance(node, ast.Call):
        _query_node(index, node)


def _shaper_use(index: Index, decl: ast.NodeDecl) -> None:
    """`shaper: s` names a shaper program (declared here or imported) unless `s` is one of
    the built-in shapers, which win over a program of the same name."""
    for prop in decl.props:
        if prop.name.name != "shaper":
            continue
        target = prop.value.func if isinstance(prop.value, ast.Call) else prop.value
        if isinstance(target, ast.Name) and target.id not in SHAPERS:
            index.refs.append(Ref("shaper", target.id, target.span))
        elif isinstance(target, ast.String) and target.value not in SHAPERS:
            inner = _string_name(target, target.value)
            if inner is not None:
                index.refs.append(Ref("shaper", target.value, inner))


def _query_node(index: Index, call: ast.Call) -> None:
    """The node named in `shape("node")` or `itf("node.top")`."""
    if not (isinstance(call.func, ast.Name) and call.func.id in NODE_QUERIES and call.args):
        return
    arg = call.args[0]
    if not isinstance(arg, ast.String):
        return
    node, dot, _ = arg.value.partition(".")
    if call.func.id == "itf" and not dot:
        return  # `itf("top")`: the interface of the node being patterned
    inner = _string_name(arg, node)
    if inner is not None and node.isidentifier():
        index.refs.append(Ref("node", node, inner))


def _string_name(string: ast.String, name: str) -> Span | None:
    """The span of `name` at the start of a string literal's text, when the literal is
    written plainly (no escapes: then its value is its text between the quotes)."""
    written = string.span.end - string.span.start - 2
    if written != len(string.value) or string.span.line != string.span.end_line:
        return None
    return _name_span(string.span, 1, len(name))
