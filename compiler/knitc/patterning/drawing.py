"""Drawn layers: `draw`, `stretch` and `tile GRID where Q` (thesis ch. 5.3.3, 6.9.4).

A drawn layer writes a chart of instructions onto the stitches its query selects (and a
colour chart, whose cells name the design's yarns, gives those stitches the yarn: the
cells may mix both, `.` leaves a stitch as it is). The chart
is read like a knitting chart (`patterning.raster`): its last row lands on the selection's
first course, its first column on the selection's left wale; `.` is transparent. The three
modes are the original's singular, scalable and tileable drawings:

- `draw`: once, centred in the selection (each course centred on its own selected wales);
- `stretch`: nearest-neighbour scaled onto the selection's bounding box. Crosses cannot
  be stretched: scaling would separate the two halves of a cable pair (E315);
- `tile`: repeated from the selection's lower-left corner.

The placement is computed from the selection every time the pattern pass runs, so a motif
follows the shape when its parameters change (a longer sleeve moves a centred motif up).
If the query is a grid (`wale_grid`, `stitch_grid`, or one clipped with `and`/`-`), the
chart is placed in the grid's coordinates instead: it follows the wales through shaping and
tiles from the grid's seed.

On a tube, wales run around the whole tube in yarn order (front left to right, then back
right to left): seen from outside, that is left to right on both faces, so a chart reads
the right way round on either side. Select `side(front)` or `side(back)` to place a
drawing on one face (`draw` then centres it on that face).

Inside an `apply`d pattern definition the layer's selection is the caller's selection
(intersected with the statement's own `where`), so the definition's drawing is placed on
it. Diagnostics: E704 unknown grid name, E710 not a grid, E220 an unknown instruction and
E315 crosses in a stretched grid (the codes the resolver gives a grid written in place;
this pass checks grids bound with `let`, with the same scan, `raster.cell_problems`), E716
a grid that is not rectangular, W710 a singular drawing larger than its selection (the
cells outside are skipped).
"""

from __future__ import annotations

import numpy as np

from knitc.frontend import ast
from knitc.patterning import raster
from knitc.patterning.query import evaluate_frame
from knitc.shaping.stitch_graph import INSTRUCTIONS


def apply_grid(run, stmt: ast.GridStmt, node, env, within) -> None:
    """Write the grid of `stmt` on the stitches its query selects (`run` is the pattern
    pass's state: `run.instr`, `run.mark`, `run.coords`, `run.diags`, `run.warned`)."""
    if _is_image(stmt.grid):
        _apply_image(run, stmt, node, env, within)
        return
    grid = _grid(run, stmt, env)
    if grid is None:
        return
    values = _instructions(run, stmt, grid)
    if values is None:
        return
    fr = evaluate_frame(run.g, node, stmt.where, env, run.diags, c=run.coords, within=within)
    if fr is None:
        return
    vals = raster.place(values, fr, stmt.mode)
    m = vals >= 0
    run.instr[m] = vals[m].astype(run.instr.dtype)
    run.mark(m, stmt.span)
    yarns = raster.chart_values(grid, lambda t: -1 if t in INSTRUCTIONS else run.yarn_index[t])
    if (yarns >= 0).any():  # a colour chart: its yarn cells knit with those yarns
        placed = raster.place(yarns, fr, stmt.mode)
        run.set_yarn(placed >= 0, placed, stmt.span)
    if stmt.mode == "draw" and raster.overflow(values, fr):
        _once(
            run,
            "W710",
            f"the drawing ({values.shape[0]} x {values.shape[1]}) is larger "
            "than its selection: the cells outside are left out",
            stmt.span,
            hint="select more courses or wales, or draw a smaller chart",
            warn=True,
        )


def _is_image(g: ast.Node) -> bool:
    return isinstance(g, ast.Call) and isinstance(g.func, ast.Name) and g.func.id == "img"


