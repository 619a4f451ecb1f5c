"""The pipeline, readable in one place, and the table of its stages.

    source ──parse──▶ AST ──resolve──▶ Skeleton ──shape, pattern, check──▶ StitchGraph
      ──trace──▶ Trace ──slice──▶ Slices ──schedule──▶ Schedule ──stack──▶ YarnStacks
      ──generate, simulate──▶ MachineProgram ──▶ Knitout text | DAT bytes

`STAGES` lists the IR stages in pipeline order and `TARGETS` the machine formats that follow
the last one. Each `Stage` names its function, the verifier run after it and its dump, and
everything else is derived from the table: `--emit` (the stages that have a dump),
`--until`, `knitc check` (every IR stage, no target), the output files and
`--time-passes`. A stage is a function of the `Result` so far that stores its IR there and
returns False when it reported errors; the driver stops after the first stage that did,
because later stages would only repeat them in other words.

`compile_source` / `compile_file` run the pipeline from the start up to a stage; `resume`
continues a `Result` further, reusing the IRs it holds, so a tool that first asked for the
skeleton (the language server) can later ask for the machine program without parsing again.
"""

from __future__ import annotations

import importlib
import json
import os
import time
from collections.abc import Callable
from dataclasses import field
from typing import TYPE_CHECKING, Any, TypeVar

from knitc.access import ReadRoots, reading_below
from knitc.codegen import machine as mp
from knitc.diagnostics import Diagnostics, Note
from knitc.limits import MAX_STITCHES
from knitc.records import record
from knitc.source import SourceFile, Span

if TYPE_CHECKING:
    from knitc.codegen import yarn_stack as ys
    from knitc.frontend import ast
    from knitc.frontend import skeleton as sk
    from knitc.scheduling import schedule as sc
    from knitc.scheduling import slices as sl
    from knitc.scheduling import trace as tr
    from knitc.shaping import stitch_graph as sg

T = TypeVar("T")


def _lazy(name: str) -> Any:
    """A stage's module, imported when the stage first runs or is dumped: `k2dat` and
    `dat2k` start from a machine program and need none of the front end (nor its import
    time)."""
    return importlib.import_module(name)


class InternalError(Exception):
    """A verifier between stages found an IR that breaks its invariants: a bug in knitc,
    never in the design (the CLI reports it as an internal error, exit 3)."""


@record
class Result:
    """Everything one compilation produced so far: the IR of every stage it reached, the
    diagnostics, the time each stage took, and the output of the target stage if one ran."""

    diagnostics: Diagnostics
    path: str = "<input>"
    text: str = ""
    werror: bool = False
    module: ast.Module | None = None
    skeleton: sk.Skeleton | None = None
    graph: sg.StitchGraph | None = None
    trace: tr.Trace | None = None
    slices: sl.Slices | None = None
    schedule: sc.Schedule | None = None
    stacks: ys.YarnStacks | None = None
    program: mp.MachineProgram | None = None
    output: str | bytes | None = None
    stage_reached: str = "none"
    defines: dict[str, ast.Node] = field(default_factory=dict)
    include: tuple[str, ...] = ()
    """Folders besides the design's own that its imports and images may read (`--include`;
    `access.ReadRoots`)."""
    max_stitches: int = MAX_STITCHES
    """The stitch budget (E512, `--max-stitches`)."""
    machine_problems: list[str] | None = None
    """`machine.verify` of `program`, once (see `_generate`)."""
    timings: list[tuple[str, float]] = field(default_factory=list)
    """(stage, seconds) for every stage run, in order (`knitc --time-passes`)."""

    @property
    def ok(self) -> bool:
        return not self.diagnostics.has_errors


@record(frozen=True)
class Stage:
    """One step of the pipeline: `run` computes its IR from the earlier ones in the
    `Result` and stores it (False: it reported errors, stop); `verify` lists the IR's
    broken invariants (empty when valid); `dump` is its stable JSON (`--emit NAME`) and
    `text` its compact text form (`--format text`; by default the dump one record per
    line, `text_form`)."""

    name: str
    run: Callable[[Result], bool]
    verify: Callable[[Result], list[str]] | None = None
    dump: Callable[[Result], Any] | None = None
    doc: str = ""
    text: Callable[[Result], str] | None = None


# ---- the stages, in pipeline order ----------------------------------------------------------


def _parse(r: Result) -> bool:
    from knitc.frontend.parser import parse_source

    r.module = parse_source(SourceFile(r.path, r.text), r.diagnostics)
    return r.module is not None


def _resolve(r: Result) -> bool:
    from knitc.frontend.resolve import resolve

    assert r.module is not None
    r.skeleton = resolve(r.module, r.path, r.diagnostics, r.defines, r.max_stitches)
    return r.skeleton is not None


