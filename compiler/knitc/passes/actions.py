"""Stitch actions (`use ACTION where Q`): user pre/main/post programs (thesis ch. 6.9.1).

STUB: being written. Until then `attach` warns W706 and leaves the stitches as they are.
"""

from __future__ import annotations

from knitc.syntax import ast


def attach(run, stmt: ast.UseStmt, node, env, within) -> None:
    """Attach the action `stmt` names to the stitches its query selects (`run` is the
    pattern pass's state: `run.select`, `run.action`, `run.mark`, `run.diags`)."""
    if stmt.span not in run.warned:
        run.warned.add(stmt.span)
        run.diags.warning("W706", "stitch actions (`use`) are not applied yet: these stitches "
                          "keep their other instructions", stmt.span,
                          hint="write the motif with `set` statements for now")


def lower(gen, ctx, s: int, d: int, pos):
    """The `steps.Action` of stitch `s`, whose `g.action` is an attached action, visited in
    direction `d` at `pos` (code generation's state `gen`, the course's context `ctx`);
    None: use the stitch's instruction instead."""
    return None
