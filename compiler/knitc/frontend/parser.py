"""Source text → AST, with diagnostics instead of exceptions.

The grammar is `grammars/knit.lark` (shipped as package data), run by Lark's LALR parser.
Two details make it pleasant to write in:

* Keywords are contextual. Words such as `shaper` or `start` are keywords only where the
  parser can accept them; elsewhere (`shaper: left` in a node) they are plain names. LALR
  lookahead sets are merged across contexts, so the contextual lexer alone would still
  reserve them; `_ContextualKeywords` asks the parse table whether the keyword can really be
  shifted here and otherwise re-types it as a NAME.
* Syntax errors are reported per top-level statement. When the whole file does not parse,
  it is cut into statements at lines that start a new top-level item (one scan), and each
  statement is parsed on its own text, so every independent mistake is reported once and
  none cascades. Error recovery stays linear in the size of the file: the statements
  together are the file once, and the error messages look only at their own statement.
"""

from __future__ import annotations

import re
from functools import lru_cache

from lark import Lark, Token, Transformer, Tree, v_args
from lark.exceptions import UnexpectedCharacters, UnexpectedEOF, UnexpectedInput, UnexpectedToken
from lark.lexer import Lexer
from lark.parsers.lalr_analysis import Shift

from knitc.diagnostics import Diagnostics
from knitc.frontend import ast, tables
from knitc.frontend.scanners import share_root_scanner
from knitc.lang import arith
from knitc.records import record
from knitc.resources import grammar_text
from knitc.source import SourceFile, Span

# Word-like terminals that must fall back to NAME where the parser cannot take them.
_KEYWORD_TYPES = frozenset(
    {
        "KW_SHAPER",
        "KW_START",
        "KW_IMPORT",
        "KW_PARAM",
        "KW_MACHINE",
        "KW_YARN",
        "KW_PATTERN",
        "KW_ACTION",
        "KW_OPEN",
        "KW_CLOSED",
        "KW_SET",
        "KW_USE",
        "KW_APPLY",
        "KW_WHERE",
        "KW_LET",
        "KW_KNIT",
        "KW_BACKING",
        "KW_INTARSIA",
        "NODE_KIND",
        "GRID_MODE",
        "STEP",
        "INSTR",
    }
)

# Words that open a top-level item: a line starting with one of them at brace depth 0
# begins a new statement for error recovery.
_TOP_LEVEL_WORDS = (
    "import",
    "param",
    "machine",
    "yarn",
    "sheet",
    "tube",
    "joint",
    "split",
    "pattern",
    "action",
    "shaper",
    "start",
)


def _can_shift(parse_table, state_stack: list[int], token_type: str) -> bool:
    """Simulate the LALR automaton on a copy of the state stack: is `token_type` shifted?"""
    stack = list(state_stack)
    states = parse_table.states
    while True:
        action = states[stack[-1]].get(token_type)
        if action is None:
            return False
        kind, arg = action
        if kind is Shift:
            return True
        size = len(arg.expansion)
        if size:
            del stack[-size:]
        _kind, goto = states[stack[-1]][arg.origin.name]
        stack.append(goto)


def _dot_next(text: str, pos: int) -> bool:
    """Is the next token after `pos` (past blanks and comments) a `.`, not a number `.5`?

    No keyword is ever followed by one, so a keyword-like word that is must be a name: the
    node in `start.top -> cuff.bottom`.
    """
    n = len(text)
    while pos < n:
        if text[pos].isspace():
            pos += 1
        elif text.startswith("//", pos):
            newline = text.find("\n", pos)
            pos = n if newline < 0 else newline
        elif text.startswith("/*", pos):
            close = text.find("*/", pos + 2)
            if close < 0:
                return False
            pos = close + 2
        else:
            break
    return text.startswith(".", pos) and not text[pos + 1 : pos + 2].isdigit()


class _ContextualKeywords:
    """Wraps Lark's contextual lexer: a keyword the parser cannot shift becomes a NAME."""

    def __init__(self, inner: Lexer):
        self.inner = inner

    def lex(self, lexer_state, parser_state):
        table = parser_state.parse_conf.parse_table
        for tok in self.inner.lex(lexer_state, parser_state):
            assert tok.end_pos is not None  # the lexer sets every token's positions
            if tok.type in _KEYWORD_TYPES and (
                not _can_shift(table, parser_state.state_stack, tok.type)
                or _dot_next(_text(lexer_state), tok.end_pos)
            ):
                if _can_shift(table, parser_state.state_stack, "NAME"):
                    tok = Token.new_borrow_pos("NAME", tok.value, tok)
            yield tok

    def __getattr__(self, name):
        return getattr(self.inner, name)


