"""The time-needle bed (`knitc view --bed`): carriage passes up, needles across.

The picture machine knitters read (thesis Fig. 3-16, 5-2): one row per carriage pass, one
column per needle, the front bed and the back bed side by side, each cell coloured by what
the pass did there (knit, purl, tuck, miss, transfer, split, drop). Beside them the
carriers each pass used and its racking, and the hazards of knitc's simulation as red
crosses on the cell of the op that caused them.

A row is a carriage pass as `machine.estimate_passes` counts them (`pass_rows` follows the
same rules, and the tests hold the two to the same count), so the picture and the pass
count quoted in the compile summary agree. A purl is a knit of a stitch whose instruction
is P (a Knitout file has no instructions: its knits are knits on either bed).

`--compact` collapses the suspended sections (thesis Fig. 5-2b): each pass drops down to
just above the last pass that worked on its range of needles, so pieces knitted one after
the other on different needles sit side by side and time becomes local. The cells are one
image per bed (never an artist per cell), so a 100k-stitch program draws in a second.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, cast

import numpy as np

from knitc.codegen.machine import Op, pass_index
from knitc.records import record
from knitc.view import figure

if TYPE_CHECKING:
    from knitc.view.source import ViewInput

_P = 1  # INSTRUCTIONS.index("P")


def pass_rows(ops: list[Op]) -> np.ndarray:
    """Per op, the carriage pass it belongs to (0, 1, ...), -1 for ops the carriage does not
    make: `machine.pass_index`, so the rows are the passes knitc reports."""
    return np.asarray(pass_index(ops), dtype=np.int64)


@record
class Bed:
    """The grid the picture shows: `cells[bed]` (rows x needles, 0 empty, else 1 +
    index into `figure.OP_CATEGORIES`), the row of each pass, and per row its carriers
    and racking; `op_row`/`op_bed`/`op_col` place every op (-1 when it has no cell)."""

    cells: np.ndarray  # (2, rows, cols) uint8
    lo: int  # needle of column 0
    row_of_pass: np.ndarray
    carriers: list[int]  # the carriers used, in order; columns of `carrier_cells`
    carrier_cells: np.ndarray  # (rows, len(carriers)) bool
    racking: np.ndarray  # (rows,) float
    op_row: np.ndarray
    op_bed: np.ndarray
    op_col: np.ndarray
    passes: int

    @property
    def rows(self) -> int:
        return int(self.cells.shape[1])


def build(input: ViewInput, *, compact: bool = False) -> Bed:
    """The time-needle grid of `input`'s program (see `Bed`)."""
    ops = input.program.ops
    n = len(ops)
    prow = pass_rows(ops)
    instr = input.graph.instr if input.graph is not None else None
    n_instr = instr.shape[0] if instr is not None else 0
    cat = np.zeros(n, np.uint8)
    bed = np.full(n, -1, np.int64)
    needle = np.zeros(n, np.int64)
    racking_at = np.zeros(n)
    code = {c: i + 1 for i, c in enumerate(figure.OP_CATEGORIES)}
    kind_code = {
        "knit": code["knit"],
        "tuck": code["tuck"],
        "miss": code["miss"],
        "amiss": code["miss"],
        "xfer": code["transfer"],
        "split": code["split"],
        "drop": code["drop"],
    }
    carriers_of: dict[int, tuple[int, ...]] = {}
    racking: float = 0
    for i, op in enumerate(ops):
        if op.kind == "rack":
            racking = float(op.value)  # type: ignore[arg-type]
            continue
        racking_at[i] = racking
        if prow[i] < 0 or op.needle is None:
            continue
        c = kind_code.get(op.kind, 0)
        if c == code["knit"] and 0 <= op.stitch < n_instr and instr is not None:
            if instr[op.stitch] == _P:
                c = code["purl"]
        cat[i] = c
        bed[i] = 0 if op.needle.is_front else 1
        needle[i] = op.needle.index
        if op.carriers and int(prow[i]) not in carriers_of:
            carriers_of[int(prow[i])] = op.carriers
    placed = bed >= 0
    passes = int(prow.max()) + 1 if n and prow.max() >= 0 else 0
    if np.any(placed):
        lo, hi = int(needle[placed].min()), int(needle[placed].max())
    else:
        lo, hi = 0, 0
    cols = hi - lo + 1
    # the row of each pass: its number, or (compact) just above what came before on its needles
    if compact and passes:
        plo = np.full(passes, hi, np.int64)
        phi = np.full(passes, lo, np.int64)
        np.minimum.at(plo, prow[placed], needle[placed])
        np.maximum.at(phi, prow[placed], needle[placed])
        sky = np.zeros(cols, np.int64)
        row_of_pass = np.zeros(passes, np.int64)
        for p in range(passes):
            a, b = int(plo[p]) - lo, int(phi[p]) - lo + 1
            if b <= a:
                a, b = 0, cols
            r = int(sky[a:b].max())
            row_of_pass[p] = r
            sky[a:b] = r + 1
        rows = int(sky.max())
    else:
        row_of_pass = np.arange(passes, dtype=np.int64)
        rows = passes
    rows = max(rows, 1)
    cells = np.zeros((2, rows, cols), np.uint8)
    op_row = np.where(prow >= 0, row_of_pass[np.maximum(prow, 0)] if passes else 0, -1)
    op_col = np.where(placed, needle - lo, -1)
    cells[bed[placed], op_row[placed], op_col[placed]] = cat[placed]
    used = sorted({c for cs in carriers_of.values() for c in cs})
    cidx = {c: k for k, c in enumerate(used)}
    carrier_cells = np.zeros((rows, len(used)), bool)
    for p, cs in carriers_of.items():
        for c in cs:
            carrier_cells[row_of_pass[p], cidx[c]] = True
    rack_row = np.zeros(rows)
    has = prow >= 0
    rack_row[op_row[has]] = racking_at[has]
    return Bed(
        cells,
        lo,
        row_of_pass,
        used,
        carrier_cells,
        rack_row,
        op_row,
        np.where(placed, bed, -1),
        op_col,
        passes,
    )


