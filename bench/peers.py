"""Side-by-side whole-process benchmarks of knitc against two peers, each given the same job:

- knit-script 0.2.1 (the peer DSL, PyPI) compiling a plain 50k-stitch stockinette sheet to
  Knitout, against `knitc sheet.knit -o sheet.k` on a sheet of the same size. Target: knitc at
  least 25x faster.
- CMU's knitout-to-dat converter (the reference Knitout -> DAT backend, under node) converting the
  100k-operation stockinette of bench/run.py, against `knitc k2dat`. Target: at least 2x.

Both sides are whole processes, start-up included, as a user runs them; CPU seconds come from
bench/measure.py (wait4, medians of alternated runs, ratio = peer / knitc). A peer that cannot
be set up is skipped with its reason in the result, so `make bench` never fails on a peer.
The peers live in `.venv-peers/` (git-ignored) and nothing of theirs is committed.

`python bench/peers.py` runs both and prints a Markdown table; bench/run.py calls
`run_peers(tmp)` and stores what it returns as results.json["peers"].
"""

from __future__ import annotations

import hashlib
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent))
import measure  # noqa: E402
from run import K2DAT_NEEDLES, K2DAT_ROWS, stockinette  # noqa: E402

REPO = Path(__file__).resolve().parent.parent
PEERS = REPO / ".venv-peers"
KNITC = REPO / ".venv" / "bin" / "knitc"

KS_VENV = PEERS / "knit-script"
KS_PINS = ("knitout-interpreter==0.1.8", "virtual-knitting-machine==0.0.31",
           "knit-graphs==0.1.4", "knit-script==0.2.1")
"""Exact pins (research peers-and-oracles.md §1.2): the siblings' loose >= pins resolve to
sets that do not import together."""

SHEET_ROWS, SHEET_NEEDLES = 250, 200
"""200 needles x 250 rows: 50k stitches, the size knit-script was first measured at (§1.6)."""

KS_TARGET, K2DAT_TARGET = 25.0, 2.0
SLOW_SECONDS = 10.0
"""A peer run slower than this gets 3 paired runs instead of 5: its medians are steady enough,
and 5 runs of knit-script would take minutes."""

SHEET_KS = """\
// A plain stockinette sheet, `width` needles x `height` rows, knitted the way knit-script's
// own tests/resources/stst.ks does (alternating tuck cast-on, every row `knit Loops` in the
// reverse direction), closed with its standard library's chain bind-off, then dropped.
import needles;  // bind_offs.ks uses it but its own import does not reach its functions
import bind_offs;
with Carrier as c1:{
\tin Leftward direction:{
\t\ttuck Front_Needles[1:width:2];
\t}
\tin reverse direction:{
\t\ttuck Front_Needles[0:width:2];
\t}
\treleasehook;
\tfor _ in range(height):{
\t\tin reverse direction:{
\t\t\tknit Loops;
\t\t}
\t}
\tbind_offs.chain_bind_off(Front_Loops, reverse);
\tcut c1;
\tdrop Front_Loops;  // one bed at a time: `drop Loops` is refused as an all-needle drop
\tdrop Back_Loops;
}
"""

KS_COMPILE = ("import sys\n"
              "from knit_script.interpret_knit_script import knit_script_to_knitout\n"
              "knit_script_to_knitout(sys.argv[1], sys.argv[2], "
              "width=int(sys.argv[3]), height=int(sys.argv[4]))\n")
"""knit-script has no CLI (§1.1); this is the whole peer process. `knit_script_to_knitout` is
not exported at package level (knit_script#17)."""

CMU_JS_HELP = ("CMU's knitout-to-dat converter is on no PyPI release; set KNITOUT_TO_DAT_JS to "
               "a copy of it, never committed (bench/README.md says where to get one)")
"""The converter is a file the user supplies, never one the bench names or fetches."""


class Unavailable(Exception):
    """A peer that cannot be set up here; its message is the reason in the result."""


def base_python() -> str:
    """The interpreter for knit-script's venv, chosen as the Makefile's ORACLE_BASE_PYTHON is:
    python3.12 if it runs (the interpreter is about 3x faster there than on 3.11), else
    pyenv's newest 3.12, else python3.11; PEERS_BASE_PYTHON overrides."""
    if os.environ.get("PEERS_BASE_PYTHON"):
        return os.environ["PEERS_BASE_PYTHON"]
    root = Path(os.environ.get("PYENV_ROOT", Path.home() / ".pyenv"))
    pyenv = sorted(root.glob("versions/3.12.*/bin/python3.12"),
                   key=lambda p: [int(x) for x in re.findall(r"\d+", p.parent.parent.name)])
    for cand in ["python3.12", *map(str, pyenv[-1:]), "python3.11"]:
        ok = subprocess.run([cand, "-c", "import sys; sys.exit(sys.version_info[:2] not in "
                             "((3, 12), (3, 11)))"], capture_output=True, check=False) \
            if shutil.which(cand) else None
        if ok is not None and ok.returncode == 0:
            return cand
    raise Unavailable("knit-script needs python3.12 or python3.11")


