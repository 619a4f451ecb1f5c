"""Pytest-side access to the independent Knitout oracle.

The oracle is knitout-interpreter 0.1.8 + virtual-knitting-machine 0.0.31 (+ knit-graphs
0.1.4), a virtual knitting machine written by other people. It lives in its own virtual
environment, ``.venv-oracle`` (``make oracle-venv``; ``make test`` creates it), and is never a
dependency of knitc. This module runs ``tests/oracle_runner.py`` under that environment's
Python, in ONE subprocess for any number of files, and turns its JSON into `OracleReport`s.

Use from a test::

    from oracle import assert_clean, run_oracle, run_oracle_on_text

    def test_swatch_knits(tmp_path):
        path = tmp_path / "swatch.k"
        path.write_text(knitout_text)
        [report] = run_oracle([path])  # many paths at once: one start-up for all
        assert_clean(report)

    def test_inline():
        [report] = run_oracle_on_text([knitout_text])
        assert_clean(report, allow=("Knit_on_Empty_Needle_Warning",))

`assert_clean` fails (AssertionError, with every problem listed) on any error, any hazard
warning (`HAZARD_WARNINGS`), loops left on needles, carriers left in, or a hook not released.
`report.problems()` gives the same findings as data, to assert on the reason of a failure.

When the oracle environment is missing, `run_oracle` FAILS under CI (the ``CI`` environment
variable is set, as ``.ci/run`` runs) and skips the test elsewhere, saying how to get it.
``KNITC_ORACLE_PYTHON=/path/to/python`` runs the oracle with another interpreter that has
the three packages installed.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import pytest

REPO = Path(__file__).resolve().parent.parent
RUNNER = REPO / "tests" / "oracle_runner.py"
ORACLE_VENV = REPO / ".venv-oracle"
FIXTURES = REPO / "tests" / "fixtures" / "knitout"

# Warnings that mean the fabric is at risk. Others (a loose carrier brought in with `in`, a
# releasehook of another carrier, ...) are reported but do not make a program unclean.
HAZARD_WARNINGS: frozenset[str] = frozenset(
    {
        "Needle_Holds_Too_Many_Loops",  # a needle reached the 4-loop limit
        "Long_Float_Warning",  # a float longer than 20 needles
        "Knit_on_Empty_Needle_Warning",  # knit or tuck with no loop to hold the new one
    }
)

# The problem kinds `OracleReport.problems()` reports.
PROBLEM_KINDS = ("error", "hazard", "loops_left", "carriers_in", "hook")


def oracle_python() -> Path:
    """The interpreter that runs the oracle (it may not exist)."""
    override = os.environ.get("KNITC_ORACLE_PYTHON")
    return Path(override) if override else ORACLE_VENV / "bin" / "python"


def oracle_available() -> bool:
    py = oracle_python()
    return py.is_file() and os.access(py, os.X_OK)


def _in_ci() -> bool:
    return os.environ.get("CI", "").strip().lower() not in ("", "0", "false", "no")


def require_oracle() -> None:
    """Fail (under CI) or skip (elsewhere) the calling test when the oracle is missing."""
    __tracebackhide__ = True
    if oracle_available():
        return
    reason = (
        f"the Knitout oracle is not installed ({oracle_python()} missing): "
        f"run `make oracle-venv` (`make test` does it)"
    )
    if _in_ci():
        pytest.fail(reason + " -- CI must run it, so this fails instead of skipping", pytrace=False)
    pytest.skip(reason)


@dataclass(frozen=True)
class OracleError:
    kind: str  # parse | machine | header | unsupported | io | timeout | internal
    type: str  # the exception's class name, e.g. Use_Inactive_Carrier_Error
    message: str
    line: int | None  # 1-based line in the file
    source: str | None  # the text of that line
    hint: str | None = None  # set when the oracle's own limitation is the cause

    def __str__(self) -> str:
        where = f"line {self.line}: " if self.line is not None else ""
        text = f"{where}{self.type}: {self.message}"
        if self.source is not None:
            text += f"\n      | {self.source}"
        if self.hint:
            text += f"\n      (oracle limitation: {self.hint})"
        return text


@dataclass(frozen=True)
class OracleWarning:
    type: str
    message: str
    line: int | None

    def __str__(self) -> str:
        where = f"line {self.line}: " if self.line is not None else ""
        return f"{where}{self.type}: {self.message}"


@dataclass(frozen=True)
class Problem:
    kind: str  # one of PROBLEM_KINDS
    text: str


@dataclass(frozen=True)
class OracleReport:
    """One file's run. When `ok` is False the state fields describe the machine where the run
    stopped (None when it never started, e.g. on a parse error)."""

    path: Path
    ok: bool  # ran to the end without an error
    errors: tuple[OracleError, ...]
    warnings: tuple[OracleWarning, ...]
    loops_left: int | None  # loops still on needles (and sliders)
    needles_with_loops: tuple[str, ...]
    carriers_active: tuple[int, ...]  # carriers still in
    hook_in_use: bool | None
    hooked_carrier: int | None
    carriage_passes: int | None
    no_ops: int | None  # instructions that changed nothing (xfer or drop of an empty needle)
    knit_graph: dict[str, int] | None  # {"loops": n, "stitches": m} of the oracle's knit graph
    fabric: dict[str, Any] | None  # the whole knit graph, when asked for (`tests/fabric.py`)
    stripped: dict[str, int]  # line kinds removed before the run -> count (see the runner)
    lines: int
    elapsed_s: float
    raw: dict[str, Any] = field(repr=False, compare=False)

    @classmethod
    def from_json(cls, path: Path, d: dict[str, Any]) -> OracleReport:
        return cls(
            path=path,
            ok=bool(d.get("ok")),
            errors=tuple(
                OracleError(
                    kind=e.get("kind", "internal"),
                    type=e.get("type", "?"),
                    message=e.get("message", ""),
                    line=e.get("line"),
                    source=e.get("source"),
                    hint=e.get("hint"),
                )
                for e in d.get("errors", ())
            ),
            warnings=tuple(
                OracleWarning(w.get("type", "?"), w.get("message", ""), w.get("line"))
                for w in d.get("warnings", ())
            ),
            loops_left=d.get("loops_left"),
            needles_with_loops=tuple(d.get("needles_with_loops") or ()),
            carriers_active=tuple(d.get("carriers_active") or ()),
            hook_in_use=d.get("hook_in_use"),
            hooked_carrier=d.get("hooked_carrier"),
            carriage_passes=d.get("carriage_passes"),
            no_ops=d.get("no_ops"),
            knit_graph=d.get("knit_graph"),
            fabric=d.get("fabric"),
            stripped=dict(d.get("stripped") or {}),
            lines=d.get("lines", 0),
            elapsed_s=d.get("elapsed_s", 0.0),
            raw=d,
        )

    def warnings_of(self, *types: str) -> list[OracleWarning]:
        return [w for w in self.warnings if w.type in types]

    def problems(
        self,
        *,
        allow: Iterable[str] = (),
        hazards: Iterable[str] = HAZARD_WARNINGS,
        end_state: bool = True,
    ) -> list[Problem]:
        """Everything that makes the run unclean: errors, hazard warnings (less `allow`), and,
        if `end_state`, loops left on needles, carriers left in, the hook not released."""
        found = [Problem("error", str(e)) for e in self.errors]
        if self.ok is False and not self.errors:
            found.append(Problem("error", "the oracle did not finish (no error recorded)"))
        forbidden = set(hazards) - set(allow)
        found += [Problem("hazard", str(w)) for w in self.warnings if w.type in forbidden]
        if end_state:
            if self.loops_left:
                needles = " ".join(self.needles_with_loops[:24])
                more = " ..." if len(self.needles_with_loops) > 24 else ""
                found.append(
                    Problem(
                        "loops_left",
                        f"{self.loops_left} loop(s) left on {len(self.needles_with_loops)} "
                        f"needle(s): {needles}{more}",
                    )
                )
            if self.carriers_active:
                found.append(
                    Problem(
                        "carriers_in",
                        "carrier(s) never taken out: " + " ".join(map(str, self.carriers_active)),
                    )
                )
            if self.hook_in_use:
                found.append(
                    Problem("hook", f"the inserting hook still holds carrier {self.hooked_carrier}")
                )
        return found

    def problem_kinds(self, **kwargs: Any) -> set[str]:
        return {p.kind for p in self.problems(**kwargs)}

    def describe(self, problems: Sequence[Problem] | None = None) -> str:
        problems = self.problems() if problems is None else problems
        head = f"oracle: {self.path}"
        if not problems:
            return head + " is clean"
        lines = [f"{head} is not clean ({len(problems)} problem(s)):"]
        for p in problems:
            lines.append(f"  [{p.kind}] {p.text}")
        if not self.ok and any(p.kind in ("loops_left", "carriers_in", "hook") for p in problems):
            lines.append("  (the run stopped on an error: the state above is where it stopped)")
        if self.stripped:
            lines.append(f"  stripped before the run: {self.stripped}")
        return "\n".join(lines)


def assert_clean(
    report: OracleReport,
    *,
    allow: Iterable[str] = (),
    hazards: Iterable[str] = HAZARD_WARNINGS,
    end_state: bool = True,
) -> None:
    """Fail with every problem listed unless the oracle ran `report`'s file cleanly.

    allow: warning types tolerated although they are hazards.
    end_state: False for a fragment that deliberately leaves loops or carriers on the machine.
    """
    __tracebackhide__ = True
    problems = report.problems(allow=allow, hazards=hazards, end_state=end_state)
    if problems:
        raise AssertionError(report.describe(problems))


def run_oracle(
    paths: Sequence[str | os.PathLike[str]], *, timeout: float = 120.0, fabric: bool = False
) -> list[OracleReport]:
    """Run every file through the oracle in one subprocess; one report per path, in order.

    timeout: seconds allowed per file (a file over it gets a Timeout error, the others go on).
    fabric: also bring back each file's knit graph (`OracleReport.fabric`, `tests/fabric.py`).
    Fails or skips the calling test when the oracle is missing (see `require_oracle`); raises
    RuntimeError if the runner itself breaks (it never should: it reports, then exits 0).
    """
    __tracebackhide__ = True
    require_oracle()
    paths = [Path(p) for p in paths]
    if not paths:
        return []
    cmd = [str(oracle_python()), str(RUNNER), "--timeout", str(timeout)]
    if fabric:
        cmd.append("--fabric")
    cmd += [str(p.resolve()) for p in paths]
    proc = subprocess.run(
        cmd,
        capture_output=True,
        text=True,
        timeout=60 + timeout * len(paths),
        env={**os.environ, "PYTHONDONTWRITEBYTECODE": "1"},
        check=False,
    )
    try:
        data = json.loads(proc.stdout)
        reports = data["reports"]
    except (ValueError, KeyError, TypeError) as e:
        raise RuntimeError(
            f"oracle runner failed (exit {proc.returncode}): {e}\n"
            f"stdout: {proc.stdout[-2000:]}\nstderr: {proc.stderr[-4000:]}"
        ) from None
    if len(reports) != len(paths):
        raise RuntimeError(f"oracle runner returned {len(reports)} reports for {len(paths)} files")
    return [OracleReport.from_json(p, r) for p, r in zip(paths, reports)]


def run_oracle_on_text(
    texts: Sequence[str], *, timeout: float = 120.0, fabric: bool = False
) -> list[OracleReport]:
    """`run_oracle` on Knitout given as strings (written to a temporary directory)."""
    __tracebackhide__ = True
    require_oracle()
    with tempfile.TemporaryDirectory(prefix="knitc-oracle-") as tmp:
        paths = []
        for i, text in enumerate(texts):
            p = Path(tmp) / f"program{i}.k"
            p.write_text(text, encoding="utf-8", newline="\n")
            paths.append(p)
        return run_oracle(paths, timeout=timeout, fabric=fabric)


if __name__ == "__main__":  # quick manual use: python tests/oracle.py FILE.k ...
    for r in run_oracle(sys.argv[1:]):
        print(r.describe())
