"""knitc: a compiler for industrial V-bed weft-knitting machines.

knitc reads a ``.knit`` file, a textual description of one garment built from parametric
shape primitives (flat ``sheet`` and tubular ``tube`` pieces, ``joint`` short-row sections,
``split``/``merge`` nodes), the connections between their interfaces, design parameters and
stitch-pattern layers, and compiles it through a pipeline of intermediate representations
(AST, Skeleton, StitchGraph, Trace, Slices/Schedule, MachineProgram) into a machine
program: Knitout today, Shima Seiki DAT later.

The package data (the Lark grammar and the ``std`` standard library) is reached through
:mod:`knitc.resources`. The command-line entry point is :func:`knitc.cli.main`
(``knitc`` or ``python -m knitc``). See docs/architecture.md for the design.
"""

__version__ = "0.1.0"
