"""Unit tests of the parser (knitc.frontend.parser): a few per construct of knit.lark.

ASTs compare without spans, so expected trees are written without them; spans get their
own tests. The formatter's property tests (test_fmt.py) cover the combinations.
"""

from __future__ import annotations

import pytest

from knitc.frontend import ast
from knitc.frontend.ast import (
    ApplyStmt,
    Assign,
    Attr,
    Binary,
    Block,
    Bool,
    Call,
    Connect,
    ExprStmt,
    For,
    Grid,
    GridStmt,
    Ident,
    If,
    Import,
    Index,
    ItfRef,
    ItfStmt,
    KwArg,
    Let,
    ListExpr,
    MapStmt,
    Name,
    Number,
    ParamDecl,
    ParamDef,
    ParamRef,
    PatternDef,
    PatternLayer,
    Profile,
    ProfilePoint,
    Prop,
    PropRef,
    Range,
    SetStmt,
    Start,
    String,
    TupleExpr,
    Unary,
    UseStmt,
)
from knitc.frontend.parser import parse


def items(text: str) -> tuple:
    return parse(text).items


def expr(text: str):
    return items(f"param x = {text}")[0].value


def n(name: str) -> Name:
    return Name(name)


def i(name: str) -> Ident:
    return Ident(name)


def itf(node: str, path: str, index=None) -> ItfRef:
    return ItfRef(i(node), i(path), index)


def shaper_body(text: str) -> tuple:
    return items(f"shaper s() {{ {text} }}")[0].body.stmts


def layer_body(text: str) -> tuple:
    return items(f"pattern p {{ {text} }}")[0].body


def syntax_error(text: str) -> str:
    with pytest.raises(ValueError) as info:
        parse(text)
    return str(info.value)


# ---- imports and parameters ------------------------------------------------------------------


def test_import_module():
    assert items("import std.stitches") == (Import(("std", "stitches"), None, None),)


def test_import_names_with_trailing_comma():
    assert items("import std.stitches (rib, seed,)") == (
        Import(("std", "stitches"), None, (i("rib"), i("seed"))),
    )


def test_import_file():
    assert items('import "parts/lace.knit" (lace)') == (
        Import(None, "parts/lace.knit", (i("lace"),)),
    )


def test_param():
    assert items("param sleeve_len = 40\nparam w = #sleeve_len / 2") == (
        ParamDecl(i("sleeve_len"), Number(40)),
        ParamDecl(i("w"), Binary("/", ParamRef("sleeve_len"), Number(2))),
    )


# ---- machine and nodes ---------------------------------------------------------------------


def test_machine():
    (m,) = items('machine { gauge: 14, yarn: "wool" }')
    assert m == ast.MachineDecl((Prop(i("gauge"), Number(14)), Prop(i("yarn"), String("wool"))))


@pytest.mark.parametrize("kind", ["sheet", "tube", "joint", "split"])
def test_node_kinds(kind):
    assert items(f"{kind} a {{}}") == (ast.NodeDecl(kind, i("a"), ()),)


def test_props_commas_are_optional():
    with_commas = items("tube a { length: 30, width: [0: 20, 1: 12], }")
    without = items("tube a {\n  length: 30\n  width: [0: 20, 1: 12]\n}")
    assert with_commas == without
    assert with_commas[0].props[1].value == Profile(
        (ProfilePoint(Number(0), Number(20)), ProfilePoint(Number(1), Number(12)))
    )


# ---- interfaces, connections, start ----------------------------------------------------------


def test_itf_states():
    assert items("a.bottom closed b.top open c.base closed(zigzag)") == (
        ItfStmt(itf("a", "bottom"), "closed", None, None),
        ItfStmt(itf("b", "top"), "open", None, None),
        ItfStmt(itf("c", "base"), "closed", i("zigzag"), None),
    )


def test_itf_blocks():
    assert items("a.bottom closed(zigzag) { cast_on: tuck }\nb.top {}") == (
        ItfStmt(itf("a", "bottom"), "closed", i("zigzag"), (Prop(i("cast_on"), n("tuck")),)),
        ItfStmt(itf("b", "top"), None, None, ()),
    )


def test_connect_and_start():
    assert items("a.top -> s.branches[0]\nstart a.bottom") == (
        Connect(itf("a", "top"), itf("s", "branches", Number(0))),
        Start(itf("a", "bottom")),
    )


# ---- pattern layers ------------------------------------------------------------------------


