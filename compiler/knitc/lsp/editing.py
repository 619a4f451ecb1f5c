"""Editing features: formatting, semantic tokens and folding ranges.

- **Formatting** is `knitc fmt`, exactly: the current text parsed by `parse_source` and
  printed by `format_module`, so that the editor and the command line never disagree. A
  text that does not parse is never formatted (a half-written statement would be lost).
  Range formatting formats the whole text too, then keeps the changes of the top-level
  items the range touches: the file is cut into regions, one per item with the comments
  and blank lines before it, in the old text and in the formatted one alike (the formatter
  keeps the items, their order and their comments' owners), so replacing any set of
  regions by their formatted selves leaves a file that still parses and agrees with the
  full formatting on those lines.
- **Semantic tokens** come from the project's own lexer (the grammar's terminals, never a
  copy of them) and what the syntax tree and the index say each name is. Lexing goes on
  where a character does not lex, so a broken file is still coloured up to and past it.
- **Folding ranges** follow the syntax tree's blocks when the text parses, else matching
  brackets, plus runs of line comments, block comments and the import block.
"""

from __future__ import annotations

import bisect
import re
from collections.abc import Callable, Iterable, Iterator
from functools import lru_cache

from lark.exceptions import UnexpectedCharacters
from lark.utils import TextSlice
from lsprotocol import types

from knitc.diagnostics import Diagnostics
from knitc.frontend import ast
from knitc.frontend import skeleton as sk
from knitc.frontend.names import (
    ACTION_FUNCTIONS,
    ACTION_WORDS,
    BUILTIN_ACTIONS,
    QUERY_FUNCTIONS,
    QUERY_WORDS,
)
from knitc.lang.evaluate import BUILTINS
from knitc.lsp.analysis import Analysis
from knitc.lsp.index import Index
from knitc.lsp.positions import UTF16, column_to_units, units
from knitc.lsp.server import KnitServer
from knitc.records import record
from knitc.shaping.stitch_graph import INSTRUCTIONS
from knitc.source import SourceFile

# ---- formatting ---------------------------------------------------------------------------


def parse_text(text: str, path: str = "<input>") -> ast.Module | None:
    """The module of `text`, as `knitc fmt` parses it (None when it does not parse).
    Compiler thread only."""
    from knitc.frontend.parser import parse_source

    return parse_source(SourceFile(path, _without_bom(text)), Diagnostics())


def _without_bom(text: str) -> str:
    """`knitc fmt` reads files as `utf-8-sig`: a leading byte-order mark is no text."""
    return text[1:] if text.startswith("\ufeff") else text


def formatted(text: str, path: str = "<input>") -> str | None:
    """`knitc fmt`'s output for `text`; None when it does not parse. Compiler thread only."""
    from knitc.frontend.fmt import format_module

    module = parse_text(text, path)
    return None if module is None else format_module(module)


@record(frozen=True)
class Replacement:
    """Code-point offsets `start`..`end` of the old text become `text`."""

    start: int
    end: int
    text: str


def format_edits(text: str, path: str = "<input>") -> list[Replacement]:
    """The whole document's formatting as one replacement ([] when already formatted or
    not parsable). Compiler thread only."""
    out = formatted(text, path)
    if out is None or out == text:
        return []
    return [Replacement(0, len(text), out)]


