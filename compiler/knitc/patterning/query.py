"""Pattern queries (thesis ch. 5.3.2, Table 5.1): `where Q` evaluated to a stitch mask.

A query selects stitches of the stitch graph; the patterning pass then writes instructions
or actions on them. Everything here is vectorised: a query is a boolean mask over *all*
stitches, combined with numpy set algebra, so a million-stitch garment costs a few array
passes per query and never a Python loop per stitch (BFS rings of `neighbors` loop per
ring, not per stitch).

Coordinates (always per node, also for the global `before`/`after` layers):
- `course` = course index within the stitch's node (0 = the node's first course, in
  knitting order); `course_end` = the node's last course index.
- `wale` = position across the course, counted so that `wales(0:3)` means "the first four
  wales" on both kinds of course: on a flat course it is the rank of the stitch's needle
  (left to right on the bed, whichever way the yarn travels that course); on a tubular
  course it is the yarn-order position, i.e. front bed left to right, then back bed right
  to left (counter-clockwise seen from above, the stitch graph's convention).
  `wale_end` = the course length - 1, *per course*, so fractions and `end` follow shaping.
- sided wales (`wales(R, side)`, `select(Rc, Rw, side)`): the needle rank of the stitch
  among the stitches of its course on that side, left to right; the range applies to that
  side's own extent. This is what makes `wales(0:3, back)` mean the back bed's four
  leftmost wales on a tube instead of an empty set.

Ranges (inclusive): a bound `v` that mentions `end` is absolute (`end - 1`); otherwise
`v <= -1` counts from the end (`-1` = end, `-3` = end - 2), `0 < v < 1` is the fraction
`v * end`, `-1 < v < 0` the fraction counted from the end (`-0.25` = `0.75 * end`) and
anything else is an absolute index. A fractional start rounds up and a
fractional stop rounds down (so `0:0.5` and `0.5:end` share only a stitch that falls
exactly on the middle, as inclusive ranges must); a lone
number (`courses(2)`) is the single index `round_half_up(v)`. `a:s:b` keeps every s-th
index from the start; s must be a positive integer. A start after the stop selects nothing.

Drawn queries (`stretch`, `tile`, `img`, `noise`) place a raster (`patterning.raster`) over a
*frame*: the stitches of a selection with a (row, col) coordinate each. The frame is the
query's last argument or the selection it is chained on (`Q.tile(g)` = `tile(g, Q)`), else
the layer's stitches; its coordinates are course and wale, or a grid's
(`wale_grid`, `stitch_grid`, `patterning.grids`) when the frame is one. A frame built with `and`
or `-` keeps the coordinates of its grid operand, so `wale_grid() and side(front)` is a
grid clipped to the front. `evaluate_frame` gives drawn layers the same frames.

Errors (a wrong query must not crash the compiler) become E7xx diagnostics and the whole
query selects nothing: E701 unknown query or not a query, E702 bad range, E703 bad
argument, E704 unknown name, E705 unknown node in `shape(name)`, E710 not a grid, E713 an
image that cannot be read, E714 a bad image channel or threshold, E715 a bad grid size or
alignment, E716 a grid that is not rectangular, E717 a bad noise argument; a mistake in
the numbers of a `filter` is E305, as anywhere else (`knitc.lang.arith`).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from dataclasses import field
from pathlib import Path
from typing import Any

import numpy as np

from knitc.diagnostics import Diagnostics
from knitc.frontend import ast
from knitc.lang import arith
from knitc.lang.evaluate import show
from knitc.patterning import grids, raster
from knitc.patterning.raster import Placement
from knitc.records import record
from knitc.shaping.stitch_graph import StitchGraph
from knitc.source import Span

DRAWN = ("stretch", "tile", "img", "noise")
"""Queries that place a raster or noise over a frame."""
GRIDS = ("wale_grid", "stitch_grid")
"""Queries that build grid coordinates (a frame) from seed stitches."""
SUPPORTED = (
    (
        "all",
        "filter",
        "wales",
        "courses",
        "select",
        "side",
        "neighbors",
        "boundaries",
        "named",
        "shape",
        "itf",
        "inverse",
    )
    + DRAWN
    + GRIDS
)
"""Every query function of thesis Table 5.1 and ch. 6.9.1 that knitc has."""
MIN_NOISE_SCALE = 1e-6
"""Smallest noise scale: a frame's coordinates divided by it stay far below 2^53, where
floats stop holding whole numbers and the noise would no longer be the same on every
machine (a scale of 1e-320 made them infinite)."""
X_ALIGN = {"left": "left", "center": "center", "centre": "center", "right": "right"}
Y_ALIGN = {
    "bottom": "bottom",
    "middle": "middle",
    "center": "middle",
    "centre": "middle",
    "top": "top",
}


@record(frozen=True, eq=False)
class LetDef:
    """A `let`'s selection with what the `let` names it mentions meant where it was written
    (`bind_let`). Looking those names up where the selection is used instead made
    `let s = s or wales(0)` refer to itself (a RecursionError); and a query evaluates each
    `LetDef` once, so `let s2 = s1 or s1` forty times is forty evaluations, not 2^40."""

    node: ast.Node
    refs: Mapping[str, np.ndarray | ast.Node | LetDef]


def bind_let(
    node: ast.Node, lets: Mapping[str, np.ndarray | ast.Node | LetDef]
) -> ast.Node | LetDef:
    """The value `let NAME = node` binds, given the block's `lets` so far: a grid as it is
    (it names nothing), a selection as a `LetDef` holding the bindings it refers to."""
    if isinstance(node, ast.Grid):
        return node
    named = {n.id for n in node.walk() if isinstance(n, ast.Name)} & lets.keys()
    return LetDef(node, {k: lets[k] for k in named})


MAX_NESTING = 200
"""Levels of selections inside selections a query may nest, counting those of the `let`s
it names (E708): a single expression nests at most 100 (E111), but a chain of `let`s each
naming the one before could nest without end, and evaluation recurses once per level."""


@record
class QueryEnv:
    """What a query may refer to besides the graph: `#params` and `let`-bound selections.

    A `let` value is an already evaluated mask, the query AST it names (evaluated lazily on
    the same node, with the current `lets`), or a `LetDef` (`bind_let`: evaluated lazily,
    once per query, with the `let`s it named where it was written).
    """

    params: Mapping[str, object] = field(default_factory=dict)
    lets: Mapping[str, np.ndarray | ast.Node | LetDef] = field(default_factory=dict)
    values: Mapping[str, object] = field(default_factory=dict)
    """Bare names with a value: the arguments of the pattern definition being applied."""


class QueryError(Exception):
    def __init__(self, code: str, message: str, span: Span | None, hint: str | None = None):
        super().__init__(message)
        self.code, self.message, self.span, self.hint = code, message, span, hint


@record(frozen=True)
class Coords:
    """Per-stitch query coordinates of a graph (see the module docstring)."""

    course: np.ndarray
    course_end: np.ndarray
    wale: np.ndarray
    wale_end: np.ndarray
    swale: np.ndarray  # wale within (course, side), left to right
    swale_end: np.ndarray
    edge: np.ndarray  # bool: first/last course of its node, or an end of a flat course


def _group_rank(keys: tuple[np.ndarray, ...], group: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Rank of each element within its group (ordered by `keys`), and the group size."""
    n = group.shape[0]
    order = np.lexsort(keys + (group,))
    g_sorted = group[order]
    starts = np.ones(n, dtype=bool)
    starts[1:] = g_sorted[1:] != g_sorted[:-1]
    first = np.maximum.accumulate(np.where(starts, np.arange(n), 0))
    rank = np.empty(n, dtype=np.int64)
    rank[order] = np.arange(n) - first
    sizes = np.zeros(n, dtype=np.int64)
    _, inv, counts = np.unique(group, return_inverse=True, return_counts=True)
    sizes[:] = counts[inv.ravel()]
    return rank, sizes


