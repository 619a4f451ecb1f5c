"""Stitch actions, code-generation side: running the pre / main / post programs of an
action once per stitch (thesis ch. 6.9.1). What an action is, how it is attached and its
ids: `patterning.actions`.

Running (code generation calls `lower`, then `prepare_pass` cuts the pass)
    Each step runs through `knitc.lang.interp` once per stitch, with the stitch's context as
    read-only names: `needle` (where the schedule knits the stitch), `opposite` (the needle
    facing it at racking 0), `dir` (+1 rightward / -1 leftward, the carriage direction of
    this visit), `carriers` (the course's carriers, a list), `position` (the stitch's
    place in its course in the order the yarn visits it, 0 first), `side` (`front` or
    `back`: the stitch's face of the node) and `stitch` (a record with the `filter` fields
    `index course wale course_end wale_end gauge node`). Needles are values: `needle.bed`
    is `front` or `back`, `needle.index` a number, `needle + k` the needle k further on the
    same bed, `a - b` the distance of two needles, and they print as `f12`.
    The machine operations (these names always mean the operations inside an action body):
    `knit(dir, needle, carriers)`, `tuck(...)`, `miss(...)` (needle and carriers default
    to the stitch's), `kickback(dir, needle, carriers)` (a miss past the needle in `dir`,
    then the knit back in `-dir`), `split(dir, needle, to, carriers)` (`to` defaults to the
    facing needle), `xfer(from, to)` (racks as the two needles need), `drop(needle)`,
    `rack(r)`. Directions may also be written `left` / `right`. They emit through the code
    generator's bed model (`codegen.bed`, `casting.emit`), so the loop tracking stays right,
    with its stitch numbers; as everywhere in knitc, a knit on an empty needle is made as a
    tuck (a cast-on loop), and a transfer from an empty needle does nothing.
    A stitch whose steps made no loop of its own (a `miss`) is a slip stitch: its parent's
    loop stands for it. `split_by_side: true` cuts the pass into runs of stitches on one bed,
    each run doing its pre, main and post steps before the next run starts, so the loops one
    bed parks on the other are home again before that bed knits. `transfer_back: false`
    skips the post step when the next stitch of the wale, on the same needle of a flat
    course, uses the same action: the loop stays where the main step left it, for that
    stitch's pre step to find (`keeps_loop`; the shaping pass should leave such a loop in
    place, or it takes it home itself).

Safety: a stitch's steps may touch its wale's loops (its parents', the loops they hold
under a tuck or a missed needle, and a cast-on loop on its needle) and empty needles, never
another stitch's loops: a transfer onto or from, a knit, tuck, split or drop on a needle
holding them is E720 (on a full-gauge tube, the other side's fabric faces every needle). A
stitch makes one loop, and the loops it holds end with it (E726). Every runtime mistake is
an error at the call in the action, with a note at the pattern statement; that stitch's
remaining steps are skipped, its loops are accounted for as a slip stitch's, and code
generation goes on, so one mistake is one diagnostic (per code and call), not a cascade.

Codes: E720 another stitch's loops, E721 racking beyond the machine, E722 a needle outside
the machine, E723 a value of the wrong kind (direction, needle, carriers, racking), E724 a
transfer or split within one bed, E725 carriers other than the course's, E726 a second loop
for the stitch, or an old loop left away from its new one; the interpreter's own codes (E3xx,
E304 arguments, E316 a step that runs away) pass through. W720: stitches of a `use` that are
made by the node's increase instead (the action is ignored there).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import field
from typing import Any

import numpy as np

from knitc.codegen import casting as cast
from knitc.codegen.bed import Pos, Unsupported
from knitc.codegen.bed import needle as needle_of
from knitc.codegen.steps import Action, continues_in_place, empty_needle_number
from knitc.diagnostics import Note
from knitc.frontend import ast
from knitc.frontend.names import ACTION_WORDS
from knitc.lang.evaluate import EvalError, Profile, Value, Word, arith, show, type_name
from knitc.lang.interp import Host, Interpreter, StepPool, whole
from knitc.patterning.actions import (
    ACTIONS_BUDGET,
    STD_FILE,
    STEP_BUDGET,
    Program,
    std_source,
)
from knitc.patterning.query import Coords, coords
from knitc.records import record
from knitc.source import UNKNOWN_SPAN, Span

# ---- running (code generation) ----------------------------------------------------------------


@record(frozen=True, slots=True)
class ActionNeedle:
    """A needle as the action language sees it: a host value with `bed` and `index` that
    moves by whole needles (`needle + 1`). Not the machine's `Needle`, a named tuple: knitc's
    evaluators take any tuple for a list, so a machine needle in an action would be
    indexable, countable, and shown as `["f", 2]` in messages."""

    bed: str
    index: int

    def __str__(self) -> str:
        return f"{self.bed}{self.index}"


@record
class UserAction(Action):
    """The steps of a stitch made by an action (not by its instruction)."""

    program: Program | None = None


@record(frozen=True)
class StitchInfo:
    """The `stitch` record of an action's context: the fields a `filter` reads."""

    index: int
    course: int
    wale: int
    course_end: int
    wale_end: int
    gauge: int
    node: int


