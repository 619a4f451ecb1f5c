"""The stitch charts (`knitc view --chart`): each node's stitches as a knitter reads them.

One chart per node of the design, course up and wale across, every stitch a square in the
colour of its pattern instruction with the instruction's symbol (a dot for a purl, a V for
a tuck, a bar for a miss, a slash for a move, a cross for a cable, a box for a stack), so
lace, cables, purls and shaping lines show at a glance. The columns are the stitches'
needles within their node's layout, so a decrease takes a square off the edge where the
shaping happens instead of shifting the whole row. A tube's two faces sit side by side,
the back as seen from behind (mirrored), so a round reads left to right across both in
yarn order.

The picture is one raster, painted with numpy from one small sprite per instruction
(`cell` pixels square) and placed on the figure pixel for pixel (`figimage`), so a 100k
stitch design paints in a fraction of a second, the PNG has exactly the colours of the
table, and `Chart.pixel` says where each stitch is (the tests probe it). Hazards of the
simulation outline their stitch in red. Stitches knitted with another yarn than `main`
(stripes) are filled with that yarn's colour (`figure.yarn_colour`), their symbol kept.
A Knitout file's chart is drawn from the loops its
program makes (`view.loops`): one chart per yarn, rows by wale depth.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np

from knitc import arrays
from knitc.records import record
from knitc.shaping.stitch_graph import INSTRUCTIONS
from knitc.view import figure

if TYPE_CHECKING:
    from knitc.shaping.stitch_graph import StitchGraph
    from knitc.view.source import ViewInput

GAP = 2
"""Cells between the two faces of a tube, and between charts."""
LABEL_PX = 16
"""Pixels above each chart for its name."""
MAX_PX = 2400
"""The largest side of the painted raster: the cell size shrinks to keep within it."""
DPI = 100
LEFT_PX, RIGHT_PX, TOP_PX, BOTTOM_PX = 16, 200, 44, 16
"""Margins around the raster: the legend goes on the right, the title on top."""
MIN_HEIGHT_PX = 380
"""Room for the legend of all 17 instructions."""
MIN_WIDTH_PX = 560
"""Room for the title."""


@record
class Piece:
    """One node's chart on the canvas: its name, top-left cell and size in cells."""

    name: str
    row: int
    col: int
    rows: int
    cols: int
    faces: int


@record
class Chart:
    """Where everything is: `code[r, c]` (0 empty, else 1 + instruction + 17 * yarn) of
    the canvas, each stitch's canvas cell (`srow`, `scol`), the charts, the pixel scale,
    and the fill colour of each yarn but `main`."""

    code: np.ndarray
    srow: np.ndarray
    scol: np.ndarray
    pieces: list[Piece]
    cell: int
    yarn_fills: tuple[str, ...] = ()

    @property
    def width_px(self) -> int:
        return max(LEFT_PX + self.code.shape[1] * self.cell + RIGHT_PX, MIN_WIDTH_PX)

    @property
    def height_px(self) -> int:
        return max(TOP_PX + self.code.shape[0] * self.cell + BOTTOM_PX, MIN_HEIGHT_PX)

    def pixel(self, stitch: int, dx: int = 1, dy: int = 1) -> tuple[int, int]:
        """(x, y) of a pixel of `stitch`'s square in the PNG (y down from the top), `dx`,
        `dy` pixels in from its top-left corner (clear of the symbol by default)."""
        return (
            LEFT_PX + int(self.scol[stitch]) * self.cell + dx,
            TOP_PX + int(self.srow[stitch]) * self.cell + dy,
        )


