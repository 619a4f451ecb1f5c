"""The VS Code extension in editors/vscode: its grammar and its manifest.

- The TextMate grammar passes the vscode-tmgrammar-test assertion files in
  editors/vscode/tests/ (`//  ^^^ scope` lines under each source line).
- Every keyword of the language (grammars/knit.lark's keyword terminals) is an alternative
  of a rule that gives it a keyword scope (read from the grammar's JSON, without node).
- Every example, stdlib module and documented ```knit block (all of them compile) tokenises
  without an `invalid` scope and ends outside any string, grid, comment or bracket
  (editors/vscode/tests/no-invalid.js, vscode-textmate as VS Code runs it).
- package.json contributes what the language server's contract names: the language `knit`
  and `.knit`, the grammar `source.knit`, the settings and the preview command.

The grammar tests need node and the extension's npm dev dependencies (`make editors-deps`,
which `make test` runs); without them they skip, except under CI, where they fail.
"""

from __future__ import annotations

import json
import re
import shutil
import subprocess
from pathlib import Path

import pytest

from ci_tools import need

REPO = Path(__file__).resolve().parents[1]
EXT = REPO / "editors" / "vscode"
TMTEST = EXT / "node_modules" / ".bin" / "vscode-tmgrammar-test"
GRAMMAR = "syntaxes/knit.tmLanguage.json"


def _need(ok: bool, reason: str) -> None:
    __tracebackhide__ = True
    need(ok, reason, "the editor grammar tests")


@pytest.fixture(scope="module")
def node() -> str:
    exe = shutil.which("node")
    _need(exe is not None, "node is not on PATH: install Node.js, then `make editors-deps`")
    _need(
        TMTEST.exists() and (EXT / "node_modules" / "vscode-textmate").is_dir(),
        f"{TMTEST.relative_to(REPO)} is missing: run `make editors-deps` "
        "(npm ci in editors/vscode)",
    )
    assert exe is not None
    return exe


def _run(args: list[str]) -> subprocess.CompletedProcess[str]:
    return subprocess.run(args, cwd=EXT, capture_output=True, text=True, timeout=120)


# ---- the grammar ----------------------------------------------------------------------------


def test_grammar_assertions(node: str) -> None:
    cases = sorted(p.name for p in (EXT / "tests").glob("*.test.knit"))
    assert len(cases) >= 5, cases
    r = _run([str(TMTEST), "--compact", "-g", GRAMMAR, "tests/*.test.knit"])
    out = r.stdout + r.stderr
    assert r.returncode == 0 and "ERROR" not in out, out
    for name in cases:  # every file was run, not just found
        assert f"tests/{name} run successfuly" in out, out


def test_assertion_files_carry_assertions() -> None:
    # An assertion line that the tool does not recognise is read as source: a typo would
    # silently assert nothing. Each file starts with the header and asserts on most lines.
    for path in sorted((EXT / "tests").glob("*.test.knit")):
        lines = path.read_text().splitlines()
        assert re.fullmatch(r'// SYNTAX TEST "source\.knit" "[^"]+"', lines[0]), path
        asserts = [ln for ln in lines if re.match(r"//\s*(\^|<~*-)", ln)]
        assert len(asserts) >= 40, (path, len(asserts))
        for ln in asserts:  # `^^^ scope...` or `<--- scope...`, optionally ` - excluded...`
            assert re.fullmatch(
                r"//\s*(\^+|<~*-+) [\w.-]+( [\w.-]+)*( - [\w.-]+( [\w.-]+)*)?", ln
            ), (path, ln)


def _rules(node: object) -> list[dict]:
    """Every rule of a TextMate grammar with a `match`, wherever it is nested."""
    if isinstance(node, list):
        return [r for item in node for r in _rules(item)]
    if not isinstance(node, dict):
        return []
    own = [node] if isinstance(node.get("match"), str) else []
    return own + [r for value in node.values() for r in _rules(value)]


def _scopes(rule: dict) -> list[str]:
    """The scope names a rule gives: its own and its captures'."""
    return [rule.get("name", ""), *(c.get("name", "") for c in rule.get("captures", {}).values())]


def test_grammar_highlights_every_keyword_of_the_language() -> None:
    # A keyword grammars/knit.lark gains needs a rule here too (`yarn` and `knit` came
    # without one): each keyword terminal's words are an alternative of some rule's match,
    # in a rule that gives a keyword (or node-kind) scope. No node needed.
    lark = (REPO / "grammars" / "knit.lark").read_text()
    words = set(re.findall(r"^KW_\w+\.\d+: /(\w+)\(", lark, re.M))
    for group in re.findall(r"^(?:NODE_KIND|GRID_MODE|STEP)\.\d+: /\(([\w|]+)\)", lark, re.M):
        words |= set(group.split("|"))
    assert {"yarn", "knit", "machine", "where", "sheet", "draw", "main"} <= words, words
    rules = _rules(json.loads((EXT / GRAMMAR).read_text()))
    for word in sorted(words):
        alternative = re.compile(rf"\((?:[\w|]*\|)?{word}(?:\|[\w|]*)?\)")
        scoped = [
            r
            for r in rules
            if alternative.search(r["match"])
            and any(s.startswith(("keyword.", "storage.type.")) for s in _scopes(r))
        ]
        assert scoped, f"no keyword rule of {GRAMMAR} highlights `{word}`"