@record
class _State:
    """Per code generation: where each stitch sits in its course, and its query fields."""

    visit: np.ndarray
    first: np.ndarray
    coords: Coords
    steps: StepPool = field(
        default_factory=lambda: StepPool(ACTIONS_BUDGET, "the design's actions")
    )
    """The steps all the stitches' actions share (`lang.interp.StepPool`)."""

    @staticmethod
    def of(gen) -> _State:
        st = gen.action_state
        if st is None:
            g, t = gen.g, gen.t
            visit = np.full(g.n_stitches, -1, np.int64)
            visit[t.stitch] = np.arange(t.n_visits)
            first = np.full(max(g.n_courses, 1), t.n_visits, np.int64)
            np.minimum.at(first, g.course[t.stitch], np.arange(t.n_visits))
            st = _State(visit, first, coords(g))
            gen.action_state = st
        return st


def lower(gen, ctx, s: int, d: int, pos):
    """The `steps.Action` of stitch `s`, whose `g.action` is an attached action, visited in
    direction `d` at `pos` (code generation's state `gen`, the course's context `ctx`);
    None: use the stitch's instruction instead."""
    a = int(gen.g.action[s])
    progs = gen.opts.actions
    if not 0 <= a < len(progs) or not isinstance(progs[a], Program) or progs[a].plain:
        return None
    prog = progs[a]
    run = _Stitch(gen, ctx, s, d, pos, prog)
    pre = [run.step("pre")] if "pre" in prog.steps else []
    main = [run.step("main")] if "main" in prog.steps else []
    post = (
        [run.step("post")]
        if "post" in prog.steps and (prog.transfer_back or not keeps_loop(gen, s))
        else []
    )
    return UserAction(s, pre=pre, main=main, post=post + [run.finish], program=prog)


def keeps_loop(gen, s: int) -> bool:
    """Whether stitch `s`'s action leaves its new loop where its main step put it
    (`transfer_back: false`) for the next stitch of its wale, which continues in place
    (`steps.continues_in_place`) with the same action."""
    a = int(gen.g.action[s])
    progs = gen.opts.actions
    if not 0 <= a < len(progs) or getattr(progs[a], "transfer_back", True):
        return False
    kid = continues_in_place(gen, s)
    return kid >= 0 and int(gen.g.action[kid]) == a


def splits_by_side(acts: list[Action]) -> bool:
    """Whether a pass with these actions runs as one sub-pass per bed (`prepare_pass`)."""
    return any(isinstance(a, UserAction) and a.program and a.program.split_by_side for a in acts)


