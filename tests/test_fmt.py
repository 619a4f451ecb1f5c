"""Tests of the canonical formatter (knitc.frontend.fmt).

Three kinds: property tests on random ASTs (the formatter prints what the parser reads back,
and is idempotent), comment tests (every comment survives exactly once, wherever it was
written), and golden files under tests/golden/fmt/ that pin the style itself. Set
KNITC_UPDATE_GOLDEN=1 to rewrite the `.expected` files after a deliberate style change.
"""

from __future__ import annotations

import os
import re
from collections import Counter
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from golden import assert_golden
from knitc.frontend import ast
from knitc.frontend.fmt import format_expr, format_layer_stmt, format_module
from knitc.frontend.parser import parse
from strategies import exprs, modules

REPO = Path(__file__).resolve().parents[1]
GOLDEN = REPO / "tests" / "golden" / "fmt"
# KNITC_FMT_EXAMPLES=5000 for a long run; the default keeps this file at a few seconds.
EXAMPLES = int(os.environ.get("KNITC_FMT_EXAMPLES", "200"))
FAST = settings(
    max_examples=EXAMPLES,
    deadline=None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large],
)


def fmt(text: str) -> str:
    return format_module(parse(text))


def comment_texts(module: ast.Module) -> Counter[str]:
    return Counter(c.text for c in module.comments)


def assert_stable(text: str) -> str:
    """Format `text`; check meaning, comments and idempotence; return the formatted text."""
    before = parse(text)
    out = format_module(before)
    after = parse(out, "<formatted>")
    assert after == before, out
    assert comment_texts(after) == comment_texts(before), out
    assert format_module(after) == out, out
    return out


# ---- properties on generated trees ----------------------------------------------------------


@FAST
@given(modules())
def test_round_trip(module):
    out = format_module(module)
    assert parse(out) == module, out


@FAST
@given(modules())
def test_idempotent(module):
    out = format_module(module)
    assert format_module(parse(out)) == out
    check_layout(out)


@FAST
@given(exprs())
def test_expr_round_trip(expr):
    text = format_expr(expr)
    module = parse(f"param x = {text}")
    assert module.items[0].value == expr, text


def check_layout(out: str) -> None:
    """One final newline, no trailing spaces, no runs of blank lines, none inside braces."""
    assert out == "" or (out.endswith("\n") and not out.endswith("\n\n"))
    for line in out.split("\n"):
        assert line == line.rstrip(" "), repr(line)
    layout = re.sub(r'"""(.|\n)*?"""', "GRID", out)  # grids keep their empty rows
    assert "\n\n\n" not in layout
    assert "{\n\n" not in layout and "\n\n}" not in layout.replace(" ", "")


def _boundaries(module: ast.Module, text: str) -> list[int]:
    """Offsets between two tokens: where every node starts and ends (grid cells aside)."""
    points = {0, len(text)}
    for item in module.items:
        for node in item.walk():
            if not isinstance(node, ast.GridCell):
                points.update((node.span.start, node.span.end))
    return sorted(points)


