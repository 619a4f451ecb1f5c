"""Completion: what may be typed at the cursor, from the grammar and the design.

The grammar decides *what kind* of word fits: the text of the current top-level statement
up to the word being typed is fed to Lark's interactive LALR parser, whose state says which
terminals it could shift next (`NAME`, `INSTR`, `NODE_KIND`, `RBRACE`, …) and whose value
stack holds the tokens just before the cursor (`set`, `apply`, `body .`). The design
decides *which* words: the property tables of `knitc.frontend.skeleton` for the enclosing
node, machine, yarn or interface block, the module's parameters, nodes, yarns, patterns,
actions and shapers, and the standard library's modules and exports.

Only the current statement is parsed (`parser._chunks`), so an error in another one does
not matter and a glove-sized file costs well under a millisecond of parsing. When the
statement itself does not parse up to the cursor, a look at the text around it (the
enclosing block's header, the word before) stands in for the parser state.

Everything here runs on the compiler thread (the parser is shared and not reentrant) and
never raises: a completion request on any text answers some list, perhaps empty.
"""

from __future__ import annotations

import logging
import os
import re
from collections.abc import Iterable, Iterator
from dataclasses import field
from typing import TYPE_CHECKING, Any

from lark import Token
from lark.exceptions import UnexpectedInput
from lsprotocol import types

from knitc.frontend import ast, fmt
from knitc.frontend import parser as ps
from knitc.frontend import skeleton as sk
from knitc.frontend.names import QUERY_FUNCTIONS, QUERY_WORDS
from knitc.lsp.analysis import Analysis
from knitc.lsp.definitions import signature, stdlib_exports, stdlib_modules
from knitc.lsp.positions import UTF16
from knitc.records import record
from knitc.shaping.stitch_graph import INSTRUCTIONS
from knitc.view.figure import INSTR_NAMES

if TYPE_CHECKING:
    from knitc.lsp.server import KnitServer

log = logging.getLogger("knitc.lsp")

TRIGGERS = ["#", "@", ".", ":", "(", " ", '"']
"""Characters that ask for completion as they are typed. A space or a colon answers only
where the next word is one of a few (after `set`, `apply`, `import`, `gauge:` …), so typing
ordinary text does not pop up a list at every space."""

Kind = types.CompletionItemKind

# ---- items ------------------------------------------------------------------------------------


@record(frozen=True)
class Item:
    """One suggestion, in code-point offsets (converted to the client's units at the end)."""

    label: str
    kind: types.CompletionItemKind
    insert: str
    """The text that replaces the word being typed (a snippet when `snippet`)."""
    detail: str | None = None
    doc: str | None = None
    snippet: bool = False
    note: str | None = None
    """Shown after the label, e.g. `(import std.stitches)`."""
    edits: tuple[tuple[int, int, str], ...] = ()
    """Further edits (start, end, new text) made when the item is accepted."""


@record(frozen=True)
class Answer:
    """The items for one position and the part of the text they replace."""

    start: int
    end: int
    items: list[Item] = field(default_factory=list)


# ---- the cursor's context ----------------------------------------------------------------------

_IDENT = re.compile(r"[A-Za-z_]\w*")


@record
class Context:
    """What surrounds the cursor: the word being typed and the statement it is in."""

    text: str
    offset: int
    start: int
    """Where the word being typed begins (its `#` or `@` included)."""
    sigil: str
    chunk: tuple[int, int]
    """The top-level statement around the cursor."""
    accepts: frozenset[str] | None = None
    """Terminals the parser could shift at `start`; None when the statement does not parse
    up to there."""
    tokens: list[Token] = field(default_factory=list)
    """The unreduced tokens on the parser's value stack (the last one is just before)."""

    @property
    def before(self) -> str:
        return self.text[self.chunk[0] : self.start]

    @property
    def last(self) -> str | None:
        """The type of the token just before the word, if the parser knows it."""
        return self.tokens[-1].type if self.tokens else None


def _word_start(text: str, offset: int) -> tuple[int, str]:
    """Where the word ending at `offset` begins and its sigil (`#`, `@` or none)."""
    start = offset
    while start > 0 and (
        text[start - 1].isascii() and (text[start - 1].isalnum() or text[start - 1] == "_")
    ):
        start -= 1  # a backward scan: a regex search for the word before is quadratic in it
    if start > 0 and text[start - 1] in "#@":
        return start - 1, text[start - 1]
    return start, ""


def _chunk_at(text: str, offset: int) -> tuple[int, int]:
    """The top-level statement containing `offset` (or the last one before it)."""
    found = (0, len(text))
    for chunk in ps._chunks(text):
        if chunk.start > offset:
            break
        found = (chunk.start, chunk.end)
    if found[1] < offset:
        found = (found[0], len(text))
    return found


def _inside_literal(text: str, lo: int, pos: int) -> bool:
    """Is `pos` inside a comment, a string or a grid (scanning from `lo`)? The end of a
    line comment is in it (typing there continues the comment)."""
    i = lo
    while i < pos:
        end = ps._skip_literal(text, i)
        if end is None:
            i += 1
            continue
        if text.startswith('"', i) and not text.startswith('"""', i) and end == i + 1:
            if "\n" not in text[i:pos]:  # an unterminated string runs to the line's end
                return True
        elif end > pos or (end == pos and text.startswith("//", i)):
            return True
        i = end
    return False


