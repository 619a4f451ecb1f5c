"""The canonical source formatter (`knitc fmt`).

`format_module` prints an AST back as source. The only contract that matters is
`parse(format_module(m)) == m` (spans aside): the formatter changes layout, never meaning.
Everything else is a style chosen so that diffs of `.knit` files stay small and reviews are
about the design, not the whitespace:

* One canonical layout, independent of how the input was laid out, except for what the
  author deliberately expressed: item order, single blank lines (grouping is meaningful;
  runs of blank lines are not, so they collapse to one) and comments. Blank lines are never
  kept at the start or end of a block, where they carry no grouping.
* Property blocks (nodes, `machine`, interfaces) are short records: they stay on one line,
  `tube cuff { length: 30, width: @palm.width }`, as long as that line fits in 100 columns
  and the block holds no comment; otherwise one property per line. Commas are written only
  in the one-line form, where they are needed for reading; the grammar does not need them.
* Layer blocks, action bodies and statement blocks are programs: one statement per line
  always, so adding a statement is a one-line diff. Only an empty block is `{}`.
* Expressions get the fewest parentheses the grammar's precedence allows (or < and < not <
  comparison < + - < * / % < unary - < ^ < postfix), so the printed text reads like what
  the author would write, and spaces around binary operators, `name = value` for keyword
  arguments and defaults. Ranges `a:b` / `a:s:b` and profile points `t: v` differ on
  purpose: a range is one argument, a profile is a list of pairs. Two cases need
  parentheses the precedence table does not ask for: `-(-a)` (a doubled minus reads like a
  typo) and `(@a).b` (`@a.b` is the property reference `b` of node `a`).
* Numbers print so they re-parse to the same value (ints as ints, floats with `repr`,
  which the NUMBER terminal accepts, exponent included). Strings are re-escaped with the
  grammar's escapes only.
* Grids are drawings, so they are printed as drawings: `\"\"\"` after the keyword, each row
  on its own line one level deeper than the statement, cells left-aligned in columns padded
  to the widest cell (so the chart lines up however it was typed), empty rows kept, and the
  closing `\"\"\"` on its own line at the statement's indentation.
* Comments are never lost or duplicated. Each comment belongs to the item, property or
  statement after it (a leading comment, printed on its own lines at the same indentation)
  or, when it starts on the line where the previous one ends, to that previous one (a
  trailing comment, two spaces after it). Comment lines right below a trailing comment and
  indented past the start of its item continue it, so they stay aligned under it. Comments
  at the end of a block stay at its end. A comment written where it has no line of its own
  (inside an expression, between a keyword and its block, before an `else`) moves in front
  of the enclosing item, property or statement: the nearest place where it still reads as
  a comment on that code, and one that the next run of the formatter leaves alone.
* Output is a fixed point: formatting formatted text changes nothing, so `knitc fmt
  --check` can be a CI gate.

`format_expr` and `format_layer_stmt` print a single expression or statement in the same
style, for diagnostics and IR dumps.
"""

from __future__ import annotations

import math
from collections import defaultdict
from collections.abc import Callable, Sequence

from knitc.frontend import ast

__all__ = ["INDENT", "WIDTH", "format_expr", "format_layer_stmt", "format_module"]

INDENT = "  "
WIDTH = 100

# ---- expressions -----------------------------------------------------------------------------

# Precedence levels, loosest first, mirroring the expression rules of knit.lark.
_OR, _AND, _NOT, _CMP, _SUM, _PROD, _UNARY, _POW, _POSTFIX, _ATOM = range(1, 11)

# op -> (level of the operator, minimum level of its left and of its right operand). The
# grammar's rules are left-recursive (left-associative) except `^`, whose right operand is a
# `unary` (right-associative, and `a ^ -b` needs no parentheses), and comparisons, which do
# not chain at all: `a < b < c` is a syntax error, so both sides must be sums.
_BINARY: dict[str, tuple[int, int, int]] = {
    "or": (_OR, _OR, _AND),
    "and": (_AND, _AND, _NOT),
    "+": (_SUM, _SUM, _PROD),
    "-": (_SUM, _SUM, _PROD),
    "*": (_PROD, _PROD, _UNARY),
    "/": (_PROD, _PROD, _UNARY),
    "%": (_PROD, _PROD, _UNARY),
    "^": (_POW, _POSTFIX, _UNARY),
    **{op: (_CMP, _SUM, _SUM) for op in ("==", "!=", "<", "<=", ">", ">=")},
}

