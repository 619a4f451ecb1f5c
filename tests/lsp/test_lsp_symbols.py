"""Navigation through the real server: go to definition, references, rename, document and
workspace symbols; with UTF-16 positions after non-ASCII text, a half-written file and
positions in whitespace or past the end. The pure functions are tested in-process below
where that is cheaper than a server."""

from __future__ import annotations

from pathlib import Path

import pytest
from lsp_session import Session
from lsprotocol import types
from pygls.exceptions import JsonRpcException

from knitc.lsp import symbols as sy
from knitc.lsp.analysis import Analysis, analyse
from knitc.lsp.settings import Settings

LACE = "// a lace panel\npattern lace(n = 2) {\n  apply rib(1, 1)\n}\nimport std.stitches (rib)\n"

MAIN = """import "parts/lace.knit" (lace)
import std.stitches (rib)
param w = 10 // é 🧶 before
tube body { length: #w /* é 🧶 */ width: #w }
tube cuff { length: @body.length, width: #w }
body.top -> cuff.bottom
body.bottom closed
start body.bottom
pattern body { apply lace() }
pattern cuff { apply rib(1, 1) where shape("cuff") }
"""


STRIPES = (
    "yarn red {\n"
    "  carrier: 5  // é 🧶\n"
    "  carry_up: 4\n"
    "}\n"
    "tube sleeve { length: 20, width: 8 }\n"
    "pattern sleeve {\n"
    "  knit red where courses(4:7)\n"
    "  /* 🧶 */ knit red where courses(12:15)\n"
    "  knit main where courses(0:1)\n"
    "}\n"
)
"""Stripes: a declared yarn used twice (once after a character of two UTF-16 units), and
`main`, the design's own yarn, used undeclared."""


def utf16(text: str) -> int:
    return len(text.encode("utf-16-le")) // 2


def pos(text: str, needle: str, n: int = 0, into: int = 1) -> types.Position:
    """The UTF-16 position `into` code points into the `n`-th occurrence of `needle`."""
    i = -1
    for _ in range(n + 1):
        i = text.index(needle, i + 1)
    i += into
    line = text.count("\n", 0, i)
    start = text.rfind("\n", 0, i) + 1
    return types.Position(line, utf16(text[start:i]))


def rng(text: str, needle: str, n: int = 0, skip: int = 0, length: int | None = None):
    """The UTF-16 range of `needle` (from `skip` code points in, `length` long)."""
    start = pos(text, needle, n, skip)
    size = len(needle) - skip if length is None else length
    return types.Range(start, types.Position(start.line, start.character + size))


def doc(uri: str) -> types.TextDocumentIdentifier:
    return types.TextDocumentIdentifier(uri=uri)


async def definition(session: Session, uri: str, at: types.Position):
    return await session.client.text_document_definition_async(
        types.DefinitionParams(text_document=doc(uri), position=at)
    )


async def references(session: Session, uri: str, at: types.Position, decl: bool):
    return await session.client.text_document_references_async(
        types.ReferenceParams(
            context=types.ReferenceContext(include_declaration=decl),
            text_document=doc(uri),
            position=at,
        )
    )


async def rename(session: Session, uri: str, at: types.Position, new: str):
    return await session.client.text_document_rename_async(
        types.RenameParams(text_document=doc(uri), position=at, new_name=new)
    )


async def prepare(session: Session, uri: str, at: types.Position):
    return await session.client.text_document_prepare_rename_async(
        types.PrepareRenameParams(text_document=doc(uri), position=at)
    )


def open_main(session: Session) -> str:
    (session.workspace / "parts").mkdir()
    (session.workspace / "parts" / "lace.knit").write_text(LACE, encoding="utf-8")
    return session.open("main.knit", MAIN)


# ---- go to definition -----------------------------------------------------------------------