def _apply_image(run, stmt: ast.GridStmt, node, env, within) -> None:
    """`draw`/`stretch`/`tile img("file.png")`: a colour image as a chart of yarns, each
    pixel knitted with the yarn whose `colour` is nearest (`main` without a colour is
    white; a mostly transparent pixel keeps its stitch's yarn)."""
    call = stmt.grid
    assert isinstance(call, ast.Call)
    yarns = run.skel.yarn_list
    colours = [(k, y.colour or ("#ffffff" if k == 0 else "")) for k, y in enumerate(yarns)]
    colours = [(k, c) for k, c in colours if c]
    if len(colours) < 2:
        _once(
            run,
            "E718",
            "a colour image is matched to the yarns' colours, and fewer than two yarns have one",
            call.span,
            hint='give the yarns colours, e.g. `yarn red { carrier: 5, colour: "#c0392b" }` '
            "(`main` without one is white)",
        )
        return
    from knitc.patterning.query import image_path

    args = [a for a in call.args if not isinstance(a, ast.KwArg)]
    if len(args) != 1 or call.args != tuple(args) or not isinstance(args[0], ast.String):
        _once(
            run,
            "E703",
            "a colour image in a drawn layer takes one argument, its file in quotes",
            call.span,
            hint='e.g. `draw img("motif.png")`; channels and thresholds are for `where img(...)`',
        )
        return
    try:
        rgba = raster.image_rgba(image_path(args[0]))
    except raster.ImageProblem as err:
        _once(
            run,
            err.code,
            str(err),
            args[0].span,
            hint=err.hint or "image paths are relative to the file that names them",
        )
        return
    values = raster.nearest_colours(rgba, colours)
    fr = evaluate_frame(run.g, node, stmt.where, env, run.diags, c=run.coords, within=within)
    if fr is None:
        return
    placed = raster.place(values, fr, stmt.mode)
    run.set_yarn(placed >= 0, placed, stmt.span)


def _once(run, code: str, message: str, span, hint: str | None = None, warn: bool = False) -> None:
    """Report once per place: a pattern definition's layer runs for every `apply`."""
    key = (code, span)
    if key in run.warned:
        return
    run.warned.add(key)
    (run.diags.warning if warn else run.diags.error)(code, message, span, hint=hint)


def _grid(run, stmt: ast.GridStmt, env) -> ast.Grid | None:
    g = stmt.grid
    if isinstance(g, ast.Grid):
        return g
    if isinstance(g, ast.Name):
        val = env.lets.get(g.id)
        if isinstance(val, ast.Grid):
            return val
        if val is None:
            _once(
                run,
                "E704",
                f"unknown grid `{g.id}`",
                g.span,
                hint=f'bind it first: `let {g.id} = """ ... """`',
            )
        else:
            _once(
                run,
                "E710",
                f"`{g.id}` is a selection, not a grid",
                g.span,
                hint=f"to write one instruction on it: `set K where {g.id}`",
            )
        return None
    _once(
        run,
        "E710",
        f"`{stmt.mode}` needs a grid of instructions",
        g.span,
        hint='write a `"""` grid or a `let` name bound to one; an image selects stitches: '
        '`set P where img("file.png")`',
    )
    return None


def _instructions(run, stmt: ast.GridStmt, grid: ast.Grid) -> np.ndarray | None:
    """The grid as instruction indices (-1 = `.`), or None after reporting its errors."""
    ok = True
    for at, msg in raster.chart_shape_problems(grid):
        _once(
            run,
            "E716",
            msg,
            at.span,
            hint="every row of a grid has as many cells as the "
            "first; use `.` for a stitch the drawing leaves as it is",
        )
        ok = False
    for kind, cell in raster.cell_problems(grid, stmt.mode, run.yarn_index):
        ok = False
        if kind == "unknown":
            _once(
                run,
                "E220",
                f"`{cell.text}` is not a pattern instruction or a yarn",
                cell.span,
                hint="use K P T M FR1 FR2 FL1 FL2 BR1 BR2 BL1 BL2 XR+ XR- XL+ XL- S, a "
                "declared yarn, or `.` to leave a stitch as it is",
            )
        else:
            _once(
                run,
                "E315",
                "a stretched grid cannot hold crosses",
                cell.span,
                hint="scaling would tear cable pairs apart; use `tile` or `draw`",
            )
    if not ok:
        return None
    return raster.chart_values(grid, lambda t: INSTRUCTIONS.index(t) if t in INSTRUCTIONS else -1)
