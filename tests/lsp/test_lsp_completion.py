"""Completion while the designer types: keywords and snippets at the top level, properties
in blocks, their values, parameters, instructions, queries, patterns (with the import a
stdlib one needs), modules and their exports, interface paths, yarns after `knit`; on
incomplete text, next to non-ASCII characters, after a syntax error elsewhere and past the
end of the file."""

from __future__ import annotations

import time
from pathlib import Path

from lsp_session import Session
from lsprotocol import types

from knitc.lsp import completion as c
from knitc.lsp.analysis import Analysis, analyse
from knitc.lsp.positions import UTF8, UTF16
from knitc.lsp.settings import Settings
from knitc.shaping.stitch_graph import INSTRUCTIONS

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"


# ---- helpers -----------------------------------------------------------------------------------


def end_of(text: str) -> tuple[int, int]:
    """The (line, UTF-16 character) of the end of `text`."""
    lines = text.split("\n")
    return len(lines) - 1, len(lines[-1].encode("utf-16-le")) // 2


async def complete(
    session: Session, uri: str, at: tuple[int, int], trigger: str | None = None
) -> types.CompletionList:
    context = (
        types.CompletionContext(types.CompletionTriggerKind.TriggerCharacter, trigger)
        if trigger
        else types.CompletionContext(types.CompletionTriggerKind.Invoked)
    )
    got = await session.client.text_document_completion_async(
        types.CompletionParams(
            types.TextDocumentIdentifier(uri), types.Position(*at), context=context
        )
    )
    assert isinstance(got, types.CompletionList)
    return got


def labels(result: types.CompletionList) -> list[str]:
    return [i.label for i in result.items]


def by_label(result: types.CompletionList, label: str) -> types.CompletionItem:
    return next(i for i in result.items if i.label == label)


def edit_of(item: types.CompletionItem) -> types.TextEdit:
    assert isinstance(item.text_edit, types.TextEdit)
    return item.text_edit


def analysis(text: str, path: str = "/nowhere/design.knit") -> Analysis:
    return analyse("file://" + path, 1, path, text, Settings())


def inserts_at(text: str, snippets: bool = True) -> list[str]:
    """In process: the texts offered at the `|` of `text`."""
    offset = text.index("|")
    ans = c.answer(analysis(text.replace("|", "", 1)), offset, snippets)
    return [i.insert for i in ans.items]


# ---- end to end --------------------------------------------------------------------------------


async def test_an_empty_file_offers_the_top_level_keywords_and_snippets(session: Session):
    uri = session.open("empty.knit", "")
    result = await complete(session, uri, (0, 0))
    got = labels(result)
    for word in ("import", "param", "machine", "sheet", "tube", "joint", "split"):
        assert word in got
    for word in ("pattern", "action", "shaper", "start"):
        assert word in got
    tube = next(i for i in result.items if i.kind == types.CompletionItemKind.Snippet)
    assert tube.insert_text_format == types.InsertTextFormat.Snippet
    assert edit_of(tube).new_text.startswith("tube ${1:name} {\n  length: ${2:40}")
    assert by_label(result, "param").kind == types.CompletionItemKind.Keyword
    # past the end of the file: the same, at the end
    past = await complete(session, uri, (5, 40))
    assert "tube" in labels(past)
    assert edit_of(past.items[0]).range == types.Range(types.Position(0, 0), types.Position(0, 0))


async def test_node_properties_values_and_parameters(session: Session):
    text = "param finger_w = 7\ntube a {\n  length: 3\n  \n}\n"
    uri = session.open("tube.knit", text)
    props = await complete(session, uri, (3, 2))
    got = labels(props)
    assert {"width", "gauge", "shaper", "alignment"} <= set(got)
    assert "length" not in got  # already set
    assert "type" not in got  # a sheet's, not a tube's
    width = by_label(props, "width")
    assert width.kind == types.CompletionItemKind.Property
    assert edit_of(width).new_text == "width: "
    assert width.detail is not None and "1..5000" in width.detail
    assert isinstance(width.documentation, types.MarkupContent)

    session.replace_all(uri, "param finger_w = 7\ntube a {\n  length: 3\n  gauge: \n}\n")
    values = await complete(session, uri, (3, 9), trigger=" ")
    assert labels(values) == ["full", "half"]
    assert by_label(values, "half").kind == types.CompletionItemKind.EnumMember

    session.replace_all(uri, "param finger_w = 7\ntube a {\n  length: 3\n  width: #fin\n}\n")
    params = await complete(session, uri, (3, 13))
    item = by_label(params, "finger_w")
    assert item.kind == types.CompletionItemKind.Variable
    assert item.detail == "param finger_w = 7"
    edit = edit_of(item)
    assert edit.new_text == "#finger_w"  # replaces `#fin`: never `##finger_w`
    assert edit.range == types.Range(types.Position(3, 9), types.Position(3, 13))
    assert item.filter_text == "#finger_w"