async def test_definition_of_params_nodes_and_imported_definitions(session: Session):
    uri = open_main(session)
    lace_uri = session.uri("parts/lace.knit")
    # `#w` after `é 🧶` on the line: UTF-16 columns both ways.
    (loc,) = await definition(session, uri, pos(MAIN, "#w", 1, 2))
    assert loc.uri == uri and loc.range == rng(MAIN, "w = 10", length=1)
    # A node, from `@body.length`, an interface, a layer; and on its declaration.
    for at in (pos(MAIN, "@body", 0, 2), pos(MAIN, "body.top"), pos(MAIN, "body {", 1)):
        (loc,) = await definition(session, uri, at)
        assert loc.range == rng(MAIN, "body", length=4)
    (loc,) = await definition(session, uri, pos(MAIN, '"cuff"', 0, 2))
    assert loc.range == rng(MAIN, "cuff {", length=4)
    # A stdlib pattern, from its use and from the import list.
    for at in (pos(MAIN, "rib(1"), pos(MAIN, "(rib", 0, 2)):
        (loc,) = await definition(session, uri, at)
        assert loc.uri.endswith("std/stitches.knit")
        assert loc.range.start.line == 23  # `pattern rib(k = 1, p = 1)`, line 24
    # A user file's pattern, from its use and from the import list.
    for at in (pos(MAIN, "lace()"), pos(MAIN, "(lace", 0, 2)):
        (loc,) = await definition(session, uri, at)
        assert loc.uri == lace_uri and loc.range == rng(LACE, "lace(", length=4)
    # The module path and the file string go to the file.
    (loc,) = await definition(session, uri, pos(MAIN, "std.stitches", 0, 5))
    assert loc.uri.endswith("std/stitches.knit") and loc.range.start.line == 0
    (loc,) = await definition(session, uri, pos(MAIN, "parts/lace"))
    assert loc.uri == lace_uri
    # Nothing: whitespace, a keyword, past the end.
    assert not await definition(session, uri, pos(MAIN, "*/ width", 0, 2))
    assert not await definition(session, uri, pos(MAIN, "tube", 0, 2))
    assert not await definition(session, uri, types.Position(99, 5))
    assert not await definition(session, uri, types.Position(2, 400))


async def test_a_builtin_action_is_found_in_std_actions(session: Session):
    uri = session.open("a.knit", "tube t { length: 4 width: 4 }\npattern t { use purl }\n")
    (loc,) = await definition(session, uri, types.Position(1, 17))
    assert loc.uri.endswith("std/actions.knit")


async def test_a_half_written_file_still_navigates_from_its_last_tree(session: Session):
    uri = session.open("main.knit", MAIN)
    await session.diagnostics(uri)
    broken = MAIN + "tube oops { length: \n"
    session.replace_all(uri, broken)
    await session.diagnostics(uri, lambda d: len(d) > 0)
    (loc,) = await definition(session, uri, pos(broken, "#w", 1, 2))
    assert loc.range == rng(MAIN, "w = 10", length=1)
    assert await references(session, uri, pos(broken, "body.top"), True)
    symbols = await session.client.text_document_document_symbol_async(
        types.DocumentSymbolParams(doc(uri))
    )
    assert symbols and "body" in [s.name for s in symbols]
    with pytest.raises(JsonRpcException, match="syntax errors"):
        await rename(session, uri, pos(broken, "#w", 1, 2), "width")


# ---- references ----------------------------------------------------------------------------


async def test_references_with_and_without_the_declaration(session: Session):
    uri = open_main(session)
    got = await references(session, uri, pos(MAIN, "#w", 0, 1), False)
    assert [r.range for r in got] == [
        rng(MAIN, "#w", 0, 1),
        rng(MAIN, "#w", 1, 1),
        rng(MAIN, "#w", 2, 1),
    ]
    got = await references(session, uri, pos(MAIN, "w = 10"), True)
    assert got is not None and len(got) == 4 and got[0].range == rng(MAIN, "w = 10", length=1)
    # A user file's pattern: its uses here and its declaration there.
    got = await references(session, uri, pos(MAIN, "lace()"), True)
    assert got is not None
    assert {(r.uri.rsplit("/", 1)[1], r.range.start.line) for r in got} == {
        ("lace.knit", 1),
        ("main.knit", 0),
        ("main.knit", 8),
    }
    assert not await references(session, uri, pos(MAIN, "*/ width", 0, 2), True)


