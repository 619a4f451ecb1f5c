"""The fuzz targets: one function per input kind, each taking the fuzzer's bytes.

A target runs knitc the way a user does (`knitc.cli.main` on a file, so the exit status,
the diagnostics and the output files are what a user gets) and raises `Bug` when knitc
misbehaves on that input. Whatever the input, a correct knitc answers with exit status 0
(it compiled) or 1 (located diagnostics); everything else is a bug:

* exit status 3 (an internal error: a traceback, a verifier that caught bad code);
* an error that blames knitc's own output: an E8xx finding of knitc's simulation on a
  program knitc generated from a design that has no other error (a design cannot make
  the generated program invalid; after a designer's error the program is partial), or
  `knitc lint` rejecting Knitout that `knitc` or `knitc dat2k` wrote;
* an output file left behind by a failed run (never a partial output file);
* differential checks that disagree: a design that parses must format to text that parses
  to the same AST; Knitout that knitc wrote must read back and convert to DAT.

Hangs and memory blow-ups are the engine's business (libFuzzer's `-timeout` and
`-rss_limit_mb`, see engine.py): a target only has to run.

The targets are plain functions so that `run.py --reproduce` and tests/test_fuzz.py call
them on saved inputs without any fuzzing engine.
"""

from __future__ import annotations

import contextlib
import io
import os
import re
import tempfile
from collections.abc import Callable
from pathlib import Path

os.environ["KNITC_VERIFY"] = "1"  # every IR verifier between stages: a fuzzed design that
# breaks an IR's invariants is a bug even when the output happens to be legal (driver.verifying)

FUZZ_MAX_STITCHES = 20_000
"""The stitch budget of fuzzed compiles (`--max-stitches`): a legal design may be as large
as the fuzzer likes, but a large one is slow, not wrong, and would be reported as a hang.
Designs over the budget are refused with E512 before any work, which is itself checked."""

_WORK = Path(tempfile.mkdtemp(prefix="knitc-fuzz-"))
_ERROR_CODE = re.compile(r"error\[(E\d+)\]")
_DAT_MAY_LEAVE = {"E803", "E804"}
"""Findings on dat2k's Knitout that the DAT itself causes: a DAT may end with loops on the
needles or a carrier in (an unfinished or partial program); the Knitout says the same."""


sample: Callable[[str, list[str]], None] | None = None
"""Where the engine collects compiled designs for the independent machine (engine.py)."""


class Bug(Exception):
    """knitc misbehaved on this input; the message says how (with its stderr)."""


def _knitc(*argv: str) -> tuple[int, str]:
    """Run the CLI in-process; its exit status and everything it wrote to stderr."""
    from knitc.cli import main

    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        rc = main(list(argv))
    return rc, err.getvalue()


def _expect(rc: int, err: str, what: str, allowed: tuple[int, ...] = (0, 1)) -> None:
    if rc not in allowed:
        raise Bug(f"{what}: exit status {rc}\n{err}")


def _fresh(name: str, data: bytes) -> Path:
    for p in _WORK.iterdir():
        p.unlink()
    path = _WORK / name
    path.write_bytes(data)
    return path


def _no_output_on_failure(rc: int, out: Path, what: str) -> None:
    if rc != 0 and out.exists():
        raise Bug(f"{what}: exit status {rc} but it left an output file {out.name}")


def _check_own_knitout(k: Path, err: str, what: str) -> None:
    """Knitout that knitc wrote must lint clean of errors and convert to DAT (or be refused
    by the DAT writer with a located E901: a DAT limit, not a bug)."""
    rc, lint_err = _knitc("lint", "-q", str(k))
    if rc != 0:
        raise Bug(f"{what}: `knitc lint` rejects knitc's own Knitout\n{lint_err}\n{err}")
    dat = k.with_suffix(".dat")
    rc, dat_err = _knitc("k2dat", "-q", str(k), "-o", str(dat))
    _expect(rc, dat_err, f"{what}: k2dat of knitc's own Knitout")
    if rc != 0 and "E901" not in dat_err:
        raise Bug(f"{what}: k2dat refuses knitc's own Knitout\n{dat_err}")


def parse(data: bytes) -> None:
    """The parser and the formatter: any text gets diagnostics or an AST, and an AST that
    parsed cleanly formats to text that parses to the same AST (the formatter is total and
    faithful)."""
    from knitc.diagnostics import Diagnostics
    from knitc.frontend.fmt import format_module
    from knitc.frontend.parser import parse_source
    from knitc.source import SourceFile

    text = data.decode("utf-8", "replace")
    diags = Diagnostics()
    module = parse_source(SourceFile("fuzz.knit", text), diags)
    if module is None or diags.has_errors:
        return
    again = Diagnostics()
    formatted = format_module(module)
    module2 = parse_source(SourceFile("fmt.knit", formatted), again)
    if module2 is None or again.has_errors:
        raise Bug(f"the formatter's output does not parse:\n{again.render()}\n---\n{formatted}")
    if module2 != module:
        raise Bug(f"the formatter changed the meaning:\n---\n{text}\n--- formatted:\n{formatted}")


