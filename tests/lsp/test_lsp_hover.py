"""Hover and inlay hints: end to end through a real `knitc lsp` (UTF-16 positions, settings
from initializationOptions), and in-process on the pure functions of `knitc.lsp.hover`."""

from __future__ import annotations

import pytest
from lsp_session import Session
from lsprotocol import types

from knitc import driver
from knitc.frontend.names import QUERY_FUNCTIONS
from knitc.lsp import hover as hv
from knitc.lsp.analysis import Analysis, analyse
from knitc.lsp.settings import Settings
from knitc.shaping.stitch_graph import INSTRUCTIONS

TUBE = "tube body {\n  length: 10\n  width: 8\n}\n"

STRIPES = (
    "yarn red {\n"
    "  carrier: 5\n"
    "  carry_up: 4\n"
    "}\n"
    "yarn blue {}\n"
    "tube sleeve { length: 20, width: 8 }\n"
    "pattern sleeve {\n"
    "  knit red where courses(4:7) or courses(12:15)\n"
    "  knit blue where courses(18:19)\n"
    "  knit main where courses(0:1)\n"
    "}\n"
    "action twice { main { knit(dir) knit(dir) } }\n"
)


def at(text: str, needle: str, skip: int = 0) -> types.Position:
    """The UTF-16 position `skip` code points into the first `needle` of `text`."""
    offset = text.index(needle) + skip
    line = text.count("\n", 0, offset)
    start = text.rfind("\n", 0, offset) + 1
    character = len(text[start:offset].encode("utf-16-le")) // 2
    return types.Position(line, character)


async def hover(session: Session, uri: str, position: types.Position) -> types.Hover | None:
    return await session.client.text_document_hover_async(
        types.HoverParams(types.TextDocumentIdentifier(uri), position)
    )


def markdown(h: types.Hover | None) -> str:
    assert h is not None
    assert isinstance(h.contents, types.MarkupContent)
    assert h.contents.kind == types.MarkupKind.Markdown
    return h.contents.value


def local(text: str, defines: tuple[str, ...] = (), previous: Analysis | None = None) -> Analysis:
    return analyse("file:///w/d.knit", 1, "/w/d.knit", text, Settings(defines), previous)


def hover_text(a: Analysis, needle: str, skip: int = 0) -> str | None:
    info = hv.hover_at(a, a.text.index(needle) + skip)
    return None if info is None else info.markdown


# ---- end to end ------------------------------------------------------------------------------


@pytest.mark.lsp_settings({"knitc": {"defines": {"finger_w": "9"}}})
async def test_hover_on_the_glove(session: Session, glove_text: str):
    uri = session.open("glove.knit", glove_text)

    h = await hover(session, uri, at(glove_text, "#finger_w", 3))
    text = markdown(h)
    assert "`finger_w` = **9**" in text
    assert "param finger_w = 7" in text and "line 29" in text
    assert "overridden by the knitc.defines setting: finger_w = 9" in text.lower()
    assert h is not None and h.range is not None
    start = at(glove_text, "#finger_w", 1)
    assert (h.range.start, h.range.end.character) == (start, start.character + 8)

    text = markdown(await hover(session, uri, at(glove_text, "tube palm", 6)))
    assert text.startswith("```knit\ntube palm {")
    assert "stitches" in text and "courses** in the stitch graph" in text
    assert "`palm.bottom`: connected" in text and "→ `fingers.base`" in text

    text = markdown(await hover(session, uri, at(glove_text, "shaper: sides", 2)))
    assert "**shaper**" in text and "default: `uniform`" in text and "here: `sides`" in text

    text = markdown(await hover(session, uri, at(glove_text, "apply rib", 7)))
    assert "pattern rib(k = 1, p = 1)" in text
    assert "k knit wales then p purl wales" in text and "`std.stitches`" in text

    text = markdown(await hover(session, uri, at(glove_text, "courses(0.2", 3)))
    assert "`courses(…)`" in text and "pattern query" in text

    assert await hover(session, uri, at(glove_text, "\n\nimport", 1)) is None  # empty line
    assert await hover(session, uri, at(glove_text, "// Fingers", 5)) is None
    assert await hover(session, uri, at(glove_text, "= 22", 3)) is None
    end = types.Position(glove_text.count("\n") + 5, 40)
    assert await hover(session, uri, end) is None


