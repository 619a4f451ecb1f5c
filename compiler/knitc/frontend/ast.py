"""The knitc abstract syntax tree.

Frozen records (`knitc.records`), one per construct of `grammars/knit.lark`. Every node carries the span
of the text it came from; spans are excluded from equality so that `parse(fmt(x)) == x`
states exactly "the formatter changes layout, never meaning". The tree is deliberately
close to the source: names are not resolved here (that is `frontend.resolve`), so the
formatter and the language server can work on programs that do not resolve.
"""

from __future__ import annotations

from dataclasses import field, fields
from typing import Any

from knitc.records import record
from knitc.source import UNKNOWN_SPAN, Span


@record(frozen=True, slots=True)
class Node:
    """Every node is a frozen record (`knitc.records`): compared, hashed and shown by its
    fields, its span and other `compare=False` fields left out of equality, `repr=False`
    ones out of its repr."""

    span: Span = field(default=UNKNOWN_SPAN, compare=False, repr=False, kw_only=True)

    def children(self) -> list[Node]:
        out: list[Node] = []
        for f in fields(self):
            if f.name == "span":
                continue
            _collect(getattr(self, f.name), out)
        return out

    def walk(self):
        """Pre-order traversal of this subtree."""
        stack: list[Node] = [self]
        while stack:
            n = stack.pop()
            yield n
            stack.extend(reversed(n.children()))


def _collect(value: Any, out: list[Node]) -> None:
    if isinstance(value, Node):
        out.append(value)
    elif isinstance(value, tuple):
        for v in value:
            _collect(v, out)


@record(frozen=True, slots=True)
class Ident(Node):
    """A name written by the user, kept with its own span for precise diagnostics."""

    name: str


# ---- expressions ---------------------------------------------------------------------------


@record(frozen=True, slots=True)
class Number(Node):
    """`12`, `0.5`, `1e3`: a number literal (an int when written as digits only)."""

    value: int | float


@record(frozen=True, slots=True)
class String(Node):
    """`"red"`: a string literal, its escapes resolved."""

    value: str


@record(frozen=True, slots=True)
class Bool(Node):
    """`true`, `false`."""

    value: bool


@record(frozen=True, slots=True)
class GridCell(Node):
    """One cell of a drawn grid: an instruction mnemonic as written."""

    text: str


@record(frozen=True, slots=True)
class Grid(Node):
    """A drawn grid: rows of instruction mnemonics, as written (top row first)."""

    rows: tuple[tuple[GridCell, ...], ...]


@record(frozen=True, slots=True)
class ParamRef(Node):
    """`#name`: a design parameter."""

    name: str


@record(frozen=True, slots=True)
class PropRef(Node):
    """`@prop` (the enclosing node's property) or `@node.prop`."""

    node: str | None
    prop: str


@record(frozen=True, slots=True)
class Name(Node):
    """A bare name: an enum word (`half`), a local, a builtin or a definition."""

    id: str


@record(frozen=True, slots=True)
class ListExpr(Node):
    """`[a, b, ...]`: a list value."""

    items: tuple[Expr, ...]


@record(frozen=True, slots=True)
class ProfilePoint(Node):
    """`t: value`, one point of a profile."""

    t: Expr
    value: Expr


@record(frozen=True, slots=True)
class Profile(Node):
    """`[t0: v0, t1: v1, ...]`: a piecewise-linear function over t in [0, 1]."""

    points: tuple[ProfilePoint, ...]


@record(frozen=True, slots=True)
class TupleExpr(Node):
    """`(a, b, ...)`: a tuple value (the sides of a map statement)."""

    items: tuple[Expr, ...]


@record(frozen=True, slots=True)
class Unary(Node):
    """`-x`, `not x`."""

    op: str  # "-" or "not"
    operand: Expr


@record(frozen=True, slots=True)
class Binary(Node):
    """`a op b` for the arithmetic, comparison and boolean operators."""

    op: str  # + - * / % ^ == != < <= > >= and or
    left: Expr
    right: Expr


@record(frozen=True, slots=True)
class Range(Node):
    """`start:stop` or `start:step:stop` (inclusive, as in thesis Table 5.1)."""

    start: Expr
    stop: Expr
    step: Expr | None = None


@record(frozen=True, slots=True)
class KwArg(Node):
    """`name: value` in a call's arguments."""

    name: Ident
    value: Expr


