"""FileCheck golden tests: `.knit` files under `tests/filecheck/` that say how to run knitc
on themselves and what its output must contain, as xDSL's and LLVM's are written.

    // RUN: knitc --emit trace --format text %s | filecheck %s
    // CHECK: visit 0 stitch=0 yarn=0 dir=1 flags=[start]
    // CHECK-NEXT: visit 1

Each `// RUN:` line is a shell pipeline run in the file's directory with `%s` the file's
name, `knitc` this interpreter's knitc, `filecheck` the FileCheck of the test extra
(the `filecheck` package, https://github.com/mull-project/FileCheck.py) and `not CMD`
succeeding when CMD fails (for diagnostics, which exit 1). A RUN line may carry a
`--check-prefix` to match several outputs from one file. Text forms: `text_form.py`.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).parent / "filecheck"
CASES = sorted(ROOT.rglob("*.knit")) + sorted(ROOT.rglob("*.k"))
BIN = Path(sys.executable).parent
RUN = re.compile(r"^\s*(?://|;)\s*RUN:\s*(.*)$")


def run_lines(path: Path) -> list[str]:
    return [m.group(1) for line in path.read_text().splitlines() if (m := RUN.match(line))]


def _command(line: str, path: Path) -> str:
    line = line.replace("%s", path.name)
    line = re.sub(
        r"(^|\|\s*|\bnot\s+)knitc\b", lambda m: f"{m.group(1)}{sys.executable} -m knitc", line
    )
    line = re.sub(r"(^|\|\s*)filecheck\b", lambda m: f"{m.group(1)}{BIN / 'filecheck'}", line)
    return 'not() { ! "$@"; }\n' + line


@pytest.mark.parametrize("path", CASES, ids=lambda p: str(p.relative_to(ROOT)))
def test_filecheck(path: Path):
    lines = run_lines(path)
    assert lines, f"{path} has no RUN line"
    env = dict(os.environ, PYTHONIOENCODING="utf-8", NO_COLOR="1")
    for line in lines:
        proc = subprocess.run(
            ["bash", "-o", "pipefail", "-c", _command(line, path)],
            cwd=path.parent,
            capture_output=True,
            text=True,
            env=env,
            timeout=300,
        )
        assert proc.returncode == 0, (
            f"RUN: {line}\n--- stdout\n{proc.stdout}\n--- stderr\n{proc.stderr}"
        )