def _text(lexer_state) -> str:
    text = lexer_state.text
    return getattr(text, "text", text)  # a TextSlice since Lark 1.3, a str before


_comment_sink: list[list[Token]] = []


def _on_comment(tok: Token) -> Token:
    if _comment_sink:
        _comment_sink[-1].append(tok)
    return tok


@lru_cache(maxsize=1)
def _lark() -> Lark:
    options = {
        "parser": "lalr",
        "lexer": "contextual",
        "propagate_positions": True,
        "maybe_placeholders": True,
    }
    parser = tables.load_lark(grammar_text(), options, {"COMMENT": _on_comment})
    share_root_scanner(parser.parser.lexer)
    parser.parser.lexer = _ContextualKeywords(parser.parser.lexer)
    return parser


# ---- tree → AST ---------------------------------------------------------------------------

_ESCAPES = {"n": "\n", "t": "\t", '"': '"', "\\": "\\"}


def _unescape(body: str) -> str:
    return re.sub(r"\\(.)", lambda m: _ESCAPES.get(m.group(1), m.group(1)), body)


class _SyntaxProblem(Exception):
    """A construct the grammar accepts but the language does not (e.g. mixed profile lists)."""

    def __init__(self, code: str, message: str, span: Span, hint: str | None = None):
        super().__init__(message)
        self.code, self.message, self.span, self.hint = code, message, span, hint


def _binary(op: str):
    def build(self, meta, ch):
        return ast.Binary(op, ch[0], ch[1], span=self._span(meta))

    return build


