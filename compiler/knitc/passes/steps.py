"""Stitch actions as code generation runs them: pre, main and post steps per stitch.

Kept apart from `codegen` so that user actions (`passes.actions`) and the built-in lowering
of pattern instructions build the same kind of object without importing each other.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

ActionStep = Callable[[], None]


@dataclass
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
    for part in ("pre", "main", "post"):
        lists = [getattr(a, part) for a in actions]
        if part == "main":
            order = [f for fs in lists for f in fs]
        else:
            depth = max((len(fs) for fs in lists), default=0)
            order = [fs[k] for k in range(depth) for fs in lists if k < len(fs)]
        for f in order:
            f()
