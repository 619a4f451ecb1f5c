"""`make bench`: time and peak memory of knitc on every example and on a scaling series.

Each case runs in a fresh Python process (so peak RSS is its own), compiling to Knitout
(or, where the back end does not support a design yet, as far as it goes). Results go to
bench/results.json and a Markdown table to stdout, which the README quotes.
"""

from __future__ import annotations

import json
import platform
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent

CHILD = r"""
import json, resource, sys, time
from knitc.driver import compile_file
from knitc.backends.knitout import write_knitout
t0 = time.perf_counter()
r = compile_file(sys.argv[1], until="machine")
stage = r.stage_reached
text = write_knitout(r.program) if r.program is not None else ""
dt = time.perf_counter() - t0
stitches = r.graph.n_stitches if r.graph is not None else 0
print(json.dumps({"seconds": round(dt, 3), "stage": stage, "stitches": stitches,
                  "ops": len(r.program) if r.program is not None else 0,
                  "knitout_lines": text.count("\n"),
                  "peak_mb": round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024, 1)}))
"""

SCALING = [("tube-10k", 100, 50), ("tube-100k", 400, 125), ("tube-1M", 1000, 500)]
LACE = [("lace-10k", 100, 100), ("lace-100k", 400, 250)]
"""Flat sheets under eyelet lace and cables: every other course carries loops (`_carry`)."""


def run_case(path: Path) -> dict:
    out = subprocess.run([sys.executable, "-c", CHILD, str(path)], capture_output=True,
                         text=True, check=False)
    if out.returncode != 0:
        return {"error": out.stderr.strip().splitlines()[-1] if out.stderr else "failed"}
    return json.loads(out.stdout.strip().splitlines()[-1])


def main() -> int:
    cases: list[tuple[str, Path]] = []
    for p in sorted((REPO / "examples").glob("*.knit")):
        cases.append((p.stem, p))
    for p in sorted((REPO / "examples" / "knitskel").glob("*.knit")):
        cases.append((f"knitskel/{p.stem}", p))
    tmp = Path(tempfile.mkdtemp(prefix="knitc-bench-"))
    for name, length, width in SCALING:
        f = tmp / f"{name}.knit"
        f.write_text(f"// {name}: a plain tube of {length} courses x {2 * width} stitches\n"
                     f"tube t {{ length: {length}, width: {width} }}\n")
        cases.append((name, f))
    for name, length, width in LACE:
        f = tmp / f"{name}.knit"
        f.write_text(f"// {name}: a sheet of {length} courses x {width} wales, lace and cables\n"
                     "import std.stitches (cable, eyelets)\n"
                     f"sheet s {{ length: {length}, width: {width} }}\n"
                     "pattern s {\n  apply eyelets() where wales(0.05:0.5)\n"
                     "  apply cable(2, 8) where wales(0.5:0.95)\n}\n")
        cases.append((name, f))
    results = []
    for name, path in cases:
        t0 = time.perf_counter()
        r = run_case(path)
        r["case"] = name
        r["wall_seconds"] = round(time.perf_counter() - t0, 3)
        results.append(r)
        print(f"{name}: {r}", file=sys.stderr)
    doc = {"machine": {"python": platform.python_version(), "cpu": platform.processor() or
                       platform.machine()},
           "date": time.strftime("%Y-%m-%d"), "results": results}
    (REPO / "bench" / "results.json").write_text(json.dumps(doc, indent=1) + "\n")
    print("| case | stitches | stage reached | knitc seconds | peak MB |")
    print("|---|---:|---|---:|---:|")
    for r in results:
        if "error" in r:
            print(f"| {r['case']} | | error | | |")
        else:
            print(f"| {r['case']} | {r['stitches']} | {r['stage']} | {r['seconds']} | "
                  f"{r['peak_mb']} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
