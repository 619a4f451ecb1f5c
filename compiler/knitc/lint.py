"""`knitc lint`: knitc's own simulation of any Knitout program, from any tool.

A Knitout file is read as `knitc k2dat` reads it (`backends.knitout_read`: every op keeps
the span of its line, and what the spec forbids is an E91x error there), then run on
knitc's machine model (`codegen.simulate`), the one `knitc check` runs on compiled
designs. Reusing both means a Knitout file is judged exactly as knitc's own output is, and
that every rule added for one benefits the other. The machine profile is the one the
header names (`;;Machine:`, `;;Gauge:`, `;;Carriers:`) with knitc's defaults for the rest:
its needles, racking limit, carriers per pass and hazard thresholds (`codegen.machine.Machine`).
Its needle numbers are placed on the bed as its `;;Position:` says (as the Shima converter
places them): with `Keep` they must lie on the bed, otherwise the program must fit its width.

What it reports (docs/architecture.md §7, "Lint"):

* the reader's errors (E910-E916: header, opcodes, arguments, needles, carriers and their
  state, transfers not across the beds or not aligned), and its W910 warnings; a file with
  reader errors is not simulated (its ops are not all known);
* the simulator's errors: racking (E807), needles off the bed or sliders misused (E806,
  E808), the inserting hook (E805, including a stitch where the parked hook blocks the
  bed), carriers taken out without a stitch (E809), too many carriers in one op (E811),
  loops or carriers left at the end (E803, E804);
* its hazards: stacks of loops (W801), knits on empty needles (W802), long floats (W803),
  knits through long-missed loops (W804), transfers that stretch the yarn (W805), reverse
  stitches whose facing needle was occupied (W806), a yarn brought in loose onto empty
  needles (W807), a cast-on knitted before its carrier turned (W808).

Each diagnostic is at the Knitout line of the op to blame, with the op in a note (an op's
index in the program, which `knitc check` gives for compiled designs, means nothing to the
reader of a Knitout file: its line does).
"""

from __future__ import annotations

from knitc.backends.knitout_read import read_knitout, read_knitout_file
from knitc.codegen.machine import MachineProgram
from knitc.codegen.simulate import Finding, simulate
from knitc.diagnostics import Diagnostics, Note


def lint_text(text: str, path: str) -> Diagnostics:
    """The diagnostics of Knitout `text` (read from `path`, which the spans name): the
    reader's errors alone when it does not parse, else the simulation's findings too."""
    return _lint(*read_knitout(text, path))


def lint_file(path: str) -> Diagnostics:
    """`knitc lint FILE.k`: `lint_text` of the file at `path` (E001 when it cannot be read
    or is not UTF-8)."""
    return _lint(*read_knitout_file(path))


def _lint(prog: MachineProgram | None, diags: Diagnostics) -> Diagnostics:
    if prog is not None:
        report(simulate(prog, placed=True), prog, diags)
    return diags


def report(findings: list[Finding], prog: MachineProgram, diags: Diagnostics) -> None:
    """The simulator's findings as diagnostics at their ops' Knitout lines, each with the
    op in a note (as `knitc k2dat` names the op it refuses)."""
    for f in findings:
        notes = []
        if 0 <= f.op < len(prog.ops):
            notes.append(Note(f"the operation: `{prog.ops[f.op]}`"))
        add = diags.error if f.is_error else diags.warning
        add(f.code, f.message, f.span, notes=notes)