def _parse_state(ctx: Context) -> None:
    """Feed the statement up to the word to the interactive parser; fill `accepts` and
    `tokens` (left as they are when it does not parse)."""
    prefix = ctx.before
    sink: list[Token] = []
    ps._comment_sink.append(sink)  # comments lexed here go to a list of ours, not a parse's
    try:
        ip = ps._lark().parse_interactive(prefix)
        ip.exhaust_lexer()
    except UnexpectedInput:
        return
    finally:
        ps._comment_sink.pop()
    state = ip.parser_state
    table = state.parse_conf.parse_table
    choices = table.states[state.position]
    ctx.accepts = frozenset(
        t for t in choices if t.isupper() and ps._can_shift(table, state.state_stack, t)
    )
    ctx.tokens = [v for v in state.value_stack if isinstance(v, Token)]


def context_at(text: str, offset: int) -> Context | None:
    """The cursor's context; None inside a comment or a string."""
    offset = max(0, min(offset, len(text)))
    start, sigil = _word_start(text, offset)
    chunk = _chunk_at(text, start)
    if _inside_literal(text, chunk[0], start):
        return None
    ctx = Context(text, offset, start, sigil, chunk)
    _parse_state(ctx)
    return ctx


# ---- the enclosing block ----------------------------------------------------------------------

_HEADERS: tuple[tuple[str, re.Pattern[str]], ...] = (
    ("node", re.compile(r"\b(sheet|tube|joint|split)\s+([A-Za-z_]\w*)\s*\Z")),
    ("machine", re.compile(r"\bmachine\s*\Z")),
    ("yarn", re.compile(r"\byarn\s+[A-Za-z_]\w*\s*\Z")),
    ("action", re.compile(r"\baction\s+[A-Za-z_]\w*\s*\Z")),
    ("layer", re.compile(r"\bpattern\s+[A-Za-z_]\w*\s*(\([^{}]*\)\s*)?\Z")),
    (
        "itf",
        re.compile(
            r"(?<![\w.@#])([A-Za-z_]\w*)\s*\.\s*([A-Za-z_]\w*)\s*(\[[^\]]*\]\s*)?"
            r"(open\s*|closed\s*(\(\s*\w*\s*\)\s*)?)?\Z"
        ),
    ),
)


@record(frozen=True)
class Block:
    """The innermost `{ … }` the cursor is in: its kind (node, machine, yarn, action, layer,
    itf, code or top), the node kind for a node block, where it opens, and whether the
    cursor is also inside parentheses or brackets in it."""

    kind: str
    brace: int = -1
    node_kind: str | None = None
    node_name: str | None = None
    nested: bool = False


def block_at(ctx: Context) -> Block:
    opens = ps._open_brackets(ctx.text, ctx.chunk[0], ctx.start)
    braces = [i for i in opens if ctx.text[i] == "{"]
    if not braces:
        return Block("top", nested=bool(opens))
    brace = braces[-1]
    nested = opens[-1] != brace
    lo = max(ctx.chunk[0], brace - 400)
    header = ctx.text[lo:brace]
    for kind, pattern in _HEADERS:
        m = pattern.search(header)
        if m is None or (kind == "itf" and ctx.text[ctx.chunk[0] : lo + m.start()].strip()):
            continue  # an interface block is a statement of its own, not `if a.b {`
        if kind == "node":
            return Block(kind, brace, m.group(1), m.group(2), nested)
        return Block(kind, brace, nested=nested)
    return Block("code", brace, nested=nested)


def _set_props(ctx: Context, block: Block) -> set[str]:
    """Property names already written in the block (before and after the cursor)."""
    text, end = ctx.text, ctx.chunk[1]
    names: set[str] = set()
    depth, i = 0, block.brace + 1
    while i < end:
        skipped = ps._skip_literal(text, i)
        if skipped is not None:
            i = skipped
            continue
        ch = text[i]
        if ch in "([{":
            depth += 1
        elif ch in ")]}":
            if depth == 0:
                break
            depth -= 1
        elif depth == 0 and (ch.isalpha() or ch == "_") and not _glued(text, i):
            m = _PROP_NAME.match(text, i)
            word = _IDENT.match(text, i)
            assert word is not None
            if m is not None and not (i == ctx.start < ctx.offset):
                names.add(m.group(1))
            i = word.end()
            continue
        i += 1
    return names


_PROP_NAME = re.compile(r"([A-Za-z_]\w*)\s*:")


def _glued(text: str, i: int) -> bool:
    """Is the letter at `i` inside a longer word, a number or a reference?"""
    return i > 0 and (text[i - 1].isalnum() or text[i - 1] in "_#@.")


# ---- the design's names ------------------------------------------------------------------------


@record
class Names:
    """The definitions and declarations completion can offer, from the analysis."""

    params: dict[str, str] = field(default_factory=dict)
    """Parameter name → its value (as text, '' when unknown)."""
    nodes: dict[str, tuple[str, list[str]]] = field(default_factory=dict)
    """Node name → (kind, interface paths)."""
    yarns: dict[str, str] = field(default_factory=dict)
    """Yarn name → what to show beside it (its carrier); `main` first, declared or not."""
    defs: dict[str, list[tuple[str, str, str]]] = field(default_factory=dict)
    """'pattern' / 'action' / 'shaper' → [(name, signature, where from)]."""
    imported: dict[str, str] = field(default_factory=dict)
    """std module → '*' (all of it) or the text of its selective import's name list."""


