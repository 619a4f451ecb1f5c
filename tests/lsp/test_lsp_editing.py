"""Formatting, semantic tokens and folding ranges, through the real server (UTF-16
positions), and the pure functions behind them in-process."""

from __future__ import annotations

from collections.abc import Sequence

from lsp_session import Session
from lsprotocol import types

from knitc.frontend.fmt import format_module
from knitc.frontend.parser import parse
from knitc.lsp import editing
from knitc.lsp.analysis import analyse
from knitc.lsp.positions import UTF16, units_to_column
from knitc.lsp.settings import Settings

MESSY = (
    "// é 🧶 a tube\n"
    "tube   body{length:10 width:8}\n"
    "\n\n\n"
    "param w=3   // é 🧶\n"
    "pattern body { set P where courses(0:end)\n"
    "   }\n"
    "tube  cuff {length : 4\n"
    "width: #w}\n"
)

BROKEN = "tube body {\n  length: 10\n  width: \n}\npattern body { apply rib( }\n"


def doc(uri: str) -> types.TextDocumentIdentifier:
    return types.TextDocumentIdentifier(uri=uri)


def apply(text: str, edits: Sequence[types.TextEdit]) -> str:
    """`text` with LSP edits (UTF-16 positions) applied, last first."""
    lines = text.split("\n")
    starts = [0]
    for line in lines[:-1]:
        starts.append(starts[-1] + len(line) + 1)

    def offset(p: types.Position) -> int:
        if p.line >= len(lines):
            return len(text)
        return starts[p.line] + units_to_column(lines[p.line], p.character, UTF16)

    spans = sorted((offset(e.range.start), offset(e.range.end), e.new_text) for e in edits)
    for start, end, new in reversed(spans):
        text = text[:start] + new + text[end:]
    return text


def empty(got: Sequence[object] | None) -> bool:
    """An answer, and no items in it (the client gives lists as tuples)."""
    return got is not None and len(got) == 0


def fmt(text: str) -> str:
    return format_module(parse(text))


# ---- formatting -------------------------------------------------------------------------------


async def test_formatting_is_knitc_fmt_and_nothing_on_formatted_or_broken_text(session: Session):
    uri = session.open("messy.knit", MESSY)
    edits = await session.client.text_document_formatting_async(
        types.DocumentFormattingParams(doc(uri), types.FormattingOptions(2, True))
    )
    assert edits is not None and len(edits) == 1
    assert apply(MESSY, edits) == fmt(MESSY)

    session.replace_all(uri, fmt(MESSY))
    again = await session.client.text_document_formatting_async(
        types.DocumentFormattingParams(doc(uri), types.FormattingOptions(2, True))
    )
    assert empty(again)

    bad = session.open("bad.knit", BROKEN)
    broken = await session.client.text_document_formatting_async(
        types.DocumentFormattingParams(doc(bad), types.FormattingOptions(2, True))
    )
    assert empty(broken)


async def test_range_formatting_touches_only_the_items_in_the_range(session: Session):
    uri = session.open("messy.knit", MESSY)
    # the range: `param w=3` (line 5) to inside the pattern (line 6)
    rng = types.Range(types.Position(5, 3), types.Position(6, 5))
    edits = await session.client.text_document_range_formatting_async(
        types.DocumentRangeFormattingParams(doc(uri), rng, types.FormattingOptions(2, True))
    )
    assert edits
    out = apply(MESSY, edits)
    parse(out)  # still a valid design
    full = fmt(MESSY)
    # the first and the last item are as they were, the two in the range as formatted
    assert out.startswith("// é 🧶 a tube\ntube   body{length:10 width:8}\n")
    assert out.endswith("tube  cuff {length : 4\nwidth: #w}\n")
    middle = "\nparam w = 3  // é 🧶\npattern body {\n  set P where courses(0:end)\n}\n"
    assert middle in full and middle in out
    assert fmt(out) == full

    # a range past the end of the text: the last item only, no error
    past = types.Range(types.Position(40, 0), types.Position(50, 3))
    tail = await session.client.text_document_range_formatting_async(
        types.DocumentRangeFormattingParams(doc(uri), past, types.FormattingOptions(2, True))
    )
    assert tail is not None
    assert apply(MESSY, tail).endswith("tube cuff { length: 4, width: #w }\n")