_ESCAPES = {"\\": "\\\\", '"': '\\"', "\n": "\\n", "\t": "\\t"}


def _level(e: ast.Node) -> int:
    if isinstance(e, ast.Binary):
        return _BINARY[e.op][0]
    if isinstance(e, ast.Unary):
        return _NOT if e.op == "not" else _UNARY
    if isinstance(e, ast.Call | ast.Attr | ast.Index):
        return _POSTFIX
    if isinstance(e, ast.Number) and e.value < 0:
        return _UNARY  # not produced by the parser, but printed as `-1`
    return _ATOM


def _number(value: int | float) -> str:
    if isinstance(value, bool):
        raise ValueError(f"not a number literal: {value!r}")
    if isinstance(value, int):
        return str(value)
    if not math.isfinite(value):
        raise ValueError(f"number literal has no source form: {value!r}")
    if value == 0:
        value = 0.0  # -0.0 would print as a negation
    return repr(value)


def _string(value: str) -> str:
    return '"' + "".join(_ESCAPES.get(ch, ch) for ch in value) + '"'


def _grid(grid: ast.Grid, indent: str) -> str:
    rows = grid.rows
    ncols = max((len(r) for r in rows), default=0)
    widths = [max(len(r[i].text) for r in rows if len(r) > i) for i in range(ncols)]
    lines = ['"""']
    for row in rows:
        if not row:
            lines.append("")
            continue
        cells = [c.text.ljust(widths[i]) for i, c in enumerate(row[:-1])] + [row[-1].text]
        lines.append(indent + INDENT + " ".join(cells))
    lines.append(indent + '"""')
    return "\n".join(lines)


class _Expr:
    """Expression printer; `indent` is that of the enclosing line (for grids)."""

    def __init__(self, indent: str):
        self.indent = indent

    def at(self, e: ast.Node, level: int) -> str:
        text = self.expr(e)
        return f"({text})" if _level(e) < level else text

    def expr(self, e: ast.Node) -> str:
        match e:
            case ast.Number(value=value):
                return _number(value)
            case ast.String(value=value):
                return _string(value)
            case ast.Bool(value=value):
                return "true" if value else "false"
            case ast.Grid():
                return _grid(e, self.indent)
            case ast.ParamRef(name=name):
                return f"#{name}"
            case ast.PropRef(node=node, prop=prop):
                return f"@{node}.{prop}" if node is not None else f"@{prop}"
            case ast.Name(id=name):
                return name
            case ast.ListExpr(items=items):
                return "[" + ", ".join(self.expr(i) for i in items) + "]"
            case ast.Profile(points=points):
                return (
                    "[" + ", ".join(f"{self.expr(p.t)}: {self.expr(p.value)}" for p in points) + "]"
                )
            case ast.TupleExpr(items=items):
                inner = ", ".join(self.expr(i) for i in items)
                return f"({inner},)" if len(items) == 1 else f"({inner})"
            case ast.Unary(op="not", operand=operand):
                return "not " + self.at(operand, _NOT)
            case ast.Unary(op=op, operand=operand):
                text = self.at(operand, _UNARY)
                if text.startswith("-"):
                    text = f"({text})"
                return op + text
            case ast.Binary(op=op, left=left, right=right):
                _, lmin, rmin = _BINARY[op]
                return f"{self.at(left, lmin)} {op} {self.at(right, rmin)}"
            case ast.Call(func=func, args=args):
                return f"{self.at(func, _POSTFIX)}({self.args(args)})"
            case ast.Attr(obj=obj, name=name):
                text = self.at(obj, _POSTFIX)
                if isinstance(obj, ast.PropRef) and obj.node is None:
                    text = f"({text})"
                return f"{text}.{name.name}"
            case ast.Index(obj=obj, index=index):
                return f"{self.at(obj, _POSTFIX)}[{self.expr(index)}]"
        raise TypeError(f"not an expression: {type(e).__name__}")

    def arg(self, a: ast.Node) -> str:
        if isinstance(a, ast.Range):
            if a.step is None:
                return f"{self.expr(a.start)}:{self.expr(a.stop)}"
            return f"{self.expr(a.start)}:{self.expr(a.step)}:{self.expr(a.stop)}"
        if isinstance(a, ast.KwArg):
            return f"{a.name.name} = {self.expr(a.value)}"
        return self.expr(a)

    def args(self, args: Sequence[ast.Node]) -> str:
        return ", ".join(self.arg(a) for a in args)

    def params(self, params: Sequence[ast.ParamDef]) -> str:
        return ", ".join(
            p.name.name if p.default is None else f"{p.name.name} = {self.expr(p.default)}"
            for p in params
        )