def test_pattern_layer_and_definition():
    layer, definition, empty = items(
        "pattern cuff { use rib_2x2 }\npattern rib(k = 1, p) { set K }\npattern e() {}"
    )
    assert layer == PatternLayer(i("cuff"), (UseStmt(i("rib_2x2")),))
    assert definition == PatternDef(
        i("rib"), (ParamDef(i("k"), Number(1)), ParamDef(i("p"))), (SetStmt("K"),)
    )
    assert empty == PatternDef(i("e"), (), ())


@pytest.mark.parametrize(
    "instr",
    [
        "K",
        "P",
        "T",
        "M",
        "S",
        "FR1",
        "FR2",
        "FL1",
        "FL2",
        "BR1",
        "BR2",
        "BL1",
        "BL2",
        "XR+",
        "XR-",
        "XL+",
        "XL-",
    ],
)
def test_set_every_instruction(instr):
    assert layer_body(f"set {instr} where q set K") == (SetStmt(instr, n("q")), SetStmt("K"))


def test_layer_statements():
    assert layer_body(
        "use purl where side == back\napply rib(2, k = 1) where courses(0:4)\n"
        "let edge = wales(0:1)\ntile g where not edge\nstretch g draw g"
    ) == (
        UseStmt(i("purl"), Binary("==", n("side"), n("back"))),
        ApplyStmt(
            i("rib"),
            (Number(2), KwArg(i("k"), Number(1))),
            Call(n("courses"), (Range(Number(0), Number(4)),)),
        ),
        Let(i("edge"), Call(n("wales"), (Range(Number(0), Number(1)),))),
        GridStmt("tile", n("g"), Unary("not", n("edge"))),
        GridStmt("stretch", n("g")),
        GridStmt("draw", n("g")),
    )


def test_set_rejects_a_name():
    assert "E101" in syntax_error("pattern p { set purl }")


# ---- grids -----------------------------------------------------------------------------------


def test_grid_rows_and_cells():
    (stmt,) = layer_body('draw """\n  K  P\n  XR+ .\n\n  T\n"""')
    cells = [[c.text for c in row] for row in stmt.grid.rows]
    assert cells == [["K", "P"], ["XR+", "."], [], ["T"]]


def test_grid_trims_outer_empty_rows():
    assert expr('"""\n\n K \n\n"""') == Grid(((ast.GridCell("K"),),))
    assert expr('"""K P"""') == Grid(((ast.GridCell("K"), ast.GridCell("P")),))
    assert expr('""""""') == Grid(())


def test_grid_cell_spans_and_no_comments_inside():
    text = 'param g = """\n  K // P\n"""'
    module = parse(text)
    cells = module.items[0].value.rows[0]
    assert [text[c.span.start : c.span.end] for c in cells] == ["K", "//", "P"]
    assert (cells[0].span.line, cells[0].span.column) == (2, 3)
    assert module.comments == ()


# ---- actions and shapers ---------------------------------------------------------------------


def test_action():
    (action,) = items("action purl_flat { split_by_side: true pre {} main { knit() } }")
    assert action == ast.ActionDef(
        i("purl_flat"),
        (
            Prop(i("split_by_side"), Bool(True)),
            ast.ActionStep("pre", Block(())),
            ast.ActionStep("main", Block((ExprStmt(Call(n("knit"), ())),))),
        ),
    )


def test_shaper():
    (shaper,) = items("shaper zig(M, N) { for i in range(M) { i -> i } }")
    assert shaper == ast.ShaperDef(
        i("zig"),
        (ParamDef(i("M")), ParamDef(i("N"))),
        Block((For(i("i"), Call(n("range"), (n("M"),)), Block((MapStmt(n("i"), n("i")),))),)),
    )


def test_statements():
    assert shaper_body("(x, y) -> z let a = 1 b = a f(a)") == (
        MapStmt(TupleExpr((n("x"), n("y"))), n("z")),
        Let(i("a"), Number(1)),
        Assign(i("b"), n("a")),
        ExprStmt(Call(n("f"), (n("a"),))),
    )


def test_if_else_chain():
    (stmt,) = shaper_body("if a { x } else if b { y } else { }")
    assert stmt == If(
        n("a"), Block((ExprStmt(n("x")),)), If(n("b"), Block((ExprStmt(n("y")),)), Block(()))
    )


def test_newlines_do_not_separate_statements():
    # `x = a` then `-b` on the next line is one statement: the formatter relies on this
    # being the only reading, so it is pinned here.
    assert shaper_body("x = a\n-b") == (Assign(i("x"), Binary("-", n("a"), n("b"))),)


