"""The `knitc` command line.

Compiler habits: diagnostics on stderr in `path:line:col: severity[CODE]` form, exit status
0 when clean (warnings allowed), 1 on errors, 2 on usage mistakes and 3 on internal errors;
outputs are written atomically (a temporary file renamed into place), so a failed run never
leaves a partial file behind.
"""

from __future__ import annotations

import argparse
import os
import stat
import sys

from knitc import (
    __version__,
    _process,  # (first: it sets up the process before numpy loads)
)
from knitc.diagnostics import Diagnostics
from knitc.limits import MAX_STITCHES

# The driver (and through it the pipeline and numpy) is imported by the commands that
# compile, not at the top: `knitc --version`, `fmt`, `k2dat` and `dat2k` do not need it.

EXAMPLES = """\
examples:
  knitc examples/tube.knit -o tube.k            compile to Knitout
  knitc examples/tube.knit -o tube.dat          compile to a Shima DAT (KnitPaint)
  knitc k2dat tube.k -o tube.dat                convert any Knitout file to DAT
  knitc dat2k tube.dat -o tube.k                decode a DAT back into Knitout
  knitc dat2k --passes tube.dat                 print its pass table as JSON
  knitc check examples/glove.knit               check a design, report every problem
  knitc -D finger_len=26 check examples/glove.knit
  knitc --emit skeleton examples/sock.knit      print the resolved skeleton IR as JSON
  knitc --emit ast -o sock.ast.json examples/sock.knit
  knitc --emit trace --format text examples/tube.knit
                                                the yarn path, one visit per line
  knitc --until schedule --time-passes examples/sweater.knit
                                                run up to a stage, time every stage
  knitc view examples/sweater.knit --bed -o bed.svg   the time-needle bed
  knitc view examples/glove.knit --html -o glove.html  an interactive viewer
  knitc lint other-tool.k                       simulate any Knitout, report hazards
  knitc fmt examples/sweater.knit               print the canonical form
  knitc fmt --check examples/*.knit             exit 1 if a file is not canonical
  knitc fmt -i examples/sweater.knit            rewrite a file in canonical form
"""


def _common(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "-D",
        dest="defines",
        action="append",
        default=[],
        metavar="NAME=VALUE",
        help="override a design parameter (`param NAME = ...`); repeatable",
    )
    p.add_argument(
        "-W",
        dest="warn",
        action="append",
        default=[],
        choices=["error"],
        help="-W error: treat warnings as errors",
    )
    p.add_argument(
        "-q", "--quiet", action="store_true", help="print errors only (no warnings, no summary)"
    )
    p.add_argument(
        "--time-passes",
        action="store_true",
        help="print the seconds each stage took on standard error",
    )


def _verify_each(p: argparse.ArgumentParser) -> None:
    """The option of the commands that run the pipeline to its end (compile, check)."""
    p.add_argument(
        "--verify-each",
        action="store_true",
        help="run every IR's verifier after its stage, a check of knitc itself "
        "(KNITC_VERIFY=1 does the same; the tests and fuzzers always do)",
    )