def _rows_cols(
    g: StitchGraph, rows_by_depth: bool
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Per stitch its chart row (course within its node, or wale depth) and column (needle
    within its face, the back mirrored after the front), and per node rows, cols, faces."""
    n = g.n_stitches
    nn = len(g.node_names)
    node = g.node.astype(np.int64)
    if rows_by_depth:
        from knitc.view.shape import depth

        row = depth(g)
        base = np.full(nn, np.iinfo(np.int64).max)
        np.minimum.at(base, node, row)
        row = row - base[node]
    else:
        from knitc.patterning.query import coords

        row = coords(g).course.astype(np.int64)
    needle = g.needle.astype(np.int64)
    side = g.side.astype(np.int64)
    big = np.iinfo(np.int64).max
    lo = np.full((nn, 2), big)
    hi = np.full((nn, 2), -big)
    np.minimum.at(lo, (node, side), needle)
    np.maximum.at(hi, (node, side), needle)
    has = hi >= lo
    wide = np.where(has, hi - lo + 1, 0)
    two = np.asarray(has.all(axis=1), bool)
    col = np.empty(n, np.int64)
    front = side == 0
    # a single face (a sheet, on either bed) reads left to right; a tube's back is mirrored
    single = ~two[node]
    col[single] = needle[single] - lo[node[single], side[single]]
    f2 = ~single & front
    col[f2] = needle[f2] - lo[node[f2], 0]
    b2 = ~single & ~front
    col[b2] = wide[node[b2], 0] + GAP + (hi[node[b2], 1] - needle[b2])
    cols = np.where(two, wide[:, 0] + GAP + wide[:, 1], wide.max(axis=1))
    rows = np.zeros(nn, np.int64)
    if n:
        np.maximum.at(rows, node, row + 1)
    return row, col, rows, cols, np.where(two, 2, 1)


def build(g: StitchGraph, *, rows_by_depth: bool = False, colours: Sequence[str] = ()) -> Chart:
    """Pack the node charts into one canvas (shelves in node order, top to bottom) and
    place every stitch on it."""
    row, col, rows, cols, faces = _rows_cols(g, rows_by_depth)
    nn = len(g.node_names)
    present = [v for v in range(nn) if rows[v] > 0]
    area = sum(int(rows[v] + 2) * int(cols[v] + GAP) for v in present)
    shelf_w = max([int(cols[v]) for v in present] + [int(np.sqrt(area * 1.6)), 1])
    # the cell size: as big as fits MAX_PX (at most 12 px), at least 2
    placed: dict[int, tuple[int, int]] = {}
    cell = 12
    for _ in range(2):
        label = -(-LABEL_PX // cell)
        x = y = shelf_h = 0
        for v in present:
            w, h = int(cols[v]), int(rows[v]) + label
            if x and x + w > shelf_w:
                y += shelf_h + GAP
                x = shelf_h = 0
            placed[v] = (y + label, x)
            x += w + GAP
            shelf_h = max(shelf_h, h)
        total_h, total_w = y + shelf_h, shelf_w
        fit = max(2, min(12, MAX_PX // max(total_h, total_w, 1)))
        if fit == cell:
            break
        cell = fit
    k = len(INSTRUCTIONS)
    yarns = g.yarn if g.colourwork and g.yarn is not None else None
    wide = yarns is not None and (int(yarns.max()) + 1) * k >= 255
    code = np.zeros((max(total_h, 1), max(total_w, 1)), np.uint16 if wide else np.uint8)
    node = g.node.astype(np.int64)
    top = np.array([placed.get(v, (0, 0))[0] for v in range(nn)], np.int64)
    left = np.array([placed.get(v, (0, 0))[1] for v in range(nn)], np.int64)
    srow = top[node] + (rows[node] - 1 - row)
    scol = left[node] + col
    code[srow, scol] = g.instr.astype(code.dtype) + 1
    fills: tuple[str, ...] = ()
    if yarns is not None:
        code[srow, scol] += yarns.astype(code.dtype) * k
        fills = tuple(
            figure.yarn_colour(name, i, colours[i] if i < len(colours) else "")
            for i, name in enumerate(g.yarn_names)
            if i > 0
        )
    pieces = [
        Piece(
            g.node_names[v], placed[v][0], placed[v][1], int(rows[v]), int(cols[v]), int(faces[v])
        )
        for v in present
    ]
    return Chart(code, srow, scol, pieces, cell, fills)


def _sprites(cell: int, yarn_fills: tuple[str, ...] = ()) -> np.ndarray:
    """(1 + len(INSTRUCTIONS) * yarns, cell, cell, 3) uint8: the painted square of each
    code (0: empty). Fill colour (the instruction's, or another yarn's), a symbol in dark
    ink when the cell is big enough for one, and a one-pixel grid line on the right and
    bottom edges."""
    k = len(INSTRUCTIONS)
    out = np.empty((k * (1 + len(yarn_fills)) + 1, cell, cell, 3), np.uint8)
    out[0] = figure.rgb8(figure.BACKGROUND)
    v, u = np.mgrid[0:cell, 0:cell].astype(np.float64)
    u = (u + 0.5) / cell  # 0 left .. 1 right
    v = 1 - (v + 0.5) / cell  # 0 bottom .. 1 top
    px = 1.0 / cell
    thick = max(0.08, 0.9 * px)

    def seg(x0: float, y0: float, x1: float, y1: float) -> np.ndarray:
        dx, dy = x1 - x0, y1 - y0
        t = np.clip(((u - x0) * dx + (v - y0) * dy) / (dx * dx + dy * dy), 0, 1)
        return np.hypot(u - (x0 + t * dx), v - (y0 + t * dy)) <= thick

    a, b = 0.22, 0.78
    slash = seg(a, a, b, b)
    back = seg(a, b, b, a)
    symbols = {
        "K": np.zeros((cell, cell), bool),
        "P": np.hypot(u - 0.5, v - 0.5) <= max(0.17, 1.2 * px),
        "T": seg(a, b, 0.5, a) | seg(0.5, a, b, b),
        "M": seg(a, 0.5, b, 0.5),
        "FR1": slash,
        "FR2": seg(a, 0.35, 0.65, b) | seg(0.35, a, b, 0.65),
        "FL1": back,
        "FL2": seg(a, 0.65, 0.65, a) | seg(0.35, b, b, 0.35),
        "S": seg(a, a, b, a) | seg(b, a, b, b) | seg(b, b, a, b) | seg(a, b, a, a),
    }
    symbols["BR1"], symbols["BR2"] = symbols["FR1"], symbols["FR2"]
    symbols["BL1"], symbols["BL2"] = symbols["FL1"], symbols["FL2"]
    for name in ("XR+", "XR-", "XL+", "XL-"):
        symbols[name] = slash | back
    ink = np.array([40, 40, 40], np.uint8)
    grid = np.array([190, 190, 190], np.uint8)
    for y, fill in enumerate((None, *yarn_fills)):
        for i, name in enumerate(INSTRUCTIONS):
            sq = out[1 + i + k * y]
            sq[:] = figure.rgb8(fill or figure.INSTR_COLOURS[name])
            if cell >= 6:
                sq[symbols[name]] = ink
            if cell >= 4:
                sq[:, -1] = grid
                sq[-1, :] = grid
    return out


def paint(ch: Chart, hazards: np.ndarray) -> np.ndarray:
    """The canvas as an RGB raster (rows down), hazard stitches outlined in red."""
    s = ch.cell
    sprites = _sprites(s, ch.yarn_fills)
    h, w = ch.code.shape
    img = sprites[ch.code].transpose(0, 2, 1, 3, 4).reshape(h * s, w * s, 3)
    if hazards.size:
        red = figure.rgb8(figure.HAZARD_COLOUR)
        t = max(1, s // 5)
        for r, c in zip(ch.srow[hazards], ch.scol[hazards]):
            y0, x0 = int(r) * s, int(c) * s
            # a ring one cell out, so the stitch itself stays readable
            ya, yb = max(0, y0 - s // 2), min(h * s, y0 + s + s // 2)
            xa, xb = max(0, x0 - s // 2), min(w * s, x0 + s + s // 2)
            img[ya : ya + t, xa:xb] = red
            img[yb - t : yb, xa:xb] = red
            img[ya:yb, xa : xa + t] = red
            img[ya:yb, xb - t : xb] = red
    return img


def graph_of(input: ViewInput) -> tuple[StitchGraph, np.ndarray, bool]:
    """The graph a chart or shape is drawn from: the design's, or for Knitout the loops its
    program makes; with the stitch of each hazard and whether it is a loop graph."""
    if input.graph is not None:
        st = np.array([f.stitch for f in input.findings if f.stitch >= 0], np.int64)
        st = st[st < input.graph.n_stitches]
        return input.graph, st, False
    from knitc.view.loops import loop_graph

    lg = loop_graph(input.program)
    ops = np.array([f.op for f in input.findings if 0 <= f.op < len(lg.op_loop)], np.int64)
    st = lg.op_loop[ops] if ops.size else np.zeros(0, np.int64)
    return lg.graph, st[st >= 0], True


def render(input: ViewInput, fmt: str) -> bytes:
    """The stitch charts of `input` as SVG or PNG bytes (see the module docstring)."""
    from matplotlib.patches import Patch

    g, hz, loops = graph_of(input)
    skel = input.result.skeleton if input.result is not None and not loops else None
    colours = [y.colour for y in skel.yarn_list] if skel is not None else []
    ch = build(g, rows_by_depth=loops, colours=colours)
    img = paint(ch, hz)
    fig = figure.new_figure(ch.width_px / DPI, ch.height_px / DPI)
    W, H = ch.width_px, ch.height_px
    for p in ch.pieces:
        label = p.name + ("  (front | back)" if p.faces == 2 else "")
        fig.text(
            (LEFT_PX + p.col * ch.cell) / W,
            1 - (TOP_PX + p.row * ch.cell - 3) / H,
            label,
            ha="left",
            va="bottom",
            fontsize=8,
        )
    present = sorted({int(i) for i in arrays.unique(g.instr)}) if g.n_stitches else []
    handles = [
        Patch(
            facecolor=figure.INSTR_COLOURS[INSTRUCTIONS[i]],
            edgecolor="#666666",
            linewidth=0.5,
            label=f"{INSTRUCTIONS[i]}  {figure.INSTR_NAMES[INSTRUCTIONS[i]]}",
        )
        for i in present
    ]
    if ch.yarn_fills:
        used = set(arrays.unique(g.yarn).tolist()) if g.yarn is not None else set()
        handles += [
            Patch(facecolor=fill, edgecolor="#666666", linewidth=0.5, label=f"yarn {name}")
            for y, (name, fill) in enumerate(zip(g.yarn_names[1:], ch.yarn_fills), 1)
            if y in used
        ]
    if hz.size:
        handles.append(
            Patch(
                facecolor="none",
                edgecolor=figure.HAZARD_COLOUR,
                linewidth=1.5,
                label=figure.hazard_label(input.findings),
            )
        )
    fig.legend(
        handles=handles,
        loc="upper right",
        bbox_to_anchor=(1 - 8 / W, 1 - TOP_PX / H),
        frameon=False,
        title="instructions, yarns" if ch.yarn_fills else "instructions",
    )
    name = input.path.rsplit("/", 1)[-1]
    k = len(ch.pieces)
    what = ("yarn" if loops else "node") + ("" if k == 1 else "s")
    fig.suptitle(
        f"{name}: stitch charts of {k} {what}"
        f"{' (the loops its program makes)' if loops else ''}, {g.n_stitches} stitches",
        y=1 - 6 / H,
        va="top",
    )
    return figure.save_raster(fig, img, LEFT_PX, TOP_PX, fmt, dpi=DPI)