def test_range_formatting_keeps_items_that_share_a_line_together():
    text = "param a=1 param b=2\nparam   c=3 /* x\n y */\nparam d=4\n"
    edits = editing.range_format_edits(text, 1, 1)
    out = text
    for e in sorted(edits, key=lambda e: e.start, reverse=True):
        out = out[: e.start] + e.text + out[e.end :]
    parse(out)
    assert out.startswith("param a=1 param b=2\n") and out.endswith("param d=4\n")
    assert "param c = 3" in out
    assert fmt(out) == fmt(text)


# ---- semantic tokens ---------------------------------------------------------------------------

DESIGN = (
    "/* é 🧶 */ param w = 8  // é 🧶\n"  # 0
    "tube body {\n"  # 1
    "  length: 10  /* a\n"  # 2
    "  block */ width: #w\n"  # 3
    "}\n"  # 4
    "pattern body {\n"  # 5
    '  draw """\n'  # 6
    "    K P\n"  # 7
    "    P K\n"  # 8
    '  """ where side(front)\n'  # 9
    "}\n"
)


def decode(data: Sequence[int]) -> list[tuple[int, int, int, str, set[str]]]:
    """(line, character, length, type, modifiers) of each token of LSP's relative form."""
    out = []
    line = col = 0
    for i in range(0, len(data), 5):
        dl, dc, length, kind, mods = data[i : i + 5]
        line += dl
        col = col + dc if dl == 0 else dc
        names = {m for b, m in enumerate(editing.TOKEN_MODIFIERS) if mods >> b & 1}
        out.append((line, col, length, editing.TOKEN_TYPES[kind], names))
    return out


async def test_semantic_tokens_in_utf16_one_per_line(session: Session):
    uri = session.open("design.knit", DESIGN)
    got = await session.client.text_document_semantic_tokens_full_async(
        types.SemanticTokensParams(doc(uri))
    )
    assert got is not None
    tokens = decode(got.data)
    plain = [t[:4] for t in tokens]
    # `/* é 🧶 */ ` is 10 code points but 11 UTF-16 units (🧶 is two)
    assert plain[:6] == [
        (0, 0, 10, "comment"),
        (0, 11, 5, "keyword"),
        (0, 17, 1, "variable"),
        (0, 19, 1, "operator"),
        (0, 21, 1, "number"),
        (0, 24, 7, "comment"),
    ]
    assert tokens[2][4] == {"declaration", "readonly"}
    assert (1, 0, 4, "type") in plain and (1, 5, 4, "class") in plain
    assert (2, 2, 6, "property") in plain and (2, 10, 2, "number") in plain
    assert (2, 14, 4, "comment") in plain and (3, 0, 10, "comment") in plain
    assert (3, 11, 5, "property") in plain and (3, 18, 2, "variable") in plain
    assert (5, 0, 7, "keyword") in plain and (5, 8, 4, "class") in plain
    assert (6, 2, 4, "keyword") in plain and (6, 7, 3, "string") in plain
    assert [t for t in plain if t[3] == "macro"] == [
        (7, 4, 1, "macro"),
        (7, 6, 1, "macro"),
        (8, 4, 1, "macro"),
        (8, 6, 1, "macro"),
    ]
    assert (9, 2, 3, "string") in plain and (9, 12, 4, "function") in plain
    assert (9, 17, 5, "enumMember") in plain
    assert all(length > 0 for _, _, length, _, _ in tokens)

    part = await session.client.text_document_semantic_tokens_range_async(
        types.SemanticTokensRangeParams(
            doc(uri), types.Range(types.Position(7, 0), types.Position(8, 99))
        )
    )
    assert part is not None
    assert [t[:4] for t in decode(part.data)] == [t for t in plain if t[3] == "macro"]