def relative(g: StitchGraph, c: Coords, sel: np.ndarray) -> Coords:
    """`c` counted from a selection: courses from its first course in each node, wales from
    its first wale in each course (and the ends to its last), so that a pattern applied to
    part of a piece starts its repeat at that part's corner, not at the piece's. Stitches
    outside the selection keep their coordinates (queries inside it never see them)."""
    clo, chi = raster.extent(g.node.astype(np.int64), c.course, sel)
    wlo, whi = raster.extent(g.course.astype(np.int64), c.wale, sel)
    return dataclasses.replace(
        c,
        course=np.where(sel, c.course - clo, c.course),
        course_end=np.where(sel, chi - clo, c.course_end),
        wale=np.where(sel, c.wale - wlo, c.wale),
        wale_end=np.where(sel, whi - wlo, c.wale_end),
    )


def coords(g: StitchGraph) -> Coords:
    """Compute the per-node course/wale coordinates of every stitch (vectorised)."""
    n = g.n_stitches
    if n == 0:
        z = np.zeros(0, dtype=np.int64)
        return Coords(z, z, z, z, z, z, np.zeros(0, dtype=bool))
    cids = np.arange(g.n_courses)
    crank, csize = _group_rank((cids,), g.course_node.astype(np.int64))
    course = crank[g.course]
    course_end = (csize - 1)[g.course]
    pos = np.arange(n) - g.course_start[g.course]
    circ = g.course_circular[g.course]
    nrank, _ = _group_rank((np.arange(n), g.needle.astype(np.int64)), g.course.astype(np.int64))
    wale = np.where(circ, pos, nrank)
    wale_end = (g.course_len[g.course] - 1).astype(np.int64)
    key = g.course.astype(np.int64) * 2 + g.side.astype(np.int64)
    srank, ssize = _group_rank((np.arange(n), g.needle.astype(np.int64)), key)
    edge = (course == 0) | (course == course_end) | (~circ & ((wale == 0) | (wale == wale_end)))
    return Coords(course, course_end, wale, wale_end, srank, ssize - 1, edge)


def _neighbour_table(g: StitchGraph) -> np.ndarray:
    """(N, 6) course and wale neighbours of each stitch (-1 = none); links are mutual."""
    return np.column_stack([g.cprev, g.cnext, g.wale_prev, g.wale_next]).astype(np.int64)