def range_format_edits(
    text: str, first_line: int, last_line: int, path: str = "<input>"
) -> list[Replacement]:
    """The formatting of the top-level items on 0-based lines `first_line`..`last_line`
    (inclusive). Compiler thread only."""
    old_module = parse_text(text, path)
    if old_module is None:
        return []
    from knitc.frontend.fmt import format_module

    new = format_module(old_module)
    if new == text:
        return []
    new_module = parse_text(new, path)
    if new_module is None or len(new_module.items) != len(old_module.items):
        return []  # cannot happen (the formatter keeps every item); never guess
    old_src, new_src = SourceFile(path, text), SourceFile(path, new)
    last_line = min(last_line, old_src.line_count - 1)  # past the end: the last line
    first_line = min(first_line, last_line)
    groups = _item_groups(old_module, old_src, new_module, new_src)
    old_bounds = _regions(old_src, [g[0] for g in groups])
    new_bounds = _regions(new_src, [g[1] for g in groups])
    edits = []
    for (o_first, o_last), (n_first, n_last) in zip(old_bounds, new_bounds, strict=True):
        if o_last < first_line or o_first > last_line:
            continue
        start, end = _line_offsets(old_src, o_first, o_last)
        n_start, n_end = _line_offsets(new_src, n_first, n_last)
        if text[start:end] != new[n_start:n_end]:
            edits.append(Replacement(start, end, new[n_start:n_end]))
    return edits


def _item_groups(
    old: ast.Module, old_src: SourceFile, new: ast.Module, new_src: SourceFile
) -> list[tuple[int, int]]:
    """The last 0-based line of each group of items, in the old and the new text: items
    sharing a line (in either text) are one group, since lines are what regions cut."""
    groups: list[tuple[int, int]] = []
    prev_old = prev_new = -1
    old_starts = [c.span.start for c in old.comments]  # in text order, as lexed
    new_starts = [c.span.start for c in new.comments]
    for a, b in zip(old.items, new.items, strict=True):
        o_first, o_last = _lines(old_src, a, old.comments, old_starts)
        n_first, n_last = _lines(new_src, b, new.comments, new_starts)
        if groups and (o_first <= prev_old or n_first <= prev_new):
            groups[-1] = (max(o_last, prev_old), max(n_last, prev_new))
        else:
            groups.append((o_last, n_last))
        prev_old, prev_new = groups[-1]
    return groups


def _lines(
    src: SourceFile, node: ast.Node, comments: tuple[ast.Comment, ...], starts: list[int]
) -> tuple[int, int]:
    """The 0-based first and last line of an item, down to the end of a block comment that
    starts on its lines (a region must never cut a comment in two)."""
    first, last = _line(src, node.span.start), _line(src, node.span.end)
    line_end = src.line_start(last + 2) if last + 1 < src.line_count else len(src.text)
    i = bisect.bisect_left(starts, node.span.start)
    while i < len(comments) and starts[i] < line_end:
        last = max(last, _line(src, comments[i].span.end))
        i += 1
    return first, last


def _regions(src: SourceFile, last_lines: list[int]) -> list[tuple[int, int]]:
    """Lines first..last of each group's region: from the line after the previous
    group's to its own last line; the last region runs to the end of the text."""
    out = []
    first = 0
    for i, last in enumerate(last_lines):
        end = src.line_count - 1 if i == len(last_lines) - 1 else last
        out.append((first, end))
        first = end + 1
    return out


def _line_offsets(src: SourceFile, first: int, last: int) -> tuple[int, int]:
    """The offsets of 0-based lines first..last, with the last line's newline."""
    start = src.line_start(first + 1)
    end = src.line_start(last + 2) if last + 1 < src.line_count else len(src.text)
    return start, end


def to_text_edits(a: Analysis, edits: Iterable[Replacement], encoding: str) -> list[types.TextEdit]:
    loc = a.locator(encoding)
    return [types.TextEdit(loc.offsets_range(e.start, e.end), e.text) for e in edits]


# ---- lexing ---------------------------------------------------------------------------------


@record(frozen=True)
class Tok:
    type: str
    start: int
    end: int
    value: str


def lex(text: str) -> list[Tok]:
    """Every token of `text` with comments (not blanks), by the grammar's own terminals,
    lexing on past a character that is no token. Compiler thread only (the parser's
    comment callback must not see these tokens while it parses)."""
    from knitc.frontend.parser import _lark

    lark = _lark()
    out: list[Tok] = []
    pos = 0
    while pos <= len(text):
        stream = lark.lex(TextSlice(text, pos, len(text)), dont_ignore=True)
        try:
            for t in stream:
                if t.type != "WS":
                    start = int(t.start_pos or 0)
                    out.append(Tok(t.type, start, start + len(t.value), str(t.value)))
            break
        except UnexpectedCharacters as err:
            pos = int(err.pos_in_stream or pos) + 1
    return out