def names_of(a: Analysis) -> Names:
    names = Names(defs={"pattern": [], "action": [], "shaper": []})
    names.yarns[sk.MAIN_YARN] = _yarn_detail(a, sk.MAIN_YARN, ())
    skel = a.skeleton
    own: set[str] = set()
    for sym in a.index.symbols:
        if sym.kind == "param":
            names.params[sym.name] = _param_value(a, sym.name, sym.decl)
        elif sym.kind == "node" and isinstance(sym.decl, ast.NodeDecl):
            names.nodes[sym.name] = (sym.decl.kind, _paths(a, sym.decl))
        elif sym.kind == "yarn" and isinstance(sym.decl, ast.YarnDecl):
            names.yarns[sym.name] = _yarn_detail(a, sym.name, sym.decl.props)
        elif sym.kind in names.defs:
            names.defs[sym.kind].append((sym.name, signature(sym.decl), "this file"))
            own.add(sym.name)
    for imp in a.index.imports:
        if imp.module is None or len(imp.module) != 2 or imp.module[0] != "std":
            continue
        listed = None if imp.names is None else ",".join(n.name for n in imp.names)
        _add_import(names, own, imp.module[1], listed)
    _scan(a.text, names, own)
    if skel is not None:  # definitions of imported files
        for kind, table in (
            ("pattern", skel.patterns),
            ("action", skel.actions),
            ("shaper", skel.shapers),
        ):
            for name, d in table.items():
                if name not in own:
                    names.defs[kind].append((name, signature(d), "imported"))
                    own.add(name)
    return names


_DECLS = re.compile(
    r"(?m)^[ \t]*(?:(param)\s+([A-Za-z_]\w*)\s*=([^\n]*)"
    r"|(sheet|tube|joint|split)\s+([A-Za-z_]\w*)\s*\{([^{}]*)"
    r"|(pattern|shaper)\s+([A-Za-z_]\w*)\s*\(([^)]*)\)"
    r"|(action)\s+([A-Za-z_]\w*)\s*\{"
    r"|import\s+std\s*\.\s*([A-Za-z_]\w*)\s*(\([^)]*\))?"
    r"|yarn\s+([A-Za-z_]\w*)\s*\{([^{}]*))"
)
_DEGREE = re.compile(r"\bdegree\s*:\s*(\d+)")
_CARRIER = re.compile(r"\bcarrier\s*:\s*(\d+)")


def _scan(text: str, names: Names, own: set[str]) -> None:
    """Add the declarations a look at the text finds that the syntax tree lacks: the tree is
    an earlier text's (or none) while the current one does not parse."""
    for m in _DECLS.finditer(text):
        if m.group(1) and m.group(2) not in names.params:
            names.params[m.group(2)] = m.group(3).split("//")[0].strip()
        elif m.group(4) and m.group(5) not in names.nodes:
            degree = _DEGREE.search(m.group(6)) if m.group(4) == "split" else None
            n = int(degree.group(1)) if degree else 2
            paths = ["base"] + [f"branches[{i}]" for i in range(min(n, 64))]
            names.nodes[m.group(5)] = (m.group(4), paths if m.group(4) == "split" else _ENDS)
        elif (m.group(7) or m.group(10)) and (m.group(8) or m.group(11)) not in own:
            kind, name = m.group(7) or m.group(10), m.group(8) or m.group(11)
            sig = f"{name}({' '.join(m.group(9).split())})" if m.group(7) else name
            names.defs[kind].append((name, sig, "this file"))
            own.add(name)
        elif m.group(12) and m.group(12) not in names.imported:
            _add_import(names, own, m.group(12), None if m.group(13) is None else m.group(13))
        elif m.group(14) and names.yarns.get(m.group(14)) in (None, _MAIN_DETAIL):
            carrier = _CARRIER.search(m.group(15))
            head = _MAIN_DETAIL if m.group(14) == sk.MAIN_YARN else "yarn"
            names.yarns[m.group(14)] = f"{head}, carrier {carrier.group(1)}" if carrier else head


_ENDS = ["bottom", "top"]


def _add_import(names: Names, own: set[str], module: str, listed: str | None) -> None:
    """What `import std.<module>` (or a selective import, `listed` its `(…)`) brings."""
    wanted = None if listed is None else set(re.findall(r"[A-Za-z_]\w*", listed))
    names.imported[module] = "*" if wanted is None else "some"
    for e in stdlib_exports(module):
        if (wanted is None or e.name in wanted) and e.name not in own:
            names.defs[e.kind].append((e.name, e.signature, f"std.{e.module}"))
            own.add(e.name)


_MAIN_DETAIL = "the design's own yarn"


def _yarn_detail(a: Analysis, name: str, props: tuple[ast.Prop, ...]) -> str:
    """`yarn, carrier 5`: the carrier as resolved, else as written, else none."""
    skel = a.skeleton
    yarn = skel.yarns.get(name) if skel is not None else None
    carrier = str(yarn.carrier) if yarn is not None and yarn.carrier is not None else None
    if carrier is None:
        written = next((p.value for p in props if p.name.name == "carrier"), None)
        carrier = fmt.format_expr(written) if written is not None else None
    head = _MAIN_DETAIL if name == sk.MAIN_YARN else "yarn"
    return head if carrier is None else f"{head}, carrier {carrier}"


