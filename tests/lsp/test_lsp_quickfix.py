"""Quick fixes through the real server: the hint's suggestion for a misspelt name, the
import of a standard-library definition, half gauge for reverse stitches on a tube, the
declaration of an unknown yarn; each fix applied gives a design without that mistake."""

from __future__ import annotations

from collections.abc import Sequence

import pytest
from lsp_session import Session
from lsprotocol import types
from test_lsp_editing import apply

from knitc import driver
from knitc.lsp import quickfix as qf
from knitc.lsp.analysis import analyse
from knitc.lsp.settings import Settings


def codes_of(text: str, until: str = "skeleton") -> list[str]:
    result = driver.compile_source(text, "/t/fixed.knit", until=until)
    return [d.code for d in result.diagnostics.sorted()]


async def actions(
    session: Session, uri: str, diags: Sequence[types.Diagnostic]
) -> list[types.CodeAction]:
    got = await session.client.text_document_code_action_async(
        types.CodeActionParams(
            types.TextDocumentIdentifier(uri),
            diags[0].range if diags else types.Range(types.Position(0, 0), types.Position(0, 0)),
            types.CodeActionContext(diagnostics=list(diags)),
        )
    )
    assert got is not None
    return [a for a in got if isinstance(a, types.CodeAction)]


def edits_of(action: types.CodeAction, uri: str) -> list[types.TextEdit]:
    assert action.edit is not None and action.edit.changes is not None
    return list(action.edit.changes[uri])


MISSPELT = (
    "param width = 8\n"
    "pattern ribbing(k = 1) { set P }\n"
    "tube body { length: 10, width: #widht }\n"
    "bdy.top open\n"
    "pattern body {\n"
    "  /* é 🧶 */ apply ribing()\n"
    "}\n"
)


async def test_a_misspelt_parameter_node_and_pattern_change_to_the_hint(session: Session):
    uri = session.open("misspelt.knit", MISSPELT)
    diags = await session.diagnostics(uri, lambda d: len(d) >= 3)
    got = await actions(session, uri, diags)
    by_title = {a.title: a for a in got}
    assert set(by_title) == {"Change to `width`", "Change to `body`", "Change to `ribbing`"}
    for a in got:
        assert a.kind == types.CodeActionKind.QuickFix and a.is_preferred
        assert a.diagnostics is not None and len(a.diagnostics) == 1
    (param,) = edits_of(by_title["Change to `width`"], uri)
    assert (param.range.start.line, param.range.start.character) == (2, 32)  # after the `#`
    assert param.range.end.character == 37
    (pattern,) = edits_of(by_title["Change to `ribbing`"], uri)
    # `  /* é 🧶 */ apply ` is 18 code points, 19 UTF-16 units
    assert (pattern.range.start.line, pattern.range.start.character) == (5, 19)
    assert pattern.range.end.character == 25
    fixed = apply(MISSPELT, [e for a in got for e in edits_of(a, uri)])
    assert "#width" in fixed and "body.top" in fixed and "apply ribbing()" in fixed
    assert codes_of(fixed) == []


async def test_an_unimported_stdlib_pattern_or_shaper_gets_its_import(session: Session):
    text = (
        "// a tube\n"
        "tube body { length: 10, width: 8, shaper: zigzag }\n"
        "pattern body { apply seed() }\n"
    )
    uri = session.open("imports.knit", text)
    diags = await session.diagnostics(uri, lambda d: len(d) >= 2)
    got = await actions(session, uri, diags)
    titles = sorted(a.title for a in got)
    assert titles == ["Import `seed` from std.stitches", "Import `zigzag` from std.shapers"]
    fixed = apply(text, [e for a in got for e in edits_of(a, uri)])
    assert fixed.startswith("// a tube\nimport std.shapers (zigzag)\n")  # after the comment
    assert "\nimport std.stitches (seed)\n" in fixed
    assert codes_of(fixed) == []

    # with an import of the module already there: the name joins its list
    listed = "import std.stitches (rib)  // é 🧶\n" + text
    session.replace_all(uri, listed)
    diags = await session.diagnostics(uri, lambda d: len(d) >= 2)
    got = await actions(session, uri, [d for d in diags if d.code == "E218"])
    (fix,) = got
    fixed = apply(listed, edits_of(fix, uri))
    assert fixed.startswith("import std.stitches (rib, seed)  // é 🧶\n")
    assert "E218" not in codes_of(fixed)