@v_args(meta=True)
class _ToAst(Transformer):
    def __init__(self, source: SourceFile):
        super().__init__()
        self.source = source

    # -- spans
    def _span(self, meta) -> Span:
        if getattr(meta, "empty", True):
            return self.source.span(0, 0)
        return self.source.span(meta.start_pos, meta.end_pos)

    def _tok(self, tok: Token) -> Span:
        assert tok.start_pos is not None and tok.end_pos is not None
        return self.source.span(tok.start_pos, tok.end_pos)

    def _ident(self, tok: Token) -> ast.Ident:
        return ast.Ident(str(tok), span=self._tok(tok))

    # -- top level
    def start(self, meta, items):
        return ast.Module(tuple(items), span=self.source.span(0, len(self.source.text)))

    def import_stmt(self, meta, ch):
        _kw, target, names = ch
        if isinstance(target, Token):
            return ast.Import(None, _unescape(target[1:-1]), names, span=self._span(meta))
        return ast.Import(target, None, names, span=self._span(meta))

    def module_path(self, meta, ch):
        return tuple(str(t) for t in ch)

    def import_names(self, meta, ch):
        return tuple(self._ident(t) for t in ch)

    def param_decl(self, meta, ch):
        _kw, name, value = ch
        return ast.ParamDecl(self._ident(name), value, span=self._span(meta))

    def machine_decl(self, meta, ch):
        return ast.MachineDecl(ch[1], span=self._span(meta))

    def yarn_decl(self, meta, ch):
        _kw, name, props = ch
        return ast.YarnDecl(self._ident(name), props, span=self._span(meta))

    def node_decl(self, meta, ch):
        kind, name, props = ch
        return ast.NodeDecl(str(kind), self._ident(name), props, span=self._span(meta))

    def prop_block(self, meta, ch):
        return tuple(ch)

    def prop(self, meta, ch):
        name, value = ch
        return ast.Prop(self._ident(name), value, span=self._span(meta))

    def itf_ref(self, meta, ch):
        node, path, index = ch
        return ast.ItfRef(self._ident(node), self._ident(path), index, span=self._span(meta))

    def itf_open(self, meta, ch):
        return ("open", None)

    def itf_closed(self, meta, ch):
        mode = ch[1] if len(ch) > 1 else None
        return ("closed", self._ident(mode) if mode is not None else None)

    def itf_stmt(self, meta, ch):
        if len(ch) == 3:
            itf, (state, closing), props = ch
        elif isinstance(ch[1], tuple) and ch[1] and isinstance(ch[1][0], str):
            itf, (state, closing) = ch
            props = None
        else:
            itf, props = ch
            state = closing = None
        return ast.ItfStmt(itf, state, closing, props, span=self._span(meta))

    def connect_stmt(self, meta, ch):
        return ast.Connect(ch[0], ch[1], span=self._span(meta))

    def start_stmt(self, meta, ch):
        return ast.Start(ch[1], span=self._span(meta))

    # -- patterns
    def pattern_layer(self, meta, ch):
        _kw, name, body = ch
        return ast.PatternLayer(self._ident(name), body, span=self._span(meta))

    def pattern_def(self, meta, ch):
        _kw, name, params, body = ch
        return ast.PatternDef(self._ident(name), params or (), body, span=self._span(meta))

    def params(self, meta, ch):
        return tuple(ch)

    def param(self, meta, ch):
        name, default = ch
        return ast.ParamDef(self._ident(name), default, span=self._span(meta))

    def layer_block(self, meta, ch):
        return tuple(ch)

    def where(self, meta, ch):
        return ch[1]

    def set_stmt(self, meta, ch):
        _kw, instr, where = ch
        return ast.SetStmt(str(instr), where, span=self._span(meta))

    def use_stmt(self, meta, ch):
        _kw, name, where = ch
        return ast.UseStmt(self._ident(name), where, span=self._span(meta))

    def apply_stmt(self, meta, ch):
        _kw, name, args, where = ch
        return ast.ApplyStmt(self._ident(name), args or (), where, span=self._span(meta))

    def grid_stmt(self, meta, ch):
        mode, grid, where = ch
        return ast.GridStmt(str(mode), grid, where, span=self._span(meta))

    def knit_stmt(self, meta, ch):
        _kw, name, where = ch
        return ast.KnitStmt(self._ident(name), where, span=self._span(meta))

    def intarsia_stmt(self, meta, ch):
        _kw, where = ch
        return ast.IntarsiaStmt(where, span=self._span(meta))

    def backing_stmt(self, meta, ch):
        _kw, name, where = ch
        return ast.BackingStmt(self._ident(name), where, span=self._span(meta))

    def let_stmt(self, meta, ch):
        _kw, name, value = ch
        return ast.Let(self._ident(name), value, span=self._span(meta))

    # -- actions and shapers
    def action_def(self, meta, ch):
        _kw, name, *items = ch
        return ast.ActionDef(self._ident(name), tuple(items), span=self._span(meta))

    def action_step(self, meta, ch):
        step, body = ch
        return ast.ActionStep(str(step), body, span=self._span(meta))

    def shaper_def(self, meta, ch):
        _kw, name, params, body = ch
        return ast.ShaperDef(self._ident(name), params or (), body, span=self._span(meta))

    def block(self, meta, ch):
        return ast.Block(tuple(ch), span=self._span(meta))

    def assign_stmt(self, meta, ch):
        name, value = ch
        return ast.Assign(self._ident(name), value, span=self._span(meta))

    def if_stmt(self, meta, ch):
        cond, then, *rest = ch
        orelse = rest[0] if rest else None
        return ast.If(cond, then, orelse, span=self._span(meta))

    def for_stmt(self, meta, ch):
        var, it, body = ch
        return ast.For(self._ident(var), it, body, span=self._span(meta))

    def map_stmt(self, meta, ch):
        return ast.MapStmt(ch[0], ch[1], span=self._span(meta))

    def expr_stmt(self, meta, ch):
        return ast.ExprStmt(ch[0], span=self._span(meta))

    # -- expressions
    def or_(self, meta, ch):
        return ast.Binary("or", ch[0], ch[1], span=self._span(meta))

    def and_(self, meta, ch):
        return ast.Binary("and", ch[0], ch[1], span=self._span(meta))

    def not_(self, meta, ch):
        return ast.Unary("not", ch[0], span=self._span(meta))

    def compare(self, meta, ch):
        return ast.Binary(str(ch[1]), ch[0], ch[2], span=self._span(meta))

    add, sub, mul, div, mod = _binary("+"), _binary("-"), _binary("*"), _binary("/"), _binary("%")

    def neg(self, meta, ch):
        return ast.Unary("-", ch[0], span=self._span(meta))

    def pow(self, meta, ch):
        return ast.Binary("^", ch[0], ch[1], span=self._span(meta))

    def attr(self, meta, ch):
        return ast.Attr(ch[0], self._ident(ch[1]), span=self._span(meta))

    def call(self, meta, ch):
        func, args = ch
        return ast.Call(func, args or (), span=self._span(meta))

    def index(self, meta, ch):
        return ast.Index(ch[0], ch[1], span=self._span(meta))

    def number(self, meta, ch):
        text = str(ch[0])
        if len(text) > 300:
            raise _SyntaxProblem("E110", "number literal too long", self._tok(ch[0]))
        value: int | float = int(text) if re.fullmatch(r"\d+", text) else float(text)
        if not abs(value) <= arith.LIMIT:  # `1e999` is infinity; no knitting size is near it
            raise _SyntaxProblem(
                "E110",
                f"number literal `{text}` is too large: the limit is ±{arith.LIMIT:g}",
                self._tok(ch[0]),
            )
        return ast.Number(value, span=self._tok(ch[0]))

    def string(self, meta, ch):
        return ast.String(_unescape(str(ch[0])[1:-1]), span=self._tok(ch[0]))

    def grid(self, meta, ch):
        tok = ch[0]
        body_start = tok.start_pos + 3
        lines = str(tok)[3:-3].split("\n")
        rows: list[tuple[ast.GridCell, ...]] = []
        offset = body_start
        for line in lines:
            cells = tuple(
                ast.GridCell(m.group(), span=self.source.span(offset + m.start(), offset + m.end()))
                for m in re.finditer(r"\S+", line)
            )
            rows.append(cells)
            offset += len(line) + 1
        while rows and not rows[0]:
            rows.pop(0)
        while rows and not rows[-1]:
            rows.pop()
        return ast.Grid(tuple(rows), span=self._tok(tok))

    def true(self, meta, ch):
        return ast.Bool(True, span=self._span(meta))

    def false(self, meta, ch):
        return ast.Bool(False, span=self._span(meta))

    def param_ref(self, meta, ch):
        return ast.ParamRef(str(ch[0])[1:], span=self._tok(ch[0]))

    def prop_ref(self, meta, ch):
        text = str(ch[0])[1:]
        node, _, prop = text.rpartition(".")
        return ast.PropRef(node or None, prop, span=self._tok(ch[0]))

    def name(self, meta, ch):
        return ast.Name(str(ch[0]), span=self._tok(ch[0]))

    def list(self, meta, ch):
        items = ch[0] or ()
        span = self._span(meta)
        points = [isinstance(i, ast.ProfilePoint) for i in items]
        if items and all(points):
            return ast.Profile(tuple(items), span=span)
        if any(points):
            bad = next(i for i in items if not isinstance(i, ast.ProfilePoint))
            raise _SyntaxProblem(
                "E104",
                "a profile mixes `t: value` points with plain values",
                bad.span,
                "write every entry of a width profile as `t: value`, e.g. [0: 20, 1: 12]",
            )
        return ast.ListExpr(tuple(items), span=span)

    def items(self, meta, ch):
        return tuple(ch)

    def point(self, meta, ch):
        return ast.ProfilePoint(ch[0], ch[1], span=self._span(meta))

    def tuple(self, meta, ch):
        first, rest = ch[0], ch[1:]
        items = (first,) + tuple(r for r in rest if r is not None)
        return ast.TupleExpr(items, span=self._span(meta))

    def args(self, meta, ch):
        return tuple(ch)

    def range(self, meta, ch):
        if len(ch) == 2:
            return ast.Range(ch[0], ch[1], None, span=self._span(meta))
        return ast.Range(ch[0], ch[2], ch[1], span=self._span(meta))

    def kwarg(self, meta, ch):
        return ast.KwArg(self._ident(ch[0]), ch[1], span=self._span(meta))