def _param_value(a: Analysis, name: str, decl: ast.Node) -> str:
    skel = a.skeleton
    if skel is not None and name in skel.params:
        return str(skel.params[name])
    value = getattr(decl, "value", None)
    return fmt.format_expr(value) if isinstance(value, ast.Node) else ""


def _paths(a: Analysis, decl: ast.NodeDecl) -> list[str]:
    """The node's interfaces as written after `node.` (`top`, `branches[1]`)."""
    skel = a.skeleton
    node = skel.nodes.get(decl.name.name) if skel is not None else None
    if node is not None:
        paths = node.interface_paths
    elif decl.kind == "split":
        degree = next(
            (p.value for p in decl.props if p.name.name == "degree"),
            None,
        )
        n = int(degree.value) if isinstance(degree, ast.Number) else 2
        paths = ["base"] + [f"branches/{i}" for i in range(max(1, min(n, 64)))]
    else:
        paths = ["bottom", "top"]
    return [f"branches[{p.split('/')[1]}]" if p.startswith("branches/") else p for p in paths]


# ---- what to offer where ----------------------------------------------------------------------

_IMPORT_PATH = re.compile(r'(?m)^[ \t]*import\s+"[^"\n]*\Z')
_IMPORT_NAMES = re.compile(r"\A\s*import\s+std\s*\.\s*(\w+)\s*\(([^)]*)\Z")
_IMPORT_STD = re.compile(r"\A\s*import\s+std\s*\.\s*\Z")
_IMPORT_START = re.compile(r"\A\s*import\s+\Z")
_PROP_REF = re.compile(r"@([A-Za-z_]\w*)\.([A-Za-z_]\w*)?\Z")
_VALUE_OF = re.compile(r"(?<![\w#@.])([A-Za-z_]\w*)\s*:\s*\Z")
_CLOSING = re.compile(r"\bclosed\s*\(\s*\Z")
_ITF_DOT = re.compile(r"(?<![\w#@.])([A-Za-z_]\w*)\s*\.\s*\Z")
_PREV_WORD = re.compile(r"(\w+|->)\s*\Z")

SPECIFIC_AFTER_SPACE = frozenset(
    {
        "KW_SET",
        "KW_USE",
        "KW_KNIT",
        "KW_BACKING",
        "KW_APPLY",
        "KW_WHERE",
        "KW_IMPORT",
        "KW_START",
        "__ANON_0",
        "COLON",
    }
)
"""Tokens after which a typed space asks for completion (elsewhere a space just types)."""


def answer(a: Analysis, offset: int, snippets: bool = True, trigger: str | None = None) -> Answer:
    """The completions at code-point `offset` of the analysed text (never raises)."""
    try:
        return _answer(a, offset, snippets, trigger)
    except Exception:  # a bug here must not cost the editor its connection
        log.exception("completion failed at %s:%d", a.uri, offset)
        return Answer(offset, offset)


def _answer(a: Analysis, offset: int, snippets: bool, trigger: str | None) -> Answer:
    text = a.text
    offset = max(0, min(offset, len(text)))
    files = _import_files(a, offset)
    if files is not None:
        return files
    ctx = context_at(text, offset)
    if ctx is None or ctx.text[ctx.start : ctx.start + 1].isdigit():  # a comment, a number
        return Answer(offset, offset)
    special = _import_items(ctx, a.path)
    if special is not None:
        return special
    if trigger in (" ", ":", "(", '"') and not _specific(ctx):
        return Answer(offset, offset)
    names = names_of(a)
    block = block_at(ctx)
    m = _PROP_REF.search(text, ctx.chunk[0], offset)
    if m is not None:
        return Answer(m.start(), offset, _node_prop_refs(m.group(1), names))
    items = list(_dispatch(ctx, block, names, snippets))
    return Answer(ctx.start, offset, _unique(items))


def _specific(ctx: Context) -> bool:
    if ctx.last in SPECIFIC_AFTER_SPACE:
        return True
    if ctx.last is None and ctx.accepts is None:
        m = _PREV_WORD.search(ctx.before)
        words = ("set", "use", "knit", "backing", "apply", "where", "start", "->")
        return m is not None and m.group(1) in words
    return bool(_CLOSING.search(ctx.before))


def _unique(items: Iterable[Item]) -> list[Item]:
    seen: set[tuple[str, str]] = set()
    out = []
    for item in items:
        key = (item.label, item.insert)
        if key not in seen:
            seen.add(key)
            out.append(item)
    return out