def grow(
    g: StitchGraph, sel: np.ndarray, domain: np.ndarray, nbrs: np.ndarray | None = None
) -> np.ndarray:
    """`sel` plus every stitch of `domain` one course or wale link away from it."""
    if nbrs is None:
        nbrs = _neighbour_table(g)
    out = sel.copy()
    for col in nbrs.T:
        ok = col >= 0
        src = np.nonzero(ok)[0]
        out[src] |= sel[col[ok]]
    return out & domain


class _Eval:
    def __init__(
        self,
        g: StitchGraph,
        node: int | None,
        env: QueryEnv,
        c: Coords | None,
        within: np.ndarray | None = None,
    ):
        self.g = g
        self.env = env
        self.c = coords(g) if c is None else c
        self.domain = (g.node == node) if node is not None else np.ones(g.n_stitches, bool)
        self.piece = self.domain
        """The layer's node (all stitches for global layers), whatever the selection."""
        if within is not None:  # inside an applied definition: the caller's selection is
            self.domain = self.domain & within  # its whole world (`all()`, `boundaries()`)
        self.scope = self.domain
        """The layer's stitches: the default frame of drawn queries and grids."""
        self._nbrs: np.ndarray | None = None
        self.lets = env.lets
        """The `let`s names mean here: the block's, or a `LetDef`'s own while it is evaluated."""
        self._masks: dict[int, np.ndarray] = {}
        self._frames: dict[int, Placement] = {}
        self._depth = 0
        self._root: ast.Node = ast.Name("")  # set by the first `_nested`

    # -- `let`s and nesting
    def _nested(self, q: ast.Node) -> None:
        """Count one more level of `query`/`frame` (the caller uncounts it), E708 beyond
        `MAX_NESTING`."""
        if self._depth == 0:
            self._root = q  # the selection as written, where the error is reported
        if self._depth >= MAX_NESTING:
            raise QueryError(
                "E708",
                f"this selection nests more than {MAX_NESTING} levels deep, "
                "counting the `let`s it names",
                self._root.span,
                hint="a `let` that names the one before it, many times over, "
                "nests one level each time",
            )
        self._depth += 1

    def _in_let(self, let: LetDef, evaluate: Any) -> Any:
        saved, self.lets = self.lets, let.refs
        try:
            return evaluate(let.node)
        finally:
            self.lets = saved

    def _let_mask(self, let: LetDef) -> np.ndarray:
        got = self._masks.get(id(let))
        if got is None:
            got = self._masks[id(let)] = self._in_let(let, self.query)
        return got.copy()

    def _let_frame(self, let: LetDef) -> Placement:
        got = self._frames.get(id(let))
        if got is None:
            got = self._frames[id(let)] = self._in_let(let, self.frame)
        return got

    # -- selections
    def query(self, q: ast.Node | None) -> np.ndarray:
        if q is None:
            return self.domain.copy()
        self._nested(q)
        try:
            return self._query(q)
        finally:
            self._depth -= 1

    def _query(self, q: ast.Node) -> np.ndarray:
        if isinstance(q, ast.Binary) and q.op in ("or", "and", "-"):
            a, b = self.query(q.left), self.query(q.right)
            return {"or": a | b, "and": a & b, "-": a & ~b}[q.op]
        if isinstance(q, ast.Unary) and q.op == "not":
            return self.domain & ~self.query(q.operand)
        if isinstance(q, ast.Name):
            val = self.lets.get(q.id)
            if val is None:
                raise QueryError(
                    "E704",
                    f"unknown selection `{q.id}`",
                    q.span,
                    hint="bind it first with `let NAME = QUERY`",
                )
            if isinstance(val, np.ndarray):
                return val.astype(bool) & self.domain
            if isinstance(val, LetDef):
                return self._let_mask(val)
            return self.query(val)
        if isinstance(q, ast.Call) and isinstance(q.func, ast.Attr):
            name = q.func.name.name
            if name in DRAWN or name in GRIDS:
                return self.framed(name, q, self.frame(q.func.obj)).mask & self.domain
            base = self.query(q.func.obj)
            return self.call(name, q, base)
        if isinstance(q, ast.Call) and isinstance(q.func, ast.Name):
            if q.func.id in DRAWN or q.func.id in GRIDS:
                return self.framed(q.func.id, q, None).mask & self.domain
            return self.call(q.func.id, q, None)
        raise QueryError(
            "E701",
            "this expression is not a query",
            q.span,
            hint="queries are calls such as `wales(0:3)` combined with `or`, `and`, `not` and `-`",
        )

    def call(self, name: str, q: ast.Call, base: np.ndarray | None) -> np.ndarray:
        args = [a for a in q.args if not isinstance(a, ast.KwArg)]
        if name not in SUPPORTED:
            raise QueryError(
                "E701",
                f"unknown query `{name}`",
                q.func.span,
                hint="queries: " + ", ".join(SUPPORTED),
            )
        if base is not None and name not in ("neighbors", "boundaries", "inverse"):
            raise QueryError(
                "E701",
                f"`.{name}(...)` cannot be chained on a selection",
                q.func.span,
                hint="combine selections with `and`",
            )
        c, d = self.c, self.domain
        if name == "all":
            return d.copy()
        if name == "inverse":
            if base is None:
                raise QueryError("E701", "`inverse()` needs a selection: `Q.inverse()`", q.span)
            return d & ~base
        if name == "filter":
            v = self.pred(args[0])
            return d & np.broadcast_to(np.asarray(v, dtype=bool), d.shape)
        if name == "courses":
            return d & self.range(args[0], c.course, c.course_end)
        if name == "wales":
            if len(args) == 2:
                s = self.side_arg(args[1])
                return d & (self.g.side == s) & self.range(args[0], c.swale, c.swale_end)
            return d & self.range(args[0], c.wale, c.wale_end)
        if name == "select":
            rows = self.range(args[0], c.course, c.course_end)
            if len(args) == 3:
                s = self.side_arg(args[2])
                return d & rows & (self.g.side == s) & self.range(args[1], c.swale, c.swale_end)
            return d & rows & self.range(args[1], c.wale, c.wale_end)
        if name == "side":
            return d & (self.g.side == self.side_arg(args[0]))
        if name == "neighbors":
            if base is None:
                raise QueryError(
                    "E701",
                    "`neighbors(R)` needs a selection to grow from",
                    q.span,
                    hint="write `Q.neighbors(R)`, e.g. `wales(0).neighbors(1)`",
                )
            return self.neighbors(base, args[0] if args else None)
        if name == "boundaries":  # at the piece's edge, or next to a stitch not selected
            base = d if base is None else base
            rest = self.piece & ~base
            return base & (c.edge | (grow(self.g, rest, self.piece, self.nbrs()) & ~rest))
        if name == "named":
            named = np.zeros(self.g.n_courses, dtype=bool)
            named[list(self.g.course_names)] = True
            return d & named[self.g.course]
        if name == "shape":
            sname = self.string(args[0])
            if sname not in self.g.node_names:
                raise QueryError("E705", f"unknown node `{sname}`", args[0].span)
            return d & (self.g.node == self.g.node_names.index(sname))
        # itf
        iname = self.string(args[0])
        hit = np.zeros(self.g.n_courses, dtype=bool)
        for cid, names in self.g.course_names.items():
            if any(nm == iname or nm.split(".", 1)[-1] == iname for nm in names):
                hit[cid] = True
        return d & hit[self.g.course]

    # -- frames: selections with coordinates (drawn queries, grids, drawn layers)
    def plain(self, mask: np.ndarray) -> Placement:
        """A selection framed by its course/wale coordinates, per node."""
        g = self.g
        return Placement(
            mask,
            self.c.course,
            self.c.wale,
            g.node.astype(np.int64),
            row_key=g.course.astype(np.int64),
        )

    def frame(self, q: ast.Node | None) -> Placement:
        """The selection of `q` with the coordinates a raster is placed in."""
        if q is None:
            return self.plain(self.scope.copy())
        self._nested(q)
        try:
            return self._frame(q)
        finally:
            self._depth -= 1

    def _frame(self, q: ast.Node) -> Placement:
        if isinstance(q, ast.Binary) and q.op in ("and", "-"):
            right: np.ndarray | Placement
            left = self.frame(q.left)
            if left.anchored:
                right = self.query(q.right)
                keep = right if q.op == "and" else ~right
                return dataclasses.replace(left, mask=left.mask & keep)
            if q.op == "and":
                right = self.frame(q.right)
                if right.anchored:
                    return dataclasses.replace(right, mask=right.mask & left.mask)
                return self.plain(left.mask & right.mask)
            return self.plain(left.mask & ~self.query(q.right))
        if isinstance(q, ast.Name):
            val = self.lets.get(q.id)
            if isinstance(val, LetDef):
                return self._let_frame(val)
            if val is not None and not isinstance(val, np.ndarray):
                return self.frame(val)
        if isinstance(q, ast.Call):
            if isinstance(q.func, ast.Name) and q.func.id in DRAWN + GRIDS:
                return self.framed(q.func.id, q, None)
            if isinstance(q.func, ast.Attr) and q.func.name.name in DRAWN + GRIDS:
                return self.framed(q.func.name.name, q, self.frame(q.func.obj))
        return self.plain(self.query(q))

    def framed(self, name: str, q: ast.Call, base: Placement | None) -> Placement:
        """A drawn query or a grid; `base` is the frame it is chained on, if any."""
        if name == "wale_grid":
            a = self.bind(q, ("wales", "steps"))
            return self.wale_grid(base.mask if base else self.scope, a)
        if name == "stitch_grid":
            a = self.bind(q, ("w", "h", "x_align", "y_align"), need=2)
            return self.stitch_grid(base.mask if base else self.scope, a)
        if name == "img":
            a = self.bind(q, ("file", "channel", "threshold"), need=1)
            on = self.image(q, a)
            fr = base or self.plain(self.scope.copy())
            return dataclasses.replace(fr, mask=raster.place(on, fr, "stretch") >= 0)
        if name == "noise":
            a = self.bind(q, ("scale", "threshold", "seed"), need=1)
            return self.noise(base or self.plain(self.scope.copy()), a)
        a = self.bind(q, ("grid", "coords"), need=1)
        if base is not None and "coords" in a:
            raise QueryError(
                "E703",
                f"`.{name}(...)` is chained on a selection and also given one",
                a["coords"].span,
                hint=f"write `Q.{name}(grid)` or `{name}(grid, Q)`",
            )
        fr = base or (self.frame(a["coords"]) if "coords" in a else self.plain(self.scope.copy()))
        on = self.raster_arg(a["grid"])
        return dataclasses.replace(fr, mask=raster.place(on, fr, name) >= 0)

    def bind(self, q: ast.Call, names: tuple[str, ...], need: int = 0) -> dict[str, ast.Node]:
        """The call's arguments by parameter name: positional ones in order, then `k = v`."""
        fname = q.func.name.name if isinstance(q.func, ast.Attr) else q.func.id  # type: ignore
        pos = [a for a in q.args if not isinstance(a, ast.KwArg)]
        if len(pos) > len(names):
            raise QueryError(
                "E703",
                f"`{fname}` takes at most {len(names)} argument(s), got {len(pos)}",
                q.span,
                hint=f"`{fname}({', '.join(names)})`",
            )
        out: dict[str, ast.Node] = dict(zip(names, pos))
        for kw in q.args:
            if not isinstance(kw, ast.KwArg):
                continue
            k = kw.name.name
            if k not in names:
                raise QueryError(
                    "E703",
                    f"`{fname}` has no argument `{k}`",
                    kw.name.span,
                    hint=f"its arguments: {', '.join(names)}",
                )
            if k in out:
                raise QueryError("E703", f"argument `{k}` is given twice", kw.name.span)
            out[k] = kw.value
        if len(out) < need:
            missing = [n for n in names[:need] if n not in out]
            raise QueryError(
                "E703", f"`{fname}` needs " + ", ".join(f"`{m}`" for m in missing), q.span
            )
        return out

    def raster_arg(self, a: ast.Node) -> np.ndarray:
        """The on/off cells of a grid argument: a `\"\"\"` grid, a `let` name bound to one,
        or an image `img(file, channel, threshold)`."""
        if isinstance(a, ast.Name) and isinstance(self.lets.get(a.id), ast.Grid):
            a = self.lets[a.id]  # type: ignore[assignment]
        if isinstance(a, ast.Grid):
            for at, msg in raster.chart_shape_problems(a):
                raise QueryError(
                    "E716",
                    msg,
                    at.span,
                    hint="every row of a grid has as many "
                    "cells as the first; use `.` for an empty cell",
                )
            return raster.chart_values(a, lambda _text: 0)
        if isinstance(a, ast.Call) and isinstance(a.func, ast.Name) and a.func.id == "img":
            return self.image(a, self.bind(a, ("file", "channel", "threshold"), need=1))
        raise QueryError(
            "E710",
            "expected a grid",
            a.span,
            hint='a `"""` grid of cells (`.` or `0` = off, anything else on), '
            "a `let` name bound to one, or `img(file)`",
        )

    def image(self, q: ast.Call, a: dict[str, ast.Node]) -> np.ndarray:
        """Cells of an image: 0 where the channel reaches the threshold, else -1."""
        fa = a["file"]
        if not isinstance(fa, ast.String):
            raise QueryError(
                "E703",
                "the image file is a name in quotes",
                fa.span,
                hint='e.g. `img("motif.png")`, relative to the design file',
            )
        channel = "k"
        if "channel" in a:
            channel = self.string(a["channel"]).lower()
            if channel not in raster.CHANNELS:
                raise QueryError(
                    "E714",
                    f"unknown image channel `{channel}`",
                    a["channel"].span,
                    hint="channels: r g b a (opacity) l (luminance) k (darkness, the default)",
                )
        threshold = 0.5
        if "threshold" in a:
            threshold = self.scalar(a["threshold"])
            if not 0 <= threshold <= 1:
                raise QueryError(
                    "E714",
                    f"an image threshold is between 0 and 1, got {threshold:g}",
                    a["threshold"].span,
                )
        try:
            values = raster.image_channel(image_path(fa), channel)
        except raster.ImageProblem as err:
            raise QueryError(
                err.code,
                str(err),
                fa.span,
                hint=err.hint or "image paths are relative to the file that names them",
            ) from None
        return np.where(values >= threshold, 0, raster.OFF).astype(np.int64)

    def noise(self, fr: Placement, a: dict[str, ast.Node]) -> Placement:
        """Stitches where seeded 2-D simplex noise over the frame reaches the threshold."""
        scale = self.scalar(a["scale"])
        if not scale >= MIN_NOISE_SCALE:
            raise QueryError(
                "E717",
                f"the noise scale is a size in stitches of at least {MIN_NOISE_SCALE:f}, "
                f"got {scale:g}",
                a["scale"].span,
            )
        threshold = self.scalar(a["threshold"]) if "threshold" in a else 0.5
        if not 0 <= threshold <= 1:
            raise QueryError(
                "E717",
                f"a noise threshold is between 0 and 1, got {threshold:g}",
                a["threshold"].span,
            )
        seed = 1
        if "seed" in a:
            v = self.scalar(a["seed"])
            if v != int(v):
                raise QueryError(
                    "E717", f"a noise seed is a whole number, got {v:g}", a["seed"].span
                )
            seed = int(v)
        r0, c0 = raster.origin(fr)
        ids = np.nonzero(fr.mask)[0]
        val = (
            raster.simplex2(
                (fr.col[ids] - c0[ids]) / scale,
                (fr.row[ids] - r0[ids]) / scale,
                raster.permutation(seed),
            )
            + 1.0
        ) / 2.0
        mask = np.zeros_like(fr.mask)
        mask[ids[val >= threshold]] = True
        return dataclasses.replace(fr, mask=mask)

    def steps(self, e: ast.Node | None) -> tuple[int, int | None]:
        """(direction, count) of a number of stitches along a wale: `n`, `-n` (downwards),
        `end` or `-end` (as far as the wale goes: count None)."""
        if e is None or (isinstance(e, ast.Name) and e.id == "end"):
            return 1, None
        if (
            isinstance(e, ast.Unary)
            and e.op == "-"
            and isinstance(e.operand, ast.Name)
            and e.operand.id == "end"
        ):
            return -1, None
        v = self.scalar(e)
        if v != int(v) or v == 0:
            raise QueryError(
                "E715",
                f"a grid size is a whole number of stitches other than 0, or `end`, got {v:g}",
                e.span,
            )
        # No grid is taller or wider than the graph has stitches: a size beyond that is cut
        # to it (twice it, so a "middle" alignment still reaches every end) and stays a
        # machine integer in the arrays the grid is built in.
        return (1 if v > 0 else -1), min(abs(int(v)), 2 * self.g.n_stitches + 1)

    def seeds_course(self, sel: np.ndarray, top: bool) -> np.ndarray:
        """The stitches of `sel` on its lowest (or highest) course, per node."""
        lo, hi = raster.extent(self.g.node.astype(np.int64), self.c.course, sel)
        return sel & (self.c.course == (hi if top else lo))

    def wale_grid(self, sel: np.ndarray, a: dict[str, ast.Node]) -> Placement:
        """Wales traced up (or down) from the selection's first (or last) course."""
        g, c = self.g, self.c
        sign, count = self.steps(a.get("steps"))
        down = sign < 0
        seeds = self.seeds_course(sel & self.domain, down)
        node = g.node.astype(np.int64)
        rank, size = _group_rank((c.wale,), np.where(seeds, node, -1))
        if "wales" in a:
            seeds &= self.range(a["wales"], rank, size - 1)
        rank, _ = _group_rank((c.wale,), np.where(seeds, node, -1))
        ids = np.nonzero(seeds)[0]
        far = None if count is None else count - 1
        up_n, down_n = (0, far) if down else (far, 0)
        gc = grids.extrude(
            g, ids, rank[ids], np.zeros(ids.size, np.int64), up_n, down_n, self.domain
        )
        return Placement(gc.on, gc.row, gc.col, node, anchored=True)

    def stitch_grid(self, sel: np.ndarray, a: dict[str, ast.Node]) -> Placement:
        """A w x h grid from the selection's lower-left stitch (per node), along its course
        then up (or down) its wales."""
        g, c = self.g, self.c
        (ws, w), (hs, h) = self.steps(a["w"]), self.steps(a["h"])
        for key, sign in (("w", ws), ("h", hs)):
            if sign < 0:
                raise QueryError(
                    "E715",
                    "a grid size is a positive whole number or `end`",
                    a[key].span,
                    hint="place the grid with its alignments "
                    '(`"right"`, `"top"`) instead of negative sizes',
                )
        xa = self.choice(a.get("x_align"), X_ALIGN, "left")
        ya = self.choice(a.get("y_align"), Y_ALIGN, "bottom")
        sel = sel & self.domain
        node = g.node.astype(np.int64)
        ids = np.nonzero(sel)[0]
        order = ids[np.lexsort((c.wale[ids], c.course[ids], node[ids]))]
        first = np.ones(order.size, dtype=bool)
        first[1:] = node[order][1:] != node[order][:-1]
        anchors = order[first]
        run, cols = grids.course_runs(g, c.wale, anchors, w, xa)
        row0, up, down = grids.vertical_span(h, ya)
        gc = grids.extrude(g, run, cols, np.full(run.size, row0, np.int64), up, down, self.domain)
        return Placement(gc.on, gc.row, gc.col, node, anchored=True)

    def choice(self, e: ast.Node | None, table: dict[str, str], default: str) -> str:
        if e is None:
            return default
        v = self.string(e) if isinstance(e, ast.String) else None
        if v not in table:
            raise QueryError(
                "E715", "expected one of " + ", ".join(f'"{k}"' for k in table), e.span
            )
        return table[v]

    def scalar(self, e: ast.Node) -> float:
        v, uses_end = self.bound(e, None, "E703")
        if uses_end or np.ndim(v) != 0:
            raise QueryError("E703", "expected a number", e.span)
        return float(v)

    def nbrs(self) -> np.ndarray:
        if self._nbrs is None:
            self._nbrs = _neighbour_table(self.g)
        return self._nbrs

    def neighbors(self, base: np.ndarray, arg: ast.Node | None) -> np.ndarray:
        """Rings of graph distance (course + wale links, within the layer's stitches)."""
        if arg is None:
            lo, hi = 1, 1
        elif isinstance(arg, ast.Range):
            if arg.step is not None:
                raise QueryError("E702", "`neighbors` takes a ring range without a step", arg.span)
            lo, hi = self.int_scalar(arg.start), self.int_scalar(arg.stop)
        else:
            lo, hi = 1, self.int_scalar(arg)
        if lo < 0 or hi < lo:
            raise QueryError(
                "E702",
                f"bad ring range {show(lo)}:{show(hi)}",
                arg.span if arg else None,
                hint="rings are counted from 0 (the selection itself) upwards",
            )
        # No stitch is further than the graph has stitches: farther rings are empty.
        lo, hi = min(lo, self.g.n_stitches + 1), min(hi, self.g.n_stitches + 1)
        d = self.domain
        dist = np.where(base & d, 0, -1)
        cur = base & d
        for k in range(1, hi + 1):
            nxt = grow(self.g, cur, d, self.nbrs())
            dist[nxt & (dist < 0)] = k
            if np.array_equal(nxt, cur):
                break
            cur = nxt
        return (dist >= lo) & (dist <= hi)

    # -- arguments
    def side_arg(self, a: ast.Node) -> int:
        if isinstance(a, ast.Name) and a.id in ("front", "back"):
            return 0 if a.id == "front" else 1
        raise QueryError("E703", "a side is `front` or `back`", a.span)

    def string(self, a: ast.Node) -> str:
        if isinstance(a, ast.String):
            return a.value
        if isinstance(a, ast.Name) and a.id not in self.lets:
            return a.id
        raise QueryError("E703", "expected a name in quotes", a.span)

    def int_scalar(self, e: ast.Node) -> int:
        v, uses_end = self.bound(e, None)
        if uses_end or float(v) != int(v):
            raise QueryError("E702", "expected a whole number", e.span)
        return int(v)

    def bound(self, e: ast.Node, end: np.ndarray | None, code: str = "E702") -> tuple[Any, bool]:
        """Arithmetic on a range bound (`code` E702) or on a number argument (E703: a grid
        size, a noise scale); returns (value, whether it mentions `end`). The arithmetic is
        the language's one (`knitc.lang.arith`), so a result beyond its limit is E305 where
        it is computed, as in a filter."""
        if isinstance(e, ast.Number):
            return e.value, False
        if isinstance(e, ast.Name) and e.id in self.env.values:
            v = self.env.values[e.id]
            if isinstance(v, bool) or not isinstance(v, int | float):
                raise QueryError(
                    code, f"`{e.id}` is {show(v)} here, not a number a query can use", e.span
                )
            return v, False
        if isinstance(e, ast.Name) and e.id == "end":
            if end is None:
                raise QueryError(code, "`end` cannot be used here", e.span)
            return end, True
        if isinstance(e, ast.ParamRef):
            v = self.env.params.get(e.name)
            if isinstance(v, bool) or not isinstance(v, int | float):
                raise QueryError("E704", f"parameter `#{e.name}` is not a known number", e.span)
            return v, False
        if isinstance(e, ast.Unary) and e.op == "-":
            v, u = self.bound(e.operand, end, code)
            return -v, u
        if isinstance(e, ast.Binary) and e.op in arith.ARITHMETIC:
            a, ua = self.bound(e.left, end, code)
            b, ub = self.bound(e.right, end, code)
            try:
                return arith.vector(e.op, a, b), ua or ub
            except arith.ArithError as exc:
                raise QueryError(exc.code, exc.message, e.span) from None
        raise QueryError(
            code,
            "a range bound is a number, `end` or `#param` arithmetic"
            if code == "E702"
            else "a number argument is a number, a `#param` or arithmetic on them",
            e.span,
        )

    @staticmethod
    def _resolve(v: object, uses_end: bool, end: np.ndarray) -> np.ndarray:
        v = np.asarray(v, dtype=float)
        if uses_end:
            return np.broadcast_to(v, end.shape)
        frac = (v > -1) & (v < 1) & (v != 0)
        return np.where(frac, np.where(v < 0, 1 + v, v) * end, np.where(v < 0, v + end + 1, v))

    def range(self, a: ast.Node, idx: np.ndarray, end: np.ndarray) -> np.ndarray:
        """Mask of stitches whose coordinate `idx` lies in the range `a` (see module doc)."""
        if not isinstance(a, ast.Range):
            v = self._resolve(*self.bound(a, end), end)
            return idx == np.floor(v + 0.5)
        lo = np.ceil(self._resolve(*self.bound(a.start, end), end) - 1e-9)
        hi = np.floor(self._resolve(*self.bound(a.stop, end), end) + 1e-9)
        step = 1
        if a.step is not None:
            s, uses_end = self.bound(a.step, None)
            if uses_end or float(s) != math.floor(float(s)) or s < 1:
                raise QueryError(
                    "E702", f"a range step must be a positive whole number, got {s}", a.step.span
                )
            step = int(s)
        m = (idx >= lo) & (idx <= hi)
        if step > 1:
            m &= np.mod(idx - lo, step) == 0
        return m

    # -- filter predicates
    def pred(self, e: ast.Node) -> object:
        """Vectorised evaluation of a `filter` predicate over the stitch fields."""
        c = self.c
        if isinstance(e, ast.Number | ast.Bool):
            return e.value
        if isinstance(e, ast.ParamRef):
            v = self.env.params.get(e.name)
            if v is None:
                raise QueryError("E704", f"unknown parameter `#{e.name}`", e.span)
            return v
        if isinstance(e, ast.Name) and e.id in self.env.values:
            return self.env.values[e.id]
        if isinstance(e, ast.Name):
            fields_ = {
                "course": c.course,
                "wale": c.wale,
                "course_end": c.course_end,
                "wale_end": c.wale_end,
                "side": self.g.side.astype(np.int64),
                "gauge": self.g.course_gauge[self.g.course].astype(np.int64),
                "node": self.g.node.astype(np.int64),
                "index": np.arange(self.g.n_stitches),
            }
            if e.id in fields_:
                return fields_[e.id]
            if e.id in ("front", "back"):
                return 0 if e.id == "front" else 1
            raise QueryError(
                "E704",
                f"`{e.id}` is not a stitch field",
                e.span,
                hint="fields: " + ", ".join(fields_),
            )
        if isinstance(e, ast.Unary):
            v = np.asarray(self.pred(e.operand))
            if e.op == "not":
                return ~_typed(v, True, "`not` needs a boolean", e.operand.span)
            return -_typed(v, False, "`-` needs a number", e.operand.span).astype(np.float64)
        if isinstance(e, ast.Binary):
            a, b = np.asarray(self.pred(e.left)), np.asarray(self.pred(e.right))
            if e.op in ("and", "or"):
                f = np.logical_and if e.op == "and" else np.logical_or
                return f(
                    _typed(a, True, f"`{e.op}` needs booleans", e.left.span),
                    _typed(b, True, f"`{e.op}` needs booleans", e.right.span),
                )
            if e.op in ("==", "!="):
                # as in the scalar evaluator: a boolean never equals a number
                if (a.dtype == bool) != (b.dtype == bool):
                    same = np.zeros(np.broadcast(a, b).shape, dtype=bool)
                else:
                    same = np.equal(a.astype(np.float64), b.astype(np.float64))
                return same if e.op == "==" else ~same
            if e.op in arith.ARITHMETIC + arith.COMPARISONS:
                what = f"`{e.op}` needs a number"
                x, y = _typed(a, False, what, e.left.span), _typed(b, False, what, e.right.span)
                try:
                    return arith.vector(e.op, x, y)
                except arith.ArithError as exc:
                    raise QueryError(exc.code, exc.message, e.span) from None
        raise QueryError(
            "E703",
            "a filter predicate uses numbers, stitch fields and arithmetic or comparisons",
            e.span,
        )


