"""Drawn layers (`draw`, `stretch`, `tile`): grids of instructions on a selection.

STUB: being written. Until then `apply_grid` warns W706 and leaves the stitches as they are.
"""

from __future__ import annotations

from knitc.syntax import ast


def apply_grid(run, stmt: ast.GridStmt, node, env, within) -> None:
    """Write the grid of `stmt` on the stitches its query selects (`run` is the pattern
    pass's state: `run.select`, `run.instr`, `run.mark`, `run.coords`, `run.diags`)."""
    if stmt.span not in run.warned:
        run.warned.add(stmt.span)
        run.diags.warning("W706", f"drawn layers (`{stmt.mode}`) are not applied yet: these "
                          "stitches keep their other instructions", stmt.span,
                          hint="write the motif with `set` statements for now")