def test_semantic_tokens_of_a_broken_text_lex_on_past_the_mistake():
    text = "tube x { ; shaper: left $ width: 8 }\npattern x { apply rib( }\n/* open"
    a = analyse("file:///t/x.knit", 1, "/t/x.knit", text, Settings())
    toks = editing.lex(text)
    sem = editing.semantic_tokens(a, toks)
    kinds = {text[s.start : s.end]: editing.TOKEN_TYPES[s.type] for s in sem}
    assert kinds["tube"] == "type" and kinds["x"] == "class"
    assert kinds["shaper"] == "property" and kinds["width"] == "property"
    assert kinds["8"] == "number" and kinds["rib"] == "function"
    assert editing.encode(a, sem)  # encodes without error


def test_keywords_used_as_names_follow_the_tree():
    text = "tube start { length: 2, width: 2, shaper: left }\nstart.top open\nstart start.bottom\n"
    a = analyse("file:///t/s.knit", 1, "/t/s.knit", text, Settings())
    sem = editing.semantic_tokens(a, editing.lex(text))
    got = [(text[s.start : s.end], editing.TOKEN_TYPES[s.type]) for s in sem]
    assert ("shaper", "property") in got and ("left", "enumMember") in got
    assert got.count(("start", "class")) == 3 and got.count(("start", "keyword")) == 1


STRIPES = (
    "yarn red { carrier: 5 }\n"
    "yarn main {\n"
    "  carrier: 3\n"
    "}\n"
    "tube t { length: 4, width: 4 }\n"
    "pattern t { knit red where courses(0:1) knit main }\n"
    "action a { main { knit(dir) } }\n"
)


def _classes(text: str) -> list[tuple[str, str, set[str]]]:
    """(text, type, modifiers) of each semantic token of `text`, in order."""
    a = analyse("file:///t/y.knit", 1, "/t/y.knit", text, Settings())
    return [
        (
            text[s.start : s.end],
            editing.TOKEN_TYPES[s.type],
            {m for b, m in enumerate(editing.TOKEN_MODIFIERS) if s.modifiers >> b & 1},
        )
        for s in editing.semantic_tokens(a, editing.lex(text))
    ]


def test_yarns_are_constants_and_knit_is_a_keyword_only_in_a_layer():
    declared = ("variable", {"declaration", "readonly"})
    used = ("variable", {"readonly"})
    want = [
        ("yarn", "keyword", set()),
        ("red", *declared),
        ("yarn", "keyword", set()),
        ("main", *declared),  # a yarn, not the action step
        ("knit", "keyword", set()),
        ("red", *used),
        ("knit", "keyword", set()),
        ("main", *used),
        ("main", "keyword", set()),  # the action step
        ("knit", "function", {"defaultLibrary"}),
    ]
    words = {"yarn", "knit", "red", "main"}
    got = [t for t in _classes(STRIPES) if t[0] in words]
    assert got == want
    # the same from the tokens alone, when the text does not parse
    broken = [t for t in _classes(STRIPES + "tube x { ; }\n") if t[0] in words]
    assert broken == want


# ---- folding ranges ---------------------------------------------------------------------------


async def test_folding_ranges_of_the_glove(session: Session, glove_text: str):
    uri = session.open("glove.knit", glove_text)
    got = await session.client.text_document_folding_range_async(types.FoldingRangeParams(doc(uri)))
    assert got is not None
    folds = {(f.start_line, f.end_line, f.kind) for f in got}
    comment = types.FoldingRangeKind.Comment
    lines = glove_text.split("\n")
    assert (0, 23, comment) in folds  # the header comment
    palm = lines.index("tube palm {")
    assert (palm, palm + 3, None) in folds  # up to the line before its `}`
    hand = lines.index("pattern hand {")
    assert (hand, hand + 5, None) in folds  # the layer block
    assert (hand + 1, hand + 4, None) in folds  # the grid, its closing quotes stay visible
    # single-line blocks and lone comment lines do not fold
    machine = next(i for i, line in enumerate(lines) if line.startswith("machine"))
    assert not any(f.start_line == machine for f in got)


