"""Rasters on stitches: charts, images and noise placed over a selection (thesis ch. 5.3.3).

A *raster* is a small 2-D array of cell values written like a knitting chart: row 0 is the
top row as written, the last row is the first course, column 0 is the left wale. A value
of -1 is a transparent cell (`.` in a chart, an "off" pixel of an image): it selects or
writes nothing. Drawn layers store instruction indices in the cells, drawn queries store 0
for "on".

A raster is placed over a *frame*: per stitch a (row, col) coordinate, counted upwards from
the first course and rightwards from the left wale, plus a group (the node) that bounding
boxes are taken over. Three placements, the original's three kinds of drawing:

- `tile`: cell = (row - origin) mod size. The origin is the selection's lower-left corner,
  or the grid's own (0, 0) for wale and stitch grids, whose coordinates already start at
  their seed;
- `stretch`: nearest-neighbour scaling of the raster onto the selection's bounding box
  (floor sampling, so each cell covers an equal share of the box, up to one stitch);
- `draw` (singular): the raster once, centred in the selection; on plain course/wale
  coordinates each course is centred on its own selected wales (as the original's "adapt"
  mode), so a motif on a piece that narrows evenly keeps its axis instead of shearing;
  cells that fall outside the selection are skipped.

Everything is vectorised over the selected stitches; nothing loops per stitch. Images are
read with Pillow, imported only when an image is used. The 2-D simplex noise is the usual
skewed-triangle-grid construction written out in numpy, with a permutation table drawn
from the seed by a fixed integer hash so a seed means the same noise on every platform and
numpy version.
"""

from __future__ import annotations

import io
import math
import os
import warnings
from collections.abc import Collection

import numpy as np

from knitc import arrays
from knitc.access import MAX_IMAGE_BYTES, AccessProblem, active_roots, check_within, read_regular
from knitc.frontend import ast
from knitc.records import record
from knitc.shaping.stitch_graph import INSTRUCTIONS

OFF = -1
OFF_CELLS = (".", "0")
"""Cells of a chart that select or write nothing."""


@record(frozen=True)
class Placement:
    """Where a raster is placed: per-stitch frame coordinates of the stitches in `mask`."""

    mask: np.ndarray  # bool: the stitches the raster may land on
    row: np.ndarray  # int64: upwards
    col: np.ndarray  # int64: rightwards
    group: np.ndarray  # int64: bounding boxes and corners are per group (node)
    row_key: np.ndarray | None = None
    """Per-stitch key of the stitch's row (its course id) when rows are centred one by one
    (`draw` on course/wale coordinates); None centres in the group's bounding box."""
    anchored: bool = False
    """True: the coordinates have their own origin (a grid's seed), `tile` starts there;
    False: `tile` starts at the selection's lower-left corner."""


# ---- charts --------------------------------------------------------------------------------

MNEMONICS = INSTRUCTIONS
"""The 17 instruction mnemonics a drawn grid may hold (and `.`: leave the stitch)."""
CROSS_MNEMONICS = ("XR+", "XR-", "XL+", "XL-")


def cell_problems(
    grid: ast.Grid, mode: str, yarns: Collection[str] = ()
) -> list[tuple[str, ast.GridCell]]:
    """("unknown", cell) for cells that are neither instructions nor `yarns` (a colour
    chart's cells name the design's yarns), and ("cross", cell) for the first cross of a
    `stretch`ed grid (scaling would tear cable pairs apart). Shared by the resolver (grids
    written in place) and the drawing pass (grids bound by `let`), which report them under
    their own codes."""
    out: list[tuple[str, ast.GridCell]] = []
    crossed = False
    for row in grid.rows:
        for cell in row:
            if cell.text == ".":
                continue
            if cell.text not in MNEMONICS and cell.text not in yarns:
                out.append(("unknown", cell))
            elif mode == "stretch" and cell.text in CROSS_MNEMONICS and not crossed:
                crossed = True
                out.append(("cross", cell))
    return out