def compile_text(
    text: str,
    defines: list[str] | tuple[str, ...] = (),
    *,
    save: Callable[[str, list[str]], None] | None = None,
) -> int:
    """The whole pipeline on one design, to Knitout (then lint and DAT of that output);
    returns knitc's exit status. `save` receives each design that compiled, with its
    `-D` overrides (the sample the independent machine checks after a run)."""
    src = _fresh("design.knit", text.encode("utf-8", "surrogatepass"))
    out = _WORK / "design.k"
    flags = [a for d in defines for a in ("-D", d)]
    rc, err = _knitc(
        str(src), "-q", *flags, "--max-stitches", str(FUZZ_MAX_STITCHES), "-o", str(out)
    )
    _expect(rc, err, "compile")
    _no_output_on_failure(rc, out, "compile")
    errors = set(_ERROR_CODE.findall(err))
    if errors and all(c.startswith("E8") for c in errors):
        raise Bug(f"knitc's simulation rejects the program knitc generated\n{err}")
    if rc == 0:
        _check_own_knitout(out, err, "compile")
        keep = save or sample
        if keep is not None:
            keep(text, list(defines))
    return rc


def compile_bytes(data: bytes) -> None:
    """Mutated designs (the engine mutates the corpus: examples, stdlib, regressions)."""
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError:
        src = _fresh("design.knit", data)
        rc, err = _knitc(str(src), "-q", "-o", str(_WORK / "design.k"))
        _expect(rc, err, "compile of non-UTF-8 bytes", allowed=(1,))
        return
    compile_text(text)


def knitout(data: bytes) -> None:
    """Any Knitout file through `knitc lint`, `knitc k2dat` and `knitc view --bed`."""
    src = _fresh("prog.k", data)
    rc, err = _knitc("lint", "-q", str(src))
    _expect(rc, err, "lint")
    dat = _WORK / "prog.dat"
    rc, err = _knitc("k2dat", "-q", str(src), "-o", str(dat))
    _expect(rc, err, "k2dat")
    _no_output_on_failure(rc, dat, "k2dat")
    if rc == 0:
        back = _WORK / "back.k"
        rc, err = _knitc("dat2k", str(dat), "-o", str(back))
        _expect(rc, err, "dat2k of knitc's own DAT")


def dat(data: bytes) -> None:
    """Any DAT file through `knitc dat2k`; Knitout it writes must lint clean."""
    src = _fresh("prog.dat", data)
    out = _WORK / "prog.k"
    rc, err = _knitc("dat2k", str(src), "-o", str(out))
    _expect(rc, err, "dat2k")
    _no_output_on_failure(rc, out, "dat2k")
    if rc == 0:
        rc, lint_err = _knitc("lint", "-q", str(out))
        invalid = {c for c in _ERROR_CODE.findall(lint_err) if c not in _DAT_MAY_LEAVE}
        if invalid:
            raise Bug(f"dat2k wrote Knitout that `knitc lint` rejects\n{lint_err}")


def editor(data: bytes) -> None:
    """The language server's features on any text, at many offsets (editor.py)."""
    import editor as lsp_target

    try:
        lsp_target.editor(data)
    except lsp_target.Bug as bug:
        raise Bug(str(bug)) from None


TARGETS: dict[str, Callable[[bytes], None]] = {
    "parse": parse,
    "compile": compile_bytes,
    "editor": editor,
    "knitout": knitout,
    "dat": dat,
}
"""Byte-input targets. `design` (grammar-aware generation) is added by designs.py, which
needs hypothesis."""

HERE = Path(__file__).resolve().parent
REPO = HERE.parent.parent
CORPUS = HERE / "corpus"
REGRESSIONS = HERE / "regressions"
CORPUS_OF = {
    "parse": "knit",
    "compile": "knit",
    "editor": "knit",
    "design": "design",
    "knitout": "knitout",
    "dat": "dat",
}
"""Which corpus folder seeds each target (the parser and the compiler share one)."""
PROJECT_SEEDS = {
    "knit": ["examples", "examples/knitskel", "stdlib/std", "tests/golden/diagnostics"],
    "knitout": ["tests/fixtures/knitout", "tests/fixtures/dat", "tests/filecheck/lint"],
    "dat": ["tests/fixtures/dat"],
    "design": [],
}
"""The project's own files that seed the fuzzers too (read in place, never copied): the
examples and the stdlib, every diagnostic's golden case, the Knitout and DAT fixtures."""


def seed_dirs(target: str, *, project: bool = True) -> list[Path]:
    """Where a target's inputs come from: the fuzz corpus, the regressions and (unless
    `project` is false) the project's own files of that kind."""
    kind = CORPUS_OF[target]
    dirs = [CORPUS / kind, REGRESSIONS / kind]
    if project:
        dirs += [REPO / d for d in PROJECT_SEEDS[kind]]
    return [d for d in dirs if d.is_dir()]


def inputs(target: str, *, project: bool = False) -> list[Path]:
    """The saved inputs of a target (its corpus and regressions), in a stable order."""
    found = [p for d in seed_dirs(target, project=project) for p in d.iterdir()]
    return sorted(p for p in found if p.is_file() and not p.name.startswith((".", "README")))


if os.environ.get("KNITC_FUZZ_DEBUG"):  # pragma: no cover - a developer's switch
    print("fuzz work directory:", _WORK)