# ---- semantic tokens -----------------------------------------------------------------------

TOKEN_TYPES = (
    "namespace",
    "type",
    "class",
    "enumMember",
    "function",
    "parameter",
    "variable",
    "property",
    "keyword",
    "comment",
    "string",
    "number",
    "operator",
    "macro",
)
TOKEN_MODIFIERS = ("declaration", "readonly", "defaultLibrary")
LEGEND = types.SemanticTokensLegend(list(TOKEN_TYPES), list(TOKEN_MODIFIERS))

_KEYWORDS = frozenset(
    {"STEP", "GRID_MODE", "IF", "ELSE", "FOR", "IN", "TRUE", "FALSE", "AND", "OR", "NOT"}
)
_OPERATORS = frozenset(
    {"COMP_OP", "PLUS", "MINUS", "STAR", "SLASH", "PERCENT", "CIRCUMFLEX", "EQUAL", "__ANON_0"}
)
_BY_TYPE = {"NUMBER": "number", "STRING": "string", "COMMENT": "comment", "INSTR": "macro"}
_NAME_KIND = {
    "param": "variable",
    "node": "class",
    "yarn": "variable",
    "pattern": "function",
    "action": "function",
    "shaper": "function",
    "import": "function",
}
_LIBRARY_FUNCTIONS = frozenset(QUERY_FUNCTIONS) | frozenset(ACTION_FUNCTIONS) | set(BUILTINS)
_CONSTANT_KINDS = frozenset({"param", "yarn"})
"""Names that are `readonly` (a design's constants): parameters and yarns."""


@lru_cache(maxsize=1)
def _choice_words() -> frozenset[str]:
    """Every enumerated property value (`half`, `uniform`, `zigzag`…) and context word."""
    words: set[str] = set(sk.CLOSINGS) | set(QUERY_WORDS) | set(ACTION_WORDS)
    tables = (sk.MACHINE_PROPS, sk.YARN_PROPS, sk.ITF_PROPS, sk.ACTION_PROPS)
    for table in (*tables, *sk.NODE_PROPS.values()):
        for spec in table.values():
            words.update(spec.choices)
    return frozenset(words)


@record(frozen=True)
class Semantic:
    """One classified token: offsets in the text, an index into TOKEN_TYPES, a bit set
    of TOKEN_MODIFIERS."""

    start: int
    end: int
    type: int
    modifiers: int = 0


Kinds = dict[tuple[int, int], tuple[str, tuple[str, ...]]]
"""(start, end) of a name -> its token type and modifiers, from the tree and the index."""


def _tree_kinds(module: ast.Module, index: Index) -> Kinds:
    kinds: Kinds = {}
    shapers = {s.name for s in index.symbols if s.kind == "shaper"}
    shapers |= {r.name for r in index.refs if r.kind == "shaper"}

    def put(node: ast.Node, kind: str, *mods: str) -> None:
        kinds.setdefault((node.span.start, node.span.end), (kind, mods))

    for node in module.walk():
        _classify(node, put)
    for sym in index.symbols:
        mods = ("declaration", "readonly") if sym.kind in _CONSTANT_KINDS else ("declaration",)
        kinds[(sym.span.start, sym.span.end)] = (_NAME_KIND[sym.kind], mods)
    for ref in index.refs:
        if ref.kind != "param":  # `#p` is one token, coloured whole
            ref_mods = ("readonly",) if ref.kind in _CONSTANT_KINDS else ()
            kinds[(ref.span.start, ref.span.end)] = (_NAME_KIND.get(ref.kind, "variable"), ref_mods)
    for node in module.walk():
        if isinstance(node, ast.Prop) and node.name.name == "shaper":
            value = node.value.func if isinstance(node.value, ast.Call) else node.value
            if isinstance(value, ast.Name) and value.id not in shapers:
                kinds[(value.span.start, value.span.end)] = ("enumMember", ("defaultLibrary",))
    return kinds