def _docs_blocks(tmp_path: Path) -> list[Path]:
    text = (REPO / "docs" / "language.md").read_text()
    blocks = re.findall(r"^```knit\n(.*?)^```", text, re.S | re.M)
    assert len(blocks) >= 5
    out = []
    for i, block in enumerate(blocks):
        p = tmp_path / f"language_md_{i}.knit"
        p.write_text(block)
        out.append(p)
    return out


def test_sources_tokenise_without_invalid_scopes(node: str, tmp_path: Path) -> None:
    files = sorted(
        [
            *REPO.glob("examples/**/*.knit"),
            *REPO.glob("stdlib/std/**/*.knit"),
        ]
    )
    assert len(files) >= 10
    docs = _docs_blocks(tmp_path)
    r = _run([node, "tests/no-invalid.js", *map(str, files), *map(str, docs)])
    assert r.returncode == 0, r.stdout + r.stderr
    assert f"no-invalid: {len(files) + len(docs)} files, 0 problems" in r.stdout, r.stdout


def test_invalid_scopes_are_reported(node: str, tmp_path: Path) -> None:
    # The check can fail: a stray `;` (E100), a bare `#` (E106), an unclosed grid.
    bad = tmp_path / "bad.knit"
    bad.write_text('param a = 1;\nparam b = # + 1\npattern p { draw """\n  K P\n')
    r = _run([node, "tests/no-invalid.js", str(bad)])
    assert r.returncode == 1, r.stdout + r.stderr
    assert "bad.knit:1:12" in r.stdout and "bad.knit:2:11" in r.stdout, r.stdout
    assert "ends inside an unclosed grammar rule" in r.stdout, r.stdout


# ---- the manifest ---------------------------------------------------------------------------


@pytest.fixture(scope="module")
def manifest() -> dict:
    return json.loads((EXT / "package.json").read_text())


def test_manifest_language_and_grammar(manifest: dict) -> None:
    assert manifest["name"] == "knitc" and manifest["publisher"] == "knitc"
    assert manifest["main"] == "./extension.js" and (EXT / "extension.js").is_file()
    assert manifest["engines"]["vscode"] == "^1.82.0"
    contributes = manifest["contributes"]
    (lang,) = contributes["languages"]
    assert lang["id"] == "knit" and lang["extensions"] == [".knit"]
    conf = json.loads((EXT / lang["configuration"]).read_text())
    assert conf["comments"] == {"lineComment": "//", "blockComment": ["/*", "*/"]}
    for pattern in [
        conf["wordPattern"],
        *conf["indentationRules"].values(),
        *conf["folding"]["markers"].values(),
    ]:
        re.compile(pattern)
    (grammar,) = contributes["grammars"]
    assert grammar["language"] == "knit" and grammar["scopeName"] == "source.knit"
    tm = json.loads((EXT / grammar["path"]).read_text())
    assert tm["scopeName"] == "source.knit"
    # every include names a rule of the repository
    text = json.dumps(tm)
    for ref in re.findall(r'"include": "#([\w-]+)"', text):
        assert ref in tm["repository"], ref


def test_manifest_settings_and_command(manifest: dict) -> None:
    props = manifest["contributes"]["configuration"]["properties"]
    expected = {
        "knitc.defines": ("object", {}),
        "knitc.include": ("array", []),
        "knitc.maxStitches": ("integer", 2000000),
        "knitc.server.path": ("string", "knitc"),
        "knitc.server.args": ("array", ["lsp"]),
    }
    for name, (kind, default) in expected.items():
        assert name in props, name
        assert props[name]["type"] == kind and props[name]["default"] == default, name
        assert props[name].get("description") or props[name].get("markdownDescription"), name
    commands = {c["command"] for c in manifest["contributes"]["commands"]}
    assert "knit.showPreview" in commands
    # the extension registers that command and asks the server for `knitc.preview`
    js = (EXT / "extension.js").read_text()
    assert '"knit.showPreview"' in js and '"knitc.preview"' in js
    assert 'language: "knit"' in js and "configurationSection: SECTION" in js


def test_lock_file_matches_manifest(manifest: dict) -> None:
    lock = json.loads((EXT / "package-lock.json").read_text())
    root = lock["packages"][""]
    assert root.get("dependencies", {}) == manifest.get("dependencies", {})
    assert root.get("devDependencies", {}) == manifest.get("devDependencies", {})
    assert lock["packages"]["node_modules/vscode-tmgrammar-test"]["version"] == "0.1.3"
    assert lock["packages"]["node_modules/vscode-languageclient"]["version"].startswith("9.")