@record(frozen=True, slots=True)
class Call(Node):
    """`f(args)`: a call of a stdlib function, a query or a user pattern or shaper."""

    func: Expr
    args: tuple[Arg, ...]


@record(frozen=True, slots=True)
class Attr(Node):
    """`obj.name`: a field of a value (`cuff.top`, `s.course`)."""

    obj: Expr
    name: Ident


@record(frozen=True, slots=True)
class Index(Node):
    """`obj[index]`."""

    obj: Expr
    index: Expr


Expr = (
    Number
    | String
    | Bool
    | Grid
    | ParamRef
    | PropRef
    | Name
    | ListExpr
    | Profile
    | TupleExpr
    | Unary
    | Binary
    | Call
    | Attr
    | Index
)
Arg = Expr | Range | KwArg


# ---- declarations ----------------------------------------------------------------------------


@record(frozen=True, slots=True)
class Prop(Node):
    """`name: value` inside a node, machine, interface or action block."""

    name: Ident
    value: Expr


@record(frozen=True, slots=True)
class Import(Node):
    """`import std.stitches (rib)` (module) or `import "lace.knit"` (file)."""

    module: tuple[str, ...] | None
    path: str | None
    names: tuple[Ident, ...] | None = None


@record(frozen=True, slots=True)
class ParamDecl(Node):
    """`param name = value`: a design parameter, which `-D name=value` overrides."""

    name: Ident
    value: Expr


@record(frozen=True, slots=True)
class MachineDecl(Node):
    """`machine { ... }`: the machine the design is knitted on."""

    props: tuple[Prop, ...]


@record(frozen=True, slots=True)
class YarnDecl(Node):
    """`yarn red { carrier: 5 }`: a yarn the pattern layers can knit with (`knit red`)."""

    name: Ident
    props: tuple[Prop, ...]


@record(frozen=True, slots=True)
class NodeDecl(Node):
    """A shape primitive: `sheet`, `tube`, `joint` or `split`."""

    kind: str
    name: Ident
    props: tuple[Prop, ...]


@record(frozen=True, slots=True)
class ItfRef(Node):
    """`node.bottom`, `node.top`, `node.base`, `node.branches[i]`."""

    node: Ident
    path: Ident
    index: Expr | None = None


@record(frozen=True, slots=True)
class ItfStmt(Node):
    """Interface state and casting: `a.bottom closed(zigzag) { cast_on: tuck }`."""

    itf: ItfRef
    state: str | None  # "open", "closed" or None (only the block)
    closing: Ident | None
    props: tuple[Prop, ...] | None


@record(frozen=True, slots=True)
class Connect(Node):
    """`a.top -> b.bottom`: two interfaces joined into one course of fabric."""

    a: ItfRef
    b: ItfRef


@record(frozen=True, slots=True)
class Start(Node):
    """`start node.itf`: where the yarn starts (the cast-on interface)."""

    itf: ItfRef


@record(frozen=True, slots=True)
class ParamDef(Node):
    """A formal parameter of a pattern or shaper definition, with optional default."""

    name: Ident
    default: Expr | None = None


# ---- pattern layers ------------------------------------------------------------------------


@record(frozen=True, slots=True)
class SetStmt(Node):
    """`set P where q`: write a pattern instruction on the selected stitches."""

    instr: str
    where: Expr | None = None


@record(frozen=True, slots=True)
class UseStmt(Node):
    """`use purl_flat where q`: attach a stitch action to the selected stitches."""

    action: Ident
    where: Expr | None = None


@record(frozen=True, slots=True)
class ApplyStmt(Node):
    """`apply rib(2, 2) where q`: run a pattern definition on the selected stitches."""

    pattern: Ident
    args: tuple[Arg, ...]
    where: Expr | None = None


@record(frozen=True, slots=True)
class GridStmt(Node):
    """`draw` (singular, centred), `stretch` (scalable) or `tile` (tileable) a grid."""

    mode: str
    grid: Expr
    where: Expr | None = None


@record(frozen=True, slots=True)
class KnitStmt(Node):
    """`knit red where q`: the selected stitches are knitted with the yarn `red`."""

    yarn: Ident
    where: Expr | None = None


