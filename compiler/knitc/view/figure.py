"""What the static views share: a matplotlib figure on the Agg backend, saved as
deterministic SVG or PNG bytes, and the colours of instructions, operations and hazards.

matplotlib is imported here, only when a view is drawn, so `knitc --version` and every
compile stay free of it. Agg needs no display. SVG output is made reproducible (the ids
matplotlib hashes get a fixed salt, and no date is written), so a picture in the tests or
the repository only changes when what it shows changes.
"""

from __future__ import annotations

import io
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from matplotlib.figure import Figure

INSTR_COLOURS = {
    "K": "#f2f2ee",
    "P": "#e0872b",
    "T": "#4a9c4e",
    "M": "#9a9a9a",
    "FR1": "#6a8fd6",
    "FR2": "#2f5cb8",
    "FL1": "#6a8fd6",
    "FL2": "#2f5cb8",
    "BR1": "#a57fd0",
    "BR2": "#7440b0",
    "BL1": "#a57fd0",
    "BL2": "#7440b0",
    "XR+": "#c94a8a",
    "XR-": "#e58fba",
    "XL+": "#c94a8a",
    "XL-": "#e58fba",
    "S": "#c9b458",
}
"""The chart colour of each pattern instruction: plain knit pale, purls orange, tucks
green, misses grey, front moves blue, back moves purple, cables pink, stacks ochre (left
and right moves share a colour; their symbols tell them apart)."""

INSTR_NAMES = {
    "K": "knit",
    "P": "purl",
    "T": "tuck",
    "M": "miss",
    "FR1": "move right 1",
    "FR2": "move right 2",
    "FL1": "move left 1",
    "FL2": "move left 2",
    "BR1": "back move right 1",
    "BR2": "back move right 2",
    "BL1": "back move left 1",
    "BL2": "back move left 2",
    "XR+": "cross right, over",
    "XR-": "cross right, under",
    "XL+": "cross left, over",
    "XL-": "cross left, under",
    "S": "stack",
}

OP_CATEGORIES = ("knit", "purl", "tuck", "miss", "transfer", "split", "drop")
"""What a cell of the time-needle bed shows; index + 1 is its code in the bed grid."""
OP_COLOURS = {
    "knit": "#4c72b0",
    "purl": "#e0872b",
    "tuck": "#4a9c4e",
    "miss": "#c8c8c8",
    "transfer": "#8c5cc4",
    "split": "#e377c2",
    "drop": "#6b4a2b",
}
HAZARD_COLOUR = "#e00000"
ERROR_COLOUR = "#e00000"
WARNING_COLOUR = "#ff9900"
BACKGROUND = "#ffffff"

NODE_COLOURS = (
    "#4c72b0",
    "#dd8452",
    "#55a868",
    "#c44e52",
    "#8172b3",
    "#937860",
    "#da8bc3",
    "#8c8c8c",
    "#ccb974",
    "#64b5cd",
    "#1f77b4",
    "#ff7f0e",
    "#2ca02c",
    "#9467bd",
    "#8c564b",
    "#17becf",
    "#bcbd22",
    "#7f7f7f",
)
"""Piece colours of the shape view, by node index (cycled)."""

CARRIER_COLOURS = NODE_COLOURS


YARN_PALETTE = ("#c0392b", "#2e86c1", "#d4ac0d", "#7d3c98", "#17a589", "#ca6f1e", "#5d6d7e")
"""Colours of the design's other yarns whose names are not colours (`yarn_colour`)."""


def yarn_colour(name: str, k: int, declared: str = "") -> str:
    """'#rrggbb' of the design's yarn `name`, its k-th (k > 0; `main` is drawn in the
    instruction colours): its declared `colour` if it has one, else a yarn named for a
    colour (`yarn red`, `yarn coral`) is drawn in it, any other in the palette's k-th."""
    from matplotlib.colors import is_color_like, to_hex

    if declared:
        return declared.lower()
    if name.isalpha() and is_color_like(name):
        return str(to_hex(name))
    return YARN_PALETTE[(k - 1) % len(YARN_PALETTE)]


def rgb(colour: str) -> tuple[float, float, float]:
    """'#rrggbb' as floats in 0..1."""
    c = colour.lstrip("#")
    return (int(c[0:2], 16) / 255, int(c[2:4], 16) / 255, int(c[4:6], 16) / 255)


def rgb8(colour: str) -> tuple[int, int, int]:
    """'#rrggbb' as bytes, what a PNG pixel of that colour holds."""
    c = colour.lstrip("#")
    return (int(c[0:2], 16), int(c[2:4], 16), int(c[4:6], 16))


def new_figure(width: float, height: float) -> Figure:
    """A figure of `width` x `height` inches on the Agg canvas (no pyplot, no display: the
    figure is not registered anywhere, so nothing leaks between renders)."""
    import matplotlib

    matplotlib.rcParams["svg.hashsalt"] = "knitc"
    matplotlib.rcParams["svg.fonttype"] = "none"
    matplotlib.rcParams["font.size"] = 8
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(width, height), facecolor=BACKGROUND)
    FigureCanvasAgg(fig)
    return fig


def save(fig: Figure, fmt: str, *, dpi: float = 100) -> bytes:
    """`fig` as SVG or PNG bytes; the SVG carries no date and fixed ids."""
    buf = io.BytesIO()
    meta: dict[str, Any]
    if fmt == "svg":
        meta = {"Date": None}
    elif fmt == "png":
        meta = {}
    else:
        raise ValueError(fmt)
    fig.savefig(buf, format=fmt, dpi=dpi, metadata=meta, facecolor=BACKGROUND)
    return buf.getvalue()


def save_raster(fig: Figure, img: Any, left: int, top: int, fmt: str, *, dpi: float) -> bytes:
    """`fig` with the RGB raster `img` placed pixel for pixel at (`left`, `top`) pixels
    from its top-left corner. A PNG is the figure drawn by Agg with the raster pasted into
    its buffer (its background pixels let the figure's text show) and encoded by Pillow: matplotlib would resample it through float copies
    (half a gigabyte for a 100k-stitch chart) to put it exactly where it already is."""
    import numpy as np

    if fmt != "png":
        h = int(round(fig.get_figheight() * dpi))
        fig.figimage(img, xo=left, yo=h - top - img.shape[0], origin="upper")
        return save(fig, fmt, dpi=dpi)
    from PIL import Image

    fig.set_dpi(dpi)
    fig.canvas.draw()
    buf = np.array(fig.canvas.buffer_rgba())[..., :3]  # type: ignore[attr-defined]
    h, w = img.shape[:2]
    img = img[: buf.shape[0] - top, : buf.shape[1] - left]
    region = buf[top : top + h, left : left + w]
    ink = (img != np.array(rgb8(BACKGROUND), np.uint8)).any(axis=2)  # labels show through
    region[ink] = img[ink]
    out = io.BytesIO()
    Image.fromarray(buf).save(out, format="png", optimize=False)
    return out.getvalue()


def hazard_label(findings: list[Any]) -> str:
    """The legend entry of the hazard markers: how many, and their codes."""
    codes = sorted({f.code for f in findings})
    shown = ", ".join(codes[:4]) + (", ..." if len(codes) > 4 else "")
    return f"hazard ({len(findings)}: {shown})"