def _stitch_graph(r: Result) -> bool:
    from knitc.patterning.instructions import check_instructions
    from knitc.patterning.pattern import apply_patterns
    from knitc.shaping.shape import build_stitch_graph
    from knitc.shaping.stripes import orient_stripes

    assert r.skeleton is not None
    if not r.skeleton.nodes:  # a header-only program would "knit" silently
        r.diagnostics.error(
            "E511",
            f"`{r.path}` declares no sheet, tube, joint or split: there is nothing to knit",
            Span(r.path, 1, 1, 1, 1),
            hint="declare a piece, e.g. `tube body { length: 40  width: 30 }`; a file of "
            "definitions only is imported by a design (`import`), not compiled",
        )
        return False
    graph = build_stitch_graph(r.skeleton, r.diagnostics)
    if graph is None:
        return False
    patterned = apply_patterns(r.skeleton, graph, r.diagnostics)
    checked = check_instructions(patterned, r.diagnostics, racking=r.skeleton.machine.racking)
    r.graph = orient_stripes(checked)
    return True


def _trace(r: Result) -> bool:
    from knitc.scheduling.tracing import trace_courses

    assert r.graph is not None
    assert r.skeleton is not None
    r.trace = trace_courses(r.graph, carry_up=[y.carry_up for y in r.skeleton.yarn_list])
    return True


def _slice(r: Result) -> bool:
    from knitc.scheduling.slicing import slice_trace

    assert r.skeleton is not None and r.graph is not None and r.trace is not None
    m = r.skeleton.machine
    limits = (
        {"flat_limit": m.slice_shaping, "tube_limit": m.slice_shaping} if m.slice_shaping else {}
    )
    r.slices = slice_trace(r.graph, r.trace, **limits)
    return True


def _schedule(r: Result) -> bool:
    from knitc.scheduling.scheduler import schedule

    assert r.skeleton is not None and r.graph is not None and r.slices is not None
    r.schedule = schedule(
        r.graph, r.slices, needles=r.skeleton.machine.needles, diags=r.diagnostics
    )
    return r.schedule is not None


def _stack(r: Result) -> bool:
    from knitc.codegen.generate import options_from_skeleton
    from knitc.codegen.yarn_stack import stack_yarns

    assert r.skeleton is not None and r.graph is not None
    assert r.schedule is not None and r.trace is not None
    opts = options_from_skeleton(r.skeleton)  # (the ones code generation reads too)
    r.stacks = stack_yarns(r.graph, r.trace, r.schedule, opts.yarn_tuck_every, opts.yarn_inlay)
    return True


def _generate(r: Result) -> bool:
    from knitc.codegen.generate import generate, options_from_skeleton
    from knitc.codegen.simulate import add_to_diagnostics, simulate

    assert r.skeleton is not None and r.graph is not None
    assert r.schedule is not None and r.trace is not None
    m = r.skeleton.machine
    machine = mp.Machine(name=m.model, needles=m.needles, racking_limit=m.racking)
    program = generate(
        r.graph,
        r.schedule,
        r.trace,
        machine=machine,
        # `main`'s strands take these in order: its declared carrier first
        carriers=tuple(
            dict.fromkeys((r.skeleton.yarn_list[0].carrier or m.carriers[0],) + m.carriers)
        ),
        diags=r.diagnostics,
        options=options_from_skeleton(r.skeleton),
        stacks=r.stacks,
    )
    if program is None:
        return False
    r.program = program
    # Every op is validated once: here, before the simulation (which then trusts them), and
    # the stage table's verifier reads the same list (`_machine_problems`).
    r.machine_problems = mp.verify(program)
    _verify("machine", r.machine_problems)
    if not r.diagnostics.has_errors:
        # After a designer's error (an action that could not run, E72x) the program lacks
        # that stitch's steps, and simulating it would blame knitc for the gap (E809).
        add_to_diagnostics(simulate(program, verified=True), program, r.diagnostics)
    return True


def _machine_problems(r: Result) -> list[str]:
    """The machine program's broken invariants: those `_generate` found, when it ran (a
    program set by other means is verified here)."""
    if r.machine_problems is None:
        r.machine_problems = mp.verify(_the(r.program))
    return r.machine_problems


def _knitout(r: Result) -> bool:
    from knitc.backends.knitout import write_knitout

    assert r.program is not None
    r.output = write_knitout(r.program)
    return True