@settings(FAST, max_examples=max(EXAMPLES // 2, 1))
@given(modules(min_items=1), st.data())
def test_comments_anywhere(module, data):
    """Comments put between any two tokens of formatted code: none lost, none duplicated."""
    text = format_module(module)
    parsed = parse(text)
    points = _boundaries(parsed, text)
    chosen = data.draw(st.lists(st.integers(0, len(points) - 1), min_size=1, max_size=6))
    pieces, last = [], 0
    for n, pos in enumerate(sorted(points[i] for i in chosen)):
        style = data.draw(st.sampled_from(("line", "block", "multiline", "indented")))
        if style == "line":
            comment = f" // c{n}\n"
        elif style == "block":
            comment = f" /* c{n} */ "
        elif style == "multiline":
            comment = f"\n/* c{n}\n */ "
        else:  # on its own line, maybe under a trailing comment: a continuation
            comment = "\n" + " " * data.draw(st.integers(0, 12)) + f"// c{n}\n"
        pieces += [text[last:pos], comment]
        last = pos
    pieces.append(text[last:])
    commented = "".join(pieces)
    assert parse(commented) == module
    out = assert_stable(commented)
    assert len(parse(out).comments) == len(chosen)


# ---- comments in hand-written sources --------------------------------------------------------

COMMENTED = [
    # before, after and between items; blank lines around them
    """// header
/* block
   header */

import std.stitches (rib) // trailing
// between

param n = 3 /* trailing block */ // and a line
// at the end
""",
    # inside property blocks: after `{`, between, trailing, dangling, after `}`
    """tube cuff { // after brace
  length: 30, // after length
  /* before width */ width: @palm.width /* c */ /* d */
  // dangling
} // after the node
sheet s { /* only a comment */ }
machine { gauge: /* inside a value */ 14 }
""",
    # inside headers and expressions: moved in front of the item
    """tube /* kw */ cuff { length: 1 }
a.bottom /* state */ closed(zigzag /* mode */) { cast_on: tuck } // t
param x = f(1, /* arg */ 2) + [0: 1, /* pt */ 1: 2]
a.top /* arrow */ -> b.bottom // connect
start /* start */ a.bottom
import /* imp */ "lace.knit"
""",
    # layer blocks and grids
    """pattern cuff { // p
  set K where wales(1:2:3, /* arg */ step = 2)

  // before draw


  draw \"\"\"
   K P // not a comment
  \"\"\" where true // after draw
  apply rib(1 /* a */, 2) // apply
  // end of pattern
}
pattern rib(k = 1 /* default */, p) { /* empty */ }
""",
    # statements: if/else chains, loops, actions
    """shaper z(M, N) {
  for i in range(M) { i -> i /* map */ } // for
  if a { b } // after then
  else /* else */ if c { d } else { e // e
  }
  x = 1 /* multi
  line */ y = 2
  // last
}
action a { x: 1 pre /* p */ {} main { y } /* z */ }
action b { /* nothing */ }
""",
    # comment-only file, and comments at the very end without a newline
    "// only\n\n\n/* comments */",
    "param a = 1 // no newline at end",
]


@pytest.mark.parametrize("text", COMMENTED)
def test_comments_preserved(text):
    assert_stable(text)


def test_trailing_comment_continuation():
    text = "param a = 1    // one\n               // two\n// three\nparam b = 2\n"
    assert fmt(text) == "param a = 1  // one\n             // two\n// three\nparam b = 2\n"
    assert_stable(text)


def test_comment_placement():
    out = fmt("tube cuff { length: 30 /* c */ }\nparam x = 1 + /* inside */ 2 // t\n")
    assert out == ("tube cuff {\n  length: 30  /* c */\n}\n/* inside */\nparam x = 1 + 2  // t\n")


# ---- style details ---------------------------------------------------------------------------


@pytest.mark.parametrize(
    "source, expected",
    [
        ("a + b * c", "a + b * c"),
        ("(a + b) * c", "(a + b) * c"),
        ("a - (b - c)", "a - (b - c)"),
        ("(a - b) - c", "a - b - c"),
        ("a ^ b ^ c", "a ^ b ^ c"),
        ("(a ^ b) ^ c", "(a ^ b) ^ c"),
        ("(-a) ^ b", "(-a) ^ b"),
        ("-(a ^ b)", "-a ^ b"),
        ("a ^ -b", "a ^ -b"),
        ("- - a", "-(-a)"),
        ("-(-1)", "-(-1)"),
        ("a - -b", "a - -b"),
        ("not not a", "not not a"),
        ("(not a) == b", "(not a) == b"),
        ("not (a == b)", "not a == b"),
        ("(a < b) == c", "(a < b) == c"),
        ("(a or b) and c", "(a or b) and c"),
        ("a or (b and c)", "a or b and c"),
        ("(a and b) or c", "a and b or c"),
        ("(-a).b", "(-a).b"),
        ("(@a).b", "(@a).b"),
        ("@n.a.b", "@n.a.b"),
        ("(a + b)(c)[d]", "(a + b)(c)[d]"),
        ("f(1:3, 1:2:9, k=1, )", "f(1:3, 1:2:9, k = 1)"),
        ("[0:20,1:12]", "[0: 20, 1: 12]"),
        ("[ ]", "[]"),
        ("(1, )", "(1,)"),
        ("(1,2)", "(1, 2)"),
        ("0.5", "0.5"),
        ("1e-5", "1e-05"),
        ("1.0E3", "1000.0"),
        ("007", "7"),
        (".25", "0.25"),
        ('"a\\"b\\\\c\\nd\\te\\q"', '"a\\"b\\\\c\\nd\\teq"'),
    ],
)
def test_expression_style(source, expected):
    expr = parse(f"param x = {source}").items[0].value
    assert format_expr(expr) == expected
    assert parse(f"param x = {expected}").items[0].value == expr


def test_one_line_block_width():
    props = ", ".join(f"p{i}: {i}" for i in range(12))
    head = "tube t"
    head += "x" * (100 - len(f"{head} {{ {props} }}"))
    exact = f"{head} {{ {props} }}"
    assert len(exact) == 100
    assert fmt(exact) == exact + "\n"
    over = fmt(f"{head}x {{ {props} }}")
    assert over.splitlines()[:3] == [f"{head}x {{", "  p0: 0", "  p1: 1"]
    assert over.endswith("  p11: 11\n}\n")


def test_blank_lines():
    text = "param a = 1\n\n\n\nparam b = 2\nparam c = 3\n\n// c\n\nparam d = 4\n"
    assert fmt(text) == "param a = 1\n\nparam b = 2\nparam c = 3\n\n// c\n\nparam d = 4\n"
    assert fmt("shaper s() {\n\n  a\n\n\n  b\n\n}") == "shaper s() {\n  a\n\n  b\n}\n"


def test_empty():
    assert fmt("") == ""
    assert fmt("\n\n  \n") == ""
    assert fmt("tube a {}\npattern p {}\naction x {}\nshaper s() {}") == (
        "tube a {}\npattern p {}\naction x {}\nshaper s() {}\n"
    )


def test_format_expr_is_for_arguments_too():
    call = parse("param x = f(1:2, a = 3)").items[0].value
    assert [format_expr(a) for a in call.args] == ["1:2", "a = 3"]


def test_rejects_unprintable_numbers():
    with pytest.raises(ValueError):
        format_expr(ast.Number(float("inf")))


@pytest.mark.parametrize(
    "path",
    sorted((REPO / "examples").glob("*.knit")) + sorted((REPO / "stdlib").rglob("*.knit")),
    ids=lambda p: p.name,
)
def test_repository_sources_are_stable(path: Path):
    assert_stable(path.read_text(encoding="utf-8"))


# ---- golden files ----------------------------------------------------------------------------


def _golden_inputs() -> list[Path]:
    return sorted(GOLDEN.glob("*.knit"))


def test_golden_files_exist():
    assert len(_golden_inputs()) >= 3
    for path in _golden_inputs():
        assert path.with_suffix(".expected").exists(), f"{path.name} has no .expected file"


@pytest.mark.parametrize("path", _golden_inputs(), ids=lambda p: p.name)
def test_golden(path: Path):
    expected_path = path.with_suffix(".expected")
    actual = assert_stable(path.read_text(encoding="utf-8"))
    assert_golden(expected_path, actual, f"format({path.name})")
    # The expected output is itself canonical.
    expected = expected_path.read_text(encoding="utf-8")
    assert fmt(expected) == expected


def test_format_layer_stmt():
    body = (
        parse('pattern p {\n  apply rib(2,2) where courses(0:4)\n  draw """\nK P\n"""\n}')
        .items[0]
        .body
    )
    assert format_layer_stmt(body[0]) == "apply rib(2, 2) where courses(0:4)"
    assert format_layer_stmt(body[1], "  ") == '  draw """\n    K P\n  """'


@pytest.mark.parametrize(
    "path",
    sorted(
        [
            *Path(__file__).parent.parent.joinpath("examples").rglob("*.knit"),
            *Path(__file__).parent.parent.joinpath("stdlib").rglob("*.knit"),
        ]
    ),
    ids=str,
)
def test_shipped_sources_are_canonical(path: Path) -> None:
    """Examples and stdlib are documentation: they are kept in `knitc fmt` form."""
    text = path.read_text(encoding="utf-8")
    assert format_module(parse(text, str(path))) == text, f"run: knitc fmt -i {path}"