async def test_folding_of_a_broken_text_and_imports_by_brackets(session: Session):
    text = (
        "import std.stitches (rib)\n"
        "import std.motifs\n"
        "// one\n// two\n"
        "tube body {\n  length: 10\n  width: \n}\n"
        "pattern body {\n  apply rib(\n}\n"
    )
    uri = session.open("bad.knit", text)
    got = await session.client.text_document_folding_range_async(types.FoldingRangeParams(doc(uri)))
    assert got is not None
    folds = {(f.start_line, f.end_line, f.kind) for f in got}
    assert (0, 1, types.FoldingRangeKind.Imports) in folds
    assert (2, 3, types.FoldingRangeKind.Comment) in folds
    assert (4, 6, None) in folds


def test_a_yarn_block_folds():
    a = analyse("file:///t/y.knit", 1, "/t/y.knit", STRIPES, Settings())
    assert {(f.start_line, f.end_line) for f in editing.folding_ranges(a)} == {(1, 2)}


def test_folding_from_the_tree_has_the_imports_and_shaper_blocks():
    text = (
        "import std.stitches (rib)\nimport std.actions\n\n"
        "shaper s(M, N) {\n  for i in range(M) {\n    i -> i\n  }\n}\n"
        "/* a\n   b */\n"
    )
    a = analyse("file:///t/f.knit", 1, "/t/f.knit", text, Settings())
    folds = {(f.start_line, f.end_line, f.kind) for f in editing.folding_ranges(a)}
    assert folds == {
        (0, 1, types.FoldingRangeKind.Imports),
        (3, 6, None),
        (4, 5, None),
        (8, 9, types.FoldingRangeKind.Comment),
    }


# ---- never a failure -------------------------------------------------------------------------


async def test_every_editing_request_answers_on_broken_unopened_and_odd_input(session: Session):
    uri = session.open("bad.knit", BROKEN + "tube 🧶 { width: é }\n")
    await session.diagnostics(uri, lambda d: len(d) > 0)
    c = session.client
    opts = types.FormattingOptions(2, True)
    far = types.Range(types.Position(99, 99), types.Position(120, 0))
    assert empty(
        await c.text_document_formatting_async(types.DocumentFormattingParams(doc(uri), opts))
    )
    assert empty(
        await c.text_document_range_formatting_async(
            types.DocumentRangeFormattingParams(doc(uri), far, opts)
        )
    )
    tokens = await c.text_document_semantic_tokens_full_async(types.SemanticTokensParams(doc(uri)))
    assert tokens is not None and tokens.data
    ranged = await c.text_document_semantic_tokens_range_async(
        types.SemanticTokensRangeParams(doc(uri), far)
    )
    assert ranged is not None and len(ranged.data) == 0
    assert await c.text_document_folding_range_async(types.FoldingRangeParams(doc(uri)))

    blank = session.open("empty.knit", "")
    assert empty(
        await c.text_document_formatting_async(types.DocumentFormattingParams(doc(blank), opts))
    )
    got = await c.text_document_semantic_tokens_full_async(types.SemanticTokensParams(doc(blank)))
    assert got is not None and len(got.data) == 0
    assert empty(await c.text_document_folding_range_async(types.FoldingRangeParams(doc(blank))))

    never = session.uri("never-opened.knit")
    assert (
        await c.text_document_formatting_async(types.DocumentFormattingParams(doc(never), opts))
        is None
    )
    assert await c.text_document_folding_range_async(types.FoldingRangeParams(doc(never))) is None