def format_expr(expr: ast.Node, indent: str = "") -> str:
    """One expression (or call argument: range, keyword argument) in canonical form.

    `indent` is the indentation of the line the expression starts on; it only matters for
    grids, whose rows go one level deeper and whose closing quotes go at `indent`.
    """
    return _Expr(indent).arg(expr)


# ---- comment placement --------------------------------------------------------------------

_Body = tuple[int, int, int, Sequence[ast.Node]]  # key, region start, region end, children


def _bodies(node: ast.Node) -> list[_Body]:
    """The line-per-element sequences directly inside `node`, with the source regions in
    which a comment belongs to them. Keys are object ids: equal nodes may occur twice."""
    s = node.span
    match node:
        case ast.NodeDecl() | ast.YarnDecl():
            return [(id(node), node.name.span.end, s.end, node.props)]
        case ast.MachineDecl():
            return [(id(node), s.start, s.end, node.props)]
        case ast.ItfStmt() if node.props is not None:
            head: ast.Node = node.closing if node.closing is not None else node.itf
            return [(id(node), head.span.end, s.end, node.props)]
        case ast.PatternLayer():
            return [(id(node), node.target.span.end, s.end, node.body)]
        case ast.PatternDef():
            head = node.params[-1] if node.params else node.name
            return [(id(node), head.span.end, s.end, node.body)]
        case ast.ActionDef():
            return [(id(node), node.name.span.end, s.end, node.items)]
        case ast.ActionStep() | ast.ShaperDef() | ast.For():
            return [_block_body(node.body)]
        case ast.If():
            out = [_block_body(node.then)]
            if isinstance(node.orelse, ast.Block):
                out.append(_block_body(node.orelse))
            elif isinstance(node.orelse, ast.If):
                out += _bodies(node.orelse)
            return out
    return []


def _block_body(block: ast.Block) -> _Body:
    return (id(block), block.span.start, block.span.end, block.stmts)


class _Comments:
    """Where each comment of a module is printed (see the module docstring)."""

    def __init__(self, module: ast.Module):
        self.leading: dict[int, list[ast.Comment]] = defaultdict(list)
        self.moved: dict[int, list[ast.Comment]] = defaultdict(list)
        self.trailing: dict[int, list[ast.Comment]] = defaultdict(list)
        self.continued: dict[int, list[ast.Comment]] = defaultdict(list)
        self.dangling: dict[int, list[ast.Comment]] = defaultdict(list)
        self.keys_with_comments: set[int] = set()
        comments = sorted(module.comments, key=lambda c: c.span.start)
        self._place(id(module), module.items, comments)

    def _place(self, key: int, children: Sequence[ast.Node], comments: list[ast.Comment]) -> None:
        if not comments:
            return
        self.keys_with_comments.add(key)
        inside: dict[int, list[ast.Comment]] = defaultdict(list)
        i = 0  # children[:i] end at or before the current comment
        for c in comments:
            while i < len(children) and children[i].span.end <= c.span.start:
                i += 1
            if i < len(children) and children[i].span.start <= c.span.start:
                inside[i].append(c)
            elif i > 0 and c.span.line == children[i - 1].span.end_line:
                self.trailing[id(children[i - 1])].append(c)
            elif i > 0 and self._continues(children[i - 1], c):
                self.continued[id(children[i - 1])].append(c)
            elif i < len(children):
                self.leading[id(children[i])].append(c)
            else:
                self.dangling[key].append(c)
        for index, group in inside.items():
            self._place_inside(children[index], group)

    def _continues(self, node: ast.Node, c: ast.Comment) -> bool:
        """Is `c` the next line of the trailing comment of `node`, indented past `node`?"""
        above = self.continued.get(id(node)) or self.trailing.get(id(node)) or []
        return bool(above) and (
            c.span.line == above[-1].span.end_line + 1 and c.span.column > node.span.column
        )

    def _place_inside(self, node: ast.Node, comments: list[ast.Comment]) -> None:
        for key, start, end, children in _bodies(node):
            self._place(key, children, [c for c in comments if start <= c.span.start < end])
            comments = [c for c in comments if not start <= c.span.start < end]
        self.moved[id(node)].extend(comments)