# ---- error messages ---------------------------------------------------------------------

_TERMINAL_WORDS = {
    "NAME": "a name",
    "NUMBER": "a number",
    "STRING": "a string",
    "GRID": 'a """grid"""',
    "PARAM_REF": "a parameter (#name)",
    "PROP_REF": "a property reference (@name)",
    "INSTR": "an instruction (K, P, T, M, FR1, XR+, S, ...)",
    "NODE_KIND": "`sheet`, `tube`, `joint` or `split`",
    "GRID_MODE": "`draw`, `stretch` or `tile`",
    "STEP": "`pre`, `main` or `post`",
    "LBRACE": "`{`",
    "RBRACE": "`}`",
    "LPAR": "`(`",
    "RPAR": "`)`",
    "LSQB": "`[`",
    "RSQB": "`]`",
    "COLON": "`:`",
    "COMMA": "`,`",
    "DOT": "`.`",
    "EQUAL": "`=`",
    "MINUS": "`-`",
    "CIRCUMFLEX": "`^`",
    "__ANON_0": "`->`",
    "COMP_OP": "a comparison",
    "PLUS": "`+`",
    "STAR": "`*`",
    "SLASH": "`/`",
    "PERCENT": "`%`",
    "$END": "the end of the file",
    "IF": "`if`",
    "ELSE": "`else`",
    "FOR": "`for`",
    "IN": "`in`",
    "AND": "`and`",
    "OR": "`or`",
    "NOT": "`not`",
    "TRUE": "`true`",
    "FALSE": "`false`",
}
_EXPR_START = {"NAME", "NUMBER", "STRING", "PARAM_REF", "PROP_REF", "LSQB", "LPAR"}
_OPERATORS = {
    "PLUS",
    "MINUS",
    "STAR",
    "SLASH",
    "PERCENT",
    "COMP_OP",
    "CIRCUMFLEX",
    "DOT",
    "AND",
    "OR",
}


