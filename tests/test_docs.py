"""docs/language.md stays a true reference of the language.

* Its diagnostic table lists exactly the codes the compiler's source contains: every
  `"E123"` / `"W123"` string literal and every rendered `error[E123]` / `warning[W123]` in
  compiler/knitc/**/*.py, each once, with the severity its letter says.
* Its property tables list exactly the properties of `knitc.frontend.skeleton`'s tables, one
  table per kind, each with its default, its choices and its range.
* Every ```` ```knit ```` example compiles through code generation without errors (a block
  fenced ```` ```knit fragment ```` is exempt), and every fenced block says its language.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from knitc.driver import compile_source
from knitc.frontend import skeleton as sk

ROOT = Path(__file__).parent.parent
DOC = ROOT / "docs" / "language.md"
COMPILER = ROOT / "compiler" / "knitc"

LITERAL = re.compile(r"[\"']([EW]\d{3})[\"']")
SHOWN = re.compile(r"(?:error|warning)\[([EW]\d{3})\]")

PROPERTY_TABLES: dict[str, dict[str, sk.PropSpec]] = {
    "`machine` properties": sk.MACHINE_PROPS,
    "`sheet` properties": sk.SHEET_PROPS,
    "`tube` properties": sk.TUBE_PROPS,
    "`joint` properties": sk.JOINT_PROPS,
    "`split` properties": sk.SPLIT_PROPS,
    "interface properties": sk.ITF_PROPS,
    "`action` properties": sk.ACTION_PROPS,
    "`yarn` properties": sk.YARN_PROPS,
}
"""Heading of each property table in the docs -> the table it documents."""


def doc_text() -> str:
    return DOC.read_text(encoding="utf-8")


def sections(text: str) -> list[tuple[str, list[str]]]:
    """(heading, lines up to the next heading) for every `#` heading outside code blocks."""
    out: list[tuple[str, list[str]]] = [("", [])]
    fenced = False
    for line in text.splitlines():
        if line.startswith("```"):
            fenced = not fenced
        if not fenced and re.match(r"#{1,6} ", line):
            out.append((line.lstrip("#").strip(), []))
        else:
            out[-1][1].append(line)
    return out


def table_rows(lines: list[str]) -> list[list[str]]:
    """The cells of every table row in `lines` (header and separator rows excluded)."""
    rows = []
    for i, line in enumerate(lines):
        if not line.startswith("|") or re.fullmatch(r"\|(\s*:?-+:?\s*\|)+", line.strip()):
            continue
        nxt = lines[i + 1] if i + 1 < len(lines) else ""
        if re.fullmatch(r"\|(\s*:?-+:?\s*\|)+", nxt.strip()):
            continue  # a header row
        rows.append([c.strip() for c in re.split(r"(?<!\\)\|", line.strip())[1:-1]])
    return rows


# ---- diagnostic codes -----------------------------------------------------------------------


def compiler_codes() -> set[str]:
    codes: set[str] = set()
    for path in sorted(COMPILER.rglob("*.py")):
        text = path.read_text(encoding="utf-8")
        codes |= set(LITERAL.findall(text)) | set(SHOWN.findall(text))
    return codes


def documented_codes() -> list[tuple[str, str, str]]:
    """(code, severity, meaning) of every row of the Diagnostics section's table."""
    found = [lines for heading, lines in sections(doc_text()) if heading == "Diagnostics"]
    assert len(found) == 1, "docs/language.md needs exactly one `## Diagnostics` section"
    out = []
    for cells in table_rows(found[0]):
        assert len(cells) == 3, f"a diagnostic row has three cells: {cells}"
        m = re.fullmatch(r"`([EW]\d{3})`", cells[0])
        assert m, f"the first cell of a diagnostic row is a backticked code: {cells}"
        out.append((m.group(1), cells[1], cells[2]))
    return out


def test_the_diagnostic_table_lists_every_code_of_the_compiler():
    source = compiler_codes()
    rows = documented_codes()
    docs = {code for code, _, _ in rows}
    missing = sorted(source - docs)
    stale = sorted(docs - source)
    assert not missing and not stale, (
        "docs/language.md's diagnostic table and the compiler's codes differ:\n"
        f"  in compiler/knitc but not in the table: {', '.join(missing) or 'none'}\n"
        f"  in the table but not in compiler/knitc: {', '.join(stale) or 'none'}"
    )


def test_each_code_is_listed_once_in_order_with_its_severity_and_a_meaning():
    rows = documented_codes()
    codes = [code for code, _, _ in rows]
    twice = sorted({c for c in codes if codes.count(c) > 1})
    assert not twice, f"listed more than once: {', '.join(twice)}"
    assert codes == sorted(codes, key=lambda c: (c[0], c)), "keep the table sorted (E, then W)"
    for code, severity, meaning in rows:
        if code == "E000":  # the resolver's marker for an error already reported
            continue
        want = "warning" if code.startswith("W") else "error"
        assert severity == want, f"{code}: severity {severity!r}, expected {want!r}"
        assert meaning, f"{code} has no meaning"


