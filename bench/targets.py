"""The speed targets knitc holds itself to, each measured as whole processes (CPU seconds,
start-up included, as a user runs the command; bench/measure.py) and judged: start-up, the
1M-stitch tube and its scaling from 100k, lace against a plain sheet of the same size, and
the peers (bench/peers.py: knit-script, the CMU converter; bench/original.py: the original
system, optional). `run_targets(tmp)` returns {"cases": ..., "peers": ..., "original": ...,
"targets": [{name, value, limit, unit, met}]} for results.json; `table` prints the
README's table of ratios.

Nothing here is a test: a target that is not met is reported as not met, never as a
failure of `make bench`.
"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent))
import measure  # noqa: E402
import original  # noqa: E402
import peers  # noqa: E402

REPO = Path(__file__).resolve().parent.parent
KNITC = REPO / ".venv" / "bin" / "knitc"

TEN_LINES = """\
// a small sleeve in ten lines: a ribbed cuff, then a plain tube that widens
import std.stitches (rib)
param w = 8
tube cuff { length: 6, width: #w, gauge: half }
tube sleeve { length: 12, width: [0: #w, 1: 10], gauge: half }
cuff.top -> sleeve.bottom
start cuff.bottom
pattern cuff {
  apply rib(1, 1)
}
"""
"""The start-up case: `knitc check` of a ten-line design (about 400 stitches)."""

LACE = """\
// lace-100k: a sheet of 400 courses x 250 wales, eyelets and cables
import std.stitches (cable, eyelets)
sheet s { length: 400, width: 250 }
pattern s {
  apply eyelets() where wales(0.05:0.5)
  apply cable(2, 8) where wales(0.5:0.95)
}
"""
PLAIN = "// sheet-100k: the same sheet, plain\nsheet s { length: 400, width: 250 }\n"
FAIR_ISLE = """\
// fair-isle-100k: the plain sheet, every course in two yarns (issue 17's colour target)
import std.colour (checks)
yarn red { carrier: 5 }
sheet s { length: 400, width: 250 }
pattern s {
  apply checks("red")
}
"""
JACQUARD = """\
// jacquard-100k: the fair isle sheet with a birdseye back (twice the loops of the plain one)
import std.colour (checks)
yarn red { carrier: 5 }
sheet s { length: 400, width: 250 }
pattern s {
  apply checks("red")
  backing birdseye
}
"""
INTARSIA = """\
// intarsia-100k: the plain sheet with two tall intarsia blocks (five regions a course)
yarn red { carrier: 5 }
yarn navy { carrier: 6 }
sheet s { length: 400, width: 250 }
pattern s {
  knit red where courses(20:379) and wales(0.1:0.4)
  knit navy where courses(40:359) and wales(0.6:0.9)
  intarsia where courses(20:379)
}
"""
TUBE_100K = "tube t { length: 400, width: 125 }\n"
TUBE_1M = "tube t { length: 1000, width: 500 }\n"


def _compile(tmp: Path, name: str, text: str, runs: int, check: bool = False) -> dict:
    src = tmp / f"{name}.knit"
    src.write_text(text, encoding="utf-8")
    argv: list[str | Path] = [KNITC, "check", src] if check else [KNITC, src, "-o",
                                                                   tmp / f"{name}.k"]
    return measure.single(argv, runs=runs, cwd=REPO, env=measure.environ())


IMPORT_FLOOR = "import numpy, lark.lark"
"""What every compile imports before any code of knitc's: its start-up cannot go below a
Python process that does only this (with one OpenBLAS thread, as the CLI asks for)."""


def run_cases(tmp: Path) -> dict[str, dict]:
    """knitc's own whole-process cases, and the import floor under the start-up case. The
    1M tube runs once (about 15 s)."""
    return {
        "import-floor": measure.single([KNITC.parent / "python", "-c", IMPORT_FLOOR], runs=7,
                                       cwd=REPO, env=measure.environ(OPENBLAS_NUM_THREADS="1")),
        "check-ten-lines": _compile(tmp, "ten", TEN_LINES, 7, check=True),
        "sheet-100k": _compile(tmp, "sheet-100k", PLAIN, 3),
        "lace-100k": _compile(tmp, "lace-100k", LACE, 3),
        "fair-isle-100k": _compile(tmp, "fair-isle-100k", FAIR_ISLE, 3),
        "jacquard-100k": _compile(tmp, "jacquard-100k", JACQUARD, 3),
        "intarsia-100k": _compile(tmp, "intarsia-100k", INTARSIA, 3),
        "tube-100k": _compile(tmp, "tube-100k", TUBE_100K, 3),
        "tube-1M": _compile(tmp, "tube-1M", TUBE_1M, 1),
    }


def _target(name: str, value: float | None, limit: float, unit: str, at_least: bool) -> dict:
    met = None if value is None else (value >= limit if at_least else value <= limit)
    return {"name": name, "value": None if value is None else round(value, 3),
            "limit": limit, "unit": unit, "at_least": at_least, "met": met}


def judge(cases: dict[str, dict], peer: dict[str, Any], orig: dict[str, Any]) -> list[dict]:
    """Every target of the speed issue, from the measurements."""
    def cpu(name: str) -> float | None:
        return cases.get(name, {}).get("cpu_seconds")

    def ratio(a: str, b: str) -> float | None:
        x, y = cpu(a), cpu(b)
        return None if x is None or y is None or y == 0 else x / y

    out = [
        _target("`knitc check` of a 10-line design", cpu("check-ten-lines"), 0.12, "s CPU",
                False),
        _target("1M-stitch tube", cpu("tube-1M"), 10.0, "s CPU", False),
        _target("1M-stitch tube, peak memory", cases.get("tube-1M", {}).get("peak_mb"), 800,
                "MB", False),
        _target("time(1M tube) / time(100k tube)", ratio("tube-1M", "tube-100k"), 10.0, "x",
                False),
        _target("lace-and-cable sheet / plain sheet (100k)", ratio("lace-100k", "sheet-100k"),
                1.3, "x", False),
        _target("fair isle sheet / plain sheet (100k; issue 17)",
                ratio("fair-isle-100k", "sheet-100k"), 2.0, "x", False),
        _target("jacquard sheet / plain sheet (100k; issue 17)",
                ratio("jacquard-100k", "sheet-100k"), 2.0, "x", False),
        _target("intarsia sheet / plain sheet (100k; issue 17)",
                ratio("intarsia-100k", "sheet-100k"), 2.0, "x", False),
    ]
    for key, what, limit in (
        ("knit_script_sheet_50k", "knit-script / knitc, 50k-stitch sheet", peers.KS_TARGET),
        ("cmu_k2dat_100k", "CMU knitout-to-dat (node) / knitc k2dat, 100k ops", peers.K2DAT_TARGET),
    ):
        out.append(_target(what, peer.get(key, {}).get("ratio"), limit, "x", True))
    for name in original.DESIGNS:
        r = orig.get(name, {})
        out.append(_target(f"original / knitc, {name}", r.get("ratio"),
                           original.TARGETS.get(name, 1.0), "x", True))
    return out


def run_targets(tmp: Path) -> dict[str, Any]:
    tmp.mkdir(parents=True, exist_ok=True)
    cases = run_cases(tmp)
    print(f"targets: {cases}", file=sys.stderr)
    peer = peers.run_peers(tmp)
    orig = original.run_original(tmp)
    return {"cases": cases, "peers": peer, "original": orig,
            "targets": judge(cases, peer, orig)}


def table(result: dict[str, Any]) -> str:
    """The targets as the README shows them."""
    lines = ["| target | measured | limit | met |", "|---|---:|---:|---|"]
    for t in result["targets"]:
        sign = ">=" if t["at_least"] else "<="
        value = "not run" if t["value"] is None else f"{t['value']:g} {t['unit']}"
        met = {True: "yes", False: "**no**", None: "(skipped)"}[t["met"]]
        lines.append(f"| {t['name']} | {value} | {sign} {t['limit']:g} {t['unit']} | {met} |")
    return "\n".join(lines)


def main() -> int:
    import tempfile

    with tempfile.TemporaryDirectory(prefix="knitc-targets-") as tmp:
        print(table(run_targets(Path(tmp))))
    return 0


if __name__ == "__main__":
    sys.exit(main())
