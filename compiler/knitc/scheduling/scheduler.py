"""Schedule optimisation: bed slices → a layout and a needle offset per slice (ch. 6.7.2-3).

Two stages, as in the thesis.

The layout stage is `scheduling.layouts`, the offset stage `scheduling.offsets`; both read
the slices' relations (`scheduling.relations`).
"""

from __future__ import annotations

import numpy as np

from knitc.diagnostics import Diagnostics
from knitc.scheduling.layouts import Layouts
from knitc.scheduling.offsets import Offsets
from knitc.scheduling.relations import Relations
from knitc.scheduling.schedule import Schedule
from knitc.scheduling.slices import Slices
from knitc.shaping.stitch_graph import StitchGraph

MAX_SWEEPS = 8
"""Forward plus backward offset sweeps at most."""
GAP = 1
"""Free needles between a changing active block and an unrelated held block (ch. 6.7.3)."""


def schedule(
    g: StitchGraph,
    slices: Slices,
    *,
    needles: int,
    diags: Diagnostics,
    max_sweeps: int = MAX_SWEEPS,
    gap: int = GAP,
) -> Schedule | None:
    """The schedule of `slices` on a machine of `needles` needles; None (with E601) if it
    does not fit. `gap`: free needles kept around a changing active block."""
    ctx = Relations(g, slices)
    lay = Layouts(ctx)
    lay.run()
    off = Offsets(ctx, lay, needles, max_sweeps, gap)
    if not off.run():
        # Placement is greedy, so the right end of the bed can stop it where an unbounded
        # bed finds room: that placement is used when it fits, so the width E601 reports
        # is always enough.
        wide = Offsets(ctx, lay, 1 << 30, max_sweeps, gap)
        wide.run()
        need = wide.width() if ctx.ne else 0
        if need > needles:
            k = off.failed_slice
            span = (
                g.spans[int(g.span[int(slices.stitch[int(slices.start[k])])])]
                if k is not None and slices.length[k]
                else None
            )
            diags.error(
                "E601",
                f"the garment needs {need} needles but the machine has {needles}",
                span,
                hint="narrow the design, knit branches in full gauge, or use a wider machine",
            )
            return None
        off = wide
    needle = off.needle()
    a_slice, a_stitch, a_bed, a_needle = off.alignments()
    sched = Schedule(
        slices=slices,
        needles=int(needles),
        kind=lay.kind.astype(np.int8),
        nibble=lay.nibble.astype(np.int8),
        roll=lay.roll.astype(np.int32),
        main=lay.main.astype(np.int32),
        side=lay.side.astype(np.int8),
        spread=lay.spread.astype(np.int8),
        mirror=lay.mirror.astype(np.int8),
        reuse=lay.reuse.copy(),
        offset=off.x[: ctx.ns].astype(np.int32),
        step=ctx.step.astype(np.int8),
        bed=lay.bed.astype(np.int8),
        rel=lay.rel.astype(np.int32),
        needle=needle.astype(np.int32),
        align_slice=a_slice,
        align_stitch=a_stitch,
        align_bed=a_bed,
        align_needle=a_needle,
    )
    al, ro, sh = lay.total_cost()
    sched.cost = {"align": al, "roll": ro, "shift": sh}
    return sched