def ks_python() -> Path:
    """knit-script's venv python, creating `.venv-peers/knit-script` with the exact pins
    unless it is already there with them (`.pins` records what it was made with)."""
    py, pins = KS_VENV / "bin" / "python", KS_VENV / ".pins"
    want = " ".join(KS_PINS)
    if py.exists() and pins.exists() and pins.read_text().strip() == want:
        return py
    base = base_python()
    print(f"peers: creating {KS_VENV.relative_to(REPO)} with {base}: {want}", file=sys.stderr)
    shutil.rmtree(KS_VENV, ignore_errors=True)
    for argv in ([base, "-m", "venv", str(KS_VENV)],
                 [str(py), "-m", "pip", "install", "-q", "--disable-pip-version-check",
                  *KS_PINS]):
        out = subprocess.run(argv, capture_output=True, text=True, check=False,
                             env=measure.environ())
        if out.returncode != 0:
            shutil.rmtree(KS_VENV, ignore_errors=True)
            tail = out.stderr.strip().splitlines()[-1:] or ["failed"]
            raise Unavailable(f"setting up knit-script: {tail[0]}")
    pins.write_text(want + "\n")
    return py


def knitc_python() -> str:
    """The Python knitc runs under (its venv's, not necessarily this process's)."""
    return subprocess.run([str(KNITC.parent / "python"), "-c", "import platform; "
                           "print(platform.python_version())"], capture_output=True, text=True,
                          check=True).stdout.strip()


def knitout_check(path: Path) -> dict[str, Any]:
    """Is `path` non-empty Knitout: its operation count and where its `;!knitout-2` line is
    (the spec wants it first; knit-script writes its `;;` headers before it, §1.6)."""
    lines = path.read_text(encoding="utf-8").splitlines() if path.exists() else []
    magic = next((i for i, s in enumerate(lines) if s.startswith(";!knitout-")), None)
    ops = sum(1 for s in lines if s.strip() and not s.startswith(";"))
    if magic is None or ops == 0:
        raise Unavailable(f"{path.name} is not Knitout ({len(lines)} lines, {ops} operations)")
    return {"ops": ops, "magic_line": magic + 1}


def case(ours: list[str], theirs: list[str], target: float, cwd: Path) -> dict[str, Any]:
    """One comparison: a first run of each side (it fails fast, warms their caches (bytecode,
    knit-script's parser tables) and sizes the pairing), then `paired`, then the target."""
    env = measure.environ()
    firsts = [measure.run(argv, cwd=cwd, env=env) for argv in (ours, theirs)]
    for argv, first in zip((ours, theirs), firsts, strict=True):
        if first.returncode != 0:
            tail = first.stderr.strip().splitlines()[-1:] or ["failed"]
            raise Unavailable(f"{Path(argv[0]).name} exited {first.returncode}: {tail[0]}")
    runs = 3 if firsts[1].cpu_seconds > SLOW_SECONDS else 5
    got = measure.paired(ours, theirs, runs=runs, cwd=cwd, env_ours=env, env_theirs=env)
    if "error" in got:
        raise Unavailable(got["error"])
    return {**got, "target_ratio": target, "met": got["ratio"] is not None and
            got["ratio"] >= target}