def _dispatch(ctx: Context, block: Block, names: Names, snippets: bool) -> Iterator[Item]:
    if ctx.sigil == "#":
        yield from _params(names)
        return
    if ctx.sigil == "@":
        yield from _prop_refs(block, names)
        return
    if ctx.accepts is None:
        yield from _fallback(ctx, block, names, snippets)
        return
    acc, last = ctx.accepts, ctx.last
    if "INSTR" in acc:
        yield from _instructions()
    elif last == "KW_USE":
        yield from _importable(ctx, names, "action")
    elif last == "KW_KNIT":
        yield from _yarns(names)
    elif last == "KW_BACKING":
        yield from _backings()
    elif last == "KW_APPLY":
        yield from _importable(ctx, names, "pattern")
    elif last in ("KW_START", "__ANON_0"):
        yield from _nodes(names)
    elif last == "KW_PATTERN":
        yield from _nodes(names)
        yield from _words(("before", "after"), Kind.Keyword, "global pattern layers")
    elif _CLOSING.search(ctx.before):
        yield from _words(sk.CLOSINGS, Kind.EnumMember, "closing")
    elif last == "DOT" and block.kind == "top" and (m := _ITF_DOT.search(ctx.before)):
        yield from _itf_paths(m.group(1), names)
    elif "NODE_KIND" in acc and "KW_PARAM" in acc:
        yield from _top_level(snippets)
        yield from _nodes(names)
    elif "KW_OPEN" in acc:
        yield from _words(("open", "closed"), Kind.Keyword, "interface state")
    else:
        yield from _in_block(ctx, block, names, snippets)


def _in_block(ctx: Context, block: Block, names: Names, snippets: bool) -> Iterator[Item]:
    acc = ctx.accepts or frozenset()
    if block.kind in _PROP_BLOCKS and not block.nested:
        if "RBRACE" in acc and "NAME" in acc:
            yield from _props(_table(block), _set_props(ctx, block))
            if "STEP" in acc:
                yield from _steps(snippets)
            return
        m = _VALUE_OF.search(ctx.before)
        spec = _table(block).get(m.group(1)) if m is not None else None
        if spec is not None:
            yield from _values(spec, names)
            return
    if block.kind == "layer" and "KW_SET" in acc:
        yield from _layer_keywords()
        return
    if block.kind == "layer" and any(t.type == "KW_WHERE" for t in _since_brace(ctx)):
        yield from _queries(snippets)
    if "PARAM_REF" in acc:
        yield from _params(names)


def _since_brace(ctx: Context) -> list[Token]:
    """The unreduced tokens after the innermost open `{` of the value stack."""
    out: list[Token] = []
    depth = 0
    for tok in reversed(ctx.tokens):
        if tok.type == "RBRACE":
            depth += 1
        elif tok.type == "LBRACE":
            if depth == 0:
                break
            depth -= 1
        out.append(tok)
    return out


def _fallback(ctx: Context, block: Block, names: Names, snippets: bool) -> Iterator[Item]:
    """The statement does not parse up to the cursor: guess from the word before it."""
    m = _PREV_WORD.search(ctx.before)
    prev = m.group(1) if m else ""
    if prev == "set":
        yield from _instructions()
    elif prev == "use":
        yield from _importable(ctx, names, "action")
    elif prev == "knit" and block.kind == "layer":
        yield from _yarns(names)
    elif prev == "backing" and block.kind == "layer":
        yield from _backings()
    elif prev == "apply":
        yield from _importable(ctx, names, "pattern")
    elif prev == "where" and block.kind == "layer":
        yield from _queries(snippets)
    elif prev in ("start", "->"):
        yield from _nodes(names)
    elif block.kind == "top" and not block.nested:
        if _line_start(ctx):
            yield from _top_level(snippets)
    elif block.kind in _PROP_BLOCKS and not block.nested:
        v = _VALUE_OF.search(ctx.before)
        if v is not None:
            yield from _values(_table(block).get(v.group(1)), names)
        elif _line_start(ctx) or ctx.before.rstrip().endswith((",", "{")):
            yield from _props(_table(block), _set_props(ctx, block))
    elif block.kind == "layer" and _line_start(ctx):
        yield from _layer_keywords()


_PROP_BLOCKS = ("node", "machine", "yarn", "itf", "action")
"""Blocks of properties (`name: value`), whose table `_table` gives."""


def _line_start(ctx: Context) -> bool:
    line = ctx.text.rfind("\n", 0, ctx.start) + 1
    return not ctx.text[line : ctx.start].strip()


# ---- producers --------------------------------------------------------------------------------

_TOP_WORDS = {
    "import": "import a standard-library module or a file",
    "param": "a design parameter (`param n = 10`, used as `#n`)",
    "machine": "machine settings",
    "yarn": "a yarn for stripes (`knit NAME where Q` in a pattern)",
    "sheet": "a flat or cylindrical sheet",
    "tube": "a tube (knitted in the round)",
    "joint": "a joint of short rows",
    "split": "a split into branches (or a merge of them)",
    "pattern": "pattern layers for a node, or a reusable pattern definition",
    "action": "a stitch action",
    "shaper": "a shaper program",
    "start": "where the yarn starts (`start body.bottom`)",
}