def _classify(node: ast.Node, put: Callable[..., None]) -> None:
    """What the syntax tree says about the names directly in `node`."""
    if isinstance(node, ast.Prop):
        put(node.name, "property")
    elif isinstance(node, ast.ItfRef):
        put(node.node, "class")
        put(node.path, "property")
    elif isinstance(node, ast.ItfStmt) and node.closing is not None:
        put(node.closing, "enumMember")
    elif isinstance(node, ast.PatternLayer):
        put(node.target, "keyword" if node.target.name in ("before", "after") else "class")
    elif isinstance(node, ast.ParamDef):
        put(node.name, "parameter", "declaration")
    elif isinstance(node, ast.KwArg):
        put(node.name, "parameter")
    elif isinstance(node, ast.Let | ast.For):
        put(node.name if isinstance(node, ast.Let) else node.var, "variable", "declaration")
    elif isinstance(node, ast.Assign):
        put(node.name, "variable")
    elif isinstance(node, ast.UseStmt):
        lib = ("defaultLibrary",) if node.action.name in BUILTIN_ACTIONS else ()
        put(node.action, "function", *lib)
    elif isinstance(node, ast.Call) and isinstance(node.func, ast.Name):
        lib = ("defaultLibrary",) if node.func.id in _LIBRARY_FUNCTIONS else ()
        put(node.func, "function", *lib)
    elif isinstance(node, ast.Attr):
        put(node.name, "property")
    elif isinstance(node, ast.Name):
        put(node, "enumMember" if node.id in _choice_words() else "variable")
    elif isinstance(node, ast.GridCell) and node.text in INSTRUCTIONS:
        put(node, "macro")


def semantic_tokens(a: Analysis, toks: list[Tok]) -> list[Semantic]:
    """Classify the tokens of `a`'s text (from `lex`), in text order."""
    kinds: Kinds = {}
    if a.module is not None and not a.stale:
        kinds = _tree_kinds(a.module, a.index)
    cells = sorted(k for k, v in kinds.items() if v[0] == "macro")
    out: list[Semantic] = []
    for i, t in enumerate(toks):
        if t.type == "GRID" and cells:
            out += _grid(t, cells)
            continue
        got = kinds.get((t.start, t.end)) or _lexical(toks, i)
        if t.type == "PROP_REF":
            out += _prop_ref(t)
        elif got is not None:
            out.append(_semantic(t.start, t.end, *got))
    return out


def _semantic(start: int, end: int, kind: str, mods: tuple[str, ...] = ()) -> Semantic:
    bits = sum(1 << TOKEN_MODIFIERS.index(m) for m in set(mods))
    return Semantic(start, end, TOKEN_TYPES.index(kind), bits)


def _grid(t: Tok, cells: list[tuple[int, int]]) -> list[Semantic]:
    """A drawn grid: its quotes as strings, its cells as instructions."""
    out = [_semantic(t.start, t.start + 3, "string")]
    out += [_semantic(s, e, "macro") for s, e in cells if t.start < s and e < t.end]
    out.append(_semantic(t.end - 3, t.end, "string"))
    return out


def _prop_ref(t: Tok) -> list[Semantic]:
    """`@prop` is a property; `@node.prop` a node (with its `@`) and a property."""
    dot = t.value.find(".")
    if dot < 0:
        return [_semantic(t.start, t.end, "property")]
    return [
        _semantic(t.start, t.start + dot, "class"),
        _semantic(t.start + dot + 1, t.end, "property"),
    ]