def _typed(v: np.ndarray, boolean: bool, what: str, span: Span) -> np.ndarray:
    """`v` if it is booleans (`boolean`) or numbers (not), else the scalar evaluator's
    E303 for the same mistake."""
    if v.dtype.kind not in "biuf":
        raise QueryError("E303", f"{what}, got something else", span)
    if (v.dtype == bool) != boolean:
        raise QueryError("E303", f"{what}, got {'a number' if boolean else 'a boolean'}", span)
    return v


def evaluate_query(
    g: StitchGraph,
    node: int | None,
    q: ast.Node | None,
    env: QueryEnv | None,
    diags: Diagnostics,
    *,
    c: Coords | None = None,
    within: np.ndarray | None = None,
) -> np.ndarray:
    """Boolean mask (length `g.n_stitches`) of the stitches `q` selects.

    `node` is the index of the layer's node in `g.node_names` (the result is then a subset
    of that node's stitches) or None for the global `before`/`after` layers. `q` None means
    `all()`. Errors are reported in `diags` and select nothing. `c` is `coords(g)`, for
    callers that evaluate many queries on one graph (it is computed otherwise). `within`
    (optional) is the selection of an enclosing `apply`: drawn queries and grids without a
    frame of their own are placed on it instead of on the whole node (the result is not
    clipped to it; the caller does that).
    """
    ev = _Eval(g, node, env or QueryEnv(), c, within)
    try:
        return np.asarray(ev.query(q), dtype=bool) & ev.domain
    except QueryError as err:
        diags.error(err.code, err.message, err.span, hint=err.hint)
        return np.zeros(g.n_stitches, dtype=bool)


def evaluate_frame(
    g: StitchGraph,
    node: int | None,
    q: ast.Node | None,
    env: QueryEnv | None,
    diags: Diagnostics,
    *,
    c: Coords | None = None,
    within: np.ndarray | None = None,
) -> Placement | None:
    """The selection of `q` (within `within`) with the coordinates a drawn layer places its
    grid in: course/wale, or a wale/stitch grid's (see the module docstring). None after
    an error (reported in `diags`)."""
    ev = _Eval(g, node, env or QueryEnv(), c, within)
    try:
        fr = ev.frame(q)
    except QueryError as err:
        diags.error(err.code, err.message, err.span, hint=err.hint)
        return None
    return dataclasses.replace(fr, mask=fr.mask & ev.scope)


def image_path(fa: ast.String) -> str:
    """An image's file name as written (`img("motif.png")`), relative to the file that
    names it."""
    path = Path(fa.value)
    if not path.is_absolute() and fa.span is not None:
        path = Path(fa.span.file).parent / path
    return str(path)