_SNIPPETS: tuple[tuple[str, str, str], ...] = (
    ("tube", "tube ${1:name} {\n  length: ${2:40}\n  width: ${3:30}\n}", "a tube node"),
    ("sheet", "sheet ${1:name} {\n  length: ${2:40}\n  width: ${3:30}\n}", "a sheet node"),
    ("joint", "joint ${1:name} {\n  rows: ${2:10}\n  width: ${3:5}\n}", "a joint node"),
    ("split", "split ${1:name} {\n  degree: ${2:2}\n}", "a split node"),
    ("machine", "machine {\n  gauge: ${1|full,half|}\n}", "machine settings"),
    ("yarn", "yarn ${1:name} {\n  carrier: ${2:5}\n}", "a yarn on its own carrier"),
    ("param", "param ${1:name} = ${2:10}", "a design parameter"),
    ("pattern", "pattern ${1:node} {\n  ${0:set K where all()}\n}", "pattern layers of a node"),
    (
        "pattern()",
        "pattern ${1:name}(${2:n = 1}) {\n  ${0:set K where all()}\n}",
        "a reusable pattern definition",
    ),
    (
        "action",
        "action ${1:name} {\n  pre {\n    $2\n  }\n  main {\n    ${3:knit(needle)}\n  }\n"
        "  post {\n    $0\n  }\n}",
        "a stitch action with pre, main and post steps",
    ),
    (
        "shaper",
        "shaper ${1:name}(M, N) {\n  for i in range(M) {\n    ${0:i -> i}\n  }\n}",
        "a shaper program: maps M stitches to N",
    ),
    ("start", "start ${1:node}.${2:bottom}", "where the yarn starts"),
)

_PLACEHOLDER = re.compile(r"\$\{\d+:([^}]*)\}|\$\{\d+\|([^,|]*)[^}]*\}|\$\{\d+\}|\$\d+")


def plain(snippet: str) -> str:
    """A snippet's text with its placeholders' defaults, for clients without snippets."""
    return _PLACEHOLDER.sub(lambda m: m.group(1) or m.group(2) or "", snippet)


def _top_level(snippets: bool) -> Iterator[Item]:
    for word, doc in _TOP_WORDS.items():
        yield Item(word, Kind.Keyword, word, detail="keyword", doc=doc)
    for label, body, doc in _SNIPPETS:
        text = body if snippets else plain(body)
        yield Item(label, Kind.Snippet, text, detail=doc, doc=plain(body), snippet=snippets)


def _steps(snippets: bool) -> Iterator[Item]:
    for step in ("pre", "main", "post"):
        body = f"{step} {{\n  $0\n}}"
        yield Item(
            step,
            Kind.Snippet if snippets else Kind.Keyword,
            body if snippets else f"{step} {{\n}}",
            detail="action step",
            snippet=snippets,
        )


BACKING_DOCS = {
    "float": "the yarns float behind the stitches they do not show (fair isle)",
    "tubular": "the yarns that do not show knit the back: its negative, for two yarns",
    "birdseye": "the yarns take the back needles in turn, a checkerboard (the thesis' alternate)",
    "pique": "the front yarn on every other back needle, the others between",
    "horizontal": "every yarn knits every back needle: stripes on the back",
    "vertical": "each back wale in one yarn: stripes up the back",
}
"""What each jacquard backing (`stitch_graph.BACKINGS`) does, for completion and hover."""


def _backings() -> Iterator[Item]:
    for word, doc in BACKING_DOCS.items():
        yield Item(word, Kind.EnumMember, word, detail="jacquard backing", doc=doc)


def _layer_keywords() -> Iterator[Item]:
    for word, doc in (
        ("set", "write an instruction: `set P where Q`"),
        ("use", "use a stitch action: `use A where Q`"),
        ("knit", "knit with a yarn: `knit red where courses(0:4)`"),
        ("backing", "jacquard: `backing birdseye where courses(10:40)`"),
        ("intarsia", "each yarn in its own regions: `intarsia where courses(10:40)`"),
        ("apply", "apply a pattern definition: `apply rib(2, 2) where Q`"),
        ("draw", 'draw a grid: `draw """…""" where Q`'),
        ("stretch", "a grid scaled onto the selection"),
        ("tile", "a grid repeated over the selection"),
        ("let", "a local name: `let q = courses(0:5)`"),
    ):
        yield Item(word, Kind.Keyword, word, detail="layer statement", doc=doc)


def _words(words: Iterable[str], kind: types.CompletionItemKind, detail: str) -> Iterator[Item]:
    for w in words:
        yield Item(w, kind, w, detail=detail)


def _table(block: Block) -> dict[str, sk.PropSpec]:
    if block.kind == "node":
        return sk.NODE_PROPS.get(block.node_kind or "", {})
    tables = {
        "machine": sk.MACHINE_PROPS,
        "yarn": sk.YARN_PROPS,
        "itf": sk.ITF_PROPS,
        "action": sk.ACTION_PROPS,
    }
    return tables.get(block.kind, {})


def describe(spec: sk.PropSpec) -> str:
    """`int 1..100000, default 10`, `choice: full | half`: a property's type at a glance."""
    if spec.choices:
        text = f"{spec.kind}: {' | '.join(spec.choices)}"
    elif spec.min is not None or spec.max is not None:
        lo = "" if spec.min is None else f"{spec.min:g}"
        hi = "" if spec.max is None else f"{spec.max:g}"
        text = f"{spec.kind} {lo}..{hi}"
    else:
        text = spec.kind
    return text if spec.default is None else f"{text}, default {_show(spec.default)}"


def _show(value: Any) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, tuple):
        return ", ".join(map(str, value))
    return str(value)


