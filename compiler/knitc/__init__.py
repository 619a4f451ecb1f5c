"""knitc: a compiler for industrial V-bed weft-knitting machines.

knitc reads a ``.knit`` file, a textual description of one garment built from parametric
shape primitives (flat ``sheet`` and tubular ``tube`` pieces, ``joint`` short-row sections,
``split``/``merge`` nodes), the connections between their interfaces, design parameters and
stitch-pattern layers, and compiles it through a pipeline of intermediate representations
(AST, Skeleton, StitchGraph, Trace, Slices/Schedule, MachineProgram) into a machine
program: Knitout or a Shima Seiki DAT file.

The package data (the Lark grammar and the ``std`` standard library) is reached through
:mod:`knitc.resources`. The command-line entry point is :func:`knitc.cli.main`
(``knitc`` or ``python -m knitc``). See docs/architecture.md for the design.

The public surface is small, and what the CLI, the tests and the language server use::

    result = knitc.compile_file("sweater.knit", until="machine")
    result = knitc.compile_source(text, "sweater.knit", until="skeleton")
    knitc.resume(result, "knitout")        # go on from where it stopped
    result.program, result.output, result.diagnostics

plus the stage table (`STAGES`, `TARGETS`) and the IR types. Everything else is internal
and may change between versions. Names resolve lazily, so `knitc --version` imports none
of the pipeline.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

__version__ = "0.1.0"

_PUBLIC = {
    "compile_source": "knitc.driver",
    "compile_file": "knitc.driver",
    "resume": "knitc.driver",
    "Result": "knitc.driver",
    "Stage": "knitc.driver",
    "STAGES": "knitc.driver",
    "TARGETS": "knitc.driver",
    "InternalError": "knitc.driver",
    "Diagnostics": "knitc.diagnostics",
    "Diagnostic": "knitc.diagnostics",
    "Span": "knitc.source",
    "Module": "knitc.frontend.ast",
    "Skeleton": "knitc.frontend.skeleton",
    "StitchGraph": "knitc.shaping.stitch_graph",
    "Trace": "knitc.scheduling.trace",
    "Slices": "knitc.scheduling.slices",
    "Schedule": "knitc.scheduling.schedule",
    "MachineProgram": "knitc.codegen.machine",
    "Op": "knitc.codegen.machine",
    "Needle": "knitc.codegen.machine",
}

__all__ = [
    "__version__",
    "compile_source",
    "compile_file",
    "resume",
    "Result",
    "Stage",
    "STAGES",
    "TARGETS",
    "InternalError",
    "Diagnostics",
    "Diagnostic",
    "Span",
    "Module",
    "Skeleton",
    "StitchGraph",
    "Trace",
    "Slices",
    "Schedule",
    "MachineProgram",
    "Op",
    "Needle",
]

if TYPE_CHECKING:
    from knitc.codegen.machine import MachineProgram, Needle, Op
    from knitc.diagnostics import Diagnostic, Diagnostics
    from knitc.driver import (
        STAGES,
        TARGETS,
        InternalError,
        Result,
        Stage,
        compile_file,
        compile_source,
        resume,
    )
    from knitc.frontend.ast import Module
    from knitc.frontend.skeleton import Skeleton
    from knitc.scheduling.schedule import Schedule
    from knitc.scheduling.slices import Slices
    from knitc.scheduling.trace import Trace
    from knitc.shaping.stitch_graph import StitchGraph
    from knitc.source import Span


def __getattr__(name: str) -> Any:
    module = _PUBLIC.get(name)
    if module is None:
        raise AttributeError(f"module 'knitc' has no attribute {name!r}")
    import importlib

    value = getattr(importlib.import_module(module), name)
    globals()[name] = value
    return value