async def test_instructions_queries_and_actions_in_a_pattern(session: Session):
    text = "tube a { length: 4, width: 4 }\npattern a {\n  set "
    uri = session.open("p.knit", text)
    instr = await complete(session, uri, end_of(text), trigger=" ")
    assert labels(instr) == list(INSTRUCTIONS)
    assert len(instr.items) == 17 and "XR+" in labels(instr)
    assert by_label(instr, "K").detail == "knit"
    assert by_label(instr, "XR+").kind == types.CompletionItemKind.Constant

    text2 = text + "K where "
    session.replace_all(uri, text2)
    queries = await complete(session, uri, end_of(text2), trigger=" ")
    assert {"courses()", "wales()", "all()", "select()"} <= set(labels(queries))
    assert edit_of(by_label(queries, "all()")).new_text == "all()"
    assert by_label(queries, "courses()").kind == types.CompletionItemKind.Function

    text3 = text + "K\n  use "
    session.replace_all(uri, text3)
    actions = await complete(session, uri, end_of(text3))
    assert "purl_flat" in labels(actions)  # from std.actions, with its import


async def test_apply_offers_own_imported_and_importable_patterns(session: Session):
    text = (
        "import std.stitches (rib)\n"
        "pattern mine(n = 2) { set P }\n"
        "tube a { length: 4, width: 4 }\n"
        "pattern a {\n  apply "
    )
    uri = session.open("apply.knit", text)
    result = await complete(session, uri, end_of(text), trigger=" ")
    mine, rib = by_label(result, "mine"), by_label(result, "rib")
    assert mine.detail == "mine(n = 2)" and mine.additional_text_edits is None
    assert rib.detail == "rib(k = 1, p = 1)" and rib.additional_text_edits is None
    assert edit_of(rib).new_text == "rib("
    seed = by_label(result, "seed")  # std.stitches, not imported yet: into the import
    assert seed.label_details is not None
    assert seed.label_details.description == "(import std.stitches)"
    assert list(seed.additional_text_edits or ()) == [
        types.TextEdit(types.Range(types.Position(0, 24), types.Position(0, 24)), ", seed")
    ]
    crosses = by_label(result, "crosses")  # std.motifs: a new import after the last one
    assert list(crosses.additional_text_edits or ()) == [
        types.TextEdit(
            types.Range(types.Position(0, 25), types.Position(0, 25)),
            "\nimport std.motifs (crosses)",
        )
    ]


async def test_imports_modules_and_exports(session: Session):
    uri = session.open("imp.knit", "import std.")
    modules = await complete(session, uri, (0, 11), trigger=".")
    assert {"stitches", "motifs", "actions", "shapers"} <= set(labels(modules))
    assert by_label(modules, "stitches").kind == types.CompletionItemKind.Module

    session.replace_all(uri, "import std.stitches (rib, ")
    exports = await complete(session, uri, (0, 26), trigger=" ")
    got = labels(exports)
    assert {"seed", "eyelets", "cable"} <= set(got) and "rib" not in got

    (session.workspace / "parts").mkdir()
    (session.workspace / "parts" / "lace.knit").write_text("pattern lace() { set T }\n")
    session.replace_all(uri, "import ")
    start = await complete(session, uri, (0, 7), trigger=" ")
    assert {"std.stitches", '"parts/lace.knit"'} <= set(labels(start))


async def test_interface_paths_and_node_names(session: Session):
    text = "tube body { length: 4, width: 4 }\nsplit fork { degree: 3 }\nbody."
    uri = session.open("itf.knit", text)
    paths = await complete(session, uri, end_of(text), trigger=".")
    assert labels(paths) == ["bottom", "top"]
    session.replace_all(uri, text[:-5] + "fork.")
    split = await complete(session, uri, end_of(text[:-5] + "fork."), trigger=".")
    assert labels(split) == ["base", "branches[0]", "branches[1]", "branches[2]"]
    text3 = text + "top -> "
    session.replace_all(uri, text3)
    nodes = await complete(session, uri, end_of(text3), trigger=" ")
    assert {"body", "fork"} <= set(labels(nodes))