def _props(table: dict[str, sk.PropSpec], present: set[str]) -> Iterator[Item]:
    for name, spec in table.items():
        if name not in present:
            yield Item(
                name, Kind.Property, f"{name}: ", detail=describe(spec), doc=spec.doc or None
            )


def _values(spec: sk.PropSpec | None, names: Names) -> Iterator[Item]:
    if spec is None:
        return
    if spec.kind == "bool":
        yield from _words(("true", "false"), Kind.Value, "bool")
    for choice in spec.choices:
        detail = "default" if choice == spec.default else spec.kind
        yield Item(choice, Kind.EnumMember, choice, detail=detail)
    if spec.kind == "shaper":
        for name, sig, origin in names.defs.get("shaper", []):
            yield Item(name, Kind.Function, f"{name}(", detail=sig, note=f"({origin})")
    if spec.kind in ("int", "number", "width"):
        yield from _params(names)


def _params(names: Names) -> Iterator[Item]:
    for name, value in names.params.items():
        detail = f"param {name} = {value}" if value else f"param {name}"
        yield Item(name, Kind.Variable, f"#{name}", detail=detail)


def _nodes(names: Names) -> Iterator[Item]:
    for name, (kind, _paths) in names.nodes.items():
        yield Item(name, Kind.Class, name, detail=kind)


def _yarns(names: Names) -> Iterator[Item]:
    """After `knit`: the declared yarns, and `main` (declared or not)."""
    for name, detail in names.yarns.items():
        yield Item(name, Kind.Variable, name, detail=detail)


def _itf_paths(node: str, names: Names) -> Iterator[Item]:
    entry = names.nodes.get(node)
    if entry is None:
        return
    kind, paths = entry
    for path in paths:
        yield Item(path, Kind.Field, path, detail=f"interface of {kind} {node}")


def _prop_refs(block: Block, names: Names) -> Iterator[Item]:
    """After `@`: the enclosing node's own properties and the other nodes."""
    if block.kind == "node":
        for name, spec in _table(block).items():
            yield Item(name, Kind.Property, f"@{name}", detail=describe(spec), doc=spec.doc or None)
    for name, (kind, _paths) in names.nodes.items():
        yield Item(name, Kind.Class, f"@{name}.", detail=kind)


def _node_prop_refs(node: str, names: Names) -> list[Item]:
    entry = names.nodes.get(node)
    if entry is None:
        return []
    table = sk.NODE_PROPS.get(entry[0], {})
    return [
        Item(p, Kind.Property, f"@{node}.{p}", detail=describe(spec), doc=spec.doc or None)
        for p, spec in table.items()
    ]


def _instructions() -> Iterator[Item]:
    for mnemonic in INSTRUCTIONS:
        yield Item(
            mnemonic,
            Kind.Constant,
            mnemonic,
            detail=INSTR_NAMES.get(mnemonic, "instruction"),
        )


def _queries(snippets: bool) -> Iterator[Item]:
    for name, (lo, hi) in QUERY_FUNCTIONS.items():
        arity = f"{lo}" if lo == hi else f"{lo} to {hi}"
        detail = f"query, {arity} argument{'s' if hi != 1 else ''}"
        if hi == 0:
            text = f"{name}()"
        else:
            text = f"{name}($1)" if snippets else f"{name}("
        yield Item(f"{name}()", Kind.Function, text, detail=detail, snippet=snippets and hi > 0)
    yield from _words(QUERY_WORDS, Kind.Keyword, "query word")


def _importable(ctx: Context, names: Names, kind: str) -> Iterator[Item]:
    """Patterns after `apply` (actions after `use`): the available ones, then the other
    ones of the standard library with the edit that imports them."""
    opens = "(" if kind == "pattern" else ""
    for name, sig, origin in names.defs.get(kind, []):
        yield Item(name, Kind.Function, name + opens, detail=sig, note=f"({origin})")
    have = {n for n, _s, _o in names.defs.get(kind, [])}
    for module in stdlib_modules():
        if names.imported.get(module) == "*":
            continue
        for e in stdlib_exports(module):
            if e.kind != kind or e.name in have:
                continue
            yield Item(
                e.name,
                Kind.Function,
                e.name + opens,
                detail=e.signature,
                doc=e.doc or None,
                note=f"(import std.{module})",
                edits=(import_edit(ctx.text, module, e.name),),
            )


_IMPORT_LINE = re.compile(r"(?m)^import\b[^\n]*")


def import_edit(text: str, module: str, name: str) -> tuple[int, int, str]:
    """The edit that imports `name` from `std.<module>`: into its selective import if the
    file has one, else a new line after the last import (or at the top)."""
    last: re.Match[str] | None = None
    for m in _IMPORT_LINE.finditer(text):
        last = m
        sel = re.match(rf"import\s+std\s*\.\s*{module}\s*\(([^)]*)\)", m.group())
        if sel is not None:
            listed = sel.group(1).rstrip()
            at = m.start() + sel.start(1) + len(listed)
            if not listed.strip():
                return (at, at, name)
            return (at, at, f" {name}" if listed.endswith(",") else f", {name}")
    line = f"import std.{module} ({name})"
    if last is None:
        return (0, 0, line + "\n")
    return (last.end(), last.end(), "\n" + line)