async def test_hover_counts_utf16_units_before_the_cursor(session: Session):
    text = TUBE + "pattern body { /* é 🧶 */ set FR2 where courses(1) }  // é 🧶\n"
    uri = session.open("u.knit", text)
    h = await hover(session, uri, at(text, "FR2", 1))
    value = markdown(h)
    assert "`FR2`" in value and "move right 2" in value and "2 needles right" in value
    assert h is not None and h.range is not None
    start = at(text, "FR2")
    assert start.character == text.split("\n")[4].index("FR2") + 1  # 🧶 is 2 UTF-16 units
    assert (h.range.start, h.range.end) == (start, types.Position(start.line, start.character + 3))
    text2 = markdown(await hover(session, uri, at(text, "courses(1)", 2)))
    assert "courses" in text2


async def test_hover_on_a_document_with_a_syntax_error_never_fails(session: Session):
    uri = session.open("e.knit", TUBE)
    assert "tube body" in markdown(await hover(session, uri, types.Position(0, 6)))
    session.edit(uri, (2, 9), (2, 9), " +")  # `width: 8 +`: no longer parses
    await session.diagnostics(uri, lambda d: len(d) > 0)
    h = await hover(session, uri, types.Position(0, 6))
    assert "tube body" in markdown(h)  # from the last module that parsed
    for line in range(6):
        for character in (0, 3, 9, 40):
            await hover(session, uri, types.Position(line, character))
    never = session.open("never.knit", "tube {{ ( \n #")
    assert await hover(session, never, types.Position(0, 1)) is None
    assert await hover(session, never, types.Position(1, 2)) is None


async def test_inlay_hints_give_each_node_its_stitch_graph_size(session: Session, glove_text: str):
    uri = session.open("glove.knit", glove_text)
    lines = glove_text.count("\n") + 1
    hints = await session.client.text_document_inlay_hint_async(
        types.InlayHintParams(
            types.TextDocumentIdentifier(uri),
            types.Range(types.Position(0, 0), types.Position(lines, 0)),
        )
    )
    result = driver.compile_source(glove_text, "glove.knit", until="stitch-graph")
    assert result.graph is not None and result.skeleton is not None
    counts = hv.node_counts(result.graph)
    assert hints is not None and len(hints) == len(result.skeleton.nodes)
    lines_of = {at(glove_text, f" {n} {{").line: n for n in result.skeleton.nodes}
    for h in hints:
        name = lines_of[h.position.line]
        assert h.label == ": " + hv.counts_text(*counts[name])
        assert h.kind == types.InlayHintKind.Type
        header = glove_text.split("\n")[h.position.line]
        assert header[: h.position.character].endswith(f" {name}")
    assert any(h.label == f": {counts['palm'][0]:,} stitches, 23 courses" for h in hints)

    only_palm = await session.client.text_document_inlay_hint_async(
        types.InlayHintParams(
            types.TextDocumentIdentifier(uri),
            types.Range(at(glove_text, "tube palm"), at(glove_text, "tube palm", 12)),
        )
    )
    assert only_palm is not None and len(only_palm) == 1


async def test_hover_on_a_yarn_where_it_is_knitted(session: Session):
    uri = session.open("stripes.knit", STRIPES)
    text = markdown(await hover(session, uri, at(STRIPES, "knit red", 6)))
    assert text.startswith("```knit\nyarn red {\n  carrier: 5\n  carry_up: 4\n}\n```")
    assert "**128 stitches, 8 courses** knitted with it" in text and "line 1" in text
    text = markdown(await hover(session, uri, at(STRIPES, "knit red", 1)))
    assert text.startswith("**`knit`** — keyword") and "`knit YARN where Q`" in text


# ---- in process ----------------------------------------------------------------------------