# ---- rename ----------------------------------------------------------------------------------


def edits_of(edit: types.WorkspaceEdit | None, uri: str) -> list[tuple[types.Range, str]]:
    assert edit is not None and edit.changes is not None
    return sorted(
        ((e.range, e.new_text) for e in edit.changes[uri]),
        key=lambda x: (x[0].start.line, x[0].start.character),
    )


def apply(text: str, edits: list[tuple[types.Range, str]]) -> str:
    """The text after the edits (UTF-16 ranges)."""
    lines = text.split("\n")
    for r, new in sorted(edits, key=lambda x: (-x[0].start.line, -x[0].start.character)):
        line = lines[r.start.line]
        units = line.encode("utf-16-le")
        a, b = 2 * r.start.character, 2 * r.end.character
        lines[r.start.line] = (units[:a].decode("utf-16-le") + new) + units[b:].decode("utf-16-le")
    return "\n".join(lines)


async def test_rename_a_param_keeps_the_hash(session: Session):
    uri = open_main(session)
    got = await prepare(session, uri, pos(MAIN, "#w", 1, 2))
    assert got == rng(MAIN, "#w", 1, 1)
    edit = await rename(session, uri, pos(MAIN, "#w", 1, 2), "girth")
    assert set(edit.changes) == {uri}
    after = apply(MAIN, edits_of(edit, uri))
    assert after.count("#girth") == 3 and "param girth = 10 // é 🧶" in after
    assert "#w" not in after


async def test_rename_a_node_everywhere_it_is_named(session: Session):
    uri = open_main(session)
    edit = await rename(session, uri, pos(MAIN, "body {", 1), "torso")
    after = apply(MAIN, edits_of(edit, uri))
    assert "tube torso {" in after and "@torso.length" in after
    assert "torso.top -> cuff.bottom" in after and "torso.bottom closed" in after
    assert "start torso.bottom" in after and "pattern torso {" in after
    assert "body" not in after
    edit = await rename(session, uri, pos(MAIN, '"cuff"', 0, 2), "wrist")
    after = apply(MAIN, edits_of(edit, uri))
    assert 'shape("wrist")' in after and "pattern wrist" in after and "cuff" not in after


async def test_rename_a_pattern_of_a_user_file_edits_both_files(session: Session):
    uri = open_main(session)
    lace_uri = session.uri("parts/lace.knit")
    edit = await rename(session, uri, pos(MAIN, "lace()"), "openwork")
    assert set(edit.changes) == {uri, lace_uri}
    after = apply(MAIN, edits_of(edit, uri))
    assert '"parts/lace.knit" (openwork)' in after and "apply openwork()" in after
    assert "pattern openwork(n = 2)" in apply(LACE, edits_of(edit, lace_uri))


async def test_rename_refusals_say_why(session: Session):
    uri = open_main(session)
    for at, new, why in [
        (pos(MAIN, "rib(1"), "ribbing", "standard library"),
        (pos(MAIN, "(rib", 0, 2), "ribbing", "standard library"),
        (pos(MAIN, "#w", 1, 2), "2w", "not a name"),
        (pos(MAIN, "#w", 1, 2), "true", "reserved"),
        (pos(MAIN, "body {", 1), "cuff", "already a node"),
        (pos(MAIN, "body {", 1), "before", "reserved"),
        (pos(MAIN, "lace()"), "rib", "already a definition"),
        (pos(MAIN, "tube", 0, 2), "x", "no parameter"),
    ]:
        with pytest.raises(JsonRpcException, match=why):
            await rename(session, uri, at, new)
    with pytest.raises(JsonRpcException, match="standard library"):
        await prepare(session, uri, pos(MAIN, "rib(1"))
    assert await prepare(session, uri, pos(MAIN, "tube", 0, 2)) is None
    assert await prepare(session, uri, types.Position(50, 0)) is None