def _import_files(a: Analysis, offset: int) -> Answer | None:
    """Inside `import "…`: the `.knit` files near the document; None elsewhere."""
    text = a.text
    line = text.rfind("\n", 0, offset) + 1
    if _IMPORT_PATH.search(text[line:offset]) is None:
        return None
    quote = text.rfind('"', line, offset)
    end = offset + 1 if text.startswith('"', offset) else offset  # an auto-closed quote
    return Answer(quote, end, list(_files(a.path)))


def _import_items(ctx: Context, path: str) -> Answer | None:
    """After `import`: modules or a module's exports; None elsewhere."""
    before, start, offset = ctx.before, ctx.start, ctx.offset
    m = _IMPORT_NAMES.search(before)
    if m is not None:
        listed = {n.strip() for n in m.group(2).split(",")}
        items = [
            Item(e.name, Kind.Function, e.name, detail=f"{e.kind} {e.signature}", doc=e.doc or None)
            for e in stdlib_exports(m.group(1))
            if e.name not in listed
        ]
        return Answer(start, offset, items)
    if _IMPORT_STD.search(before):
        return Answer(start, offset, [_module_item(n, n) for n in stdlib_modules()])
    if _IMPORT_START.search(before):
        items = [_module_item(f"std.{n}", n) for n in stdlib_modules()]
        return Answer(start, offset, items + list(_files(path)))
    return None


def _module_item(label: str, module: str) -> Item:
    exports = stdlib_exports(module)
    doc = ", ".join(e.name for e in exports)
    return Item(label, Kind.Module, label, detail=f"std.{module}", doc=doc or None)


MAX_FILES = 100
"""Most files offered after `import "` (a document in a large folder stays quick)."""


def _files(path: str) -> Iterator[Item]:
    """`.knit` files next to the document and up to two folders down, as `"dir/x.knit"`."""
    if path.startswith("<"):
        return
    me = os.path.abspath(path)
    here = os.path.dirname(me)
    found = walked = 0
    for root, dirs, files in os.walk(here):
        walked += 1
        deep = root != here and os.path.relpath(root, here).count(os.sep) >= 1
        dirs[:] = [] if deep or walked > 50 else sorted(d for d in dirs if d[:1] != ".")
        for f in sorted(files):
            full = os.path.join(root, f)
            if not f.endswith(".knit") or full == me:
                continue
            rel = os.path.relpath(full, here).replace(os.sep, "/")
            yield Item(f'"{rel}"', Kind.File, f'"{rel}"', detail="file")
            found += 1
            if found >= MAX_FILES:
                return


# ---- the protocol -----------------------------------------------------------------------------


def to_lsp(ans: Answer, a: Analysis, encoding: str = UTF16) -> types.CompletionList:
    """The answer in the client's positions: every item replaces the word being typed."""
    loc = a.locator(encoding)
    rng = loc.offsets_range(ans.start, ans.end)
    typed = a.text[ans.start : ans.end]
    items = []
    for i, item in enumerate(ans.items):
        items.append(
            types.CompletionItem(
                label=item.label,
                kind=item.kind,
                detail=item.detail,
                documentation=types.MarkupContent(types.MarkupKind.Markdown, item.doc)
                if item.doc
                else None,
                label_details=types.CompletionItemLabelDetails(description=item.note)
                if item.note
                else None,
                filter_text=_filter(item, typed),
                sort_text=f"{i:04d}",
                insert_text_format=types.InsertTextFormat.Snippet
                if item.snippet
                else types.InsertTextFormat.PlainText,
                text_edit=types.TextEdit(rng, item.insert),
                additional_text_edits=[
                    types.TextEdit(loc.offsets_range(s, e), t) for s, e, t in item.edits
                ]
                or None,
            )
        )
    return types.CompletionList(is_incomplete=False, items=items)


def _filter(item: Item, typed: str) -> str | None:
    """What the client matches the typed word against: the inserted text when it starts
    with a sigil or quote the label lacks (`#finger_w` for the label `finger_w`)."""
    if typed[:1] in ("#", "@", '"') and not item.label.startswith(typed[:1]):
        return item.insert
    return None


def _snippet_support(ls: Any) -> bool:
    """Does the client expand `${1:name}` placeholders? (Asked afresh: capabilities arrive
    with `initialize`.)"""
    value: Any = getattr(ls, "client_capabilities", None)
    for attr in ("text_document", "completion", "completion_item", "snippet_support"):
        value = getattr(value, attr, None)
    return bool(value)


def register(server: KnitServer) -> None:
    @server.feature(
        types.TEXT_DOCUMENT_COMPLETION,
        types.CompletionOptions(trigger_characters=TRIGGERS, resolve_provider=False),
    )
    async def completion(
        ls: KnitServer, params: types.CompletionParams
    ) -> types.CompletionList | None:
        a = await ls.analysis_for(params.text_document.uri)
        if a is None:
            return None
        encoding = ls.encoding
        offset = a.locator(encoding).offset(params.position)
        ans = await ls.run_safely(answer, a, offset, _snippet_support(ls), _trigger(params.context))
        return to_lsp(ans, a, encoding) if ans is not None else None


def _trigger(context: types.CompletionContext | None) -> str | None:
    """The character that asked for completion, None when the user did."""
    if context is None or context.trigger_kind != types.CompletionTriggerKind.TriggerCharacter:
        return None
    return context.trigger_character