def _positive_int(text: str) -> int:
    """An argparse type: a whole number above 0 (a mistake is a usage error, exit 2)."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a whole number: {text!r}") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be at least 1, not {value}")
    return value


def _folder(text: str) -> str:
    """An argparse type: an existing directory (an `--include` that names nothing would
    silently allow nothing)."""
    if not os.path.isdir(text):
        raise argparse.ArgumentTypeError(f"not a directory: {text!r}")
    return text


def _reading(p: argparse.ArgumentParser, stitches: bool = True) -> None:
    """The options of the commands that compile a design: what it may read, how large it
    may be (docs/security.md)."""
    p.add_argument(
        "--include",
        dest="include",
        action="append",
        default=[],
        type=_folder,
        metavar="DIR",
        help="a folder, besides the design's own, that its imports and images may read "
        "from; repeatable",
    )
    if not stitches:
        return
    p.add_argument(
        "--max-stitches",
        type=_positive_int,
        default=MAX_STITCHES,
        metavar="N",
        help=f"refuse a design of more than N stitches (default {MAX_STITCHES:,}; E512)",
    )


def _main_parser() -> argparse.ArgumentParser:
    from knitc.driver import EMITTABLE, STAGES, TARGETS

    p = argparse.ArgumentParser(
        prog="knitc",
        formatter_class=argparse.RawDescriptionHelpFormatter,
        description="Compile a knitc garment description (.knit) for a knitting machine.\n"
        "Subcommands: `knitc check FILE`, `knitc fmt [--check] FILE...`, "
        "`knitc k2dat IN.k -o OUT.dat`, `knitc dat2k IN.dat -o OUT.k`, "
        "`knitc view FILE --bed|--chart|--shape|--html -o OUT`, `knitc lint IN.k`, "
        "`knitc lsp` (the language server, for editors: docs/editors.md).",
        epilog=EXAMPLES,
    )
    p.add_argument("file", metavar="FILE", help="the .knit design to compile")
    p.add_argument(
        "-o",
        "--output",
        metavar="OUT",
        help="output file, `-` for standard output (default: standard output "
        "for --emit; without either, compile and report only)",
    )
    p.add_argument(
        "--emit",
        metavar="IR",
        choices=EMITTABLE,
        help="print one intermediate representation as JSON: " + ", ".join(EMITTABLE),
    )
    p.add_argument(
        "--format",
        choices=["json", "text"],
        default="json",
        help="--emit as stable JSON (default) or as a compact text form, one record per line",
    )
    p.add_argument(
        "--until",
        metavar="STAGE",
        choices=[s.name for s in STAGES],
        help="run the pipeline up to this stage, report its diagnostics and "
        "write nothing: " + ", ".join(s.name for s in STAGES),
    )
    p.add_argument(
        "--target",
        choices=[t.name for t in TARGETS],
        help="machine format: "
        + "; ".join(f"{t.name}, {t.doc}" for t in TARGETS)
        + " (default: from the -o extension)",
    )
    p.add_argument("--version", action="version", version=f"knitc {__version__}")
    _common(p)
    _reading(p)
    _verify_each(p)
    return p


def _check_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="knitc check",
        description="Compile a design through code generation and "
        "its simulation, report every problem, write nothing.",
    )
    p.add_argument("file", metavar="FILE")
    _common(p)
    _reading(p)
    _verify_each(p)
    return p


def _view_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="knitc view",
        description="Draw a design (.knit) or any Knitout program (.k): the time-needle bed, "
        "the stitch charts, the garment's shape, or all three in one interactive HTML file.",
    )
    p.add_argument("file", metavar="FILE", help="a .knit design or a .k Knitout file")
    g = p.add_mutually_exclusive_group()
    g.add_argument(
        "--bed",
        dest="view",
        action="store_const",
        const="bed",
        help="the time-needle bed: passes up, needles across (default)",
    )
    g.add_argument(
        "--chart",
        dest="view",
        action="store_const",
        const="chart",
        help="each node's stitch chart, course up, wale across",
    )
    g.add_argument(
        "--shape",
        dest="view",
        action="store_const",
        const="shape",
        help="the garment's shape, a force layout of the stitch graph",
    )
    g.add_argument(
        "--html",
        dest="view",
        action="store_const",
        const="html",
        help="one self-contained interactive HTML file with all three views",
    )
    p.add_argument(
        "--compact",
        action="store_true",
        help="--bed: collapse the stretches where a piece only waits",
    )
    p.add_argument(
        "--3d",
        dest="three_d",
        action="store_true",
        help="--shape: a projected 3-D layout instead of a flat one",
    )
    p.add_argument(
        "-o",
        "--output",
        metavar="OUT",
        required=True,
        help="the picture: .svg or .png (.html for --html)",
    )
    _common(p)
    _reading(p, stitches=False)
    return p


def _lint_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="knitc lint",
        description="Simulate any Knitout program (from knitc or another tool) and report its "
        "errors and knitting hazards, each at its line and needle.",
    )
    p.add_argument("file", metavar="IN.k")
    p.add_argument(
        "-W",
        dest="warn",
        action="append",
        default=[],
        choices=["error"],
        help="-W error: treat warnings as errors",
    )
    p.add_argument("-q", "--quiet", action="store_true", help="print errors only")
    return p


def _fmt_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="knitc fmt", description="Print .knit files in canonical form."
    )
    p.add_argument("files", metavar="FILE", nargs="+")
    g = p.add_mutually_exclusive_group()
    g.add_argument(
        "--check",
        action="store_true",
        help="print nothing; exit 1 if a file is not in canonical form",
    )
    g.add_argument("-i", "--in-place", action="store_true", help="rewrite the files")
    return p


def _k2dat_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="knitc k2dat", description="Convert a Knitout file to a Shima DAT file."
    )
    p.add_argument("file", metavar="IN.k")
    p.add_argument(
        "-o",
        "--output",
        metavar="OUT.dat",
        help="output file (default: IN with the extension .dat)",
    )
    p.add_argument("-q", "--quiet", action="store_true", help="print errors only")
    return p


def _dat2k_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="knitc dat2k", description="Decode a Shima DAT file into Knitout."
    )
    p.add_argument("file", metavar="IN.dat")
    p.add_argument("-o", "--output", metavar="OUT.k", help="output file (default: stdout)")
    p.add_argument(
        "--passes",
        action="store_true",
        help="print the pass table (every raster row: direction, option bars, slot "
        "colour codes) as JSON instead of Knitout",
    )
    p.add_argument("-q", "--quiet", action="store_true", help="print errors only")
    return p


def _report(diags: Diagnostics, quiet: bool) -> None:
    items = [d for d in diags.sorted() if d.is_error or not quiet]
    from knitc.diagnostics import render

    text = "".join(render(d, diags.sources) for d in items)
    if text:
        sys.stderr.write(text)
    if not quiet and (diags.error_count or diags.warning_count):
        parts = []
        if diags.error_count:
            parts.append(f"{diags.error_count} error{'s' * (diags.error_count != 1)}")
        if diags.warning_count:
            parts.append(f"{diags.warning_count} warning{'s' * (diags.warning_count != 1)}")
        sys.stderr.write(f"knitc: {', '.join(parts)}\n")


def output_problem(path: str, inputs: tuple[str, ...] = ()) -> str | None:
    """Why `path` cannot take an output (checked before any work is done), or None: a
    missing directory, a directory, one of the `inputs` (a compile must not overwrite its
    design)."""
    target = os.path.realpath(path)
    parent = os.path.dirname(target)
    if os.path.isdir(target):
        return f"`{path}` is a directory"
    if not os.path.isdir(parent):
        return f"the directory `{os.path.dirname(path) or '.'}` does not exist"
    for i in inputs:
        if os.path.exists(i) and os.path.exists(target) and os.path.samefile(i, target):
            return f"`{path}` is the input file; it would be overwritten"
    return None


def write_atomic(path: str, data: str | bytes) -> None:
    """Write `data` to `path` so that a failed run never leaves a partial file: through a
    temporary file in the same directory and a rename. A symlink is written through (the
    link stays), an existing file keeps its mode, and what is not a regular file (a device
    such as /dev/null, a FIFO) is written to directly, never replaced by a file."""
    payload = data.encode("utf-8") if isinstance(data, str) else data
    target = os.path.realpath(path)
    if os.path.exists(target) and not stat.S_ISREG(os.stat(target).st_mode):
        with open(target, "wb") as f:
            f.write(payload)
        return
    if os.path.exists(target):
        mode = stat.S_IMODE(os.stat(target).st_mode)
    else:
        umask = os.umask(0)
        os.umask(umask)
        mode = 0o666 & ~umask  # what a plain open() would have made, not mkstemp's 0600
    import tempfile  # (only a command that writes a file needs it: `check` never does)

    fd, tmp = tempfile.mkstemp(prefix=".knitc-", dir=os.path.dirname(target))
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(payload)
        os.chmod(tmp, mode)
        os.replace(tmp, target)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise


def _write(path: str, data: str | bytes) -> bool:
    """`write_atomic`, with a failure reported as E002 instead of a traceback."""
    try:
        write_atomic(path, data)
    except OSError as exc:
        _cannot_write(path, exc.strerror or str(exc))
        return False
    return True


def _cannot_write(path: str, reason: str) -> None:
    sys.stderr.write(f"knitc: error[E002]: cannot write `{path}`: {reason}\n")


def _output_ok(path: str | None, inputs: tuple[str, ...]) -> bool:
    if not path or path == "-":
        return True
    problem = output_problem(path, inputs)
    if problem is not None:
        _cannot_write(path, problem)
        return False
    return True


def _cmd_compile(args: argparse.Namespace) -> int:
    from knitc.driver import STAGES, compile_file, emit_json, emit_text, timing_table

    werror = "error" in args.warn
    to_stdout = not args.output or args.output == "-"
    target = args.target
    if target is None and not args.emit:
        target = "dat" if not to_stdout and args.output.lower().endswith(".dat") else "knitout"
    if args.emit and args.until:
        sys.stderr.write("knitc: error: give --emit or --until, not both\n")
        return 2
    if not _output_ok(args.output, (args.file,)):
        return 1
    if target == "dat" and to_stdout and not args.emit and not args.until:
        sys.stderr.write(
            "knitc: error: a DAT file is binary: give an output file with -o FILE.dat\n"
        )
        return 1
    if not args.output and not args.emit:
        args.until = args.until or STAGES[-1].name  # nothing to write: compile and report
    until = args.emit or args.until or target
    from knitc.summary import progress

    with progress(sys.stderr.isatty() and not args.quiet, len(STAGES) + 1) as on_stage:
        result = compile_file(
            args.file,
            defines=args.defines,
            until=until,
            werror=werror,
            on_stage=on_stage,
            include=args.include,
            max_stitches=args.max_stitches,
            verify=args.verify_each or None,
        )
    if any(d.code == "E408" for d in result.diagnostics):  # a command-line mistake
        _report(result.diagnostics, args.quiet)
        return 2
    _report(result.diagnostics, args.quiet)
    if args.time_passes:
        sys.stderr.write(timing_table(result))
    if not result.ok:
        return 1
    if args.until:
        return 0
    if args.emit:
        output: str | bytes | None = (emit_text if args.format == "text" else emit_json)(
            result, args.emit
        )
    else:
        output = result.output
    assert output is not None
    if not to_stdout:
        if not _write(args.output, output):
            return 1
    elif isinstance(output, bytes):
        sys.stdout.buffer.write(output)
    else:
        sys.stdout.write(output)
    if not args.emit and not args.quiet:
        from knitc.summary import summary_line

        sys.stderr.write(summary_line(result, args.output or "standard output"))
    return 0


def _dat_bytes(prog, diags: Diagnostics, quiet: bool) -> bytes | None:
    """The DAT file of a Knitout program (`k2dat`); None after reporting why the machine
    (or its DAT format) cannot take it, at the line the refused operation came from."""
    from knitc.driver import STAGES, Result, resume

    result = Result(diags, program=prog, stage_reached=STAGES[-1].name)
    resume(result, "dat")
    if not result.ok:
        _report(diags, quiet)
        return None
    assert isinstance(result.output, bytes)
    return result.output


def _read_input(path: str, binary: bool) -> str | bytes | None:
    try:
        with open(path, "rb") as f:
            data = f.read()
        return data if binary else data.decode("utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        sys.stderr.write(f"knitc: error[E001]: cannot read `{path}`: {exc}\n")
        return None


def _cmd_k2dat(args: argparse.Namespace) -> int:
    from knitc.backends.knitout_read import (
        KnitoutError,
        knitout_diagnostics,
        knitout_to_dat,
        read_knitout,
        read_knitout_file,
    )

    out = args.output or os.path.splitext(args.file)[0] + ".dat"
    if not _output_ok(out, (args.file,)):
        return 1
    try:
        with open(args.file, "rb") as f:
            text: str | None = f.read().decode("utf-8")
    except (OSError, UnicodeDecodeError):
        text = None  # read_knitout_file says why
    if text is not None:
        # A file without errors converts straight to its DAT; one with an error, or an op
        # the DAT cannot take, is read again with its ops' spans, which locate the
        # diagnostics, and converted through the driver.
        warnings: list[KnitoutError] = []
        data = knitout_to_dat(text, args.file, warnings=warnings)
        if data is not None:
            if warnings:
                _report(knitout_diagnostics(args.file, text, (), warnings), args.quiet)
            return 0 if _write(out, data) else 1
        prog, diags = read_knitout(text, args.file)
    else:
        prog, diags = read_knitout_file(args.file)
    if prog is None:
        _report(diags, args.quiet)
        return 1
    data = _dat_bytes(prog, diags, args.quiet)
    if data is None:
        return 1
    _report(diags, args.quiet)
    return 0 if _write(out, data) else 1


def _cmd_dat2k(args: argparse.Namespace) -> int:
    import json

    from knitc.backends.dat_format import DatError, read_raster, rows
    from knitc.backends.dat_read import read_dat, width_limit
    from knitc.backends.knitout import write_knitout
    from knitc.codegen.machine import Machine

    if not _output_ok(args.output, (args.file,)):
        return 1
    data = _read_input(args.file, binary=True)
    if data is None:
        return 1
    assert isinstance(data, bytes)
    if args.passes:  # every raster row as it is, whatever its layout
        try:
            height, width = read_raster(data, max_width=width_limit(Machine())).shape
            table = [r.to_json() for r in rows(data)]
        except DatError as exc:
            sys.stderr.write(f"{args.file}: error[E902]: not a DAT file knitc can read: {exc}\n")
            return 1
        text = json.dumps({"width": width, "height": height, "rows": table}) + "\n"
    else:
        prog, diags = read_dat(data, args.file)
        if prog is None:
            _report(diags, args.quiet)
            return 1
        text = write_knitout(prog)
    if args.output:
        return 0 if _write(args.output, text) else 1
    sys.stdout.write(text)
    return 0


def _cmd_view(args: argparse.Namespace) -> int:
    from knitc.view import render_file

    if not _output_ok(args.output, (args.file,)):
        return 1
    diags, data = render_file(
        args.file,
        args.view or "bed",
        os.path.splitext(args.output)[1].lower(),
        defines=args.defines,
        compact=args.compact,
        three_d=args.three_d,
        include=args.include,
    )
    if "error" in args.warn:
        diags.promote_warnings()
    _report(diags, args.quiet)
    if diags.has_errors or data is None:
        return 1
    return 0 if _write(args.output, data) else 1


def _cmd_lint(args: argparse.Namespace) -> int:
    from knitc.lint import lint_file

    diags = lint_file(args.file)
    if "error" in args.warn:
        diags.promote_warnings()
    _report(diags, args.quiet)
    return 1 if diags.has_errors else 0


def _cmd_check(args: argparse.Namespace) -> int:
    from knitc.driver import STAGES, compile_file, timing_table

    # `check` runs the whole pipeline but writes nothing: a design that checks clean
    # compiles clean, and code generation's findings (E602, W60x, W80x) are reported too.
    result = compile_file(
        args.file,
        defines=args.defines,
        werror="error" in args.warn,
        until=STAGES[-1].name,
        include=args.include,
        max_stitches=args.max_stitches,
        verify=args.verify_each or None,
    )
    _report(result.diagnostics, args.quiet)
    if args.time_passes:
        sys.stderr.write(timing_table(result))
    if any(d.code == "E408" for d in result.diagnostics):  # a command-line mistake
        return 2
    return 0 if result.ok else 1


def _cmd_fmt(args: argparse.Namespace) -> int:
    from knitc.frontend.fmt import format_module
    from knitc.frontend.parser import parse_source
    from knitc.source import SourceFile

    status = 0
    for path in args.files:
        diags = Diagnostics()
        try:
            with open(path, encoding="utf-8-sig") as f:
                text = f.read()
        except (OSError, UnicodeDecodeError) as exc:
            diags.error("E001", f"cannot read `{path}`: {exc}", None)
            _report(diags, False)
            status = 1
            continue
        module = parse_source(SourceFile(path, text), diags)
        if module is None:
            _report(diags, False)
            status = 1
            continue
        out = format_module(module)
        if args.check:
            if out != text:
                sys.stderr.write(f"knitc fmt: {path} is not in canonical form\n")
                status = 1
        elif args.in_place:
            if out != text and not _write(path, out):
                status = 1
        else:
            sys.stdout.write(out)
    return status


_VALUED = (
    "-D",
    "-o",
    "--output",
    "--emit",
    "-W",
    "--target",
    "--until",
    "--format",
    "--include",
    "--max-stitches",
)
"""Options that take the next argument as their value (which is then no subcommand)."""


GC_THRESHOLDS = (100_000, 50, 1000)
"""Python's cyclic garbage collector's thresholds for a long-lived knitc process (the
language server and its worker). A compile allocates millions of small objects (ops,
needles, loops) that live to its end and form few cycles; with the default first
threshold (700) the collector walks them again and again, a fifth of a large compile's
time (1M-stitch tube: 29 s -> 23 s). Set by the command line and the language server's
worker, not by `import knitc`: a library user's process is theirs."""