# ---- property tables ------------------------------------------------------------------------


def _number(x: float) -> str:
    return str(int(x)) if float(x).is_integer() else str(x)


def shown_default(name: str, spec: sk.PropSpec) -> str:
    """A property's default as the docs print it."""
    d = spec.default
    if d is None and spec is sk.YARN_PROPS.get(name):
        return "chosen by knitc"
    if d is None:
        return f"the machine's `{name}`"
    if isinstance(d, bool):
        return "`true`" if d else "`false`"
    if isinstance(d, str):
        return f'`"{d}"`' if spec.kind == "string" else f"`{d}`"
    if isinstance(d, tuple):
        return "`[" + ", ".join(_number(x) for x in d) + "]`"
    return f"`{_number(d)}`"


def documented_properties() -> dict[str, dict[str, list[str]]]:
    """Property tables by heading: property name -> its row's cells."""
    out: dict[str, dict[str, list[str]]] = {}
    for heading, lines in sections(doc_text()):
        header = [line for line in lines if line.startswith("| property |")]
        if not header:
            continue
        assert heading in PROPERTY_TABLES, (
            f"a property table under `{heading}`, which documents none of knitc.frontend.skeleton's "
            f"tables (known headings: {', '.join(PROPERTY_TABLES)})"
        )
        assert heading not in out, f"two sections `{heading}`"
        assert header[0].replace(" ", "") == "|property|type|default|values|meaning|", header[0]
        rows: dict[str, list[str]] = {}
        for cells in table_rows(lines):
            m = re.fullmatch(r"`(\w+)`", cells[0])
            assert m and len(cells) == 5, f"{heading}: a malformed row {cells}"
            assert m.group(1) not in rows, f"{heading}: `{m.group(1)}` is listed twice"
            rows[m.group(1)] = cells
        out[heading] = rows
    return out


def test_every_property_table_is_documented():
    docs = documented_properties()
    missing = sorted(set(PROPERTY_TABLES) - set(docs))
    assert not missing, f"docs/language.md lacks the sections {missing}"


@pytest.mark.parametrize("heading", list(PROPERTY_TABLES))
def test_the_properties_of_each_kind_are_documented_with_default_choices_and_range(heading):
    spec_table = PROPERTY_TABLES[heading]
    rows = documented_properties().get(heading, {})
    missing = sorted(set(spec_table) - set(rows))
    extra = sorted(set(rows) - set(spec_table))
    assert not missing and not extra, (
        f"{heading}: the docs and knitc.frontend.skeleton differ:\n"
        f"  not documented: {', '.join(missing) or 'none'}\n"
        f"  documented but not a property: {', '.join(extra) or 'none'}"
    )
    for name, spec in spec_table.items():
        _, _type, default, values, meaning = rows[name]
        assert default == shown_default(name, spec), (
            f"{heading} `{name}`: default {default!r}, expected {shown_default(name, spec)!r}"
        )
        for choice in spec.choices:
            assert f"`{choice}`" in values, f"{heading} `{name}`: choice `{choice}` missing"
        for bound in (spec.min, spec.max):
            if bound is not None:
                assert f"`{_number(bound)}`" in values, (
                    f"{heading} `{name}`: bound `{_number(bound)}` missing from {values!r}"
                )
        assert meaning, f"{heading} `{name}` has no meaning"


# ---- examples -------------------------------------------------------------------------------


def fenced_blocks(text: str) -> list[tuple[int, str, str]]:
    """(line, info string, body) of every fenced code block."""
    blocks = []
    lines = text.splitlines()
    i = 0
    while i < len(lines):
        m = re.match(r"(`{3,})(.*)$", lines[i])
        if not m:
            i += 1
            continue
        fence, info, start = m.group(1), m.group(2).strip(), i + 1
        i += 1
        while i < len(lines) and not lines[i].startswith(fence):
            i += 1
        assert i < len(lines), f"docs/language.md:{start}: an unclosed code block"
        blocks.append((start, info, "\n".join(lines[start:i]) + "\n"))
        i += 1
    return blocks


def test_every_code_block_says_its_language():
    bare = [line for line, info, _ in fenced_blocks(doc_text()) if not info]
    assert not bare, (
        f"fence these blocks with ```knit (checked), ```knit fragment or ```text: lines {bare}"
    )


EXAMPLES = [(line, body) for line, info, body in fenced_blocks(doc_text()) if info == "knit"]


def test_there_are_examples():
    assert len(EXAMPLES) >= 5


@pytest.mark.parametrize(("line", "body"), EXAMPLES, ids=[f"line{n}" for n, _ in EXAMPLES])
def test_every_knit_example_compiles(line, body):
    result = compile_source(body, "doc.knit", until="machine")
    if result.diagnostics.has_errors:
        pytest.fail(
            f"the example at docs/language.md:{line} does not compile:\n"
            + result.diagnostics.render(),
            pytrace=False,
        )
