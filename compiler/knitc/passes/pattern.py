"""The pattern pass: pattern layers → an instruction on every stitch (thesis ch. 5.3, 6.9).

Layers run in the order of ch. 5.3: the global `pattern before` layers, then each node's
layers in source order, then `pattern after`; later writes win. Statements:

- `set P where Q` writes instruction P on the stitches Q selects (`passes.query`);
- `let NAME = Q` names a selection for the layer's later statements;
- `apply DEF(args) where Q` runs a pattern definition on the selection: its statements
  select within the caller's selection, with the definition's formals bound to the
  arguments (bare names in its queries and filters). Its queries count courses and wales
  from the node, not from the selection: the same as the original's for the whole node
  (the common `apply rib(1, 1)`), an approximation for partial selections;
- `use ACTION` and the drawn layers (`draw`, `stretch`, `tile`) are not applied yet: each
  says so with warning W706, never silently.

The pass never creates or deletes stitches: it returns the same graph with a new `instr`.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from knitc.diagnostics import Diagnostics
from knitc.evaluate import EvalError, Evaluator, Word
from knitc.ir import skeleton as sk
from knitc.ir.stitch_graph import INSTRUCTIONS, StitchGraph
from knitc.passes.query import Coords, QueryEnv, coords, evaluate_query
from knitc.syntax import ast

MAX_DEPTH = 32
"""Nested `apply`s deeper than this are a pattern applying itself (E707)."""


def apply_patterns(skel: sk.Skeleton, g: StitchGraph, diags: Diagnostics) -> StitchGraph:
    instr = g.instr.copy()
    run = _Run(skel, g, diags, instr)
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
    return dataclasses.replace(g, instr=instr)


@dataclasses.dataclass
class _Run:
    skel: sk.Skeleton
    g: StitchGraph
    diags: Diagnostics
    instr: np.ndarray
    envs: dict = dataclasses.field(default_factory=dict)
    warned: set = dataclasses.field(default_factory=set)
    coords: Coords | None = None

    def __post_init__(self) -> None:
        self.coords = coords(self.g)  # once for every query of every layer

    def stmts(self, body, node: int | None, env: QueryEnv, within: np.ndarray | None,
              depth: int) -> None:
        for stmt in body:
            if isinstance(stmt, ast.Let):
                env.lets[stmt.name.name] = stmt.value  # type: ignore[index]
            elif isinstance(stmt, ast.SetStmt):
                mask = self.select(node, stmt.where, env, within)
                self.instr[mask] = INSTRUCTIONS.index(stmt.instr)
            elif isinstance(stmt, ast.ApplyStmt):
                self.apply(stmt, node, env, within, depth)
            elif stmt.span not in self.warned:
                self.warned.add(stmt.span)
                what = "stitch actions (`use`)" if isinstance(stmt, ast.UseStmt) else \
                    f"drawn layers (`{stmt.mode}`)"
                self.diags.warning("W706", f"{what} are not applied yet: these stitches keep "
                                   "their other instructions", stmt.span,
                                   hint="write the motif with `set` statements for now")

    def select(self, node: int | None, where, env: QueryEnv,
               within: np.ndarray | None) -> np.ndarray:
        mask = evaluate_query(self.g, node, where, env, self.diags, c=self.coords)
        return mask if within is None else mask & within

    def apply(self, stmt: ast.ApplyStmt, node: int | None, env: QueryEnv,
              within: np.ndarray | None, depth: int) -> None:
        pdef = self.skel.patterns.get(stmt.pattern.name)
        if pdef is None:
            return  # the resolver reported it
        if depth >= MAX_DEPTH:
            self.diags.error("E707", f"`{pdef.name.name}` applies patterns more than "
                             f"{MAX_DEPTH} deep", stmt.span,
                             hint="a pattern that applies itself never ends")
            return
        values = self.arguments(pdef, stmt, env)
        if values is None:
            return
        sel = self.select(node, stmt.where, env, within)
        inner = QueryEnv(params=env.params, lets={}, values=values)
        self.stmts(pdef.body, node, inner, sel, depth + 1)

    def arguments(self, pdef: ast.PatternDef, stmt: ast.ApplyStmt,
                  env: QueryEnv) -> dict[str, object] | None:
        """The formals bound to the call's arguments (positional, then by name, then the
        defaults), evaluated as constants; None after an error."""
        def param(name, span):
            if name in env.params:
                return env.params[name]
            raise EvalError("E704", f"unknown parameter `#{name}`", span)

        def prop(node, name, span):
            raise EvalError("E703", "node properties cannot be pattern arguments", span)

        ev = Evaluator(param, prop)
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
                    self.diags.error("E703", f"`{pdef.name.name}` needs argument "
                                     f"`{f.name.name}`", stmt.span)
                    return None
                v = ev.eval(e)
                values[f.name.name] = v.name if isinstance(v, Word) else v
        except EvalError as err:
            self.diags.error(err.code, err.message, err.span)
            return None
        return values