BATCH_GC_THRESHOLDS = (1_000_000, 1_000_000, 1_000_000)
"""The thresholds for a one-shot command (compile, check, k2dat...), whose objects all live
to the process's end: a young collection every million allocations still frees the cycles
that die young, and nothing is walked a second time (the older generations are never
collected; the process ends first). With `GC_THRESHOLDS` every object is still walked in
two generations, a tenth of a 1M-stitch compile (16.3 s -> 14.5 s). Only `main()` run as
the process's command (no `argv`) sets them: a server, or a test calling `main([...])`
many times in one process, must not, since cycles that outlive one young collection would
stay until it exits."""


def tune_gc(batch: bool = False) -> None:
    import gc

    gc.set_threshold(*(BATCH_GC_THRESHOLDS if batch else GC_THRESHOLDS))


def main(argv: list[str] | None = None) -> int:
    """The `knitc` command. Run as the process's own command (no `argv`), a one-shot
    command ends the process itself (`_process.end`: no interpreter teardown); a caller
    passing `argv` gets the exit status back, and its process stays its own."""
    one_shot = argv is None  # the process's own command line (a caller's process is theirs)
    argv = list(sys.argv[1:] if argv is None else argv)
    sub = _subcommand(argv)
    batch = one_shot and (sub is None or argv[sub] != "lsp")  # (a server is long-lived)
    code = _run(argv, sub, batch)
    if batch:
        _process.end(code)
    return code