def _hazard_cells(b: Bed, input: ViewInput) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(bed, row, col) of every hazard located at an op. An op with no cell of its own (a
    carrier op, a racking) is marked on the row of the next pass, at the left edge."""
    beds, rows, cols = [], [], []
    n = len(b.op_row)
    nxt = np.full(n + 1, -1, np.int64)
    for i in range(n - 1, -1, -1):
        nxt[i] = b.op_row[i] if b.op_row[i] >= 0 else nxt[i + 1]
    for f in input.findings:
        if not 0 <= f.op < n:
            continue
        if b.op_bed[f.op] >= 0:
            beds.append(int(b.op_bed[f.op]))
            rows.append(int(b.op_row[f.op]))
            cols.append(int(b.op_col[f.op]))
        else:
            r = int(nxt[f.op]) if nxt[f.op] >= 0 else b.rows - 1
            beds.append(0)
            rows.append(r)
            cols.append(0)
    return np.array(beds, np.int64), np.array(rows, np.int64), np.array(cols, np.int64)


def render(input: ViewInput, fmt: str, *, compact: bool = False, dpi: float = 100) -> bytes:
    """The time-needle bed of `input` as SVG or PNG bytes (see the module docstring)."""
    fig, _, _ = draw(input, compact=compact, fmt=fmt)
    return figure.save(fig, fmt, dpi=dpi)


def draw(
    input: ViewInput, *, compact: bool = False, fmt: str = "png"
) -> tuple[Any, Bed, list[Any]]:
    """The figure of the bed view, its grid, and its front and back bed axes (the tests
    find a cell's pixel through their data transform)."""
    from matplotlib.colors import ListedColormap
    from matplotlib.patches import Patch

    b = build(input, compact=compact)
    rows, cols = b.rows, b.cells.shape[2]
    width = 12.0
    height = float(np.clip(2.6 + rows / 100, 5.0, 16.0))
    fig = figure.new_figure(width, height)
    ncar = max(len(b.carriers), 1)
    gs = fig.add_gridspec(
        1,
        4,
        width_ratios=[cols, cols, max(cols * 0.04 * ncar, cols * 0.04), cols * 0.12],
        left=0.06,
        right=0.98,
        bottom=0.55 / height,
        top=1 - 0.95 / height,
        wspace=0.08,
    )
    cmap = ListedColormap(
        [figure.BACKGROUND] + [figure.OP_COLOURS[c] for c in figure.OP_CATEGORIES]
    )
    extent = (b.lo - 0.5, b.lo + cols - 0.5, -0.5, rows - 0.5)
    axes: list[Any] = []
    hz = _hazard_cells(b, input)
    for k, title in enumerate(("front bed", "back bed")):
        ax = fig.add_subplot(gs[0, k], sharey=axes[0] if axes else None)
        ax.imshow(
            b.cells[k],
            cmap=cmap,
            vmin=0,
            vmax=len(figure.OP_CATEGORIES),
            origin="lower",
            interpolation="nearest",
            aspect="auto",
            extent=extent,
        )
        ax.set_title(title)
        ax.set_xlabel("needle")
        on = hz[0] == k
        if np.any(on):
            ax.scatter(
                hz[2][on] + b.lo,
                hz[1][on],
                marker="x",
                s=36,
                linewidths=1.5,
                color=figure.HAZARD_COLOUR,
                zorder=5,
            )
        axes.append(ax)
    axes[0].set_ylabel("time (passes, compacted)" if compact else "carriage pass")
    axes[1].tick_params(labelleft=False)
    # carriers: one column per carrier, filled where a pass uses it
    axc = fig.add_subplot(gs[0, 2], sharey=axes[0])
    if b.carriers:
        img = np.ones((rows, len(b.carriers), 3))
        for k, c in enumerate(b.carriers):
            col = figure.rgb(figure.CARRIER_COLOURS[(c - 1) % len(figure.CARRIER_COLOURS)])
            img[b.carrier_cells[:, k], k] = col
        axc.imshow(
            img,
            origin="lower",
            interpolation="nearest",
            aspect="auto",
            extent=(-0.5, len(b.carriers) - 0.5, -0.5, rows - 0.5),
        )
        axc.set_xticks(range(len(b.carriers)), [str(c) for c in b.carriers])
    else:
        axc.set_xticks([])
    axc.set_title("carriers")
    axc.tick_params(labelleft=False)
    # racking: a bar per row from 0 to the racking
    axr = fig.add_subplot(gs[0, 3], sharey=axes[0])
    nz = np.nonzero(b.racking)[0]
    if nz.size:
        from matplotlib.collections import PolyCollection

        r = b.racking[nz]
        verts = np.stack(
            [
                np.column_stack([np.zeros_like(r), nz - 0.5]),
                np.column_stack([r, nz - 0.5]),
                np.column_stack([r, nz + 0.5]),
                np.column_stack([np.zeros_like(r), nz + 0.5]),
            ],
            axis=1,
        )
        axr.add_collection(PolyCollection(cast(Any, verts), facecolors="#555555", linewidths=0))
    lim = max(1.0, float(np.abs(b.racking).max(initial=0)))
    axr.set_xlim(-lim - 0.5, lim + 0.5)
    axr.set_xticks([-lim, 0, lim], [f"{-lim:g}", "0", f"{lim:g}"])
    axr.axvline(0, color="#bbbbbb", linewidth=0.5)
    axr.set_title("racking")
    axr.tick_params(labelleft=False)
    axes[0].set_ylim(-0.5, rows - 0.5)
    handles: list[Any] = [
        Patch(facecolor=figure.OP_COLOURS[c], edgecolor="#333333", linewidth=0.3, label=c)
        for c in figure.OP_CATEGORIES
    ]
    if input.findings:
        from matplotlib.lines import Line2D

        handles.append(
            Line2D(
                [],
                [],
                marker="x",
                linestyle="none",
                color=figure.HAZARD_COLOUR,
                label=figure.hazard_label(input.findings),
            )
        )
    fig.legend(
        handles=handles,
        loc="upper center",
        ncol=len(handles),
        frameon=False,
        bbox_to_anchor=(0.5, 1 - 0.3 / height),
    )
    name = input.path.rsplit("/", 1)[-1]
    fig.suptitle(
        f"{name}: time-needle bed{' (compact)' if compact else ''}, {b.passes} carriage passes, "
        f"{len(input.program.ops)} operations",
        y=1 - 0.05 / height,
    )
    return fig, b, axes
