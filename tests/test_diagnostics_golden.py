"""Golden tests: the exact diagnostics `knitc check` prints for bad designs.

Each case is a small design `tests/golden/diagnostics/NNN_name.knit` with one kind of
mistake (a few hold several independent mistakes, to pin that each is reported once and
none cascades). Its first line is a comment saying what is wrong. Next to it,
`NNN_name.expected` holds the exact standard error of

    knitc check [ARGS] NNN_name.knit

run with the golden directory as the working directory (so locations render as the bare
file name), followed by a final line `exit: N` with the exit status.

Extra command-line arguments (e.g. `-D` or `-W error`) are given in a leading comment line
`// args: -D foo=3 -W error` (split like a shell would). Files in subfolders (`lib/`) are
helpers imported by the cases, not cases themselves.

The check runs in-process (`knitc.cli.main`), so the whole suite takes well under a second.
Besides the exact comparison, every case asserts that the output is well-formed: no
internal error or traceback, every headline in `path:line:col: severity[CODE]: message`
form (or `knitc: severity[CODE]: ...` for diagnostics without a location), every other
line a source excerpt, caret, note, hint or the final summary, and the summary and exit
status agree with the headlines.

After an intended change to a message, regenerate the expected files with

    KNITC_UPDATE_GOLDEN=1 python -m pytest tests/test_diagnostics_golden.py

then review the diff (`git diff tests/golden/diagnostics`) before committing: every
changed line is a change the designer will see.

A case that crashes knitc today is listed in `KNOWN_INTERNAL_ERRORS` (a strict xfail, with
no `.expected` file); once the crash is fixed the test reports XPASS: remove the entry and
regenerate.
"""

from __future__ import annotations

import re
import shlex
from pathlib import Path

import pytest

from golden import UPDATE, assert_golden
from knitc.cli import main

GOLDEN = Path(__file__).resolve().parent / "golden" / "diagnostics"
CASES = sorted(GOLDEN.glob("*.knit"))

KNOWN_INTERNAL_ERRORS: dict[str, str] = {}
"""Cases that crash knitc today. They have no `.expected` file yet; they are strict xfails,
so the fix makes them fail loudly: then remove the entry here and regenerate."""

HEADLINE = re.compile(r"^[^:]+:\d+:\d+: (error|warning)\[[EW]\d{3}\]: .+")
HEADLINE_NOLOC = re.compile(r"^knitc: (error|warning)\[[EW]\d{3}\]: .+")
OTHER_LINES = [
    re.compile(r"^ *\d+ \| .*"),  # the source line
    re.compile(r"^ +\| +\^+$"),  # the caret under it
    re.compile(r"^ += (note|hint): .+"),  # notes and hints
]
SUMMARY = re.compile(r"^knitc: (?:(\d+) errors?)?(?:, )?(?:(\d+) warnings?)?$")


def _args(case: Path) -> list[str]:
    """Extra arguments from a `// args: ...` line in the leading comment block."""
    for line in case.read_text(encoding="utf-8").splitlines():
        if not line.startswith("//"):
            break
        body = line[2:].strip()
        if body.startswith("args:"):
            return shlex.split(body[len("args:") :])
    return []


def _run(case: Path, monkeypatch, capsys) -> tuple[str, int]:
    monkeypatch.chdir(GOLDEN)
    capsys.readouterr()  # drop anything printed before
    code = main(["check", *_args(case), case.name])
    out = capsys.readouterr()
    assert out.out == "", f"`knitc check` wrote to stdout:\n{out.out}"
    return out.err, code


def _check_well_formed(stderr: str, code: int) -> None:
    assert "internal error" not in stderr and "Traceback" not in stderr, stderr
    errors = warnings = 0
    summary = None
    for line in stderr.splitlines():
        m = HEADLINE.match(line) or HEADLINE_NOLOC.match(line)
        if m:
            assert summary is None, f"diagnostic after the summary line: {line!r}"
            if m.group(1) == "error":
                errors += 1
            else:
                warnings += 1
            continue
        s = SUMMARY.match(line)
        if s and (s.group(1) or s.group(2)):
            summary = (int(s.group(1) or 0), int(s.group(2) or 0))
            continue
        assert any(p.match(line) for p in OTHER_LINES), f"malformed diagnostic line: {line!r}"
    if errors or warnings:
        assert summary == (errors, warnings), (
            f"summary {summary} does not match {errors} error(s), {warnings} warning(s)"
        )
    usage = "error[E408]" in stderr  # a -D mistake is a command-line mistake: exit 2
    assert code == (2 if usage else 1 if errors else 0), (
        f"exit status {code} with {errors} error(s)"
    )


def test_there_are_enough_cases():
    assert len(CASES) >= 45
    for case in CASES:
        first = case.read_text(encoding="utf-8").splitlines()[0]
        assert first.startswith("//"), f"{case.name}: the first line must say what is wrong"


def _param(case: Path):
    reason = KNOWN_INTERNAL_ERRORS.get(case.stem)
    marks = [pytest.mark.xfail(reason=f"knitc bug: {reason}", strict=True)] if reason else []
    return pytest.param(case, id=case.stem, marks=marks)


@pytest.mark.parametrize("case", [_param(c) for c in CASES])
def test_golden_diagnostics(case: Path, monkeypatch, capsys):
    stderr, code = _run(case, monkeypatch, capsys)
    actual = f"{stderr}exit: {code}\n"
    expected_path = case.with_suffix(".expected")
    _check_well_formed(stderr, code)  # never write a malformed output as the expectation
    if case.stem in KNOWN_INTERNAL_ERRORS and not expected_path.exists() and not UPDATE:
        return  # fixed: the strict xfail now reports XPASS, asking for an .expected file
    assert_golden(expected_path, actual, f"diagnostics of {case.name}")