def _lexical(toks: list[Tok], i: int) -> tuple[str, tuple[str, ...]] | None:
    """A token's class from its type and neighbours: all there is when the text does not
    parse, and what names the tree does not (keywords, import paths)."""
    t = toks[i]
    before = toks[i - 1].type if i > 0 else ""
    after = toks[i + 1].type if i + 1 < len(toks) else ""
    if t.type in _BY_TYPE:
        return _BY_TYPE[t.type], ()
    if t.type == "GRID":
        return "string", ()
    if t.type == "PARAM_REF":
        return "variable", ("readonly",)
    if t.type in _OPERATORS:
        return "operator", ()
    word = t.type == "NAME" or t.type.startswith("KW_") or t.type in ("NODE_KIND", "STEP")
    if word and after == "COLON" and before in ("LBRACE", "COMMA", "RBRACE", "NAME", "NUMBER"):
        return "property", ()
    if t.type in ("NAME", "STEP") and before in ("KW_YARN", "KW_KNIT"):  # `knit main`: a yarn
        mods = ("declaration", "readonly") if before == "KW_YARN" else ("readonly",)
        return "variable", mods
    if t.type == "KW_KNIT" and after == "LPAR":  # `knit(needle)`: an action step's operation
        return "function", ("defaultLibrary",)
    if t.type.startswith("KW_") or t.type in _KEYWORDS:
        return "keyword", ()
    if t.type == "NODE_KIND":
        return "type", ()
    if t.type != "NAME":
        return None
    return _lexical_name(toks, i, before, after)


def _lexical_name(
    toks: list[Tok], i: int, before: str, after: str
) -> tuple[str, tuple[str, ...]] | None:
    if _in_import_path(toks, i):
        return "namespace", ()
    if before == "KW_PARAM":
        return "variable", ("declaration", "readonly")
    if before == "NODE_KIND":
        return "class", ("declaration",)
    if before in ("KW_ACTION", "KW_SHAPER") or (before == "KW_PATTERN" and after == "LPAR"):
        return "function", ("declaration",)
    if before == "KW_PATTERN":
        return "class", ()
    if before in ("KW_APPLY", "KW_USE") or after == "LPAR":
        return "function", ()
    if before == "KW_BACKING":  # `backing birdseye`: one of a fixed set of words
        return "enumMember", ()
    if toks[i].value in _choice_words():
        return "enumMember", ()
    return "variable", ()


def _in_import_path(toks: list[Tok], i: int) -> bool:
    """Is NAME `i` part of `import a.b.c`'s module path?"""
    j = i - 1
    while j >= 1 and toks[j].type == "DOT" and toks[j - 1].type == "NAME":
        j -= 2
    return j >= 0 and toks[j].type == "KW_IMPORT"


def encode(a: Analysis, tokens: list[Semantic], encoding: str = UTF16) -> list[int]:
    """LSP's relative five-integer form, one token per line of a multi-line one, columns
    and lengths in the client's code units."""
    src = a.source
    data: list[int] = []
    prev_line = prev_col = 0
    for line, col, length, tok in _pieces(src, tokens, encoding):
        delta_col = col - prev_col if line == prev_line else col
        data += [line - prev_line, delta_col, length, tok.type, tok.modifiers]
        prev_line, prev_col = line, col
    return data


def _pieces(
    src: SourceFile, tokens: list[Semantic], encoding: str
) -> Iterator[tuple[int, int, int, Semantic]]:
    """(0-based line, column, length) of each line's part of each token, in order."""
    last_end = -1
    for tok in sorted(tokens, key=lambda t: t.start):
        if tok.start < last_end or tok.end <= tok.start:
            continue  # never overlap: LSP tokens must not
        last_end = tok.end
        line, col = src.position(tok.start)
        end_line, _ = src.position(tok.end)
        for ln in range(line, end_line + 1):
            text = src.line_text(ln).rstrip("\r")
            start_col = col - 1 if ln == line else 0
            stop = tok.end - src.line_start(ln) if ln == end_line else len(text)
            stop = min(stop, len(text))
            if stop <= start_col:
                continue
            at = column_to_units(text, start_col, encoding)
            yield ln - 1, at, units(text[start_col:stop], encoding), tok


def document_tokens(a: Analysis) -> list[Semantic]:
    """The classified tokens of the document's text. Compiler thread only (it lexes)."""
    return semantic_tokens(a, lex(a.text))