def prepare_pass(gen, acts: list[Action]) -> list[list[Action]]:
    """The sub-passes a pass's actions run as (each runs pre, main, post in turn): one, or
    with a `split_by_side` action in the pass, one per run of stitches on the same bed.
    Reports W720 for stitches whose action the node's increase overrides."""
    g = gen.g
    for a in acts:
        if int(g.action[a.stitch]) >= 0 and not isinstance(a, UserAction):
            _warn_increase(gen, a.stitch)
    if not splits_by_side(acts):
        return [acts]
    parts: list[list[Action]] = []
    for a in acts:
        bed = gen.pos(a.stitch)[0]
        if parts and gen.pos(parts[-1][-1].stitch)[0] == bed:
            parts[-1].append(a)
        else:
            parts.append([a])
    return parts


def _warn_increase(gen, s: int) -> None:
    progs = gen.opts.actions
    a = int(gen.g.action[s])
    if not 0 <= a < len(progs) or not isinstance(progs[a], Program) or progs[a].plain:
        return
    span = _origin(gen, s)
    key = f"W720@{span}"
    if key in gen.warned:
        return
    gen.warned.add(key)
    gen.diags.warning(
        "W720",
        f"some stitches selected here are increases: they are made by "
        f"the node's increase, not by action `{progs[a].name}`",
        span,
        hint="an increase forms its new loop itself (`increase: kickback` or "
        "`split`); leave the increases out of the selection",
    )


def _origin(gen, s: int) -> Span | None:
    k = int(gen.g.origin[s])
    return gen.g.spans[k].chain()[0] if k >= 0 else gen.bed.span(s)


# ---- the interpreter: needles and stitch records as values ------------------------------------


class _ActionInterp(Interpreter):
    def _Attr(self, e: ast.Attr) -> Value:
        obj = self.eval(e.obj)
        name = e.name.name
        if isinstance(obj, ActionNeedle) and name in ("bed", "index"):
            return Word("front" if obj.bed == "f" else "back") if name == "bed" else obj.index
        if isinstance(obj, StitchInfo) and name in StitchInfo.__dataclass_fields__:
            return getattr(obj, name)
        what = (
            "a needle has `bed` and `index`"
            if isinstance(obj, ActionNeedle)
            else "`stitch` has " + ", ".join(f"`{f}`" for f in StitchInfo.__dataclass_fields__)
            if isinstance(obj, StitchInfo)
            else f"{type_name(obj)} has no fields"
        )
        raise EvalError("E303", f"no field `{name}` here: {what}", e.name.span)

    def _Binary(self, e: ast.Binary) -> Value:
        if e.op not in ("+", "-"):
            return super()._Binary(e)
        a, b = self.eval(e.left), self.eval(e.right)
        if isinstance(a, ActionNeedle) or isinstance(b, ActionNeedle):
            return _needle_arith(e, a, b)
        if isinstance(a, Profile) or isinstance(b, Profile):
            return self._profile_arith(e, a, b)
        x = self._as_number(a, e.left.span, f"`{e.op}`")
        y = self._as_number(b, e.right.span, f"`{e.op}`")
        return arith(e.op, x, y, e.right.span)


def _needle_arith(e: ast.Binary, a: Value, b: Value) -> Value:
    if isinstance(a, ActionNeedle) and isinstance(b, ActionNeedle) and e.op == "-":
        if a.bed != b.bed:
            raise EvalError("E723", f"{a} and {b} are on different beds", e.span)
        return a.index - b.index
    k = whole(b) if isinstance(a, ActionNeedle) else whole(a) if e.op == "+" else None
    if k is None:
        raise EvalError(
            "E723",
            f"`{e.op}` moves a needle by a whole number of needles, got {show(a)} {e.op} {show(b)}",
            e.span,
            "write `needle + 1` (one needle to the right) or `needle - 1`",
        )
    n = a if isinstance(a, ActionNeedle) else b
    assert isinstance(n, ActionNeedle)
    return ActionNeedle(n.bed, n.index + (k if e.op == "+" else -k))


# ---- one stitch's run -------------------------------------------------------------------------

_UNSET = object()