def chart_shape_problems(grid: ast.Grid) -> list[tuple[ast.Node, str]]:
    """Rows of a different length than the first one, or an empty grid (with a message)."""
    if not grid.rows or not any(grid.rows):
        return [(grid, "the grid has no cells")]
    width = len(grid.rows[0])
    out: list[tuple[ast.Node, str]] = []
    for row in grid.rows[1:]:
        if len(row) != width:
            at = row[0] if row else grid
            out.append((at, f"this row has {len(row)} cell(s), the first row has {width}"))
    return out


def chart_values(grid: ast.Grid, value_of) -> np.ndarray:
    """The grid's cells mapped by `value_of(text) -> int` (OFF cells: -1), top row first.
    The grid must be rectangular (see `chart_shape_problems`)."""
    return np.array(
        [[OFF if c.text in OFF_CELLS else value_of(c.text) for c in row] for row in grid.rows],
        dtype=np.int64,
    ).reshape(len(grid.rows), -1)


# ---- images --------------------------------------------------------------------------------

CHANNELS = ("r", "g", "b", "a", "l", "k")
"""Red, green, blue, alpha (opacity), luminance, and k = darkness (1 - luminance, over
white): with `k` the dark strokes of a drawing are "on", on a transparent or white
background alike."""

MAX_PIXELS = 4096 * 4096


class ImageProblem(Exception):
    """An image that cannot be used; the message says why (for a located diagnostic):
    `code` E713 (unreadable) or E226 (outside the folders the design may read)."""

    def __init__(self, message: str, code: str = "E713", hint: str | None = None):
        super().__init__(message)
        self.code, self.hint = code, hint


def _image_bytes(path: str) -> bytes:
    """The file at `path` under the running compilation's access rules (see `access`)."""
    roots = active_roots()
    try:
        real = check_within(path, path, roots, "images") if roots is not None else path
        if not os.path.exists(real):
            raise ImageProblem(f"no image file `{path}`")
        return read_regular(real, path, MAX_IMAGE_BYTES)
    except AccessProblem as problem:
        code = "E226" if problem.refused else "E713"
        raise ImageProblem(problem.message, code, problem.hint) from None


IMAGE_FORMATS = ("PNG", "JPEG", "GIF", "BMP")
"""The formats `img()` decodes. Pillow would also open EPS (by running Ghostscript, an
interpreter of PostScript programs) and dozens of rarer formats; a design is untrusted,
so only these plain raster formats are parsed."""


def image_channel(path: str, channel: str) -> np.ndarray:
    """The channel of the image at `path` as floats in [0, 1], top row first (`image_rgba`
    says what is read and refused)."""
    rgba = image_rgba(path)
    if channel in "rgba":
        return rgba[:, :, "rgba".index(channel)]
    alpha = rgba[:, :, 3]
    over_white = rgba[:, :, :3] * alpha[:, :, None] + (1.0 - alpha[:, :, None])
    lum = over_white @ np.array([0.299, 0.587, 0.114])
    return lum if channel == "l" else 1.0 - lum


def image_rgba(path: str) -> np.ndarray:
    """The image at `path` as (rows, columns, 4) floats in [0, 1], top row first.

    During a compilation the path must lie below its folders (`access.ReadRoots`); only a
    regular file of at most `access.MAX_IMAGE_BYTES` is read (a FIFO never blocks, a device
    is never read), and an image of more than `MAX_PIXELS` is refused from its header,
    before its pixels are decoded (a small file can hold a decompression bomb)."""
    try:
        from PIL import Image, UnidentifiedImageError
    except ImportError as err:  # pragma: no cover - Pillow is a dependency
        raise ImageProblem("reading images needs Pillow (pip install Pillow)") from err
    data = _image_bytes(path)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("error", Image.DecompressionBombWarning)
            with Image.open(io.BytesIO(data), formats=IMAGE_FORMATS) as im:
                if im.width * im.height > MAX_PIXELS:
                    raise ImageProblem(
                        f"the image is {im.width}x{im.height} pixels; a pattern "
                        f"image may have at most {MAX_PIXELS} pixels"
                    )
                rgba = np.asarray(im.convert("RGBA"), dtype=np.float64) / 255.0
    except UnidentifiedImageError as err:
        raise ImageProblem(
            f"`{path}` is not an image knitc reads (use PNG, JPEG, GIF or BMP)"
        ) from err
    except (Image.DecompressionBombError, Image.DecompressionBombWarning) as err:
        raise ImageProblem(
            f"`{path}` is too large an image; a pattern image may have at most {MAX_PIXELS} pixels"
        ) from err
    except (OSError, ValueError, EOFError, SyntaxError) as err:  # Pillow's decoders raise these
        raise ImageProblem(f"cannot read `{path}`: {err}") from err
    return rgba