def _word(terminal: str) -> str:
    if terminal.startswith("KW_"):
        return f"`{terminal[3:].lower()}`"
    return _TERMINAL_WORDS.get(terminal, f"`{terminal.lower()}`")


_LAYER_START = {
    "KW_SET",
    "KW_USE",
    "KW_APPLY",
    "GRID_MODE",
    "KW_LET",
    "KW_KNIT",
    "KW_BACKING",
    "KW_INTARSIA",
}
_TOP_START = {
    "KW_IMPORT",
    "KW_PARAM",
    "KW_MACHINE",
    "KW_YARN",
    "NODE_KIND",
    "KW_PATTERN",
    "KW_ACTION",
    "KW_SHAPER",
    "KW_START",
}
_LAYER_WORDS = (
    "set",
    "use",
    "apply",
    "knit",
    "backing",
    "intarsia",
    "draw",
    "stretch",
    "tile",
    "let",
)


def _describe_expected(expected: set[str]) -> str:
    names = set(expected)
    words: list[str] = []
    if _TOP_START <= names:
        names -= _TOP_START
        words.append("a declaration")
    if _LAYER_START <= names:
        names -= _LAYER_START
        words.append("a layer statement (" + ", ".join(f"`{w}`" for w in _LAYER_WORDS) + ")")
    if _EXPR_START <= names:
        names -= _EXPR_START | {"GRID", "TRUE", "FALSE", "MINUS", "NOT"}
        words.append("an expression")
    if len(names & _OPERATORS) >= 3:
        names -= _OPERATORS
        words.append("an operator")
    words += sorted({_word(n) for n in names if n not in {"WS", "COMMENT"}})
    if not words:
        return "something else"
    if len(words) > 6:
        words = words[:5] + ["another token"]
    if len(words) == 1:
        return words[0]
    return ", ".join(words[:-1]) + " or " + words[-1]


def _found(tok: Token) -> str:
    if tok.type == "$END":
        return "the end of the file"
    text = str(tok)
    if tok.type in ("NAME", "NUMBER", "STRING", "PARAM_REF", "PROP_REF"):
        return f"`{text}`"
    if tok.type.startswith("KW_") or tok.type in {"NODE_KIND", "GRID_MODE", "STEP"}:
        return f"keyword `{text}`"
    return f"`{text.splitlines()[0] if text else tok.type}`"