async def test_yarns_after_knit_and_their_properties(session: Session):
    text = "yarn red { carrier: 5 }\ntube a { length: 4, width: 4 }\npattern a {\n  knit "
    uri = session.open("stripes.knit", text)
    yarns = await complete(session, uri, end_of(text), trigger=" ")
    assert labels(yarns) == ["main", "red"]
    assert by_label(yarns, "red").detail == "yarn, carrier 5"
    assert by_label(yarns, "main").detail == "the design's own yarn"
    assert edit_of(by_label(yarns, "red")).new_text == "red"
    text2 = "yarn red {\n  carrier: 5\n  \n}\n"
    session.replace_all(uri, text2)
    props = await complete(session, uri, (2, 2))
    assert labels(props) == ["carry_up", "tuck_every", "plating", "inlay", "colour"]
    carry = by_label(props, "carry_up")
    assert (
        carry.kind == types.CompletionItemKind.Property and edit_of(carry).new_text == "carry_up: "
    )
    assert carry.detail == "int 0..1000, default 8"


async def test_ranges_are_utf16_after_non_ascii_text(session: Session):
    text = "tube a { /* é 🧶 */ len"
    uri = session.open("utf.knit", text)
    line, char = end_of(text)
    assert char == len(text) + 1  # 🧶 is two UTF-16 units
    result = await complete(session, uri, (line, char))
    edit = edit_of(by_label(result, "length"))
    assert edit.range == types.Range(types.Position(0, char - 3), types.Position(0, char))
    assert edit.new_text == "length: "


async def test_ranges_are_utf8_where_negotiated(neovim_session: Session):
    text = "tube a { /* é 🧶 */ len"
    uri = neovim_session.open("utf8.knit", text)
    char = len(text.encode("utf-8"))
    result = await complete(neovim_session, uri, (0, char))
    edit = edit_of(by_label(result, "length"))
    assert edit.range.start == types.Position(0, char - 3)


async def test_a_syntax_error_elsewhere_and_incomplete_text(session: Session):
    text = "tube a {\n  length: 3 3\n}\n\ntube b {\n  len"
    uri = session.open("broken.knit", text)
    await session.diagnostics(uri, lambda d: len(d) > 0)
    result = await complete(session, uri, end_of(text))
    assert {"length", "width"} <= set(labels(result))
    # in whitespace inside the broken node, and in a comment: no error, sensible answers
    inside = await complete(session, uri, (1, 0))
    assert "width" in labels(inside)
    session.replace_all(uri, "// é 🧶 a comment")
    assert len((await complete(session, uri, (0, 10))).items) == 0
    # an unopened document
    other = await session.client.text_document_completion_async(
        types.CompletionParams(
            types.TextDocumentIdentifier(session.uri("never.knit")), types.Position(0, 0)
        )
    )
    assert other is None


# ---- in process --------------------------------------------------------------------------------


def test_plain_text_for_clients_without_snippets():
    offered = inserts_at("|", snippets=False)
    assert "tube name {\n  length: 40\n  width: 30\n}" in offered
    assert "machine {\n  gauge: full\n}" in offered
    assert all("$" not in t for t in offered)


def test_machine_interface_and_action_blocks():
    assert "needles: " in inserts_at("machine {\n  |\n}")
    assert inserts_at("tube a {}\na.top closed(|") == ["collapse", "zigzag", "zigzagreturn"]
    assert inserts_at("tube a {}\na.top |") == ["open", "closed"]
    assert "cast_on: " in inserts_at("tube a {}\na.top { | }")
    assert "cast_on: " not in inserts_at("shaper z(M, N) { if a.b { | } }")
    action = inserts_at("action x {\n  |")
    assert "split_by_side: " in action and any(t.startswith("pre {") for t in action)