def knit_script_sheet(tmp: Path) -> dict[str, Any]:
    """knit-script and knitc each compiling a 50k-stitch stockinette sheet to Knitout."""
    py = ks_python()
    about = json.loads(subprocess.run(
        [str(py), "-c", "import importlib.metadata as m, json, platform; print(json.dumps("
         "[m.version('knit-script'), platform.python_version()]))"],
        capture_output=True, text=True, check=True).stdout)
    (tmp / "sheet.ks").write_text(SHEET_KS, encoding="utf-8")
    (tmp / "sheet.knit").write_text(f"sheet s {{ length: {SHEET_ROWS}, width: "
                                    f"{SHEET_NEEDLES} }}\n", encoding="utf-8")
    summary = subprocess.run([str(KNITC), "sheet.knit", "-o", "sheet.k"], cwd=tmp,
                             env=measure.environ(), capture_output=True, text=True,
                             check=False).stderr
    stitches = re.search(r"(\d+) stitches", summary)
    if not stitches or int(stitches.group(1)) != SHEET_ROWS * SHEET_NEEDLES:
        raise Unavailable(f"knitc's sheet is not {SHEET_ROWS * SHEET_NEEDLES} stitches: "
                          f"{summary.strip()}")
    got = case([str(KNITC), "sheet.knit", "-o", "sheet.k"],
               [str(py), "-c", KS_COMPILE, "sheet.ks", "sheet-ks.k", str(SHEET_NEEDLES),
                str(SHEET_ROWS)], KS_TARGET, tmp)
    ours, theirs = knitout_check(tmp / "sheet.k"), knitout_check(tmp / "sheet-ks.k")
    return {**got, "stitches": int(stitches.group(1)), "knitc_ops": ours["ops"],
            "peer_ops": theirs["ops"], "peer_knitout_magic_line": theirs["magic_line"],
            "peer": f"knit-script {about[0]}", "peer_python": about[1],
            "knitc_python": knitc_python()}


def cmu_k2dat(tmp: Path) -> dict[str, Any]:
    """CMU's converter under node (the file named by KNITOUT_TO_DAT_JS) and `knitc k2dat`,
    each converting the same 100k-operation Knitout to DAT; whether the two DATs are
    byte-identical is recorded too."""
    js = Path(os.environ.get("KNITOUT_TO_DAT_JS", ""))
    node = shutil.which("node")
    if not os.environ.get("KNITOUT_TO_DAT_JS"):
        raise Unavailable(CMU_JS_HELP)
    if not js.is_file():
        raise Unavailable(f"KNITOUT_TO_DAT_JS={js} is not a file")
    if node is None:
        raise Unavailable("node is not on PATH")
    (tmp / "k2dat.k").write_text(stockinette(K2DAT_ROWS, K2DAT_NEEDLES), encoding="utf-8")
    got = case([str(KNITC), "k2dat", "k2dat.k", "-o", "knitc.dat"],
               [node, str(js), "k2dat.k", "cmu.dat"], K2DAT_TARGET, tmp)
    ours, theirs = (tmp / "knitc.dat").read_bytes(), (tmp / "cmu.dat").read_bytes()
    if not ours or not theirs:
        raise Unavailable(f"empty DAT: knitc {len(ours)} bytes, CMU {len(theirs)} bytes")
    version = subprocess.run([node, "--version"], capture_output=True, text=True,
                             check=True).stdout.strip()
    return {**got, "ops": knitout_check(tmp / "k2dat.k")["ops"], "knitc_dat_bytes": len(ours),
            "peer_dat_bytes": len(theirs), "dat_identical": ours == theirs,
            "peer": "CMU knitout-to-dat (node) sha256:" + hashlib.sha256(js.read_bytes())
            .hexdigest()[:12], "peer_node": version, "knitc_python": knitc_python()}


CASES = {"knit_script_sheet_50k": (knit_script_sheet, KS_TARGET),
         "cmu_k2dat_100k": (cmu_k2dat, K2DAT_TARGET)}


def run_peers(tmp: Path) -> dict[str, Any]:
    """Every comparison, each in its own folder under `tmp`; a peer that cannot be set up
    is {"skipped": reason, "target_ratio": ..., "met": None} rather than an error."""
    out: dict[str, dict[str, Any]] = {}
    for name, (fn, target) in CASES.items():
        where = tmp / name
        where.mkdir(parents=True, exist_ok=True)
        try:
            out[name] = fn(where)
        except (Unavailable, OSError, subprocess.CalledProcessError, ValueError) as e:
            out[name] = {"skipped": str(e), "target_ratio": target, "met": None}
        print(f"{name}: {out[name]}", file=sys.stderr)
    return out


def main() -> dict[str, Any]:
    """Run the comparisons in a scratch folder and print them as a Markdown table."""
    with tempfile.TemporaryDirectory(prefix="knitc-peers-") as tmp:
        got = run_peers(Path(tmp))
    print("| case | knitc CPU s | peer CPU s | ratio | target |")
    print("|---|---:|---:|---:|---|")
    for name, r in got.items():
        if "skipped" in r:
            print(f"| {name} | | | skipped: {r['skipped']} | >= {r['target_ratio']} |")
        else:
            print(f"| {name} ({r['peer']}) | {r['knitc_cpu_seconds']} | "
                  f"{r['peer_cpu_seconds']} | {r['ratio']} | >= {r['target_ratio']} "
                  f"({'met' if r['met'] else 'not met'}) |")
    return got


if __name__ == "__main__":
    main()