# ---- expressions -----------------------------------------------------------------------------


def test_precedence_levels():
    a, b, c = n("a"), n("b"), n("c")
    assert expr("a or b and c") == Binary("or", a, Binary("and", b, c))
    assert expr("not a and b") == Binary("and", Unary("not", a), b)
    assert expr("not a == b") == Unary("not", Binary("==", a, b))
    assert expr("a + b < c") == Binary("<", Binary("+", a, b), c)
    assert expr("a - b * c") == Binary("-", a, Binary("*", b, c))
    assert expr("-a * b") == Binary("*", Unary("-", a), b)
    assert expr("-a ^ b") == Unary("-", Binary("^", a, b))
    assert expr("a ^ -b") == Binary("^", a, Unary("-", b))
    assert expr("-a.b") == Unary("-", Attr(a, i("b")))


def test_associativity():
    a, b, c = n("a"), n("b"), n("c")
    assert expr("a - b - c") == Binary("-", Binary("-", a, b), c)
    assert expr("a / b % c") == Binary("%", Binary("/", a, b), c)
    assert expr("a ^ b ^ c") == Binary("^", a, Binary("^", b, c))
    assert expr("(a - b) == c") == expr("a - b == c")


def test_comparisons_do_not_chain():
    assert "E101" in syntax_error("param x = a < b < c")


@pytest.mark.parametrize("op", ["==", "!=", "<", "<=", ">", ">="])
def test_comparison_operators(op):
    assert expr(f"a {op} 1") == Binary(op, n("a"), Number(1))


def test_postfix_chain():
    assert expr("f(1)[2].g") == Attr(Index(Call(n("f"), (Number(1),)), Number(2)), i("g"))


def test_call_arguments():
    call = expr("f(1:2, 0:2:10, k = 3, x,)")
    assert call.args == (
        Range(Number(1), Number(2)),
        Range(Number(0), Number(10), step=Number(2)),  # `a:s:b` is start, step, stop
        KwArg(i("k"), Number(3)),
        n("x"),
    )


def test_lists_profiles_tuples():
    assert expr("[]") == ListExpr(())
    assert expr("[1, 2,]") == ListExpr((Number(1), Number(2)))
    assert expr("[0: 1]") == Profile((ProfilePoint(Number(0), Number(1)),))
    assert expr("(1,)") == TupleExpr((Number(1),))
    assert expr("(1, 2)") == TupleExpr((Number(1), Number(2)))
    assert expr("(1)") == Number(1)


def test_mixed_profile_is_an_error():
    assert "E104" in syntax_error("param x = [0: 1, 2]")


def test_a_literal_beyond_the_float_range_is_an_error():
    # `1e999` parsed to infinity, which crashed the queries (an int of it) and the formatter
    msg = syntax_error("param x = 1e999")
    assert "E110" in msg and "`1e999` is too large: the limit is ±1e+300" in msg
    assert "E110" in syntax_error("param x = 2e300")
    assert expr("1e300").value == 1e300
    assert expr("1e-999").value == 0.0  # too small is just zero


def test_numbers():
    assert expr("42") == Number(42) and isinstance(expr("42").value, int)
    assert expr("0.5").value == 0.5
    assert expr(".5").value == 0.5
    assert expr("1e-05").value == 1e-05
    assert expr("2E+3").value == 2000.0
    assert expr("-1") == Unary("-", Number(1))
    assert expr("1.x") == Attr(Number(1), i("x"))


def test_strings():
    assert expr(r'"a\"b\\c\nd\te"') == String('a"b\\c\nd\te')
    assert expr(r'"\q"') == String("q")
    assert expr('"// not a comment"') == String("// not a comment")


def test_references_and_booleans():
    assert expr("#n") == ParamRef("n")
    assert expr("@width") == PropRef(None, "width")
    assert expr("@palm.width") == PropRef("palm", "width")
    assert expr("@palm.width.half") == Attr(PropRef("palm", "width"), i("half"))
    assert expr("(@width).half") == Attr(PropRef(None, "width"), i("half"))
    assert expr("true") == Bool(True) and expr("false") == Bool(False)


# ---- contextual keywords ---------------------------------------------------------------------