def in_range(tokens: list[Semantic], start: int, end: int) -> list[Semantic]:
    return [t for t in tokens if t.end > start and t.start < end]


# ---- folding ranges ---------------------------------------------------------------------------

_BLOCKS = (
    ast.NodeDecl,
    ast.MachineDecl,
    ast.YarnDecl,
    ast.ItfStmt,
    ast.PatternLayer,
    ast.PatternDef,
    ast.ActionDef,
    ast.ActionStep,
    ast.ShaperDef,
    ast.Block,
    ast.Grid,
    ast.ListExpr,
    ast.Profile,
)


def folding_ranges(a: Analysis) -> list[types.FoldingRange]:
    """Blocks, grids, comments and the imports of `a`'s text."""
    src = a.source
    if a.module is not None and not a.stale:
        spans = [(n.span.start, n.span.end) for n in a.module.walk() if isinstance(n, _BLOCKS)]
        imports = [i for i in a.module.items if isinstance(i, ast.Import)]
        import_lines = [(_line(src, i.span.start), _line(src, i.span.end)) for i in imports]
    else:
        spans = _bracket_pairs(src.text)
        import_lines = _import_lines(src)
    seen: set[int] = set()
    out: list[types.FoldingRange] = []
    for start, end in sorted(spans, key=lambda s: (s[0], -s[1])):
        fold = _block_fold(src, start, end)
        if fold is not None and fold[0] not in seen:
            seen.add(fold[0])
            out.append(types.FoldingRange(fold[0], fold[1]))
    if import_lines and import_lines[-1][1] > import_lines[0][0]:
        first, last = import_lines[0][0], import_lines[-1][1]
        out.append(types.FoldingRange(first, last, kind=types.FoldingRangeKind.Imports))
    out += _comment_folds(src)
    return sorted(out, key=lambda f: (f.start_line, f.end_line))


def _line(src: SourceFile, offset: int) -> int:
    return src.position(offset)[0] - 1


def _block_fold(src: SourceFile, start: int, end: int) -> tuple[int, int] | None:
    """Lines to fold for a block from `start` to `end` (its closing bracket or quotes):
    the closing line stays visible when the closer begins it."""
    closer = end - 3 if src.text.startswith('"""', end - 3) else max(end - 1, start)
    first, last = _line(src, start), _line(src, closer)
    if last <= first:
        return None
    col = src.position(closer)[1] - 1
    if not src.line_text(last + 1)[:col].strip():
        last -= 1
    return (first, last) if last > first else None


def _bracket_pairs(text: str) -> list[tuple[int, int]]:
    """(opening offset, offset after the closer) of each matched bracket and grid, skipping
    strings and comments: the blocks of a text that does not parse."""
    from knitc.frontend.parser import _skip_literal

    pairs: list[tuple[int, int]] = []
    stack: list[tuple[str, int]] = []
    closers = {"}": "{", ")": "(", "]": "["}
    i = 0
    while i < len(text):
        skipped = _skip_literal(text, i)
        if skipped is not None:
            if text.startswith('"""', i):
                pairs.append((i, skipped))
            i = skipped
            continue
        ch = text[i]
        if ch in "{([":
            stack.append((ch, i))
        elif ch in closers and stack and stack[-1][0] == closers[ch]:
            pairs.append((stack.pop()[1], i + 1))
        i += 1
    return pairs


_IMPORT = re.compile(r"[ \t]*import\b")


def _import_lines(src: SourceFile) -> list[tuple[int, int]]:
    """The first run of lines that start with `import` (blank lines and comments between
    them allowed): the import block of a text that does not parse."""
    found: list[tuple[int, int]] = []
    for ln in range(1, src.line_count + 1):
        text = src.line_text(ln)
        if _IMPORT.match(text):
            found.append((ln - 1, ln - 1))
        elif found and text.strip() and not text.strip().startswith("//"):
            break
    return found