def _bind(name: str, params: tuple[str, ...], args: tuple, kwargs: dict) -> list:
    vals = list(args) + [_UNSET] * (len(params) - len(args))
    for k, v in kwargs.items():
        if k not in params:
            raise EvalError(
                "E304",
                f"`{name}` has no argument `{k}`",
                UNKNOWN_SPAN,
                "its arguments: " + ", ".join(params),
            )
        i = params.index(k)
        if vals[i] is not _UNSET:
            raise EvalError("E304", f"argument `{k}` of `{name}` is given twice", UNKNOWN_SPAN)
        vals[i] = v
    return vals


class _Stitch:
    """One stitch's action at code generation: its context, host operations and steps."""

    def __init__(self, gen, ctx: cast.Ctx, s: int, d: int, pos: Pos, prog: Program):
        self.gen, self.ctx, self.s, self.d, self.pos, self.prog = gen, ctx, s, d, pos, prog
        self.bed = gen.bed
        g = gen.g
        self.parents = {int(p) for p in g.wale_prev[s] if p >= 0}
        half = int(g.course_gauge[int(g.course[s])]) == 2
        numbers = gen.opts.numbers
        self.plain = numbers.knit_half_gauge if half else numbers.knit
        self.failed = False
        bed = self.bed
        self.cast_on: set[Pos] = {pos} if bed.loops.get(pos, 0) and not bed.at.get(pos) else set()
        """Where the loops of no stitch that this stitch knits through are (a cast-on loop on
        its needle, followed through transfers)."""
        st = _State.of(gen)
        c = st.coords
        course = int(g.course[s])
        info = StitchInfo(
            s,
            int(c.course[s]),
            int(c.wale[s]),
            int(c.course_end[s]),
            int(c.wale_end[s]),
            int(g.course_gauge[course]),
            int(g.node[s]),
        )
        other = "b" if pos[0] == "f" else "f"
        constants: dict[str, Any] = {  # Values and host objects (ActionNeedle, StitchInfo)
            "needle": ActionNeedle(pos[0], pos[1]),
            "opposite": ActionNeedle(other, pos[1]),
            "dir": d,
            "carriers": (ctx.carrier,),
            "position": int(st.visit[s] - st.first[course]),
            "side": Word("back" if int(g.side[s]) else "front"),
            "stitch": info,
        }

        def host(fn: Callable, params: tuple[str, ...], lo: int) -> Host:
            return Host(lambda *a, **kw: fn(*_bind(fn.__name__, params, a, kw)), lo, len(params))

        loop = ("dir", "needle", "carriers")
        self.interp = _ActionInterp(
            functions={
                "knit": host(self.knit, loop, 1),
                "tuck": host(self.tuck, loop, 1),
                "miss": host(self.miss, loop, 1),
                "kickback": host(self.kickback, loop, 0),
                "split": host(self.split, ("dir", "needle", "to", "carriers"), 2),
                "xfer": host(self.xfer, ("source", "target"), 2),
                "drop": host(self.drop, ("needle",), 1),
                "rack": host(self.rack, ("r",), 1),
            },
            constants=constants,
            words=ACTION_WORDS,
            param=self._param,
            budget=STEP_BUDGET,
            pool=st.steps,
            what=f"action `{prog.name}`",
        )

    # -- steps
    def step(self, part: str) -> Callable[[], None]:
        block = self.prog.steps[part]

        def run() -> None:
            if self.failed:
                return
            try:
                self.interp.run(block)
            except EvalError as err:
                self._fail(err)

        return run

    def finish(self) -> None:
        """After the last step, the loops the wale held (a tuck's, a split's or a missed
        needle's old loop) stand for this stitch, as a knit's new loop does: a stitch that
        made no loop of its own is a slip stitch. So the next course finds one stitch per
        needle, and the loop model never loses a loop."""
        bed, s = self.bed, self.s
        held = sorted(self._own() - {s})
        anon = sorted(q for q in self.cast_on if bed.loops.get(q, 0) and not bed.at.get(q))
        if s not in bed.where:
            here = bed.where[held[0]] if held else anon[0] if anon else self.pos
            if not bed.loops.get(here, 0):
                return  # dropped, or nothing was ever there
            bed.place(s, here)
        r = bed.where[s]
        for x in held:
            if x not in bed.where:
                continue  # dropped with a loop it shared
            if bed.where[x] == r:
                bed.at[r].discard(x)
                del bed.where[x]
            else:
                self._strand(bed.where[x], x)
        for q in anon:
            if q != r:
                self._strand(q, -1)

    def _strand(self, q: Pos, x: int) -> None:
        """A loop of the wale left away from the stitch's own: nothing would knit it off."""
        r = self.bed.where[self.s]
        if not self.failed:
            self._fail(
                EvalError(
                    "E726",
                    f"the old loop on {q[0]}{q[1]} is left apart from the stitch's new "
                    f"loop on {r[0]}{r[1]}: nothing would knit it off",
                    self.prog.defn.name.span,
                    "bring it back in the post step, e.g. `xfer(opposite, needle)`",
                )
            )
        self.bed.drop(q, x)  # the program is wrong anyway: no second error about its loops

    def _own(self) -> set[int]:
        """This stitch and the wale's loops still on the needles: its parents', and theirs
        while they are held (under a tuck, a split or a missed needle)."""
        where = self.bed.where
        own, todo = {self.s}, [p for p in self.parents if p in where]
        while todo and len(own) < 64:
            x = todo.pop()
            if x not in own:
                own.add(x)
                todo += [int(p) for p in self.gen.g.wale_prev[x] if p >= 0 and int(p) in where]
        return own

    def _fail(self, err: EvalError) -> None:
        self.failed = True
        gen = self.gen
        key = f"{err.code}@{err.span}"
        if key in gen.warned:
            return
        gen.warned.add(key)
        if err.span is not None and err.span.file == STD_FILE:
            gen.diags.add_source(std_source())
        origin = _origin(gen, self.s)
        notes = [Note("the stitch's pattern is written here", origin)] if origin else []
        gen.diags.error(
            err.code,
            f"action `{self.prog.name}` at {self.pos[0]}{self.pos[1]}: {err.message}",
            err.span,
            notes=notes,
            hint=err.hint,
        )

    def _param(self, name: str, span: Span) -> Value:
        if name in self.prog.params:
            return self.prog.params[name]
        raise EvalError("E403", f"unknown parameter `#{name}`", span)

    # -- argument checks
    def _dir(self, v: object) -> int:
        if v is _UNSET:
            return self.d
        if isinstance(v, Word) and v.name in ("left", "right"):
            return 1 if v.name == "right" else -1
        if not isinstance(v, bool) and v in (1, -1):
            return int(v)
        raise EvalError(
            "E723",
            f"a direction is 1, -1, `left` or `right`, got {_show(v)}",
            UNKNOWN_SPAN,
            "use `dir` (this course's direction) or `-dir`",
        )

    def _needle(self, v: object, default: Pos | None = None) -> Pos:
        if v is _UNSET and default is not None:
            return default
        if not isinstance(v, ActionNeedle) or v.bed not in ("f", "b"):
            raise EvalError(
                "E723",
                f"expected a needle, got {_show(v)}",
                UNKNOWN_SPAN,
                "needles are `needle`, `opposite` and those reached from them, e.g. `needle + 1`",
            )
        n = self.bed.prog.machine.needles
        if not 0 <= v.index < n:
            raise EvalError(
                "E722",
                f"needle {v.bed}{show(v.index)} is outside the machine (needles 0 to {n - 1})",
                UNKNOWN_SPAN,
            )
        return v.bed, v.index

    def _carriers(self, v: object) -> None:
        if v is _UNSET:
            return
        cs = v if isinstance(v, tuple) else (v,)
        if not cs or any(isinstance(c, bool) or whole(c) is None for c in cs):
            raise EvalError(
                "E723",
                f"carriers are a carrier number or a list of them, got {_show(v)}",
                UNKNOWN_SPAN,
                "use `carriers`",
            )
        if {whole(c) for c in cs} != {self.ctx.carrier}:
            raise EvalError(
                "E725",
                f"only this course's carrier ({self.ctx.carrier}) can be used here, got {_show(v)}",
                UNKNOWN_SPAN,
                "an action works with the yarn of its course (`carriers`); other "
                "yarns are not brought in for it",
            )

    def _mine(self, pos: Pos, what: str) -> None:
        """Refuse to touch loops that are not this stitch's wale's (nor its cast-on loop)."""
        bed = self.bed
        others = bed.at.get(pos, set()) - self._own()
        foreign = bool(others) or (
            bed.loops.get(pos, 0) and not bed.at.get(pos) and pos not in self.cast_on
        )
        if not foreign:
            return
        if others:
            x = min(others)
            whose = (
                f"the loop of stitch {x} (of `{self.gen.g.node_names[int(self.gen.g.node[x])]}`)"
            )
            hint = (
                "an action may only move and knit its own stitch's loops; on a tube, knit "
                "in half gauge (`gauge: half`) so that the facing needles are free"
            )
        else:
            whose = "a loop of no stitch (a cast-on loop, or a new yarn's catching tuck)"
            hint = (
                "a new yarn's catching tucks stay until its first course is knitted; "
                "attach the action from the second course on, e.g. `courses(1:end)`"
            )
        raise EvalError("E720", f"{what} {pos[0]}{pos[1]}, which holds {whose}", UNKNOWN_SPAN, hint)

    def _one_loop(self, pos: Pos) -> None:
        """A stitch makes one loop: a second one elsewhere would be lost to the loop model
        (and to the next course)."""
        q = self.bed.where.get(self.s)
        if q is not None and q != pos:
            raise EvalError(
                "E726",
                f"the stitch already has its new loop on {q[0]}{q[1]}; a "
                f"stitch makes one loop, not a second on {pos[0]}{pos[1]}",
                UNKNOWN_SPAN,
                "move the loop with `xfer` instead",
            )

    def _rack(self, r: float) -> None:
        try:
            self.bed.set_rack(r)
        except Unsupported:
            raise EvalError(
                "E721",
                f"racking {show(r)} is beyond the machine's limit of {self.bed.max_rack}",
                UNKNOWN_SPAN,
                "move loops by fewer needles, or raise `machine { racking: ... }`",
            ) from None

    # -- the machine operations
    def knit(self, dir=_UNSET, needle=_UNSET, carriers=_UNSET) -> None:
        d, pos = self._dir(dir), self._needle(needle, self.pos)
        self._carriers(carriers)
        self._one_loop(pos)
        self._mine(pos, "cannot knit on")
        if self.bed.loops.get(pos, 0):
            cast.emit(self.ctx, "knit", d, pos, self.s, self.plain)
        else:
            cast.emit(
                self.ctx, "tuck", d, pos, self.s, empty_needle_number(self.gen, self.s, self.plain)
            )

    def tuck(self, dir=_UNSET, needle=_UNSET, carriers=_UNSET) -> None:
        d, pos = self._dir(dir), self._needle(needle, self.pos)
        self._carriers(carriers)
        self._one_loop(pos)
        self._mine(pos, "cannot tuck on")
        cast.emit(self.ctx, "tuck", d, pos, self.s, self.plain)

    def miss(self, dir=_UNSET, needle=_UNSET, carriers=_UNSET) -> None:
        d, pos = self._dir(dir), self._needle(needle, self.pos)
        self._carriers(carriers)
        cast.emit(self.ctx, "miss", d, pos, self.s)

    def kickback(self, dir=_UNSET, needle=_UNSET, carriers=_UNSET) -> None:
        d, pos = self._dir(dir), self._needle(needle, self.pos)
        self._carriers(carriers)
        self._one_loop(pos)
        self._mine(pos, "cannot knit on")
        number = self.gen.opts.numbers.increase
        cast.emit(self.ctx, "miss", d, pos, self.s)
        cast.emit(
            self.ctx, "knit" if self.bed.loops.get(pos, 0) else "tuck", -d, pos, self.s, number
        )

    def xfer(self, source=_UNSET, target=_UNSET) -> None:
        a, b = self._needle(source), self._needle(target)
        if a[0] == b[0]:
            raise EvalError(
                "E724",
                f"a transfer goes to the other bed: {a[0]}{a[1]} and "
                f"{b[0]}{b[1]} are both on the {_bed_name(a)} bed",
                UNKNOWN_SPAN,
                "transfer to `opposite` (or a needle near it), then back",
            )
        if not self.bed.loops.get(a, 0):
            return  # nothing to move (e.g. a loop a previous course left on the other bed)
        self._mine(a, "cannot transfer from")
        self._mine(b, "cannot transfer onto")
        self.bed.prog.stitch_number(self.gen.opts.numbers.transfer)
        self._rack(_racking(a, b))
        self.bed.xfer(a, b, self.s)
        if a in self.cast_on:
            self.cast_on.discard(a)
            self.cast_on.add(b)

    def split(self, dir=_UNSET, needle=_UNSET, to=_UNSET, carriers=_UNSET) -> None:
        d, src = self._dir(dir), self._needle(needle)
        dst = self._needle(to, ("b" if src[0] == "f" else "f", src[1]))
        self._carriers(carriers)
        if src[0] == dst[0]:
            raise EvalError(
                "E724",
                f"a split sends the old loop to the other bed: "
                f"{src[0]}{src[1]} and {dst[0]}{dst[1]} are both on the "
                f"{_bed_name(src)} bed",
                UNKNOWN_SPAN,
            )
        self._one_loop(src)
        self._mine(src, "cannot split on")
        self._mine(dst, "cannot split onto")
        bed = self.bed
        if not bed.loops.get(src, 0):  # no old loop to split: a loop laid onto the needle
            cast.emit(
                self.ctx, "tuck", d, src, self.s, empty_needle_number(self.gen, self.s, self.plain)
            )
            return
        self._rack(_racking(src, dst))
        bed.prog.stitch_number(self.gen.opts.numbers.increase)
        bed.prog.split(
            d,
            needle_of(src),
            needle_of(dst),
            (self.ctx.carrier,),
            stitch=self.s,
            span=bed.span(self.s),
        )
        bed.loops[dst] += bed.loops.pop(src, 0)
        moved = bed.at.pop(src, set())
        for x in moved:  # the old loops keep their stitches
            bed.where[x] = dst
            bed.at[dst].add(x)
        if src in self.cast_on or self.s in moved:  # its cast-on loop: held, of no stitch
            self.cast_on.discard(src)
            self.cast_on.add(dst)
        bed.loops[src] = 1
        bed.place(self.s, src)
        bed.carrier_at[self.ctx.carrier] = src[1] + 0.5 * d

    def drop(self, needle=_UNSET) -> None:
        pos = self._needle(needle)
        self._mine(pos, "cannot drop")
        if self.bed.loops.get(pos, 0):
            self.bed.drop(pos, self.s)

    def rack(self, r=_UNSET) -> None:
        if (
            isinstance(r, bool)
            or not isinstance(r, int | float)
            or (r - np.floor(r)) not in (0, 0.25)
        ):
            raise EvalError(
                "E723",
                f"a racking is a whole number of needles (or that plus "
                f"0.25, the quarter pitch), got {_show(r)}",
                UNKNOWN_SPAN,
            )
        self._rack(int(r) if float(r).is_integer() else float(r))


def _racking(a: Pos, b: Pos) -> int:
    """The racking at which `a` and `b` (on different beds) face each other."""
    front, back = (a, b) if a[0] == "f" else (b, a)
    return front[1] - back[1]


def _bed_name(p: Pos) -> str:
    return "front" if p[0] == "f" else "back"


def _show(v: object) -> str:
    if v is _UNSET:
        return "nothing"
    if isinstance(v, ActionNeedle | StitchInfo) or v is None:
        return "the stitch record" if isinstance(v, StitchInfo) else str(v)
    return show(v) if not isinstance(v, Word) else f"`{v.name}`"