STRIPES = (
    "yarn red { carrier: 1 }  // é 🧶\n"
    "tube body { length: 10, width: 8 }\n"
    "pattern body {\n"
    "  knit rde where courses(0:1)\n"
    "  knit blue where courses(4:5)\n"
    "}\n"
)


async def test_an_unknown_yarn_is_declared_or_corrected(session: Session):
    uri = session.open("stripes.knit", STRIPES)
    diags = await session.diagnostics(uri, lambda d: len(d) >= 2)
    assert {d.code for d in diags} == {"E228"}
    got = await actions(session, uri, diags)
    by_title = {a.title: a for a in got}
    assert set(by_title) == {"Change to `red`", "Declare yarn `rde`", "Declare yarn `blue`"}
    assert by_title["Change to `red`"].is_preferred and by_title["Declare yarn `blue`"].is_preferred
    assert not by_title["Declare yarn `rde`"].is_preferred  # a misspelling, more likely
    (declare,) = edits_of(by_title["Declare yarn `blue`"], uri)
    # after the last yarn, past its comment (23 + 8 code points, 🧶 two UTF-16 units);
    # carrier 1 is red's and 3 main's: the lowest free one is 2
    assert declare.range.start == types.Position(0, 32) and declare.range.end.character == 32
    assert declare.new_text == "\nyarn blue { carrier: 2 }"
    chosen = [by_title["Change to `red`"], by_title["Declare yarn `blue`"]]
    fixed = apply(STRIPES, [e for a in chosen for e in edits_of(a, uri)])
    assert fixed.startswith("yarn red { carrier: 1 }  // é 🧶\nyarn blue { carrier: 2 }\n")
    assert "knit red where" in fixed
    assert codes_of(fixed, "stitch-graph") == []


@pytest.mark.parametrize(
    ("head", "want"),
    [
        ("", "yarn blue { carrier: 1 }\n\ntube t"),
        ("import std.stitches\nparam n = 2\n", "param n = 2\n\nyarn blue { carrier: 1 }\ntube t"),
        (
            "machine { carriers: [1] }\nparam n = 2\n",
            "machine { carriers: [1] }\n\nyarn blue { carrier: 2 }\nparam n",
        ),
        (
            "yarn main { carrier: 1 }\nyarn red {}\nyarn x { carrier: 2 }\n",
            "yarn x { carrier: 2 }\nyarn blue { carrier: 3 }\ntube t",
        ),
    ],
)
def test_a_yarn_is_declared_beside_the_others_on_a_free_carrier(head: str, want: str):
    text = head + "tube t { length: 4, width: 4 }\npattern t { knit blue }\n"
    a = analyse("file:///t/y.knit", 1, "/t/y.knit", text, Settings())
    start = text.index("blue")
    fix = qf.yarn_fix(a, start, start + 4, preferred=True)
    assert fix is not None and fix.title == "Declare yarn `blue`"
    ((at, end, new),) = fix.edits
    fixed = text[:at] + new + text[end:]
    assert want in fixed
    assert codes_of(fixed) == []
    assert qf.yarn_fix(a, text.index("knit"), start + 4, preferred=True) is None  # not a name


GAUGE = (
    "import std.stitches (rib)\n"
    "tube body {\n"
    "  length: 10\n"
    "  width: 8  // é 🧶\n"
    "}\n"
    "pattern body {\n"
    "  apply rib(1, 1)\n"
    "}\n"
)


