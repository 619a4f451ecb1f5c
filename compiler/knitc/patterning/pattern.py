"""The pattern pass: pattern layers → an instruction on every stitch (thesis ch. 5.3, 6.9).

Layers run in the order of ch. 5.3: the global `pattern before` layers, then each node's
layers in source order, then `pattern after`; later writes win. Statements:

- `set P where Q` writes instruction P on the stitches Q selects (`patterning.query`);
- `let NAME = Q` names a selection for the layer's later statements;
- `apply DEF(args) where Q` runs a pattern definition on the selection: its statements
  select within the caller's selection, with the definition's formals bound to the
  arguments (bare names in its queries and filters), and its courses and wales count from
  the selection's corner (`query.relative`), so a rib or a cable applied to a panel
  starts its repeat at the panel's edge;
- `use ACTION where Q` attaches a stitch action (`patterning.actions`);
- `draw` / `stretch` / `tile GRID where Q` write a drawn grid of instructions
  (`patterning.drawing`).

Every write also records the statement in the graph's `origin`, so later warnings about a
stitch's pattern point at the line that wrote it. The pass never creates or deletes
stitches: it returns the same graph with new `instr`, `action` and `origin` arrays.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from typing import cast

import numpy as np

from knitc import arrays
from knitc.diagnostics import Diagnostics, Note
from knitc.frontend import ast
from knitc.frontend import skeleton as sk
from knitc.lang.evaluate import EvalError, Evaluator, Value, Word
from knitc.limits import MACHINE_CARRIERS
from knitc.patterning import actions, drawing
from knitc.patterning.query import (
    Coords,
    QueryEnv,
    bind_let,
    coords,
    evaluate_query,
    relative,
)
from knitc.records import record
from knitc.shaping.stitch_graph import (
    BACKINGS,
    COURSE_KINDS,
    INSTRUCTIONS,
    INTARSIA,
    TWO_BED,
    StitchGraph,
    two_bed,
)
from knitc.source import Span

MAX_DEPTH = 32
"""Nested `apply`s deeper than this are a pattern applying itself (E707)."""

MAX_APPLIES = 10_000
"""`apply`s one design may expand in all (E707): depth alone does not bound them, a
definition applying the next one twice, 30 deep, expands 2^30 times."""


def apply_patterns(skel: sk.Skeleton, g: StitchGraph, diags: Diagnostics) -> StitchGraph:
    assert g.origin is not None  # filled in by StitchGraph.__post_init__
    if not skel.layers:  # (nothing to query: no stitch coordinates, no copies of the arrays)
        return g
    run = _Run(skel, g, diags, g.instr.copy(), g.action.copy(), g.origin.copy(), list(g.spans))
    names = tuple(y.name for y in skel.yarn_list)
    run.yarn_index = {name: i for i, name in enumerate(names)}
    before = [la for la in skel.layers if la.target == "before"]
    after = [la for la in skel.layers if la.target == "after"]
    nodes = [la for la in skel.layers if la.target not in ("before", "after")]
    for layer in before + nodes + after:
        node = None
        if layer.target not in ("before", "after"):
            if layer.target not in g.node_names:
                continue
            node = g.node_names.index(layer.target)
        # the statements of one `pattern X { ... }` block share its `let`s
        env = run.envs.setdefault(layer.origin, QueryEnv(params=dict(skel.params), lets={}))
        run.stmts((layer.stmt,), node, env, None, 0)
    if run.yarn is None and run.backing is None and run.inlay is None:
        return dataclasses.replace(
            g, instr=run.instr, action=run.action, origin=run.origin, spans=run.spans
        )
    if run.yarn is None:
        run.yarn = np.zeros(g.n_stitches, np.int8)
        run.yarn_origin = np.full(g.n_stitches, -1, np.int32)
    _check_fair_isle(run)
    _check_backing(run)
    return dataclasses.replace(
        g,
        instr=run.instr,
        action=run.action,
        origin=run.origin,
        spans=run.spans,
        yarn=run.yarn,
        yarn_names=names,
        yarn_origin=run.yarn_origin,
        backing=run.backing,
        backing_origin=run.backing_origin,
        inlay=run.inlay,
        inlay_origin=run.inlay_origin,
    )


def _check_fair_isle(run: _Run) -> None:
    """A course of several yarns (fair isle) is knitted yarn by yarn, each yarn knitting
    its own stitches and floating behind the others: that is lowered for plain knit
    stitches of regular courses only. A mixed course with purls, tucks, moves, actions,
    increases or short rows is E711, at the `knit` statement that last changed a yarn in
    it. A jacquard course (`backing`) is knitted in the same way, with its backing on the
    other bed, and has the same rule (intarsia, which would knit those, is not lowered
    yet)."""
    g, yarn, where = run.g, run.yarn, run.yarn_origin
    assert yarn is not None and where is not None
    if g.n_stitches == 0:
        return
    first = np.repeat(yarn[g.course_start], g.course_len)
    mixed = arrays.unique(g.course[yarn != first])
    if run.backing is not None:  # a jacquard course knits every yarn of its region
        mixed = arrays.union(mixed, g.course[run.backing >= TWO_BED])
    if mixed.size == 0:
        return
    increase = np.zeros(g.n_stitches, bool)
    forks = np.nonzero((g.wale_next >= 0).sum(axis=1) == 2)[0]
    kids = g.wale_next[forks].ravel()
    increase[kids[kids >= 0]] = True
    by_stmt: dict[int, list[tuple[int, str]]] = {}  # statement -> (course, why), in order
    for c in mixed.tolist():
        ids = g.course_ids(c)
        why = ""
        if COURSE_KINDS[int(g.course_kind[c])] in ("short_row", "continuity"):
            why = "short rows"
        elif np.any(run.instr[ids] != 0):
            names = sorted({INSTRUCTIONS[int(i)] for i in run.instr[ids] if i != 0})
            why = "/".join(names) + " stitches"
        elif np.any(run.action[ids] >= 0):
            why = "stitch actions"
        elif np.any(increase[ids]):
            why = "increases"
        if why:
            k = where[ids]
            if not (k >= 0).any() and run.backing_origin is not None:
                k = run.backing_origin[ids]  # a jacquard course of one yarn here
            by_stmt.setdefault(int(k[k >= 0][-1]), []).append((c, why))
    for k, bad in by_stmt.items():
        c, why = bad[0]
        ids = g.course_ids(c)
        used = [run.g_names[int(y)] for y in arrays.unique(yarn[ids]).tolist()]
        node = g.node_names[int(g.course_node[c])]
        more = f" (and {len(bad) - 1} more course{'s' * (len(bad) > 2)})"
        run.diags.error(
            "E711",
            f"course {c - _node_first_course(g, c)} of `{node}` is knitted with "
            + " and ".join(f"`{u}`" for u in used)
            + f" and has {why}"
            + (more if len(bad) > 1 else ""),
            run.spans[k],
            hint="a course of several yarns (fair isle, jacquard) knits plain stitches "
            "only, each yarn floating or knitting its backing behind the others' "
            "stitches; keep its purls, moves, actions and shaping in courses of one yarn",
        )


def _check_backing(run: _Run) -> None:
    """A jacquard backing knits on the needles behind the course's stitches. A sheet leaves
    them free, and so does a half-gauge tube (every other needle, on both beds); a
    full-gauge tube knits its other side there: a two-bed backing on it is E719, at the
    `backing` statement (a tube's colourwork floats: fair isle, or `backing float`). On a
    half-gauge tube the band must also be unshaped (E719 too): a tube's shaping moves
    loops around the whole round between its slices, across the back layer's needles."""
    g, backing, where = run.g, run.backing, run.backing_origin
    if backing is None or where is None or g.n_stitches == 0:
        return
    _check_intarsia(run)
    tube = two_bed(backing) & g.course_circular[g.course]
    if not tube.any():
        return
    kids = (g.wale_next >= 0).sum(axis=1)
    only = np.maximum(g.wale_next.max(axis=1), 0)
    straight = (kids == 1) & ((g.wale_prev[only] >= 0).sum(axis=1) == 1)
    bent = np.zeros(g.n_courses, bool)
    bent[g.course[~straight & (kids > 0)]] = True  # (a last course has no wales to bend)
    full = g.course_gauge[g.course] == 1
    for bad, why, hint in (
        (
            tube & full,
            "`{node}` is a full-gauge tube: its other side is knitted there",
            "knit `{node}` in half gauge (`gauge: half`), which leaves the needles behind "
            "both sides free, or let its yarns float (fair isle, `backing float`)",
        ),
        (
            tube & ~full & bent[g.course],
            "`{node}` is shaped in the band, and a tube's shaping moves its loops across "
            "the back layer's needles",
            "keep the tube's increases and decreases out of the jacquard band, or let its "
            "yarns float (fair isle, `backing float`)",
        ),
    ):
        for k in arrays.unique(where[bad]).tolist():
            sel = bad & (where == k)
            c = int(g.course[np.argmax(sel)])
            node = g.node_names[int(g.course_node[c])]
            kind = BACKINGS[int(backing[np.argmax(sel)])]
            run.diags.error(
                "E719",
                f"a `{kind}` backing knits on the needles behind the fabric, but "
                + why.format(node=node),
                run.spans[k],
                hint=hint.format(node=node),
            )


def _check_intarsia(run: _Run) -> None:
    """Intarsia is knitted between courses of one yarn: a region's yarn is brought in over
    the loops below it and taken out under the loops above it, so an intarsia course that
    casts on or binds off stitches is E730."""
    g, backing, where = run.g, run.backing, run.backing_origin
    assert backing is not None and where is not None and run.yarn is not None
    mine = backing == INTARSIA
    if not mine.any():
        return
    _check_intarsia_courses(run, mine)
    course = np.zeros(g.n_courses, bool)
    course[g.course[mine]] = True
    on = course[g.course]  # every stitch of an intarsia course
    bad = on & ((g.wale_prev[:, 0] < 0) | (g.wale_next < 0).all(axis=1))
    if not bad.any():
        return
    first = int(np.argmax(bad))
    c = int(g.course[first])
    k = where[(g.course == c) & mine]
    k = k[k >= 0]
    what = "casts on" if g.wale_prev[first, 0] < 0 else "binds off"
    run.diags.error(
        "E730",
        f"course {c - _node_first_course(g, c)} of `{g.node_names[int(g.course_node[c])]}` "
        f"is intarsia and {what} stitches",
        run.spans[int(k[-1])] if k.size else None,
        hint="keep a course of one yarn below and above an intarsia band: its regions' "
        "yarns come in over the loops below and go out under the loops above",
    )


def _check_intarsia_courses(run: _Run, mine: np.ndarray) -> None:
    """A course is intarsia or jacquard, not both (E731: its regions' carriers would have
    to knit a back layer they do not pass over); and an intarsia course has a carrier per
    run of one yarn, no more runs than the machine's carriers beside the yarn resting at
    the side (E732)."""
    g, backing, where, yarn = run.g, run.backing, run.backing_origin, run.yarn
    assert backing is not None and where is not None and yarn is not None
    band = np.zeros(g.n_courses, bool)
    band[g.course[mine]] = True
    both = band[g.course] & two_bed(backing)
    if both.any():
        s = int(np.argmax(both))
        c = int(g.course[s])
        run.diags.error(
            "E731",
            f"course {c - _node_first_course(g, c)} of `{g.node_names[int(g.course_node[c])]}` "
            "is both intarsia and jacquard",
            run.spans[int(where[s])],
            hint="a course is knitted one way: keep the `backing` and the `intarsia` "
            "selections apart",
        )
    changes = np.zeros(g.n_courses, np.int64)
    nxt = g.cnext
    has = band[g.course] & (nxt >= 0)
    np.add.at(changes, g.course[has], yarn[has] != yarn[nxt[has]])
    runs = np.where(g.course_circular, np.maximum(changes, 1), changes + 1)
    room = MACHINE_CARRIERS - 1
    over = band & (runs > room)
    if over.any():
        c = int(np.argmax(over))
        k = where[(g.course == c) & mine]
        run.diags.error(
            "E732",
            f"course {c - _node_first_course(g, c)} of `{g.node_names[int(g.course_node[c])]}` "
            f"has {int(runs[c])} intarsia regions side by side, each a carrier of its own, "
            f"and the machine has {room} beside the yarn resting at the side",
            run.spans[int(k[k >= 0][-1])],
            hint="merge small regions of one yarn, or knit small motifs as fair isle",
        )


def _shown(v: object) -> str:
    """A value as a message shows it."""
    return f'"{v}"' if isinstance(v, str) else repr(v)


def _node_first_course(g: StitchGraph, c: int) -> int:
    """The first course of course c's node (courses count from it in messages)."""
    node = g.course_node[c]
    return int(np.argmax(g.course_node == node))


@record
class _Run:
    skel: sk.Skeleton
    g: StitchGraph
    diags: Diagnostics
    instr: np.ndarray
    action: np.ndarray
    origin: np.ndarray
    spans: list
    envs: dict = dataclasses.field(default_factory=dict)
    warned: set = dataclasses.field(default_factory=set)
    coords: Coords | None = None
    span_ids: dict = dataclasses.field(default_factory=dict)
    chain: list = dataclasses.field(default_factory=list)
    """The `apply` statements being expanded, outermost first."""
    yarn: np.ndarray | None = None
    """The yarn of each stitch, once a `knit` statement has run (`StitchGraph.yarn`)."""
    yarn_origin: np.ndarray | None = None
    """The `spans` index of the `knit` statement that last set each stitch's yarn."""
    backing: np.ndarray | None = None
    """Each stitch's jacquard backing, once a `backing` statement has run
    (`StitchGraph.backing`)."""
    backing_origin: np.ndarray | None = None
    """The `spans` index of the `backing` statement that last set each stitch's backing."""
    inlay: np.ndarray | None = None
    """Each stitch's inlay yarn, once a `knit` of an inlay yarn has run (`StitchGraph.inlay`)."""
    inlay_origin: np.ndarray | None = None
    yarn_index: dict = dataclasses.field(default_factory=dict)

    @property
    def g_names(self) -> list[str]:
        return list(self.yarn_index)

    applied: int = 0
    """`apply` statements expanded so far (`MAX_APPLIES`)."""

    def __post_init__(self) -> None:
        self.coords = coords(self.g)  # once for every query of every layer

    def mark(self, mask: np.ndarray, span: Span) -> None:
        """Record `span` (a pattern statement) as the origin of the stitches in `mask`;
        inside applied definitions, chained to the `apply` statements it expanded from
        (`Span.parent`), the designer's own `apply` outermost."""
        self.origin[mask] = self.span_id(span)

    def span_id(self, span: Span) -> int:
        """The `spans` index of `span` as expanded from the `apply`s in progress."""
        chain = (*self.chain, span)
        k = self.span_ids.get(chain)
        if k is None:
            k = self.span_ids[chain] = len(self.spans)
            self.spans.append(Span.expanded(chain))
        return k

    def stmts(
        self, body, node: int | None, env: QueryEnv, within: np.ndarray | None, depth: int
    ) -> None:
        for stmt in body:
            if isinstance(stmt, ast.Let):
                env.lets[stmt.name.name] = bind_let(stmt.value, env.lets)  # type: ignore[index]
            elif isinstance(stmt, ast.SetStmt):
                mask = self.select(node, stmt.where, env, within)
                self.instr[mask] = INSTRUCTIONS.index(stmt.instr)
                self.mark(mask, stmt.span)
            elif isinstance(stmt, ast.ApplyStmt):
                self.apply(stmt, node, env, within, depth)
            elif isinstance(stmt, ast.UseStmt):
                actions.attach(self, stmt, node, env, within)
            elif isinstance(stmt, ast.KnitStmt):
                self.knit_with(stmt, node, env, within)
            elif isinstance(stmt, ast.BackingStmt):
                self.back_with(stmt, node, env, within)
            elif isinstance(stmt, ast.IntarsiaStmt):
                self.set_backing(self.select(node, stmt.where, env, within), INTARSIA, stmt.span)
            elif isinstance(stmt, ast.GridStmt):
                drawing.apply_grid(self, stmt, node, env, within)

    def knit_with(
        self, stmt: ast.KnitStmt, node: int | None, env: QueryEnv, within: np.ndarray | None
    ) -> None:
        """`knit YARN where Q`: the selected stitches take the yarn (in a definition,
        `YARN` may be a parameter bound to a yarn's name, `apply checks("red")`)."""
        name = stmt.yarn.name
        if env.values and name in env.values:
            bound = env.values[name]
            k = self.yarn_index.get(bound) if isinstance(bound, str) else None
            if k is None:
                self.diags.error(
                    "E228",
                    f"`{name}` is {_shown(bound)}, not the name of a yarn",
                    self.chain[-1] if self.chain else stmt.yarn.span,
                    notes=[Note("used by this `knit`", stmt.yarn.span)],
                    hint="pass a declared yarn's name in quotes, e.g. "
                    + (f'"{next(iter(self.yarn_index))}"' if self.yarn_index else '"main"')
                    + " (yarns: "
                    + ", ".join(self.yarn_index or ["main"])
                    + ")",
                )
                return
        else:
            k = self.yarn_index.get(name)
        if k is None:
            return  # the resolver reported it (E228)
        mask = self.select(node, stmt.where, env, within)
        if self.skel.yarn_list[k].inlay:  # laid in over the stitches, not knitting them
            if self.inlay is None or self.inlay_origin is None:
                self.inlay = np.zeros(self.g.n_stitches, np.int8)
                self.inlay_origin = np.full(self.g.n_stitches, -1, np.int32)
            self.inlay[mask] = k
            self.inlay_origin[mask] = self.span_id(stmt.span)
            return
        self.set_yarn(mask, k, stmt.span)

    def back_with(
        self, stmt: ast.BackingStmt, node: int | None, env: QueryEnv, within: np.ndarray | None
    ) -> None:
        """`backing KIND where Q`: the selected stitches' courses are jacquard."""
        if stmt.kind.name not in BACKINGS[1:INTARSIA]:
            return  # the resolver reported it (E229)
        mask = self.select(node, stmt.where, env, within)
        self.set_backing(mask, BACKINGS.index(stmt.kind.name), stmt.span)

    def set_backing(self, mask: np.ndarray, kind: int, span: Span) -> None:
        """The stitches in `mask` take backing `kind` (`BACKINGS`), written at `span`."""
        if self.backing is None or self.backing_origin is None:
            self.backing = np.zeros(self.g.n_stitches, np.int8)
            self.backing_origin = np.full(self.g.n_stitches, -1, np.int32)
        self.backing[mask] = kind
        self.backing_origin[mask] = self.span_id(span)

    def set_yarn(self, mask: np.ndarray, yarn: int | np.ndarray, span: Span) -> None:
        """The stitches in `mask` take `yarn` (a yarn index, or one per stitch), written by
        the statement at `span`."""
        if self.yarn is None or self.yarn_origin is None:
            self.yarn = np.zeros(self.g.n_stitches, np.int8)
            self.yarn_origin = np.full(self.g.n_stitches, -1, np.int32)
        self.yarn[mask] = yarn if isinstance(yarn, int) else yarn[mask]
        self.yarn_origin[mask] = self.span_id(span)

    def select(
        self, node: int | None, where, env: QueryEnv, within: np.ndarray | None
    ) -> np.ndarray:
        mask = evaluate_query(self.g, node, where, env, self.diags, c=self.coords, within=within)
        return mask if within is None else mask & within

    def apply(
        self,
        stmt: ast.ApplyStmt,
        node: int | None,
        env: QueryEnv,
        within: np.ndarray | None,
        depth: int,
    ) -> None:
        pdef = self.skel.patterns.get(stmt.pattern.name)
        if pdef is None:
            return  # the resolver reported it
        if depth >= MAX_DEPTH:
            self.diags.error(
                "E707",
                f"`{pdef.name.name}` applies patterns more than {MAX_DEPTH} deep",
                stmt.span,
                hint="a pattern that applies itself never ends",
            )
            return
        self.applied += 1
        if self.applied > MAX_APPLIES:
            if self.applied == MAX_APPLIES + 1:  # once: every further `apply` stops here too
                self.diags.error(
                    "E707",
                    f"the design applies patterns more than {MAX_APPLIES:,} times",
                    self.chain[0] if self.chain else stmt.span,
                    hint="a definition that applies another one twice, many levels deep, "
                    "doubles the count at each level",
                )
            return
        values = self.arguments(pdef, stmt, env)
        if values is None:
            return
        sel = self.select(node, stmt.where, env, within)
        inner = QueryEnv(params=env.params, lets={}, values=values)
        self.chain.append(stmt.span)
        outer = self.coords
        assert outer is not None  # set by __post_init__
        self.coords = relative(self.g, outer, sel)  # the definition counts from its corner
        self.stmts(pdef.body, node, inner, sel, depth + 1)
        self.coords = outer
        self.chain.pop()

    def arguments(
        self, pdef: ast.PatternDef, stmt: ast.ApplyStmt, env: QueryEnv
    ) -> dict[str, object] | None:
        """The formals bound to the call's arguments (positional, then by name, then the
        defaults), evaluated as constants; None after an error."""

        def param(name, span):
            if name in env.params:
                return env.params[name]
            raise EvalError("E704", f"unknown parameter `#{name}`", span)

        def prop(node, name, span):
            raise EvalError("E703", "node properties cannot be pattern arguments", span)

        ev = _ArgumentEvaluator(param, prop, env.values)
        given: dict[str, ast.Node] = {}
        formals = [f.name.name for f in pdef.params]
        for i, a in enumerate(stmt.args):
            if isinstance(a, ast.KwArg):
                given[a.name.name] = a.value
            elif i < len(formals):
                given[formals[i]] = a
        values: dict[str, object] = {}
        try:
            for f in pdef.params:
                e = given.get(f.name.name, f.default)
                if e is None:
                    self.diags.error(
                        "E703", f"`{pdef.name.name}` needs argument `{f.name.name}`", stmt.span
                    )
                    return None
                v = ev.eval(e)
                values[f.name.name] = v.name if isinstance(v, Word) else v
        except EvalError as err:
            self.diags.error(err.code, err.message, err.span)
            return None
        return values


class _ArgumentEvaluator(Evaluator):
    """Evaluates an `apply`'s arguments: inside a definition, a bare name that is one of
    its own formals is that formal's value (`apply p(n + 1)` passes a number on), any
    other bare name a word."""

    def __init__(self, param, prop, formals: Mapping[str, object]) -> None:
        super().__init__(param, prop)
        self.formals = formals

    def _Name(self, e: ast.Name) -> Value:
        if e.id in self.formals:
            return cast(Value, self.formals[e.id])
        return super()._Name(e)
