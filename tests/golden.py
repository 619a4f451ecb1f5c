"""The one golden-file check the golden tests share.

`assert_golden(path, actual, what)` compares `actual` with the file at `path` and fails
with a unified diff; with KNITC_UPDATE_GOLDEN=1 it rewrites the file instead (review the
diff in git before committing it).
"""

from __future__ import annotations

import difflib
import os
from pathlib import Path

import pytest

UPDATE = os.environ.get("KNITC_UPDATE_GOLDEN") == "1"


def assert_golden(path: Path, actual: str, what: str) -> None:
    if UPDATE:
        path.write_text(actual, encoding="utf-8")
        return
    if not path.exists():
        pytest.fail(
            f"{path.name} is missing; create it with KNITC_UPDATE_GOLDEN=1, then review it",
            pytrace=False,
        )
    expected = path.read_text(encoding="utf-8")
    if actual != expected:
        diff = "".join(
            difflib.unified_diff(
                expected.splitlines(keepends=True),
                actual.splitlines(keepends=True),
                fromfile=f"{path.name} (expected)",
                tofile=f"{what} (actual)",
            )
        )
        pytest.fail(
            f"{what} differs from {path.name} (KNITC_UPDATE_GOLDEN=1 to accept):\n{diff}",
            pytrace=False,
        )
