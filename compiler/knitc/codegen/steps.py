"""Stitch actions as code generation runs them: pre, main and post steps per stitch.

Kept apart from `codegen` so that user actions (`patterning.actions`) and the built-in lowering
of pattern instructions build the same kind of object without importing each other.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import field

from knitc.records import record

ActionStep = Callable[[], None]


@record
class Action:
    """One stitch's steps (thesis "Action Pass", after the pre-main-post stitch actions of
    Narayanan et al.): `pre` steps bring loops where the main step needs them, `main` steps
    make the stitch, `post` steps finish (return loops, remove local yarns). A pass runs the
    k-th pre step of every stitch for k = 0, 1, ..., then the main steps in yarn order, then
    the post steps like the pre steps."""

    stitch: int
    pre: list[ActionStep] = field(default_factory=list)
    main: list[ActionStep] = field(default_factory=list)
    post: list[ActionStep] = field(default_factory=list)


def run_actions(actions: list[Action]) -> None:
    """Run the steps of a sub-sequence of stitches in the order of the thesis's action pass."""
    run_by_depth([a.pre for a in actions])
    for f in [f for a in actions for f in a.main]:
        f()
    run_by_depth([a.post for a in actions])


def run_by_depth(lists: list[list[ActionStep]]) -> None:
    """Pre or post steps: the k-th step of every stitch for k = 0, 1, ..."""
    depth = max((len(fs) for fs in lists), default=0)
    for f in [fs[k] for k in range(depth) for fs in lists if k < len(fs)]:
        f()


def continues_in_place(gen, s: int) -> int:
    """The next stitch of `s`'s wale when a loop of `s` may wait for it where it was made:
    a plain continuation (one loop out of `s`, one into the next) on the same needle of a
    flat course, with no loops carried after either course (`codegen._carry`); else -1.
    A purl, or an action with `transfer_back: false`, whose next stitch is the same then
    leaves its loop on the facing needle instead of taking it home and back (knitsketching
    issue #5), and the alignment and shaping passes leave it there. `gen` is code
    generation's state (`g`, `pos`, `carrying`)."""
    g = gen.g
    kid = int(g.wale_next[s, 0])
    if (
        kid < 0
        or int(g.wale_next[s, 1]) >= 0
        or int(g.wale_prev[kid, 1]) >= 0
        or g.course_circular[g.course[s]]
        or g.course_circular[g.course[kid]]
        or gen.carrying[g.course[s]]
        or gen.carrying[g.course[kid]]
        or gen.pos(kid) != gen.pos(s)
    ):
        return -1
    return kid


def empty_needle_number(gen, s: int, plain: int) -> int:
    """The stitch number of the loop stitch `s` lays onto an empty needle: the cast-on's
    when the stitch starts its wale (a partial cast-on, a first course with `cast_on:
    none`), else the course's own `plain` (a yarn-over where a lace move emptied the
    needle), so a pass keeps one stitch number and its DAT one row. `gen` is code
    generation's state (`g`, `opts`)."""
    return gen.opts.numbers.cast_on if int(gen.g.wale_prev[s, 0]) < 0 else plain
