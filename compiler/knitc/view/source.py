"""What every view draws from (`ViewInput`), loaded once from a design or a Knitout file."""

from __future__ import annotations

from dataclasses import field

from knitc.codegen.machine import MachineProgram
from knitc.codegen.simulate import Finding
from knitc.diagnostics import Diagnostics
from knitc.driver import Result
from knitc.records import record
from knitc.scheduling.schedule import Schedule
from knitc.shaping.stitch_graph import StitchGraph


@record
class ViewInput:
    """A machine program and, for a design, the stitch graph and schedule it came from.

    `findings` are knitc's simulation of `program` (every hazard, located at an op);
    `result` is the whole compilation of a design (None for Knitout), so a view can reach
    any IR and the diagnostics; `diagnostics` are the loading's (the compilation's, or the
    Knitout reader's warnings), with the sources they point into, for views that list
    them (the HTML viewer's warnings panel)."""

    path: str
    program: MachineProgram
    findings: list[Finding] = field(default_factory=list)
    graph: StitchGraph | None = None
    schedule: Schedule | None = None
    result: Result | None = None
    diagnostics: Diagnostics = field(default_factory=Diagnostics)

    @property
    def from_design(self) -> bool:
        return self.graph is not None


@record
class Loaded:
    diagnostics: Diagnostics
    input: ViewInput | None


def load(
    path: str, defines: list[str] | tuple[str, ...] = (), include: list[str] | tuple[str, ...] = ()
) -> Loaded:
    """Compile `path` (.knit) through the machine stage, or read it as Knitout (.k, or any
    file starting with `;!knitout-`), and simulate the program. `include`: folders the
    design's imports and images may read besides its own (`--include`)."""
    from knitc.codegen.simulate import simulate

    if _is_knitout(path):
        from knitc.backends.knitout_read import read_knitout_file

        prog, diags = read_knitout_file(path)
        if prog is None:
            return Loaded(diags, None)
        return Loaded(diags, ViewInput(path, prog, simulate(prog), diagnostics=diags))
    from knitc.driver import compile_file

    result = compile_file(path, defines=list(defines), until="machine", include=list(include))
    return Loaded(result.diagnostics, from_result(result))


def from_result(result: Result) -> ViewInput | None:
    """What the views draw of a design compiled through the machine stage (None when it
    did not get there): its program simulated, with the stitch graph and schedule."""
    from knitc.codegen.simulate import simulate

    if not result.ok or result.program is None:
        return None
    return ViewInput(
        result.path,
        result.program,
        simulate(result.program),
        graph=result.graph,
        schedule=result.schedule,
        result=result,
        diagnostics=result.diagnostics,
    )


def _is_knitout(path: str) -> bool:
    if path.endswith(".k"):
        return True
    try:
        with open(path, "rb") as f:
            return f.read(11) == b";!knitout-2"
    except OSError:
        return False