@record(frozen=True, slots=True)
class BackingStmt(Node):
    """`backing birdseye where q`: the selected stitches' courses of several yarns are
    jacquard, their yarns knitting a backing on the other bed (`stitch_graph.BACKINGS`)."""

    kind: Ident
    where: Expr | None = None


@record(frozen=True, slots=True)
class IntarsiaStmt(Node):
    """`intarsia where q`: the selected stitches' courses are intarsia: each region of one
    yarn is knitted by a carrier of its own, joined to its neighbours by tucks."""

    where: Expr | None = None


@record(frozen=True, slots=True)
class Let(Node):
    """`let name = value`: a local name."""

    name: Ident
    value: Expr


LayerStmt = SetStmt | UseStmt | ApplyStmt | GridStmt | KnitStmt | BackingStmt | IntarsiaStmt | Let


@record(frozen=True, slots=True)
class PatternLayer(Node):
    """`pattern cuff { ... }`; the target `before`/`after` means the global layers."""

    target: Ident
    body: tuple[LayerStmt, ...]


@record(frozen=True, slots=True)
class PatternDef(Node):
    """`pattern name(params) { ... }`: a reusable pattern, applied with `apply`."""

    name: Ident
    params: tuple[ParamDef, ...]
    body: tuple[LayerStmt, ...]


# ---- statements (shaper programs and action steps) ------------------------------------------


@record(frozen=True, slots=True)
class Block(Node):
    """`{ stmts }`: the body of a shaper, an action step or a branch."""

    stmts: tuple[Stmt, ...]


@record(frozen=True, slots=True)
class Assign(Node):
    """`name = value`: rebinds a local name."""

    name: Ident
    value: Expr


@record(frozen=True, slots=True)
class If(Node):
    """`if cond { ... } else ...`."""

    cond: Expr
    then: Block
    orelse: Block | If | None = None


@record(frozen=True, slots=True)
class For(Node):
    """`for var in iter { ... }`."""

    var: Ident
    iter: Expr
    body: Block


@record(frozen=True, slots=True)
class MapStmt(Node):
    """`i -> j` (map), `i -> (j1, j2)` (increase), `(i1, i2) -> j` (decrease)."""

    src: Expr
    dst: Expr


@record(frozen=True, slots=True)
class ExprStmt(Node):
    """An expression on a line of its own in a shaper or action body, evaluated for what
    it does (a call)."""

    expr: Expr


Stmt = Let | Assign | If | For | MapStmt | ExprStmt


@record(frozen=True, slots=True)
class ActionStep(Node):
    """`pre { ... }`, `main { ... }` or `post { ... }`: one step of a user action."""

    step: str  # pre, main, post
    body: Block


@record(frozen=True, slots=True)
class ActionDef(Node):
    """A user stitch action (thesis ch. 6.9.1): properties and pre/main/post steps."""

    name: Ident
    items: tuple[Prop | ActionStep, ...]


@record(frozen=True, slots=True)
class ShaperDef(Node):
    """A user shaper program mapping a course of M stitches onto one of N (ch. 5.4.1)."""

    name: Ident
    params: tuple[ParamDef, ...]
    body: Block


Item = (
    Import
    | ParamDecl
    | MachineDecl
    | YarnDecl
    | NodeDecl
    | ItfStmt
    | Connect
    | Start
    | PatternLayer
    | PatternDef
    | ActionDef
    | ShaperDef
)


@record(frozen=True, slots=True)
class Comment(Node):
    """`// text`: kept on the module for the formatter, which writes it back."""

    text: str


@record(frozen=True, slots=True)
class Module(Node):
    """One source file: its items in order, and its comments (kept for the formatter)."""

    items: tuple[Item, ...]
    comments: tuple[Comment, ...] = field(default=(), compare=False, repr=False)


# ---- stable JSON (`knitc --emit ast`) ----------------------------------------------------------


def to_json(value: Any) -> Any:
    """A deterministic, JSON-ready view of an AST (or any part of it)."""
    if isinstance(value, Node):
        out: dict[str, Any] = {"node": type(value).__name__}
        for f in fields(value):
            if f.name in ("span", "comments"):
                continue
            out[f.name] = to_json(getattr(value, f.name))
        out["span"] = value.span.to_json()
        return out
    if isinstance(value, tuple):
        return [to_json(v) for v in value]
    return value