def nearest_colours(rgba: np.ndarray, colours: list[tuple[int, str]]) -> np.ndarray:
    """Per pixel, the first item of the `colours` pair ("#rrggbb") nearest to it in RGB
    (-1 where the pixel is mostly transparent): a colour image as a chart of yarns."""
    table = np.array(
        [[int(c[i : i + 2], 16) / 255.0 for i in (1, 3, 5)] for _, c in colours], np.float64
    )
    d = ((rgba[:, :, None, :3] - table[None, None, :, :]) ** 2).sum(axis=3)
    ids = np.array([k for k, _ in colours], np.int64)[np.argmin(d, axis=2)]
    return np.where(rgba[:, :, 3] >= 0.5, ids, OFF).astype(np.int64)


# ---- noise ---------------------------------------------------------------------------------

_GRAD = np.array(
    [
        (1, 1),
        (-1, 1),
        (1, -1),
        (-1, -1),
        (1, 0),
        (-1, 0),
        (1, 0),
        (-1, 0),
        (0, 1),
        (0, -1),
        (0, 1),
        (0, -1),
    ],
    dtype=np.float64,
)
_F2 = 0.5 * (math.sqrt(3.0) - 1.0)
_G2 = (3.0 - math.sqrt(3.0)) / 6.0
_MASK64 = (1 << 64) - 1


def permutation(seed: int) -> np.ndarray:
    """A shuffle of 0..255 (doubled to 512 entries) fixed by `seed`: Fisher-Yates driven
    by splitmix64, so it does not depend on numpy's generators."""
    state = seed & _MASK64
    perm = list(range(256))
    for i in range(255, 0, -1):
        state = (state + 0x9E3779B97F4A7C15) & _MASK64
        z = state
        z = ((z ^ (z >> 30)) * 0xBF58476D1CE4E5B9) & _MASK64
        z = ((z ^ (z >> 27)) * 0x94D049BB133111EB) & _MASK64
        z ^= z >> 31
        j = z % (i + 1)
        perm[i], perm[j] = perm[j], perm[i]
    return np.array(perm + perm, dtype=np.int64)


def simplex2(x: np.ndarray, y: np.ndarray, perm: np.ndarray) -> np.ndarray:
    """2-D simplex noise in about [-1, 1] at the points (x, y)."""
    x = np.asarray(x, dtype=np.float64)
    y = np.asarray(y, dtype=np.float64)
    s = (x + y) * _F2
    i = np.floor(x + s)
    j = np.floor(y + s)
    t = (i + j) * _G2
    x0 = x - (i - t)
    y0 = y - (j - t)
    i1 = (x0 > y0).astype(np.int64)  # lower or upper triangle of the skewed cell
    j1 = 1 - i1
    corners = (
        (x0, y0, 0, 0),
        (x0 - i1 + _G2, y0 - j1 + _G2, i1, j1),
        (x0 - 1.0 + 2.0 * _G2, y0 - 1.0 + 2.0 * _G2, 1, 1),
    )
    ii = i.astype(np.int64) & 255
    jj = j.astype(np.int64) & 255
    total = np.zeros_like(x)
    for cx, cy, di, dj in corners:
        gi = perm[ii + di + perm[jj + dj]] % 12
        falloff = np.maximum(0.5 - cx * cx - cy * cy, 0.0)
        total += falloff**4 * (_GRAD[gi, 0] * cx + _GRAD[gi, 1] * cy)
    return 70.0 * total