# ---- symbols ---------------------------------------------------------------------------------


async def test_document_symbols_of_the_glove(session: Session, glove_text: str):
    uri = session.open("glove.knit", glove_text)
    got = await session.client.text_document_document_symbol_async(
        types.DocumentSymbolParams(doc(uri))
    )
    assert got is not None
    by_name = {s.name: s for s in got}
    assert isinstance(got[0], types.DocumentSymbol)
    assert by_name["std.stitches"].kind == types.SymbolKind.Module
    assert by_name["std.stitches"].detail == "(rib, eyelets)"
    finger = by_name["finger_len"]
    assert finger.kind == types.SymbolKind.Constant and finger.detail == "22"
    assert finger.selection_range == rng(glove_text, "finger_len = 22", length=10)
    assert by_name["machine"].kind == types.SymbolKind.Namespace
    assert [c.name for c in by_name["machine"].children] == [
        "gauge",
        "increase",
        "cast_on",
        "cast_off",
    ]
    palm = by_name["palm"]
    assert palm.kind == types.SymbolKind.Class and palm.detail == "tube"
    assert [c.name for c in palm.children] == ["length", "width", "shaper"]
    assert by_name["fingers"].detail == "split"
    assert by_name["ring"].children[0].detail == "@middle.length - 2"
    connections = by_name["connections"]
    assert len(connections.children) == 9
    assert connections.children[0].name == "index.top -> fingers.branches[0]"
    assert "index.bottom closed" in by_name and "start index.bottom" in by_name
    layers = [s.name for s in got if s.kind == types.SymbolKind.Event and s.name[:7] == "pattern"]
    assert layers == ["pattern cuff", "pattern palm", "pattern hand"]


async def test_workspace_symbols_find_unopened_files(session: Session):
    (session.workspace / "parts").mkdir()
    (session.workspace / "parts" / "lace.knit").write_text(LACE, encoding="utf-8")
    (session.workspace / ".hidden").mkdir()
    (session.workspace / ".hidden" / "x.knit").write_text("pattern lacework() {}\n")
    uri = session.open("main.knit", MAIN)
    got = await session.client.workspace_symbol_async(types.WorkspaceSymbolParams(query="LAC"))
    assert got is not None
    names = {(s.name, s.location.uri) for s in got}
    assert names == {("lace", session.uri("parts/lace.knit"))}
    got = await session.client.workspace_symbol_async(types.WorkspaceSymbolParams(query="bod"))
    assert got is not None and [(s.name, s.location.uri) for s in got] == [("body", uri)]
    assert got[0].kind == types.SymbolKind.Class


async def test_yarns_navigate_like_nodes(session: Session):
    uri = session.open("stripes.knit", STRIPES)
    red = rng(STRIPES, "red {", length=3)
    # from each use (UTF-16 columns after 🧶) and from the declaration itself
    for at in (pos(STRIPES, "red where"), pos(STRIPES, "red where", 1, 2), pos(STRIPES, "red {")):
        (loc,) = await definition(session, uri, at)
        assert loc.uri == uri and loc.range == red
    assert not await definition(session, uri, pos(STRIPES, "main where"))  # undeclared
    got = await references(session, uri, pos(STRIPES, "red where", 1), True)
    assert got is not None and [r.range for r in got] == [
        red,
        rng(STRIPES, "red where", 0, length=3),
        rng(STRIPES, "red where", 1, length=3),
    ]
    got = await references(session, uri, pos(STRIPES, "main where"), False)
    assert got is not None and [r.range for r in got] == [rng(STRIPES, "main", length=4)]

    edit = await rename(session, uri, pos(STRIPES, "red where", 1, 2), "blue")
    after = apply(STRIPES, edits_of(edit, uri))
    assert after == STRIPES.replace("red", "blue")
    assert await prepare(session, uri, pos(STRIPES, "red {")) == red
    for at, new, why in [
        (pos(STRIPES, "main where"), "base", "the design's own yarn"),
        (pos(STRIPES, "red {"), "main", "already a yarn named `main`"),
    ]:
        with pytest.raises(JsonRpcException, match=why):
            await rename(session, uri, at, new)

    symbols = await session.client.text_document_document_symbol_async(
        types.DocumentSymbolParams(doc(uri))
    )
    assert symbols is not None and isinstance(symbols[0], types.DocumentSymbol)
    assert [s.name for s in symbols] == ["red", "sleeve", "pattern sleeve"]
    yarn = symbols[0]
    assert yarn.kind == types.SymbolKind.Object and yarn.detail == "yarn"
    assert yarn.selection_range == red and yarn.range.end == types.Position(3, 1)
    assert [(c.name, c.detail) for c in yarn.children or ()] == [
        ("carrier", "5"),
        ("carry_up", "4"),
    ]