def _comment_folds(src: SourceFile) -> list[types.FoldingRange]:
    """Runs of two or more lines that are only a `//` comment; multi-line block comments."""
    from knitc.frontend.parser import _skip_literal

    out: list[types.FoldingRange] = []
    text = src.text
    run: list[int] = []
    i = 0
    while i < len(text):
        skipped = _skip_literal(text, i)
        if skipped is None:
            i += 1
            continue
        if text.startswith("//", i):
            ln = _line(src, i)
            own_line = not src.line_text(ln + 1)[: i - src.line_start(ln + 1)].strip()
            if own_line:
                if run and run[-1] != ln - 1:
                    _close_run(run, out)
                run.append(ln)
        elif text.startswith("/*", i) and _line(src, skipped) > _line(src, i):
            out.append(_comment_range(_line(src, i), _line(src, skipped)))
        i = skipped
    _close_run(run, out)
    return out


def _close_run(run: list[int], out: list[types.FoldingRange]) -> None:
    if len(run) >= 2:
        out.append(_comment_range(run[0], run[-1]))
    run.clear()


def _comment_range(first: int, last: int) -> types.FoldingRange:
    return types.FoldingRange(first, last, kind=types.FoldingRangeKind.Comment)


# ---- the handlers ------------------------------------------------------------------------------


def register(server: KnitServer) -> None:
    @server.feature(types.TEXT_DOCUMENT_FORMATTING)
    async def formatting(
        ls: KnitServer, params: types.DocumentFormattingParams
    ) -> list[types.TextEdit] | None:
        a = await ls.analysis_for(params.text_document.uri)
        if a is None:
            return None
        edits = await ls.run_safely(format_edits, a.text, a.path)
        return to_text_edits(a, edits or [], ls.encoding)

    @server.feature(types.TEXT_DOCUMENT_RANGE_FORMATTING)
    async def range_formatting(
        ls: KnitServer, params: types.DocumentRangeFormattingParams
    ) -> list[types.TextEdit] | None:
        a = await ls.analysis_for(params.text_document.uri)
        if a is None:
            return None
        first, last = params.range.start.line, params.range.end.line
        if last > first and params.range.end.character == 0:
            last -= 1  # a selection of whole lines ends at the next line's start
        edits = await ls.run_safely(range_format_edits, a.text, first, last, a.path)
        return to_text_edits(a, edits or [], ls.encoding)

    async def tokens_of(ls: KnitServer, uri: str) -> tuple[Analysis, list[Semantic]] | None:
        a = await ls.analysis_for(uri)
        if a is None:
            return None
        toks = await ls.run_safely(document_tokens, a)
        return a, toks or []

    @server.feature(types.TEXT_DOCUMENT_SEMANTIC_TOKENS_FULL, LEGEND)
    async def tokens_full(
        ls: KnitServer, params: types.SemanticTokensParams
    ) -> types.SemanticTokens | None:
        got = await tokens_of(ls, params.text_document.uri)
        if got is None:
            return None
        return types.SemanticTokens(data=encode(got[0], got[1], ls.encoding))

    @server.feature(types.TEXT_DOCUMENT_SEMANTIC_TOKENS_RANGE, LEGEND)
    async def tokens_range(
        ls: KnitServer, params: types.SemanticTokensRangeParams
    ) -> types.SemanticTokens | None:
        got = await tokens_of(ls, params.text_document.uri)
        if got is None:
            return None
        a, toks = got
        loc = a.locator(ls.encoding)
        start, end = loc.offset(params.range.start), loc.offset(params.range.end)
        return types.SemanticTokens(data=encode(a, in_range(toks, start, end), ls.encoding))

    @server.feature(types.TEXT_DOCUMENT_FOLDING_RANGE)
    async def folding(
        ls: KnitServer, params: types.FoldingRangeParams
    ) -> list[types.FoldingRange] | None:
        a = await ls.analysis_for(params.text_document.uri)
        if a is None:
            return None
        return await ls.run_safely(folding_ranges, a) or []
