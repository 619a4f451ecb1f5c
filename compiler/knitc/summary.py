"""The one line a successful compile prints (stitches, courses, yarns, carriage passes,
needles, an estimate of machine time), and the progress display of long compiles.

Machine time is an estimate from the program alone, for comparing designs and versions, not
a promise: every carriage pass crosses the needles the program uses plus a run-out at each
end, at a typical speed for its kind (knitting passes faster than transfer passes, which a
V-bed makes slowly so loops are not torn), and reverses in a fixed time. The constants are
those of a 15-gauge Shima SWG-class machine; a technician's real settings (speed per
course, presser, takedown) change the figure, not the comparison.
"""

from __future__ import annotations

import sys
import threading
from collections.abc import Callable, Iterator
from contextlib import contextmanager

from knitc.codegen.machine import MachineProgram, pass_index
from knitc.driver import Result
from knitc.records import record

PITCH_MM = 25.4 / 15
"""Needle pitch of a 15-gauge bed."""
RUN_OUT_MM = 100.0
"""How far the carriage runs past the fabric at each end of a pass."""
KNIT_SPEED = 0.8
"""Metres per second of a knitting pass."""
TRANSFER_SPEED = 0.5
"""Metres per second of a transfer pass."""
REVERSAL_S = 0.3
"""Seconds to stop and reverse the carriage."""


@record(frozen=True)
class Workload:
    """What the carriage does for a program: its knitting and transfer passes (the passes
    knitc reports, `machine.pass_index`) and the needles it spans."""

    knit_passes: int
    transfer_passes: int
    needles: int

    @property
    def passes(self) -> int:
        return self.knit_passes + self.transfer_passes

    @property
    def seconds(self) -> float:
        """Estimated knitting time (see the module docstring)."""
        travel = (self.needles * PITCH_MM + 2 * RUN_OUT_MM) / 1000.0
        return self.knit_passes * (travel / KNIT_SPEED + REVERSAL_S) + self.transfer_passes * (
            travel / TRANSFER_SPEED + REVERSAL_S
        )


def workload(prog: MachineProgram) -> Workload:
    """One walk over the program's passes: each is a transfer pass or a knitting one by
    the kind of its operations (a pass never mixes them)."""
    ops = prog.ops
    kinds: list[str] = []  # the kind of each pass's first op (pass numbers only grow)
    last = -1
    for op, p in zip(ops, pass_index(ops), strict=True):
        if p > last:
            kinds.append(op.kind)
            last = p
    xfers = kinds.count("xfer")
    # (a program names a few hundred distinct needles: a set of them, then their indices)
    needles = {op.needle for op in ops} | {op.needle2 for op in ops}
    idx = [n.index for n in needles if n is not None]
    width = max(idx) - min(idx) + 1 if idx else 0
    return Workload(len(kinds) - xfers, xfers, width)


def machine_seconds(prog: MachineProgram) -> float:
    """Estimated knitting time of `prog` (see the module docstring)."""
    return workload(prog).seconds


def summary_line(result: Result, output: str) -> str:
    """`knitc: wrote OUT: 18184 stitches, 212 courses, 4 yarns, 1475 carriage passes on 120
    needles, about 25 min on the machine`."""
    parts = []
    if result.graph is not None:
        parts += [f"{result.graph.n_stitches} stitches", f"{result.graph.n_courses} courses"]
    if result.trace is not None:
        yarns = len(set(result.trace.yarn.tolist()))
        parts.append(f"{yarns} yarn{'s' * (yarns != 1)}")
        g = result.graph
        laid = g is not None and g.inlay is not None and bool(g.inlay.any())
        if g is not None and (g.colourwork or laid):  # colour: which, and the ends they leave
            assert g.yarn is not None
            ys = set(g.yarn.tolist()) | (
                set(g.inlay.tolist()) - {0} if g.inlay is not None else set()
            )
            used = sorted({g.yarn_names[y] for y in ys})
            # every yarn brought in (a strand of the trace, or a fair isle yarn) is a
            # length of yarn with two ends
            ins = yarns
            if result.program is not None:
                # (a carrier set brought in together is a yarn per carrier: plating)
                ins = sum(
                    len(op.carriers) for op in result.program.ops if op.kind in ("in", "inhook")
                )
            parts[-1] = f"{len(used)} yarns ({', '.join(used)}), {2 * ins} ends to weave in"
    if result.program is not None:
        w = workload(result.program)
        parts.append(f"{w.passes} carriage passes on {w.needles} needles")
        time = f"{w.seconds / 60:.0f} min" if w.seconds >= 60 else f"{w.seconds:.0f} s"
        parts.append(f"about {time} on the machine")
    return f"knitc: wrote {output}: " + ", ".join(parts) + "\n"


@contextmanager
def progress(enabled: bool, total: int) -> Iterator[Callable[[str], None]]:
    """A callback for each stage started; a progress bar on standard error once the work
    has taken more than a second, if `enabled` (standard error is a terminal)."""
    if not enabled:
        yield lambda name: None
        return
    from rich.console import Console
    from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

    bar = Progress(
        TextColumn("knitc: {task.description:<14}"),
        BarColumn(),
        TimeElapsedColumn(),
        console=Console(file=sys.stderr),
        transient=True,
    )
    task = bar.add_task("", total=total)
    started = [0]
    shown = threading.Event()

    def show() -> None:
        shown.set()
        bar.start()

    timer = threading.Timer(1.0, show)
    timer.daemon = True
    timer.start()

    def step(name: str) -> None:
        bar.update(task, description=name, completed=started[0])
        started[0] += 1

    try:
        yield step
    finally:
        timer.cancel()
        timer.join()
        if shown.is_set():
            bar.stop()
