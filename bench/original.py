"""knitc against the system it is modelled on: A. Kaspar's knitskel (xionluhnis/knitskel),
whole process against whole process, .skel -> DAT beside `knitc X.knit -o X.k`, for the
seven designs ported in examples/knitskel/. Optional, because the original is JavaScript
from a checkout we do not ship: set KNITSKEL_DIR to it (bench/README.md says how to get one).

The original runs through bench/original-runner.js, which calls knitskel's own modules in
the order its browser's "save DAT" does. The issue's targets: knitc at least twice as fast
on glove, sweatpants and wristband2, and not slower on any design.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path
from typing import Any

try:
    import measure  # run as bench/original.py, or imported by bench/run.py
except ImportError:  # imported as bench.original
    from bench import measure  # type: ignore[no-redef]

REPO = Path(__file__).resolve().parent.parent
RUNNER = REPO / "bench" / "original-runner.js"
KNITC = REPO / ".venv" / "bin" / "knitc"
DESIGNS = tuple(sorted(p.stem for p in (REPO / "examples" / "knitskel").glob("*.knit")))
"""The ported designs: every `.knit` in examples/knitskel/, each named as its `.skel`."""
TARGETS = {"glove": 2.0, "sweatpants": 2.0, "wristband2": 2.0}
"""Required ratio original/knitc CPU; every other design only must not be slower (1.0)."""
RUNS = 5
SKIP = "set KNITSKEL_DIR to a checkout of xionluhnis/knitskel (see bench/README.md)"


def _commit(checkout: Path) -> str | None:
    """The checkout's commit, so a result says which original it timed (None if the
    checkout is not a git work tree, e.g. an unpacked archive)."""
    r = subprocess.run(
        ["git", "-C", str(checkout), "rev-parse", "HEAD"], capture_output=True, text=True
    )
    return r.stdout.strip() if r.returncode == 0 else None


def run_original(tmp: Path) -> dict[str, Any]:
    """Paired runs of knitc and the original for every design, outputs written to `tmp`:
    {design: measure.paired(...) fields + "target" + "met", "node": version,
    "knitskel_commit": sha}, or {"skipped": why} without a usable checkout or node."""
    where = os.environ.get("KNITSKEL_DIR")
    if not where:
        return {"skipped": SKIP}
    checkout = Path(where).resolve()
    node = shutil.which("node")
    if node is None:
        return {"skipped": "node is not on PATH (the original is JavaScript)"}
    if not (checkout / "src" / "compiler.js").is_file():
        return {"skipped": f"KNITSKEL_DIR={where} has no src/compiler.js: not a knitskel checkout"}
    if not (checkout / "node_modules" / "simplenoise").is_dir():
        return {"skipped": f"simplenoise is not installed in {checkout} (see bench/README.md)"}
    version = subprocess.run([node, "--version"], capture_output=True, text=True).stdout.strip()
    env_theirs = dict(os.environ, KNITSKEL_DIR=str(checkout))
    result: dict[str, Any] = {"node": version, "knitskel_commit": _commit(checkout)}
    for name in DESIGNS:
        ours: list[str | Path] = [
            KNITC,
            REPO / "examples" / "knitskel" / f"{name}.knit",
            "-o",
            tmp / f"{name}.k",
        ]
        theirs: list[str | Path] = [
            node,
            RUNNER,
            checkout / "skeletons" / f"{name}.skel",
            tmp / f"{name}.dat",
        ]
        got = measure.paired(
            ours, theirs, runs=RUNS, cwd=REPO, env_ours=measure.environ(), env_theirs=env_theirs
        )
        target = TARGETS.get(name, 1.0)
        ratio = got.get("ratio")
        got.update(target=target, met=ratio is not None and ratio >= target)
        result[name] = got
    return result


def table(result: dict[str, Any]) -> str:
    """The result as the Markdown table bench/README.md shows."""
    if "skipped" in result:
        return f"skipped: {result['skipped']}"
    lines = [
        f"knitskel {result['knitskel_commit'] or '(commit unknown)'}, node {result['node']},"
        f" {RUNS} alternated runs each, median CPU seconds (user + system)",
        "",
        "| design | knitc CPU s | original CPU s | ratio | target |",
        "|---|---:|---:|---:|---:|",
    ]
    for name in DESIGNS:
        r = result[name]
        if "error" in r:
            lines.append(f"| {name} | | | {r['error']} | {r['target']:g}× |")
            continue
        mark = "met" if r["met"] else "**not met**"
        lines.append(
            f"| {name} | {r['knitc_cpu_seconds']:.3f} | {r['peer_cpu_seconds']:.3f} |"
            f" {r['ratio']:.2f}× | {r['target']:g}× ({mark}) |"
        )
    return "\n".join(lines)


def main() -> int:
    with tempfile.TemporaryDirectory(prefix="knitc-original-") as tmp:
        result = run_original(Path(tmp))
    if "--json" in sys.argv[1:]:
        print(json.dumps(result, indent=1))
    else:
        print(table(result))
    return 0


if __name__ == "__main__":
    sys.exit(main())