def test_hover_on_a_node_declaration_and_its_uses(glove_text: str):
    a = local(glove_text)
    assert a.graph is not None
    first = hover_text(a, "tube index", 6)
    use = hover_text(a, "index.top ->", 1)
    assert first is not None and first == use
    stitches, courses = hv.node_counts(a.graph)["index"]
    assert f"**{stitches:,} stitches, {courses} courses**" in first
    assert "`index.bottom`: closed (collapse), 14 stitches, tubular" in first
    assert hover_text(a, "@middle.length", 3) == hover_text(a, "tube middle", 7)


def test_hover_on_properties_interfaces_keywords_and_modules(glove_text: str):
    a = local(glove_text)
    length = hover_text(a, "@middle.length", 10)
    assert length is not None and "**length**: whole number" in length
    assert "`1` to `100000`" in length
    machine = hover_text(a, "machine { gauge", 11)
    assert machine is not None and "property of `machine`" in machine
    itf = hover_text(a, "fingers.base ->", 9)
    assert itf is not None and "`fingers.base`: connected, 54 stitches" in itf
    assert "→ `palm.bottom`" in itf
    branch = hover_text(a, "fingers.branches[3]", 9)
    assert branch is not None and "12 stitches" in branch
    for needle, keyword in (
        ("split fingers", "split"),
        ("param thumb_w", "param"),
        ("pattern cuff", "pattern"),
        ("start index", "start"),
        ('draw """', "draw"),
        ("where side(back)", "where"),
        ("and side(front)", "and"),
        ("closed\nmiddle", "closed"),
        ("import std", "import"),
    ):
        got = hover_text(a, needle, 1)
        assert got is not None and got.startswith(f"**`{keyword}`** — keyword"), needle
    module = hover_text(a, "std.stitches (", 6)
    assert module is not None and "**module** `std.stitches`" in module
    assert "`pattern eyelets`" in module
    draw_cell = hover_text(a, "FL1 .   FR1", 1)
    assert draw_cell is not None and "move left 1" in draw_cell


def test_hover_on_definitions_local_and_imported():
    text = (
        "import std.actions (purl_flat)\nimport std.shapers (edges)\n"
        "// A local rib: two and two.\n// (the doc comment)\n"
        "pattern mine(a, b = 2 * 3) { set K }\n"
        "sheet s { length: 4  width: [0: 6, 1: 8]  shaper: edges }\n"
        "pattern s { apply mine(1) use purl_flat where wales(0) }\n"
    )
    a = local(text)
    mine = hover_text(a, "apply mine", 7)
    assert mine is not None and "pattern mine(a, b = 2 * 3)" in mine
    assert "A local rib: two and two.\n(the doc comment)" in mine and "this file (line 5)" in mine
    action = hover_text(a, "use purl_flat", 5)
    assert action is not None and "action purl_flat" in action and "`std.actions`" in action
    shaper = hover_text(a, "shaper: edges", 9)
    assert shaper is not None and "shaper edges(M, N)" in shaper
    assert hover_text(a, "(purl_flat)", 1) == action


def test_a_stale_module_answers_only_where_the_text_still_matches():
    good = local(TUBE + "param n = 3\n")
    bad = local("tube body {\n  length: 10\n  width: +\n}\nparam n = 3\n", previous=good)
    assert bad.stale and bad.skeleton is None
    node = hover_text(bad, "body", 1)
    assert node is not None and "tube body" in node and "stitch graph" not in node
    assert hover_text(bad, "param n", 6) is not None  # same offsets
    shifted = local("\n\n" + TUBE + "param n = 3 +", previous=good)
    assert shifted.stale
    assert hover_text(shifted, "body", 1) is None  # the old spans point elsewhere
    assert hv.inlay_hints(bad, 0, len(bad.text)) == []


def test_no_hover_and_no_hints_where_nothing_parsed_or_shaped():
    a = local("tube {{ (")
    assert a.module is None
    assert all(hv.hover_at(a, i) is None for i in range(len(a.text) + 3))
    assert hv.inlay_hints(a, 0, 100) == []
    unshaped = local(TUBE)
    object.__setattr__(unshaped, "shaped", False)
    assert hv.inlay_hints(unshaped, 0, len(TUBE)) == []


