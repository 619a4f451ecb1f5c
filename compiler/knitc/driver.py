"""The pipeline, readable in one place.

    source ──parse──▶ AST ──resolve + verify──▶ Skeleton ──shape──▶ StitchGraph ──pattern──▶
      StitchGraph ──trace──▶ Trace
      ──slice──▶ Slices ──schedule──▶ Schedule ──codegen──▶ MachineProgram
      ──simulate──▶ diagnostics;  MachineProgram ──emit──▶ Knitout
    (DAT comes later)

Each stage is a pure function of the previous IR plus a `Diagnostics` collection; the driver
stops after the first stage that reported errors, because later stages would only repeat
them in other words. `compile_file` is what the CLI, the tests and (later) the language
server call.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from typing import Any

from knitc.diagnostics import Diagnostics
from knitc.ir import machine as mp
from knitc.ir import schedule as sc
from knitc.ir import skeleton as sk
from knitc.ir import slices as sl
from knitc.ir import stitch_graph as sg
from knitc.ir import trace as tr
from knitc.passes.codegen import generate, options_from_skeleton
from knitc.passes.instructions import check_instructions
from knitc.passes.pattern import apply_patterns
from knitc.passes.resolve import parse_define, resolve
from knitc.passes.schedule import schedule
from knitc.passes.shape import build_stitch_graph
from knitc.passes.simulate import add_to_diagnostics, simulate
from knitc.passes.slice import slice_trace
from knitc.passes.trace import trace_courses
from knitc.source import SourceFile
from knitc.syntax import ast
from knitc.syntax.parser import parse_source

STAGES = ("ast", "skeleton", "stitch-graph", "trace", "slices", "schedule", "machine")
"""IRs that `--emit` can print today, in pipeline order."""

PLANNED_STAGES: tuple[str, ...] = ()


@dataclass
class Result:
    diagnostics: Diagnostics
    module: ast.Module | None = None
    skeleton: sk.Skeleton | None = None
    graph: sg.StitchGraph | None = None
    trace: tr.Trace | None = None
    slices: sl.Slices | None = None
    schedule: sc.Schedule | None = None
    program: mp.MachineProgram | None = None
    stage_reached: str = "none"
    defines: dict[str, ast.Node] = field(default_factory=dict)

    @property
    def ok(self) -> bool:
        return not self.diagnostics.has_errors


def compile_source(text: str, path: str, *, defines: list[str] = (), until: str = "skeleton",
                   werror: bool = False) -> Result:
    """Run the front end on `text` up to and including stage `until`."""
    diags = Diagnostics()
    result = Result(diags)
    parsed_defines: dict[str, ast.Node] = {}
    for d in defines:
        got = parse_define(d, diags)
        if got is not None:
            parsed_defines[got[0]] = got[1]
    result.defines = parsed_defines
    module = parse_source(SourceFile(path, text), diags)
    if module is None:
        return result
    result.module, result.stage_reached = module, "ast"
    if until == "ast" or diags.has_errors:
        return _finish(result, werror)
    skel = resolve(module, path, diags, parsed_defines)
    result.skeleton = skel
    result.stage_reached = "skeleton"
    if until == "skeleton" or skel is None or diags.has_errors:
        return _finish(result, werror)
    graph = build_stitch_graph(skel, diags)
    if graph is None:
        return _finish(result, werror)
    graph = check_instructions(apply_patterns(skel, graph, diags), diags,
                               racking=skel.machine.racking)
    sg.check(graph)  # the verifier between passes: a violation is a knitc bug
    result.graph, result.stage_reached = graph, "stitch-graph"
    if until == "stitch-graph" or diags.has_errors:
        return _finish(result, werror)
    trace = trace_courses(graph)
    problems = tr.verify(graph, trace)
    if problems:
        raise AssertionError("tracing produced an invalid trace: " + "; ".join(problems))
    result.trace, result.stage_reached = trace, "trace"
    if until == "trace":
        return _finish(result, werror)
    m = skel.machine
    limits = {"flat_limit": m.slice_shaping, "tube_limit": m.slice_shaping} \
        if m.slice_shaping else {}
    slices = slice_trace(graph, trace, **limits)
    sl.check(graph, trace, slices)  # the verifier between passes: a violation is a knitc bug
    result.slices, result.stage_reached = slices, "slices"
    if until == "slices":
        return _finish(result, werror)
    sched = schedule(graph, slices, needles=m.needles, diags=diags)
    if sched is None:
        return _finish(result, werror)
    sc.check(graph, sched)  # the verifier between passes: a violation is a knitc bug
    result.schedule, result.stage_reached = sched, "schedule"
    if until == "schedule":
        return _finish(result, werror)
    machine = mp.Machine(name=m.model, needles=m.needles, racking_limit=m.racking)
    program = generate(graph, sched, trace, machine=machine, carriers=m.carriers, diags=diags,
                       options=options_from_skeleton(skel))
    if program is None:
        return _finish(result, werror)
    mp.check(program)  # the verifier between passes: a violation is a knitc bug
    add_to_diagnostics(simulate(program), program, diags)
    result.program, result.stage_reached = program, "machine"
    return _finish(result, werror)


def _finish(result: Result, werror: bool) -> Result:
    if werror:
        result.diagnostics.promote_warnings()
    return result


def compile_file(path: str, **kw: Any) -> Result:
    """Read `path` (UTF-8) and compile it; unreadable files become diagnostics."""
    try:
        with open(path, encoding="utf-8") as f:
            text = f.read()
    except (OSError, UnicodeDecodeError) as exc:
        diags = Diagnostics()
        reason = exc.strerror if isinstance(exc, OSError) and exc.strerror else str(exc)
        diags.error("E001", f"cannot read `{path}`: {reason}", None)
        return Result(diags)
    return compile_source(text, path, **kw)


def emit_json(result: Result, stage: str) -> str:
    """The stable JSON text of one IR (`knitc --emit STAGE`)."""
    if stage == "ast":
        assert result.module is not None
        obj: Any = ast.to_json(result.module)
    elif stage == "skeleton":
        assert result.skeleton is not None
        obj = sk.to_json(result.skeleton)
    elif stage == "stitch-graph":
        assert result.graph is not None
        obj = sg.to_json(result.graph)
    elif stage == "trace":
        assert result.graph is not None and result.trace is not None
        obj = tr.to_json(result.graph, result.trace)
    elif stage == "slices":
        assert result.graph is not None and result.slices is not None
        obj = sl.to_json(result.graph, result.slices)
    elif stage == "schedule":
        assert result.graph is not None and result.schedule is not None
        obj = sc.to_json(result.graph, result.schedule)
    elif stage == "machine":
        assert result.program is not None
        obj = mp.to_json(result.program)
    else:
        raise ValueError(stage)
    return json.dumps(obj, indent=1, ensure_ascii=True, allow_nan=False) + "\n"