def _subcommand(argv: list[str]) -> int | None:
    """The index of the subcommand in `argv`, if any: options may come before it (`knitc -D
    x=1 check f.knit`)."""
    return next(
        (
            i
            for i, a in enumerate(argv)
            if a in ("check", "fmt", "k2dat", "dat2k", "view", "lint", "lsp")
            and (i == 0 or argv[i - 1] not in _VALUED)
        ),
        None,
    )


def _run(argv: list[str], sub: int | None, batch: bool) -> int:
    """Run the command; its exit status. `batch`: a one-shot command that is the process's
    own (`tune_gc`)."""
    try:
        if argv == ["--version"]:  # what argparse would print, without building the parser
            sys.stdout.write(f"knitc {__version__}\n")  # (whose choices need the driver)
            return 0
        tune_gc(batch=batch)
        if sub is not None:
            rest = argv[:sub] + argv[sub + 1 :]
            if argv[sub] == "lsp":
                from knitc.lsp import main as lsp_main

                return lsp_main(rest)
            if argv[sub] == "check":
                return _cmd_check(_check_parser().parse_args(rest))
            if argv[sub] == "k2dat":
                return _cmd_k2dat(_k2dat_parser().parse_args(rest))
            if argv[sub] == "dat2k":
                return _cmd_dat2k(_dat2k_parser().parse_args(rest))
            if argv[sub] == "view":
                return _cmd_view(_view_parser().parse_args(rest))
            if argv[sub] == "lint":
                return _cmd_lint(_lint_parser().parse_args(rest))
            return _cmd_fmt(_fmt_parser().parse_args(rest))
        return _cmd_compile(_main_parser().parse_args(argv))
    except SystemExit as exc:  # argparse: --help, --version, usage errors
        return exc.code if isinstance(exc.code, int) else 2
    except KeyboardInterrupt:
        sys.stderr.write("knitc: interrupted\n")
        return 130
    except BrokenPipeError:
        return 0
    except Exception as exc:  # a bug in knitc, never the designer's fault
        sys.stderr.write(
            f"knitc: internal error: {type(exc).__name__}: {exc}\n"
            "This is a bug in knitc, not in your design. Please report it with the input "
            "file and this message:\n"
        )
        import traceback

        traceback.print_exc(file=sys.stderr)
        return 3


if __name__ == "__main__":
    raise SystemExit(main())