# ---- items and statements ----------------------------------------------------------------

_Render = Callable[[ast.Node, str], list[str]]


class _Printer:
    def __init__(self, module: ast.Module):
        self.module = module
        self.comments = _Comments(module)

    # -- sequences with comments and blank lines
    def seq(
        self, key: int, children: Sequence[ast.Node], indent: str, render: _Render
    ) -> list[str]:
        cm = self.comments
        out: list[str] = []
        prev_last: int | None = None

        def unit(first: int, last: int, lines: list[str]) -> None:
            nonlocal prev_last
            if prev_last is not None and first - prev_last > 1:
                out.append("")
            out.extend(lines)
            prev_last = last if prev_last is None else max(last, prev_last)

        def comment(c: ast.Comment) -> list[str]:
            return [indent + c.text]

        for child in children:
            for c in cm.leading.get(id(child), ()):
                unit(c.span.line, c.span.end_line, comment(c))
            for c in cm.moved.get(id(child), ()):
                unit(child.span.line, child.span.line, comment(c))
            lines = render(child, indent)
            last = child.span.end_line
            trailing = cm.trailing.get(id(child), ())
            if trailing:
                column = len(lines[-1].rsplit("\n", 1)[-1]) + 2
                lines[-1] += "".join("  " + c.text for c in trailing)
                continued = cm.continued.get(id(child), ())
                lines += [" " * column + c.text for c in continued]
                last = max(last, *(c.span.end_line for c in (*trailing, *continued)))
            unit(child.span.line, last, lines)
        for c in cm.dangling.get(key, ()):
            unit(c.span.line, c.span.end_line, comment(c))
        return out

    def braced(
        self, head: str, key: int, children: Sequence[ast.Node], indent: str, render: _Render
    ) -> list[str]:
        """`head {` + one element per line + `}`, or `head {}`."""
        if not children and key not in self.comments.keys_with_comments:
            return [head + " {}"]
        return [head + " {", *self.seq(key, children, indent + INDENT, render), indent + "}"]

    def prop_block(self, head: str, key: int, props: Sequence[ast.Prop], indent: str) -> list[str]:
        if props and key not in self.comments.keys_with_comments:
            line = head + " { " + ", ".join(self.prop(p, indent)[0] for p in props) + " }"
            if "\n" not in line and len(line) <= WIDTH:
                return [line]
        return self.braced(head, key, props, indent, self.prop)

    def prop(self, p: ast.Node, indent: str) -> list[str]:
        assert isinstance(p, ast.Prop)
        return [f"{indent}{p.name.name}: {format_expr(p.value, indent)}"]

    # -- top level
    def format(self) -> str:
        lines = self.seq(id(self.module), self.module.items, "", self.item)
        return "\n".join(lines) + "\n" if lines else ""

    def item(self, node: ast.Node, indent: str) -> list[str]:
        ex = _Expr(indent)
        match node:
            case ast.Import():
                target = (
                    ".".join(node.module) if node.module is not None else _string(node.path or "")
                )
                names = " (" + ", ".join(n.name for n in node.names) + ")" if node.names else ""
                return [f"{indent}import {target}{names}"]
            case ast.ParamDecl():
                return [f"{indent}param {node.name.name} = {ex.expr(node.value)}"]
            case ast.MachineDecl():
                return self.prop_block(f"{indent}machine", id(node), node.props, indent)
            case ast.YarnDecl():
                return self.prop_block(
                    f"{indent}yarn {node.name.name}", id(node), node.props, indent
                )
            case ast.NodeDecl():
                return self.prop_block(
                    f"{indent}{node.kind} {node.name.name}", id(node), node.props, indent
                )
            case ast.ItfStmt():
                head = indent + self.itf(node.itf, ex)
                if node.state is not None:
                    head += f" {node.state}"
                    if node.closing is not None:
                        head += f"({node.closing.name})"
                if node.props is None:
                    return [head]
                return self.prop_block(head, id(node), node.props, indent)
            case ast.Connect():
                return [f"{indent}{self.itf(node.a, ex)} -> {self.itf(node.b, ex)}"]
            case ast.Start():
                return [f"{indent}start {self.itf(node.itf, ex)}"]
            case ast.PatternLayer():
                return self.braced(
                    f"{indent}pattern {node.target.name}", id(node), node.body, indent, self.stmt
                )
            case ast.PatternDef():
                head = f"{indent}pattern {node.name.name}({ex.params(node.params)})"
                return self.braced(head, id(node), node.body, indent, self.stmt)
            case ast.ActionDef():
                return self.braced(
                    f"{indent}action {node.name.name}",
                    id(node),
                    node.items,
                    indent,
                    self.action_item,
                )
            case ast.ShaperDef():
                head = f"{indent}shaper {node.name.name}({ex.params(node.params)})"
                return self.block(head, node.body, indent)
        raise TypeError(f"not a top-level item: {type(node).__name__}")

    @staticmethod
    def itf(ref: ast.ItfRef, ex: _Expr) -> str:
        text = f"{ref.node.name}.{ref.path.name}"
        return text if ref.index is None else f"{text}[{ex.expr(ref.index)}]"

    def action_item(self, node: ast.Node, indent: str) -> list[str]:
        if isinstance(node, ast.ActionStep):
            return self.block(indent + node.step, node.body, indent)
        return self.prop(node, indent)

    def block(self, head: str, block: ast.Block, indent: str) -> list[str]:
        return self.braced(head, id(block), block.stmts, indent, self.stmt)

    # -- layer statements and program statements
    def stmt(self, node: ast.Node, indent: str) -> list[str]:
        ex = _Expr(indent)
        match node:
            case ast.SetStmt():
                return [f"{indent}set {node.instr}{self.where(node.where, ex)}"]
            case ast.UseStmt():
                return [f"{indent}use {node.action.name}{self.where(node.where, ex)}"]
            case ast.KnitStmt():
                return [f"{indent}knit {node.yarn.name}{self.where(node.where, ex)}"]
            case ast.BackingStmt():
                return [f"{indent}backing {node.kind.name}{self.where(node.where, ex)}"]
            case ast.IntarsiaStmt():
                return [f"{indent}intarsia{self.where(node.where, ex)}"]
            case ast.ApplyStmt():
                return [
                    f"{indent}apply {node.pattern.name}({ex.args(node.args)})"
                    f"{self.where(node.where, ex)}"
                ]
            case ast.GridStmt():
                return [f"{indent}{node.mode} {ex.expr(node.grid)}{self.where(node.where, ex)}"]
            case ast.Let():
                return [f"{indent}let {node.name.name} = {ex.expr(node.value)}"]
            case ast.Assign():
                return [f"{indent}{node.name.name} = {ex.expr(node.value)}"]
            case ast.If():
                return self.if_(node, indent, ex)
            case ast.For():
                head = f"{indent}for {node.var.name} in {ex.expr(node.iter)}"
                return self.block(head, node.body, indent)
            case ast.MapStmt():
                return [f"{indent}{ex.expr(node.src)} -> {ex.expr(node.dst)}"]
            case ast.ExprStmt():
                return [indent + ex.expr(node.expr)]
        raise TypeError(f"not a statement: {type(node).__name__}")

    @staticmethod
    def where(where: ast.Node | None, ex: _Expr) -> str:
        return "" if where is None else f" where {ex.expr(where)}"

    def if_(self, node: ast.If, indent: str, ex: _Expr) -> list[str]:
        lines = self.block(f"{indent}if {ex.expr(node.cond)}", node.then, indent)
        if isinstance(node.orelse, ast.If):
            rest = self.if_(node.orelse, indent, ex)
            rest[0] = rest[0][len(indent) :]
        elif isinstance(node.orelse, ast.Block):
            rest = self.block("", node.orelse, indent)
            rest[0] = rest[0].lstrip()
        else:
            return lines
        lines[-1] += " else " + rest[0]
        return lines + rest[1:]


def format_module(module: ast.Module) -> str:
    """The canonical source text of `module`, comments included; ends with one newline.

    Any tree the parser builds round-trips. A hand-built tree can have no source form:
    newlines do not end statements, so `x = a` followed by the statement `-b` prints as text
    that parses as `x = a - b` (tests/strategies.py avoids generating such trees).
    """
    return _Printer(module).format()


def format_layer_stmt(stmt: ast.Node, indent: str = "") -> str:
    """One statement of a pattern layer (or of a shaper or action) in canonical form, at
    `indent`, without comments; only grids and nested blocks make it span lines."""
    return "\n".join(_Printer(ast.Module(())).stmt(stmt, indent))