def _dat(r: Result) -> bool:
    """The DAT file's bytes; an error at the line of the operation the machine (or its DAT
    format) cannot take."""
    from knitc.backends.dat_format import DatError, encode
    from knitc.backends.dat_write import DatWriteError, to_dat

    prog = r.program
    assert prog is not None
    try:
        r.output = encode(to_dat(prog))
    except (DatWriteError, DatError) as exc:
        index = getattr(exc, "op_index", None)
        op = prog.ops[index] if index is not None and 0 <= index < len(prog.ops) else None
        r.diagnostics.error(
            "E901",
            f"cannot write a DAT file: {getattr(exc, 'message', exc)}",
            op.span if op is not None else None,
            notes=[] if op is None else [Note(f"the operation: `{op}`")],
        )
        return False
    return True


def _ast_text(r: Result) -> str:
    """The AST's text form is the canonical source (`knitc fmt`)."""
    from knitc.frontend.fmt import format_module

    return format_module(_the(r.module))


def _the(ir: T | None) -> T:
    """An earlier stage's IR, which the pipeline order guarantees is there."""
    assert ir is not None, "a stage ran before the stage it depends on"
    return ir


STAGES: tuple[Stage, ...] = (
    Stage(
        "ast",
        _parse,
        None,
        lambda r: _lazy("knitc.frontend.ast").to_json(_the(r.module)),
        "the syntax tree, every node with its source span",
        text=_ast_text,
    ),
    Stage(
        "skeleton",
        _resolve,
        None,
        lambda r: _lazy("knitc.frontend.skeleton").to_json(_the(r.skeleton)),
        "the primitives with resolved parameters, interfaces and connections",
    ),
    Stage(
        "stitch-graph",
        _stitch_graph,
        lambda r: _lazy("knitc.shaping.stitch_graph").verify(_the(r.graph)),
        lambda r: _lazy("knitc.shaping.stitch_graph").to_json(_the(r.graph)),
        "stitches, courses and wales, with pattern instructions and actions",
    ),
    Stage(
        "trace",
        _trace,
        lambda r: _lazy("knitc.scheduling.trace").verify(_the(r.graph), _the(r.trace)),
        lambda r: _lazy("knitc.scheduling.trace").to_json(_the(r.graph), _the(r.trace)),
        "the yarn path through every stitch",
    ),
    Stage(
        "slices",
        _slice,
        lambda r: _lazy("knitc.scheduling.slices").verify(
            _the(r.graph), _the(r.trace), _the(r.slices)
        ),
        lambda r: _lazy("knitc.scheduling.slices").to_json(_the(r.graph), _the(r.slices)),
        "the trace cut into bed slices",
    ),
    Stage(
        "schedule",
        _schedule,
        lambda r: _lazy("knitc.scheduling.schedule").verify(_the(r.graph), _the(r.schedule)),
        lambda r: _lazy("knitc.scheduling.schedule").to_json(_the(r.graph), _the(r.schedule)),
        "each slice's layout and needle offset",
    ),
    Stage(
        "yarn-stack",
        _stack,
        lambda r: _lazy("knitc.codegen.yarn_stack").verify(_the(r.graph), _the(r.stacks)),
        lambda r: _lazy("knitc.codegen.yarn_stack").to_json(_the(r.graph), _the(r.stacks)),
        "each stitch's front yarn and the back yarns that miss, tuck or knit behind it",
    ),
    Stage(
        "machine",
        _generate,
        _machine_problems,
        lambda r: mp.to_json(_the(r.program)),
        "machine operations, each with its stitch and source line (simulated)",
    ),
)
"""The IR stages in pipeline order."""

TARGETS: tuple[Stage, ...] = (
    Stage("knitout", _knitout, doc="Knitout text (`.k`)"),
    Stage("dat", _dat, doc="a Shima Seiki DAT file (`.dat`, binary)"),
)
"""The machine formats; each runs after the last IR stage."""

EMITTABLE: tuple[str, ...] = tuple(s.name for s in STAGES if s.dump is not None)
"""The names `--emit` accepts."""

_BY_NAME: dict[str, Stage] = {s.name: s for s in STAGES + TARGETS}


def stage(name: str) -> Stage:
    """The stage called `name`; ValueError (listing the names) for any other."""
    try:
        return _BY_NAME[name]
    except KeyError:
        raise ValueError(
            f"unknown stage {name!r}: expected one of " + ", ".join(_BY_NAME)
        ) from None


VERIFY_ENV = "KNITC_VERIFY"
"""Set to 1 to run every IR verifier between stages (`--verify-each` does the same for one
run). The test suite and the fuzzers set it."""


def verifying() -> bool:
    """Whether the IR verifiers run between stages. They re-derive each IR's invariants from
    scratch, which costs a tenth to a quarter of a compile (issue 16), and they find bugs in
    knitc, not in designs: so like LLVM's `-verify-each` they are the developers' check,
    on in the tests and the fuzzers and off for a designer's compile. What a designer's
    compile never skips is the check of its output: every machine op is validated
    (`machine.verify`) and the program simulated, and the machine stage's verifier reads
    that result, so it always runs."""
    return os.environ.get(VERIFY_ENV, "") not in ("", "0")