def test_yarn_declarations_and_knit_statements():
    offered = inserts_at("|", snippets=False)
    assert "yarn" in offered and "yarn name {\n  carrier: 5\n}" in offered
    assert "yarn ${1:name} {\n  carrier: ${2:5}\n}" in inserts_at("|")
    assert inserts_at("yarn red {\n  |\n}") == [
        "carrier: ",
        "carry_up: ",
        "tuck_every: ",
        "plating: ",
        "inlay: ",
        "colour: ",
    ]
    assert inserts_at("yarn red { carrier: 5, c| }") == [
        "carry_up: ",
        "tuck_every: ",
        "plating: ",
        "inlay: ",
        "colour: ",
    ]
    assert "#n" in inserts_at("param n = 4\nyarn red { carrier: | }")
    layer = "tube a { length: 4, width: 4 }\npattern a {\n  |\n}"
    assert {"set", "use", "knit", "apply"} <= set(inserts_at(layer))
    # the yarns after `knit`, `main` first: with the resolved carriers when the text parses
    design = "machine { carriers: [2] }\nyarn red { carrier: 5 }\n" + layer
    text = design.replace("|", "knit re|")
    ans = c.answer(analysis(text.replace("|", "")), text.index("|"))
    assert [(i.label, i.detail) for i in ans.items] == [
        ("main", "the design's own yarn, carrier 2"),
        ("red", "yarn, carrier 5"),
    ]
    assert ans.start == text.index("re|")
    # and from the word before when the statement does not parse up to the cursor
    assert inserts_at(design.replace("|", "set K K\n  knit |")) == ["main", "red"]
    # the layer statements of colourwork, and the backings after `backing`
    assert {"backing", "intarsia"} <= set(inserts_at(layer))
    backings = ["float", "tubular", "birdseye", "pique", "horizontal", "vertical"]
    assert inserts_at(design.replace("|", "backing |")) == backings
    assert inserts_at(design.replace("|", "set K K\n  backing |")) == backings
    a = analysis(design.replace("|", "knit "))
    assert [i.insert for i in c.answer(a, a.text.index("knit ") + 5, trigger=" ").items] == [
        "main",
        "red",
    ]
    # `knit(` in an action step is an operation: no yarns there
    assert "red" not in inserts_at("yarn red {}\naction x { main { knit(|) } }")


def test_shaper_values_include_the_modules_shapers():
    text = "shaper z(M, N) { for i in range(M) { i -> i } }\ntube a { shaper: | }"
    got = inserts_at(text)
    assert "uniform" in got and "z(" in got


def test_property_references():
    assert "@length" in inserts_at("tube a { length: 3, width: @| }")
    got = inserts_at("tube a { length: 3 }\ntube b { length: @a.| }")
    assert "@a.length" in got


def test_a_space_pops_up_only_where_few_words_fit():
    a = analysis("tube a { length: 3 }")
    assert c.answer(a, 9, trigger=" ").items == []
    assert "width: " in [i.insert for i in c.answer(a, 9).items]
    assert c.answer(a, 18).items == []  # typing a number


def test_import_edit_into_an_empty_file_and_after_imports():
    assert c.import_edit("tube a {}\n", "stitches", "rib") == (0, 0, "import std.stitches (rib)\n")
    text = "import std.actions\nimport std.stitches ()\n"
    assert c.import_edit(text, "stitches", "rib") == (40, 40, "rib")


def test_describe_a_property():
    from knitc.frontend import skeleton as sk

    assert c.describe(sk.MACHINE_PROPS["gauge"]) == "choice: full | half, default full"
    assert c.describe(sk.TUBE_PROPS["length"]) == "int 1..100000, default 10"


def test_no_position_raises():
    text = (EXAMPLES / "glove.knit").read_text(encoding="utf-8")
    broken = text[: len(text) // 2] + "\ntube x { width: [0: , }\n" + text[len(text) // 2 :]
    for t in (text, broken, "", '"""', "/*", 'import "', "tube a { width: @a."):
        a = analysis(t)
        for offset in range(-1, len(t) + 3, max(1, len(t) // 300)):
            c.answer(a, offset)


def test_fast_on_the_glove():
    text = (EXAMPLES / "glove.knit").read_text(encoding="utf-8")
    a = analysis(text, str(EXAMPLES / "glove.knit"))
    c.answer(a, len(text))  # the standard library's exports, parsed once
    for m in c.stdlib_modules():
        c.stdlib_exports(m)
    worst = 0.0
    for offset in range(0, len(text), 37):
        start = time.perf_counter()
        c.answer(a, offset)
        worst = max(worst, time.perf_counter() - start)
    assert worst < 0.05


def test_encodings_of_the_range():
    text = "tube a { /* é 🧶 */ len"
    a = analysis(text)
    ans = c.answer(a, len(text))
    utf8 = c.to_lsp(ans, a, UTF8).items[0].text_edit
    utf16 = c.to_lsp(ans, a, UTF16).items[0].text_edit
    assert isinstance(utf8, types.TextEdit) and isinstance(utf16, types.TextEdit)
    assert utf8.range.end.character == len(text.encode("utf-8"))
    assert utf16.range.end.character == len(text) + 1