def test_every_instruction_and_query_has_a_text():
    for mnemonic in INSTRUCTIONS:
        text = hv.instruction_markdown(mnemonic)
        assert hv.instruction_ops(mnemonic) and "{" not in text, mnemonic
    assert "2 needles left" in hv.instruction_ops("BL2")
    for name in QUERY_FUNCTIONS:
        assert name in hv.QUERY_DOCS and hv.query_markdown(name)


def test_hover_never_raises_on_any_offset(glove_text: str):
    a = local(glove_text)
    edited = local(glove_text[:1500] + " ( " + glove_text[1500:], previous=a)
    for analysis in (a, edited):
        for i in range(-2, len(analysis.text) + 3):
            info = hv.hover_at(analysis, i)
            if info is not None:
                assert info.start <= i <= info.end


def test_hover_on_yarns_their_keywords_and_properties():
    a = local(STRIPES)
    assert a.graph is not None
    red = hover_text(a, "yarn red", 6)
    assert red is not None and red == hover_text(a, "knit red", 6)
    assert hv.yarn_counts(a.graph, "red") == (128, 8)
    assert hv.yarn_counts(a.graph, "main") == (320 - 128 - 32, 20 - 8 - 2)
    # the design's own yarn, undeclared: on the machine's first carrier
    main = hover_text(a, "knit main", 6)
    assert main is not None and main.startswith("```knit\nyarn main {\n  carrier: 3\n")
    assert "The design's own yarn" in main and "Declared" not in main
    blue = hover_text(a, "knit blue", 6)
    assert blue is not None and "Carrier: chosen by knitc" in blue and "16" not in blue
    assert "**32 stitches, 2 courses**" in blue and "*Declared on line 5*" in blue
    for needle, keyword in (("yarn red", "yarn"), ("yarn blue", "yarn"), ("knit main", "knit")):
        got = hover_text(a, needle, 1)
        assert got is not None and got.startswith(f"**`{keyword}`** — keyword"), needle
    assert hover_text(a, "knit(dir)", 1) is None  # an action step's operation

    carrier = hover_text(a, "carrier: 5", 2)
    assert carrier is not None and "**carrier**: whole number — property of `yarn`" in carrier
    assert "- default: chosen by knitc" in carrier and "- here: `5`" in carrier
    carry = hover_text(a, "carry_up", 3)
    assert carry is not None and "- default: `8`" in carry and "- here: `4`" in carry


def test_hover_on_the_colourwork_statements():
    a = local(
        "yarn red { carrier: 5 }\nsheet s { length: 12, width: 10 }\npattern s {\n"
        "  knit red where courses(2:4) and wales(3:6)\n  backing birdseye where courses(2:3)\n"
        "  intarsia where courses(4:4)\n}\n"
    )
    for needle in ("backing birdseye", "intarsia where"):
        word = needle.split()[0]
        got = hover_text(a, needle, 2)
        assert got is not None and got.startswith(f"**`{word}`** — keyword"), got
        assert f"`{word} " in got
    got = hover_text(a, "birdseye", 2)  # a backing's word says what it does
    assert got is not None and got.startswith("**`birdseye`** — jacquard backing"), got
    assert "checkerboard" in got


def test_hover_on_a_yarn_of_a_stale_module():
    text = "yarn red { carrier: #n }\ntube t { length: 4, width: 4 }\n"
    text += "pattern t { knit red knit main knit green }\n"
    good = local(text + "param n = 5\n")
    assert good.skeleton is not None
    a = local(text + "param n = 5 +\n", previous=good)  # the same offsets, and no skeleton
    assert a.stale and a.skeleton is None
    red = hover_text(a, "knit red", 6)
    assert red == "```knit\nyarn red {\n  carrier: #n\n}\n```\n\n*Declared on line 1*"
    main = hover_text(a, "knit main", 6)
    assert main is not None and main.startswith("**yarn** `main`")
    assert hover_text(a, "knit green", 6) is None  # E228: no such yarn