def test_keywords_as_property_names():
    words = [
        "shaper",
        "start",
        "open",
        "closed",
        "set",
        "use",
        "apply",
        "where",
        "let",
        "param",
        "import",
        "machine",
        "pattern",
        "action",
        "tube",
        "draw",
        "pre",
        "K",
    ]
    (node,) = items("tube a { " + " ".join(f"{w}: {k}" for k, w in enumerate(words)) + " }")
    assert [p.name.name for p in node.props] == words


def test_shaper_and_start_properties_then_items():
    assert items("tube a { shaper: left\n start: 3 }\nstart a.bottom\nshaper s() {}") == (
        ast.NodeDecl("tube", i("a"), (Prop(i("shaper"), n("left")), Prop(i("start"), Number(3)))),
        Start(itf("a", "bottom")),
        ast.ShaperDef(i("s"), (), Block(())),
    )


def test_keywords_as_names_in_expressions():
    assert shaper_body("let x = start + shaper where = draw") == (
        Let(i("x"), Binary("+", n("start"), n("shaper"))),
        Assign(i("where"), n("draw")),
    )
    assert layer_body("let draw = 1 set K where draw draw g") == (
        Let(i("draw"), Number(1)),
        SetStmt("K", n("draw")),
        GridStmt("draw", n("g")),
    )


def test_step_words_inside_steps():
    (action,) = items("action a { pre { pre = main } }")
    assert action.items[0].body == Block((Assign(i("pre"), n("main")),))


def test_keyword_named_nodes():
    assert items(
        "tube start {}\nstart start.bottom\nstart.top -> tube.bottom\npattern.top // c\n  open"
    ) == (
        ast.NodeDecl("tube", i("start"), ()),
        Start(itf("start", "bottom")),
        Connect(itf("start", "top"), itf("tube", "bottom")),
        ItfStmt(itf("pattern", "top"), "open", None, None),
    )


def test_instruction_mnemonics_as_names():
    assert expr("K + XR - 1") == Binary("-", Binary("+", n("K"), n("XR")), Number(1))


# ---- comments, spans and errors ------------------------------------------------------------


def test_comments_are_collected_with_spans():
    text = "// one\nparam a = 1 /* two\n three */ // four\n"
    module = parse(text)
    assert [c.text for c in module.comments] == ["// one", "/* two\n three */", "// four"]
    assert [(c.span.line, c.span.column, c.span.end_line) for c in module.comments] == [
        (1, 1, 1),
        (2, 13, 3),
        (3, 11, 3),
    ]
    assert all(text[c.span.start : c.span.end] == c.text for c in module.comments)


def test_spans():
    text = "tube cuff {\n  length: 30\n}\n"
    (node,) = parse(text, "cuff.knit").items
    assert (node.span.file, node.span.line, node.span.end_line) == ("cuff.knit", 1, 3)
    prop = node.props[0]
    assert text[prop.span.start : prop.span.end] == "length: 30"
    assert (prop.name.span.line, prop.name.span.column) == (2, 3)


def test_syntax_errors():
    assert "error[E102]: unclosed `{`" in syntax_error("tube a { x: 1")
    assert "error[E105]" in syntax_error('param x = "abc')
    assert "error[E103]" in syntax_error("}")
    assert "error[E106]" in syntax_error("param x = #")
    assert "error[E100]" in syntax_error("param x = 1 $")


def test_independent_errors_reported_once_each():
    message = syntax_error("tube a { x = 1 }\nparam y = \nparam z = 3")
    assert message.count("error[") == 2
    assert "properties are written `name: value`" in message


def test_keyword_before_comments_mentioning_dots():
    # The `.` that makes a keyword-like word a name must be the very next token, not one
    # found past a comment that merely contains or precedes it.
    text = "shaper /* a */ s() {}\nx.top -> y /* b */ .bottom\nstart // see a.b\n x.bottom"
    shaper, _connect, start = items(text)
    assert shaper == ast.ShaperDef(i("s"), (), Block(()))
    assert start == Start(itf("x", "bottom"))


def test_errors_are_never_silent(monkeypatch):
    from knitc.frontend import parser

    monkeypatch.setattr(parser, "_recover", lambda source, diags: None)
    assert "error[E101]" in syntax_error("param x = = 1")


# ---- error recovery stays linear ----------------------------------------------------------------