def _hint(tok: Token, expected: set[str]) -> str | None:
    text = str(tok)
    if tok.type == "EQUAL" and "COLON" in expected:
        return "properties are written `name: value`"
    if text == ":" and "EQUAL" in expected:
        return "parameters are written `param name = value`"
    if text == "=" and "__ANON_0" in expected:
        return "connections are written `a.top -> b.bottom`"
    if "COLON" in expected and tok.type in _EXPR_START:
        return "add `:` between a property name and its value"
    if tok.type == "NAME" and {"COMMA", "RPAR"} <= expected:
        return "separate arguments with `,`"
    if text == "}" and "NAME" in expected and "NUMBER" in expected:
        return "an expression is missing before `}` (e.g. a query after `where`)"
    if tok.type == "NAME" and "INSTR" in expected:
        return (
            "`set` takes one of the 17 instructions: K P T M FR1 FR2 FL1 FL2 BR1 BR2 "
            "BL1 BL2 XR+ XR- XL+ XL- S; use `use NAME` for a stitch action"
        )
    return None


@record
class _Chunk:
    start: int
    end: int
    unclosed: int | None  # offset of an unmatched `{` / `(` / `[`, if any


_OPEN = {"{": "}", "(": ")", "[": "]"}


_STRING = re.compile(r'"([^"\\\n]|\\.)*"?')


def _skip_literal(text: str, i: int) -> int | None:
    """If a grid, string or comment starts at `i`, the offset just after it (brackets inside
    them do not count); else None."""
    n = len(text)
    if text.startswith('"""', i):
        j = text.find('"""', i + 3)
        return n if j < 0 else j + 3
    if text.startswith('"', i):
        m = _STRING.match(text, i)
        return m.end() if m else i + 1
    if text.startswith("//", i):
        j = text.find("\n", i)
        return n if j < 0 else j
    if text.startswith("/*", i):
        j = text.find("*/", i + 2)
        return n if j < 0 else j + 2
    return None


_WORD = re.compile(r"[A-Za-z_]\w*")


def _chunks(text: str) -> list[_Chunk]:
    """Cut the file into top-level statements for independent error recovery."""
    chunks: list[_Chunk] = []
    stack: list[int] = []
    start = 0
    i, n = 0, len(text)
    at_line_start = True
    while i < n:
        ch = text[i]
        if at_line_start and ch not in " \t\r\n":
            word = _WORD.match(text, i)
            top = word is not None and word.group() in _TOP_LEVEL_WORDS
            if (not stack and (top or word is not None)) or (stack and top):
                if i > start and text[start:i].strip():
                    chunks.append(_Chunk(start, i, stack[0] if stack else None))
                    start = i
                stack = []
        at_line_start = False
        skipped = _skip_literal(text, i)
        if skipped is not None:
            i = skipped
            continue
        if ch in _OPEN:
            stack.append(i)
        elif ch in ")]}" and stack:
            stack.pop()
        elif ch == "\n":
            at_line_start = True
        i += 1
    if text[start:].strip():
        chunks.append(_Chunk(start, n, stack[0] if stack else None))
    return chunks


def _open_brackets(text: str, start: int, end: int) -> list[int]:
    """Offsets of the brackets still open at `end`, scanning from `start` (skips strings
    and comments)."""
    stack: list[int] = []
    i = start
    while i < end:
        skipped = _skip_literal(text, i)
        if skipped is not None:
            i = skipped
            continue
        ch = text[i]
        if ch in _OPEN:
            stack.append(i)
        elif ch in ")]}" and stack:
            stack.pop()
        i += 1
    return stack


_BLANK_TO_END = re.compile(r"\s*\Z")


def _blank_before(text: str, end: int) -> int:
    """The offset where the blanks just before `end` begin (`end` if there are none).

    A backward scan, not `text[:end].rstrip()`: that copies everything before `end`, once
    per error, which is quadratic when every statement has one."""
    while end > 0 and text[end - 1].isspace():
        end -= 1
    return end


def _word_before(text: str, end: int) -> int:
    """The start of the run of non-blank characters that ends at `end` (`end - 1` for
    none), found by scanning backwards: a regex search for `\\S+\\s*$` tries every
    start inside a long run and was quadratic in its length (40 KB took 24 s)."""
    start = end
    while start > 0 and not text[start - 1].isspace():
        start -= 1
    return start if start < end else max(end - 1, 0)