# ---- in process ------------------------------------------------------------------------------


def analysis(tmp_path: Path, text: str, name: str = "main.knit") -> Analysis:
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    return analyse(path.as_uri(), 1, str(path), text, Settings())


def test_an_imported_shaper_is_a_use(tmp_path: Path):
    text = "import std.shapers (edges)\ntube t { length: 9 width: [0: 4, 1: 8] shaper: edges }\n"
    a = analysis(tmp_path, text)
    (loc,) = sy.definition(a, text.index("edges }") + 1)
    assert loc.uri.endswith("std/shapers.knit")
    refs = sy.references(a, text.index("edges)"), False)
    assert [r.range.start.line for r in refs] == [0, 1]


def test_a_file_that_does_not_resolve_still_finds_its_imports(tmp_path: Path):
    text = (
        "import std.stitches (rib)\ntube t { length: #nope width: 4 }\npattern t { apply rib() }\n"
    )
    a = analysis(tmp_path, text)
    (loc,) = sy.definition(a, text.index("rib()"))
    assert loc.uri.endswith("std/stitches.knit")


def test_a_name_a_user_file_already_defines_is_refused(tmp_path: Path):
    (tmp_path / "lib.knit").write_text("pattern a() {}\npattern b() {}\n", encoding="utf-8")
    text = 'import "lib.knit" (a)\ntube t { length: 4 width: 4 }\npattern t { apply a() }\n'
    a = analysis(tmp_path, text)
    with pytest.raises(sy.RenameRefused, match="already defines `b`"):
        sy.rename(a, text.index("a()"), "b")


def test_an_unparsed_document_answers_nothing(tmp_path: Path):
    a = analysis(tmp_path, "tube t { length: \n")
    assert sy.definition(a, 5) == []
    assert sy.references(a, 5, True) == []
    assert sy.document_symbols(a) == []
    assert sy.prepare_rename(a, 5) is None


def test_a_declared_main_is_a_yarn_to_go_to_but_never_renamed(tmp_path: Path):
    text = "yarn main { carrier: 4 }\n" + STRIPES
    a = analysis(tmp_path, text)
    (loc,) = sy.definition(a, text.index("main where") + 1)
    assert (loc.range.start.line, loc.range.start.character) == (0, 5)
    for offset in (text.index("main {") + 1, text.index("main where") + 1):
        with pytest.raises(sy.RenameRefused, match="`main` is the design's own yarn"):
            sy.prepare_rename(a, offset)
    # a node may share a yarn's name: the namespaces are apart
    edit = sy.rename(a, text.index("red {"), "sleeve")
    assert edit is not None and edit.changes is not None
    (edits,) = edit.changes.values()
    assert [(e.range.start.line, e.new_text) for e in edits] == [
        (1, "sleeve"),
        (7, "sleeve"),
        (8, "sleeve"),
    ]


def test_workspace_symbols_list_yarns(tmp_path: Path):
    a = analysis(tmp_path, STRIPES)
    got = sy.workspace_symbols("RE", sy.open_files([a]))
    assert [(s.name, s.kind) for s in got] == [("red", types.SymbolKind.Object)]