def test_recovery_parses_the_file_about_twice(monkeypatch):
    # Error recovery parses each top-level statement on its own text: the work is the file
    # once for the first try and once more in statements, however many statements there
    # are (it used to parse the text before each statement again, blanked: quadratic).
    from knitc.frontend import parser

    lines = ["sheet a { width: 10 length: 10 }"]
    lines += [f"param x{k} = {k}" for k in range(300)]
    lines += ["sheet b { width: 3 length: }"]
    text = "\n".join(lines) + "\n"
    parsed: list[int] = []
    real = parser._parse

    def counting(chunk: str, comments: list) -> object:
        parsed.append(len(chunk))
        return real(chunk, comments)

    monkeypatch.setattr(parser, "_parse", counting)
    message = syntax_error(text)
    assert message.count("error[") == 1
    assert f"<input>:{len(lines)}:28: error[E101]" in message
    assert sum(parsed) <= 2 * len(text)


def test_long_word_before_the_end_of_the_file():
    # The last word before an unexpected end is found by scanning back, not by a regex
    # search that tried every start inside the run (quadratic: 40 KB took 24 s).
    word = "x" * 400_000
    message = syntax_error(f"param p = 1 + {word} +")
    assert f"<input>:1:{len('param p = 1 + ') + len(word) + 2}: error[E101]" in message
    assert "error[E102]: unclosed `{`" in syntax_error("sheet a { width: 10 length: " + word)


def test_many_errors_each_reported():
    # One report per broken statement, each at its own line, with no cascade.
    text = "".join(f"param p{k} = \n" for k in range(200))
    message = syntax_error(text)
    assert message.count("error[E101]") == 200
    assert "<input>:200:" in message


def test_enormous_source_line_is_clipped_around_the_caret():
    text = "param p = " + "x" * 40_000 + " $ " + "y" * 40_000
    message = syntax_error(text)
    head, source_line, caret_line = message.splitlines()[:3]
    assert head.startswith("<input>:1:40012: error[E100]")
    assert len(source_line) < 120 and len(caret_line) < 120
    assert source_line.count("…") == 2
    assert source_line[caret_line.index("^")] == "$"


# ---- the shared root scanner (frontend/scanners.py) against Lark's own contextual lexer ------


def _stock_parser():
    """The parser as Lark makes it: a compiled scanner per state (no `share_root_scanner`)."""
    from knitc.frontend import parser as ps
    from knitc.frontend import tables
    from knitc.resources import grammar_text

    options = {
        "parser": "lalr",
        "lexer": "contextual",
        "propagate_positions": True,
        "maybe_placeholders": True,
    }
    lark = tables.load_lark(grammar_text(), options, {"COMMENT": ps._on_comment})
    lark.parser.lexer = ps._ContextualKeywords(lark.parser.lexer)
    return lark


def _tokens(lark, text: str) -> object:
    """Every token the lexer hands the parser and every comment (type, text, place), then
    the error the parse stops at, if any."""
    from lark.exceptions import UnexpectedInput

    from knitc.frontend import parser as ps

    seen: list[tuple] = []
    keywords = lark.parser.lexer  # (`_ContextualKeywords`: what the parser reads)
    lex = keywords.lex

    def recording(lexer_state, parser_state):
        for tok in lex(lexer_state, parser_state):
            seen.append((tok.type, str(tok), tok.start_pos, tok.end_pos))
            yield tok

    keywords.lex = recording
    comments: list = []
    ps._comment_sink.append(comments)
    try:
        lark.parse(text)
        end: object = "parsed"
    except UnexpectedInput as exc:
        end = ("error", type(exc).__name__, exc.pos_in_stream, str(exc))
    finally:
        ps._comment_sink.pop()
        del keywords.lex
    return seen, [(c.type, str(c), c.start_pos) for c in comments], end


def _inputs() -> list[tuple[str, str]]:
    from pathlib import Path

    repo = Path(__file__).resolve().parent.parent
    files = [
        *sorted((repo / "examples").rglob("*.knit")),
        *sorted((repo / "stdlib").rglob("*.knit")),
        *sorted((repo / "tests").rglob("*.knit")),
        *sorted((repo / "tests" / "fuzz" / "corpus" / "knit").iterdir()),
    ]
    out = [
        (str(p.relative_to(repo)), p.read_text(encoding="utf-8", errors="replace")) for p in files
    ]
    # and each file cut short, so that errors in every state are compared too
    out += [(f"{n} (cut)", t[: len(t) // 2]) for n, t in out[:60]]
    return out


def test_the_shared_root_scanner_lexes_as_each_state_s_own_scanner() -> None:
    from knitc.frontend.parser import _lark

    stock, shared = _stock_parser(), _lark()
    for name, text in _inputs():
        assert _tokens(shared, text) == _tokens(stock, text), name