def _report(
    err: UnexpectedInput, source: SourceFile, diags: Diagnostics, chunk: _Chunk | None
) -> None:
    text = source.text
    if chunk is not None:
        first = re.match(r"\s*([A-Za-z_]\w*)", text[chunk.start : chunk.end])
        if first and first.group(1) in _LAYER_WORDS and not isinstance(err, UnexpectedCharacters):
            at = chunk.start + first.start(1)
            word = first.group(1)
            diags.error(
                "E109",
                f"`{word}` only appears inside a pattern block",
                source.span(at, at + len(word)),
                hint=f"write it inside `pattern NODE {{ ... }}`, e.g. "
                f"`pattern body {{ {word} ... }}`",
            )
            return
    if (
        isinstance(err, UnexpectedToken)
        and err.token.type == "$END"
        or isinstance(err, UnexpectedEOF)
    ):
        if chunk is not None and chunk.unclosed is not None:
            opener = source.text[chunk.unclosed]
            diags.error(
                "E102",
                f"unclosed `{opener}`",
                source.span(chunk.unclosed, chunk.unclosed + 1),
                hint=f"add `{_OPEN[opener]}` to close it",
            )
            return
        stop = chunk.end if chunk is not None else len(source.text)
        end = _blank_before(text, stop)
        expected = set(getattr(err, "expected", ()) or ())
        start = _word_before(text, end)
        what = "end of file" if _BLANK_TO_END.match(text, stop) else "end of statement"
        stmt = source.text[chunk.start : stop] if chunk is not None else source.text
        hint = None
        if m := re.search(r"\bclosed\s+([A-Za-z_]\w*)\s*$", stmt):
            hint = f"write the closing mode in parentheses: `closed({m.group(1)})`"
        elif m := re.search(r"\bstart\s+([A-Za-z_]\w*)\s*$", stmt):
            hint = f"the yarn starts at an interface, e.g. `start {m.group(1)}.bottom`"
        diags.error(
            "E101",
            f"unexpected {what}; expected {_describe_expected(expected)}",
            source.span(start, end),
            hint=hint,
        )
        return
    if isinstance(err, UnexpectedToken):
        tok = err.token
        expected = set(err.accepts or err.expected)
        span = source.span(
            tok.start_pos, tok.end_pos if tok.end_pos is not None else tok.start_pos + len(str(tok))
        )
        if text.startswith("/*", tok.start_pos):
            diags.error(
                "E107",
                "unterminated comment",
                source.span(tok.start_pos, tok.start_pos + 2),
                hint="close it with `*/`",
            )
            return
        base = chunk.start if chunk is not None else 0
        opened = _open_brackets(text, base, tok.start_pos)
        if opened and text[opened[-1]] in "([":
            opener = text[opened[-1]]
            closer = _OPEN[opener]
            closes_other = str(tok) in ")]}" and str(tok) != closer
            later_line = source.position(opened[-1])[0] < source.position(tok.start_pos)[0]
            if closes_other or (later_line and {"RPAR", "RSQB"} & expected):
                diags.error(
                    "E102",
                    f"unclosed `{opener}`",
                    source.span(opened[-1], opened[-1] + 1),
                    hint=f"add `{closer}` to close it",
                )
                return
        if str(tok) == "}" and not opened:
            diags.error("E103", "unmatched `}`", span, hint="remove it, or open a block with `{`")
            return
        diags.error(
            "E101",
            f"unexpected {_found(tok)}; expected {_describe_expected(expected)}",
            span,
            hint=_hint(tok, expected),
        )
        return
    assert isinstance(err, UnexpectedCharacters)
    pos = err.pos_in_stream
    assert pos is not None  # always set for UnexpectedCharacters
    char = source.text[pos] if pos < len(source.text) else ""
    span = source.span(pos, pos + 1)
    if source.text.startswith('"""', pos) or source.text.startswith('"""', pos - 2):
        at = pos if source.text.startswith('"""', pos) else pos - 2
        diags.error(
            "E108", "unterminated grid", source.span(at, at + 3), hint='close the grid with `"""`'
        )
    elif source.text.startswith("/*", pos):
        diags.error(
            "E107", "unterminated comment", source.span(pos, pos + 2), hint="close it with `*/`"
        )
    elif char == '"':
        diags.error(
            "E105",
            "unterminated string",
            span,
            hint='close it with `"` on the same line, or use """...""" for a grid',
        )
    elif char == ";":
        diags.error(
            "E100",
            "unexpected `;`",
            span,
            hint="knitc needs no `;`: separate statements and properties with "
            "newlines, spaces or `,`",
        )
    elif char == "#" or char == "@":
        diags.error(
            "E106",
            f"`{char}` must be followed by a name",
            span,
            hint="write `#param` for a design parameter, `@prop` or `@node.prop` for a property",
        )
    else:
        diags.error("E100", f"unexpected character `{char}`", span)