# ---- placement -----------------------------------------------------------------------------


def extent(key: np.ndarray, vals: np.ndarray, mask: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per stitch, the min and max of `vals` over the masked stitches with the same key
    (meaningful on masked stitches only)."""
    lo = np.zeros(vals.shape[0], dtype=np.int64)
    hi = np.zeros(vals.shape[0], dtype=np.int64)
    if not mask.any():
        return lo, hi
    k = key[mask]
    v = vals[mask]
    uk, inv = np.unique(k, return_inverse=True)
    inv = inv.ravel()
    glo = np.full(uk.shape[0], np.iinfo(np.int64).max, dtype=np.int64)
    ghi = np.full(uk.shape[0], np.iinfo(np.int64).min, dtype=np.int64)
    np.minimum.at(glo, inv, v)
    np.maximum.at(ghi, inv, v)
    lo[mask] = glo[inv]
    hi[mask] = ghi[inv]
    return lo, hi


def origin(p: Placement) -> tuple[np.ndarray, np.ndarray]:
    """Per-stitch (row, col) origin of `tile` and `noise` on placement `p`."""
    if p.anchored:
        z = np.zeros(p.row.shape[0], dtype=np.int64)
        return z, z
    r0, _ = extent(p.group, p.row, p.mask)
    c0, _ = extent(p.group, p.col, p.mask)
    return r0, c0


def place(values: np.ndarray, p: Placement, mode: str) -> np.ndarray:
    """Per stitch, the raster cell value that lands on it (-1: none or transparent)."""
    n = p.mask.shape[0]
    out = np.full(n, OFF, dtype=np.int64)
    rows, cols = values.shape
    if rows == 0 or cols == 0 or not p.mask.any():
        return out
    m = p.mask
    r, c = p.row, p.col
    if mode == "tile":
        r0, c0 = origin(p)
        i = np.mod(r - r0, rows)
        j = np.mod(c - c0, cols)
    elif mode == "stretch":
        rlo, rhi = extent(p.group, r, m)
        clo, chi = extent(p.group, c, m)
        i = ((r - rlo) * rows) // np.maximum(rhi - rlo + 1, 1)
        j = ((c - clo) * cols) // np.maximum(chi - clo + 1, 1)
    elif mode == "draw":
        rlo, rhi = extent(p.group, r, m)
        key = p.group if p.row_key is None else p.row_key
        clo, chi = extent(key, c, m)
        i = (r - rlo) - (rhi - rlo + 1 - rows) // 2
        j = (c - clo) - (chi - clo + 1 - cols) // 2
    else:
        raise ValueError(mode)
    inside = m & (i >= 0) & (i < rows) & (j >= 0) & (j < cols)
    ids = np.nonzero(inside)[0]
    out[ids] = values[rows - 1 - i[ids], j[ids]]
    return out


def overflow(values: np.ndarray, p: Placement) -> bool:
    """Whether a singular drawing is larger than its selection in some group (rows beyond
    the selected courses, or columns beyond its widest course)."""
    if not p.mask.any():
        return False
    rlo, rhi = extent(p.group, p.row, p.mask)
    key = p.group if p.row_key is None else p.row_key
    clo, chi = extent(key, p.col, p.mask)
    m = p.mask
    too_tall = np.any((rhi - rlo + 1)[m] < values.shape[0])
    widest = np.zeros(int(p.group.max(initial=0)) + 1, dtype=np.int64)
    np.maximum.at(widest, p.group[m], (chi - clo + 1)[m])
    too_wide = np.any(widest[arrays.unique(p.group[m])] < values.shape[1])
    return bool(too_tall or too_wide)