def _verify(name: str, problems: list[str]) -> None:
    """The one way a verifier runs between stages."""
    if problems:
        raise InternalError(f"stage `{name}` produced an invalid IR: " + "; ".join(problems[:5]))


# ---- running it -----------------------------------------------------------------------------


def resume(
    result: Result,
    until: str = "machine",
    on_stage: Callable[[str], None] | None = None,
    verify: bool | None = None,
) -> Result:
    """Continue `result` through stage `until` (an IR stage or a target), reusing the IRs it
    already holds. Stops early after a stage that reported errors. `on_stage` is told the
    name of each stage as it starts (a progress display). `verify` runs every IR verifier
    after its stage (None: as `verifying()` says; the machine stage's always runs)."""
    every = verifying() if verify is None else verify
    names = [s.name for s in STAGES]
    plan = STAGES[: names.index(until) + 1] if until in names else STAGES + (stage(until),)
    with reading_below(ReadRoots.for_design(result.path, result.include)):
        for step in plan[_index(result.stage_reached) :]:
            if result.diagnostics.has_errors:
                break
            if on_stage is not None:
                on_stage(step.name)
            start = time.perf_counter()
            ok = step.run(result)
            if ok and step.verify is not None and (every or step.name == "machine"):
                _verify(step.name, step.verify(result))
            result.timings.append((step.name, time.perf_counter() - start))
            if not ok:
                break
            if step.name in names:
                result.stage_reached = step.name
    if result.werror:
        result.diagnostics.promote_warnings()
    return result


def _index(name: str) -> int:
    """How many IR stages a result that reached `name` holds."""
    names = [s.name for s in STAGES]
    return names.index(name) + 1 if name in names else 0


def compile_source(
    text: str,
    path: str,
    *,
    defines: list[str] | tuple[str, ...] = (),
    until: str = "skeleton",
    werror: bool = False,
    on_stage: Callable[[str], None] | None = None,
    include: list[str] | tuple[str, ...] = (),
    max_stitches: int = MAX_STITCHES,
    verify: bool | None = None,
) -> Result:
    """Run the pipeline on `text` up to and including stage `until` (`on_stage`, `verify`:
    see `resume`). Imports and images may read below the folder of `path` and the `include`
    folders only; `max_stitches` is the stitch budget (E512)."""
    from knitc.frontend.resolve import parse_define

    stage(until)  # a misspelt stage is a mistake of the caller, not "run everything"
    result = Result(
        Diagnostics(),
        path=path,
        text=text,
        werror=werror,
        include=tuple(include),
        max_stitches=max_stitches,
    )
    for d in defines:
        got = parse_define(d, result.diagnostics)
        if got is not None:
            result.defines[got[0]] = got[1]
    return resume(result, until, on_stage, verify)


def compile_file(path: str, **kw: Any) -> Result:
    """Read `path` (UTF-8) and compile it; unreadable files become diagnostics."""
    try:
        with open(path, encoding="utf-8-sig") as f:  # a BOM some editors write is not text
            text = f.read()
    except (OSError, UnicodeDecodeError) as exc:
        diags = Diagnostics()
        reason = exc.strerror if isinstance(exc, OSError) and exc.strerror else str(exc)
        diags.error("E001", f"cannot read `{path}`: {reason}", None)
        return Result(diags, path=path)
    return compile_source(text, path, **kw)


def emit_json(result: Result, name: str) -> str:
    """The stable JSON text of one IR (`knitc --emit NAME`)."""
    return json.dumps(_dump(result, name), indent=1, ensure_ascii=True, allow_nan=False) + "\n"


def emit_text(result: Result, name: str) -> str:
    """The compact text form of one IR (`knitc --emit NAME --format text`)."""
    s = stage(name)
    if s.text is not None:
        _dump(result, name)  # the same checks
        return s.text(result)
    from knitc.text_form import render

    return render(_dump(result, name))


def _dump(result: Result, name: str) -> Any:
    s = stage(name)
    if s.dump is None:
        raise ValueError(f"stage {name!r} has no dump")
    if _index(result.stage_reached) < _index(name):
        raise ValueError(f"the compilation stopped before stage {name!r}")
    return s.dump(result)


def timing_table(result: Result) -> str:
    """`--time-passes`: seconds per stage, then the total."""
    rows = [f"  {name:<14} {sec:8.3f}" for name, sec in result.timings]
    total = sum(sec for _, sec in result.timings)
    return "knitc: seconds per stage\n" + "\n".join(rows) + f"\n  {'total':<14} {total:8.3f}\n"