MAX_NESTING = 100
"""Deepest parse tree accepted: the AST builder and the evaluators recurse once (or a few
frames) per level, so a design nested deeper than this would exhaust Python's stack
instead of getting a located error (E111)."""


def _too_deep(tree: Tree) -> Tree | None:
    """The first subtree found below `MAX_NESTING` levels, walked without recursion."""
    stack = [(tree, 1)]
    while stack:
        node, depth = stack.pop()
        if depth > MAX_NESTING:
            return node
        stack.extend((c, depth + 1) for c in node.children if isinstance(c, Tree))
    return None


def parse_source(source: SourceFile, diags: Diagnostics) -> ast.Module | None:
    """Parse one file. On syntax errors, report them all and return None."""
    diags.add_source(source)
    comments: list[Token] = []
    try:
        tree = _parse(source.text, comments)
    except UnexpectedInput as err:
        before = diags.error_count
        _recover(source, diags)
        if diags.error_count == before:  # every statement parses alone: report the whole
            _report(err, source, diags, None)
        return None
    deep = _too_deep(tree)
    if deep is not None:
        meta = deep.meta
        at = source.span(meta.start_pos, meta.end_pos) if not meta.empty else None
        diags.error(
            "E111",
            f"expressions or blocks nest more than {MAX_NESTING} levels deep here",
            at,
            hint="split the expression with `param`s or `let`s, or a deep `if` chain with "
            "`else if`; no garment needs this depth",
        )
        return None
    try:
        module = _ToAst(source).transform(tree)
    except Exception as exc:  # lark wraps transformer errors in VisitError
        problem = getattr(exc, "orig_exc", exc)
        if isinstance(problem, _SyntaxProblem):
            diags.error(problem.code, problem.message, problem.span, hint=problem.hint)
            return None
        raise
    comment_nodes = tuple(
        ast.Comment(str(c), span=source.span(c.start_pos, c.end_pos))  # type: ignore[arg-type]
        for c in comments
    )
    return ast.Module(module.items, comment_nodes, span=module.span)


def _parse(text: str, comments: list[Token]):
    # Lark calls lexer callbacks for ignored terminals too: that is how comments survive.
    _comment_sink.append(comments)
    try:
        return _lark().parse(text)
    finally:
        _comment_sink.pop()


def _recover(source: SourceFile, diags: Diagnostics) -> None:
    """Parse each top-level statement on its own and report its first error, if any.

    Each statement's own text is parsed (not the file with the text before it blanked
    out, which made recovery quadratic: 4,000 parameters and one error took 10 s), and
    the error's offsets are moved back to the file's."""
    text = source.text
    for chunk in _chunks(text):
        try:
            _parse(text[chunk.start : chunk.end], [])
        except UnexpectedInput as err:
            _report(_shifted(err, chunk.start), source, diags, chunk)


def _shifted(err: UnexpectedInput, offset: int) -> UnexpectedInput:
    """`err`, raised while parsing text that starts at `offset` of the file, with its
    offsets made the file's (only offsets are read by `_report`; lines come from them)."""
    if offset == 0:
        return err
    if isinstance(err, UnexpectedCharacters) and err.pos_in_stream is not None:
        err.pos_in_stream = err.pos_in_stream + offset
    token = getattr(err, "token", None)
    if isinstance(token, Token) and token.type != "$END":
        err.token = Token(  # type: ignore[attr-defined]
            token.type,
            token.value,
            start_pos=(token.start_pos or 0) + offset,
            end_pos=None if token.end_pos is None else token.end_pos + offset,
        )
    return err


def parse(text: str, path: str = "<input>", diags: Diagnostics | None = None) -> ast.Module:
    """Parse `text`; raise ValueError with rendered diagnostics if it does not parse.

    Convenience for tests and tools; the driver uses `parse_source` and keeps diagnostics.
    """
    own = diags if diags is not None else Diagnostics()
    module = parse_source(SourceFile(path, text), own)
    if module is None:
        raise ValueError(own.render())
    return module
