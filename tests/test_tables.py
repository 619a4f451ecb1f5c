"""The parser's LALR tables kept as JSON between runs (knitc/frontend/tables.py): a parser
loaded from the file parses exactly as a freshly built one, the file is used only in a
folder that is the user's alone, and a broken or foreign file costs only a rebuild."""

from __future__ import annotations

import json
import os
from pathlib import Path

import lark
import pytest

from knitc.frontend import parser, tables
from knitc.resources import grammar_text

REPO = Path(__file__).resolve().parent.parent
OPTIONS = {
    "parser": "lalr",
    "lexer": "contextual",
    "propagate_positions": True,
    "maybe_placeholders": True,
}
SOURCES = sorted(REPO.glob("examples/**/*.knit")) + sorted(REPO.glob("stdlib/**/*.knit"))


@pytest.fixture
def cache(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    monkeypatch.delenv("KNITC_NO_CACHE", raising=False)
    return tmp_path / "knitc"


def _trees(p: lark.Lark) -> list[lark.Tree]:
    p.parser.lexer = parser._ContextualKeywords(p.parser.lexer)
    return [p.parse(path.read_text(encoding="utf-8")) for path in SOURCES]


def _forbid_build(monkeypatch: pytest.MonkeyPatch) -> None:
    def refuse(*args: object, **kwargs: object) -> None:
        raise AssertionError("the tables were built, not read")

    monkeypatch.setattr(tables, "Lark", type("NoBuild", (lark.Lark,), {"__init__": refuse}))


def test_loaded_tables_parse_as_built_ones(cache: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    built = tables.load_lark(grammar_text(), OPTIONS, {})
    (path,) = cache.glob("knit-lalr-*.json")
    assert oct(cache.stat().st_mode & 0o777) == "0o700"
    _forbid_build(monkeypatch)
    loaded = tables.load_lark(grammar_text(), OPTIONS, {})
    assert _trees(loaded) == _trees(built)
    assert json.loads(path.read_text())["data"]  # plain JSON, nothing else


def test_comment_callbacks_are_given_not_stored(cache: Path) -> None:
    seen: list[str] = []
    tables.load_lark(grammar_text(), OPTIONS, {})
    loaded = tables.load_lark(grammar_text(), OPTIONS, {"COMMENT": lambda t: seen.append(t)})
    loaded.parse("// a note\nsheet s { length: 4, width: 4 }\n")
    assert seen == ["// a note"]


@pytest.mark.parametrize("damage", ["", "{", '{"data": 1}', "[]"])
def test_a_broken_file_is_rebuilt(cache: Path, damage: str) -> None:
    tables.load_lark(grammar_text(), OPTIONS, {})
    (path,) = cache.glob("knit-lalr-*.json")
    path.write_text(damage)
    again = tables.load_lark(grammar_text(), OPTIONS, {})
    assert again.parse("sheet s { length: 4, width: 4 }\n")
    assert json.loads(path.read_text())["memo"]  # written again, whole


def test_the_file_name_follows_the_grammar_and_lark(
    cache: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    one = tables.table_file(grammar_text(), OPTIONS)
    assert one != tables.table_file(grammar_text() + "\n// changed\n", OPTIONS)
    assert one != tables.table_file(grammar_text(), {**OPTIONS, "maybe_placeholders": False})
    monkeypatch.setattr(lark, "__version__", "0.0.0")
    assert one != tables.table_file(grammar_text(), OPTIONS)


def test_a_shared_folder_is_not_used(cache: Path) -> None:
    cache.mkdir(mode=0o755)
    os.chmod(cache, 0o755)
    assert tables.table_file(grammar_text(), OPTIONS) is None
    tables.load_lark(grammar_text(), OPTIONS, {})
    assert not list(cache.iterdir())


def test_no_cache_setting(cache: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("KNITC_NO_CACHE", "1")
    assert tables.table_file(grammar_text(), OPTIONS) is None
    tables.load_lark(grammar_text(), OPTIONS, {})
    assert not cache.exists()


def test_an_unwritable_folder_costs_only_speed(
    cache: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    def full(*args: object, **kwargs: object) -> None:
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(tables.tempfile, "mkstemp", full)
    got = tables.load_lark(grammar_text(), OPTIONS, {})
    assert got.parse("sheet s { length: 4, width: 4 }\n")
    assert not list(cache.iterdir())


def test_the_encoding_round_trips_lark_data() -> None:
    data = {0: ("shift", 3), "rules": [{"empty_indices": (True, False)}], "n": None}
    text = json.dumps(tables._encode(data))
    assert json.loads(text, object_hook=tables._decode) == data
    with pytest.raises(TypeError):
        tables._encode({"f": print})


def test_a_relative_or_missing_home_is_never_the_working_folder(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.chdir(tmp_path)
    monkeypatch.delenv("KNITC_NO_CACHE", raising=False)
    monkeypatch.setenv("XDG_CACHE_HOME", "relcache")  # relative: XDG says ignore it
    monkeypatch.setenv("HOME", str(tmp_path / "home"))
    (tmp_path / "home" / ".cache").mkdir(parents=True)
    got = tables.table_file(grammar_text(), OPTIONS)
    assert got is not None and got.startswith(str(tmp_path / "home" / ".cache" / "knitc"))
    assert not (tmp_path / "relcache").exists()
    monkeypatch.delenv("XDG_CACHE_HOME")
    monkeypatch.setattr(tables.os.path, "expanduser", lambda p: p)  # no HOME, no passwd
    assert tables.table_file(grammar_text(), OPTIONS) is None
    assert not (tmp_path / "~").exists()


def test_a_symlinked_or_foreign_file_is_not_read(cache: Path, tmp_path: Path) -> None:
    tables.load_lark(grammar_text(), OPTIONS, {})
    (path,) = cache.glob("knit-lalr-*.json")
    planted = tmp_path / "planted.json"
    planted.write_text(path.read_text())
    path.unlink()
    path.symlink_to(planted)
    with pytest.raises(OSError):
        tables._load(str(path), {})
    again = tables.load_lark(grammar_text(), OPTIONS, {})  # rebuilt, written over the link
    assert again.parse("sheet s { length: 4, width: 4 }\n")
    assert not path.is_symlink()


def test_other_tables_and_left_temporaries_are_removed(cache: Path) -> None:
    cache.mkdir(mode=0o700)
    (cache / "knit-lalr-0123456789abcdef01234567.json").write_text("{}")
    (cache / ".knit-lalr-killed").write_text("")
    (cache / "other-tool.json").write_text("{}")
    tables.load_lark(grammar_text(), OPTIONS, {})
    names = sorted(p.name for p in cache.iterdir())
    assert len(names) == 2 and "other-tool.json" in names
    assert (
        names[0].startswith("knit-lalr-") and names[0] != "knit-lalr-0123456789abcdef01234567.json"
    )


def test_writing_the_file_leaves_the_built_parser_whole(cache: Path) -> None:
    built = tables.load_lark(grammar_text(), OPTIONS, {"COMMENT": lambda t: t})
    assert "COMMENT" in built.options.lexer_callbacks


def test_a_new_home_without_a_cache_folder_gets_one(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A fresh account (or CI machine) has no ~/.cache: the cache must still work there,
    making ~/.cache and ~/.cache/knitc mode 0700 as XDG asks."""
    monkeypatch.delenv("KNITC_NO_CACHE", raising=False)
    monkeypatch.delenv("XDG_CACHE_HOME", raising=False)
    home = tmp_path / "home"
    home.mkdir()
    monkeypatch.setenv("HOME", str(home))
    got = tables.table_file(grammar_text(), OPTIONS)
    assert got is not None and got.startswith(str(home / ".cache" / "knitc"))
    for made in (home / ".cache", home / ".cache" / "knitc"):
        assert oct(made.stat().st_mode & 0o777) == "0o700"


def test_no_cache_folder_is_made_in_a_home_that_is_not_ours(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.delenv("KNITC_NO_CACHE", raising=False)
    monkeypatch.delenv("XDG_CACHE_HOME", raising=False)
    home = tmp_path / "home"
    home.mkdir()
    monkeypatch.setenv("HOME", str(home))
    monkeypatch.setattr(tables.os, "getuid", lambda: os.stat(home).st_uid + 1)
    assert tables.table_file(grammar_text(), OPTIONS) is None
    assert not (home / ".cache").exists()