async def test_reverse_stitches_on_a_full_gauge_tube_get_half_gauge(session: Session):
    uri = session.open("gauge.knit", GAUGE)
    diags = await session.diagnostics(uri, lambda d: any(x.code == "W603" for x in d))
    got = await actions(session, uri, [d for d in diags if d.code == "W603"])
    (fix,) = got
    assert fix.title == "Knit `body` in half gauge" and fix.is_preferred
    fixed = apply(GAUGE, edits_of(fix, uri))
    assert "  width: 8  // é 🧶\n  gauge: half\n}" in fixed
    assert "W603" not in codes_of(fixed, "knitout")


@pytest.mark.parametrize(
    ("text", "want"),
    [
        ("tube b { length: 4, width: 4 }\n", "tube b { length: 4, width: 4, gauge: half }\n"),
        ("tube b { length: 4, gauge: full }\n", "tube b { length: 4, gauge: half }\n"),
        (
            "tube b {\n  length: 4\n  width: 4 }\n",
            "tube b {\n  length: 4\n  width: 4\n  gauge: half\n}\n",
        ),
        ("tube b {}\n", "tube b { gauge: half }\n"),
    ],
)
def test_half_gauge_goes_into_any_node_block(text: str, want: str):
    text += "pattern b { set P }\n"
    a = analyse("file:///t/g.knit", 1, "/t/g.knit", text, Settings())
    fix = qf.gauge_fix(a, text.index("set P"))
    assert fix is not None
    ((start, end, new),) = fix.edits
    assert (text[:start] + new + text[end:]).startswith(want)


def test_half_gauge_of_a_global_layer_goes_into_machine():
    text = "import std.stitches (rib)\ntube b { length: 4, width: 4 }\npattern before { apply rib() }\n"
    a = analyse("file:///t/g.knit", 1, "/t/g.knit", text, Settings())
    fix = qf.gauge_fix(a, text.index("apply"))
    assert fix is not None
    ((start, end, new),) = fix.edits
    out = text[:start] + new + text[end:]
    assert out.startswith("import std.stitches (rib)\n\nmachine { gauge: half }\ntube b")
    machine = "machine {\n  cast_on: tuck\n}\n" + text
    a = analyse("file:///t/g.knit", 1, "/t/g.knit", machine, Settings())
    fix = qf.gauge_fix(a, machine.index("apply"))
    assert fix is not None and fix.title == "Knit `machine` in half gauge"
    ((start, end, new),) = fix.edits
    assert (machine[:start] + new + machine[end:]).startswith(
        "machine {\n  cast_on: tuck\n  gauge: half\n}\n"
    )


def test_the_word_replaced_is_the_misspelt_one_in_the_range():
    text = "@bdy.length @body.lenth import std.stitchs (rib)"
    assert qf._closest_word(text, 0, 11, "body") == (1, 4)
    assert qf._closest_word(text, 12, 23, "length") == (18, 23)
    assert qf._closest_word(text, 24, len(text), "std.stitches") == (31, 42)
    assert qf._closest_word("x v y", 2, 2, "#v") == (2, 3)  # an empty range: the word there


async def test_no_fix_and_no_failure_on_broken_foreign_or_odd_requests(session: Session):
    uri = session.open("bad.knit", "tube body {\n  length: 10\n  width: \n}\n// é 🧶\n")
    diags = await session.diagnostics(uri, lambda d: len(d) > 0)
    assert await actions(session, uri, diags) == []
    far = types.Range(types.Position(90, 9), types.Position(99, 0))
    odd = [
        types.Diagnostic(far, "x\nhint: did you mean `y`?", code="E211", source="knitc"),
        types.Diagnostic(far, "x", code="E218", source="knitc", data={"hint": 3}),
        types.Diagnostic(far, "did you mean `y`?", source="other"),
        types.Diagnostic(far, "x", code="W603", source="knitc", data={"hint": "`gauge: half`"}),
    ]
    assert await actions(session, uri, odd) == []
    got = await session.client.text_document_code_action_async(
        types.CodeActionParams(
            types.TextDocumentIdentifier(session.uri("never-opened.knit")),
            far,
            types.CodeActionContext(diagnostics=odd),
        )
    )
    assert got is None
