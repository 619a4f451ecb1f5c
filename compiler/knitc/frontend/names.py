"""Name checking of bodies: the scopes of pattern layers, action steps and shaper
programs (what each may name), and `NameChecker`, which the resolver runs on them."""

from __future__ import annotations

from collections.abc import Callable

from knitc.diagnostics import Diagnostics, Note
from knitc.frontend import ast
from knitc.frontend import skeleton as sk
from knitc.frontend.definitions import _Defs, _suggest
from knitc.lang.evaluate import (
    BUILTINS,
    Value,
)
from knitc.patterning.raster import cell_problems
from knitc.shaping.stitch_graph import BACKINGS, INSTRUCTIONS, INTARSIA

# ---- scopes for pattern, action and shaper bodies ----------------------------------------------

QUERY_FUNCTIONS = {
    "all": (0, 0),
    "filter": (1, 1),
    "wales": (1, 2),
    "courses": (1, 1),
    "select": (2, 3),
    "side": (1, 1),
    "neighbors": (0, 1),
    "boundaries": (0, 0),
    "named": (0, 0),
    "shape": (1, 1),
    "itf": (1, 1),
    "stretch": (1, 2),
    "tile": (1, 2),
    "img": (1, 3),
    "noise": (1, 3),
    "wale_grid": (0, 2),
    "stitch_grid": (2, 4),
}
"""Pattern queries of thesis Table 5.1, with their (min, max) positional arity."""

STITCH_FIELDS = ("course", "wale", "course_end", "wale_end", "side", "gauge", "node", "index")
"""Names a `filter(...)` predicate can read from each stitch."""

QUERY_WORDS = ("front", "back", "end")

ACTION_CONTEXT = ("needle", "opposite", "dir", "carriers", "position", "stitch", "side")
ACTION_FUNCTIONS = {
    "knit": (1, 3),
    "tuck": (1, 3),
    "miss": (1, 3),
    "xfer": (2, 2),
    "split": (2, 4),
    "drop": (1, 1),
    "kickback": (0, 3),
    "rack": (1, 1),
    "range": (1, 3),
    "len": (1, 1),
}
ACTION_WORDS = ("left", "right", "front", "back")
SHAPER_CONTEXT = ("turn",)
"""Names a shaper program can read besides its parameters (`shaping.shapers`)."""
BUILTIN_ACTIONS = ("knit", "purl", "tuck", "miss", "kickback", "split")
SHAPER_FUNCTIONS = {"range": (1, 3), "len": (1, 1)}


class NameChecker:
    """Checks the names used inside pattern layers, action steps and shaper programs against
    what each context can see (its scope: parameters, formals, `let`s, the context names
    and functions above), so their mistakes surface at resolution rather than when the
    pattern pass or code generation runs them."""

    def __init__(
        self,
        module: ast.Module,
        diags: Diagnostics,
        defs: _Defs,
        node_decls: dict[str, ast.NodeDecl],
        param_decls: dict[str, ast.ParamDecl],
        props_block: Callable[..., dict[str, Value]],
    ) -> None:
        self.module = module
        self.diags = diags
        self.defs = defs
        self.node_decls = node_decls
        self.param_decls = param_decls
        self._props_block = props_block
        self.yarns: set[str] = {sk.MAIN_YARN}
        """Yarn names `knit NAME` may use (set by the resolver once it has read them)."""

    def layers(self, skel: sk.Skeleton) -> None:
        for item in self.module.items:
            if not isinstance(item, ast.PatternLayer):
                continue
            target = item.target.name
            if target not in ("before", "after") and target not in skel.nodes:
                self.diags.error(
                    "E216",
                    f"pattern for unknown node `{target}`",
                    item.target.span,
                    hint=_suggest(target, list(skel.nodes) + ["before", "after"])
                    or "write `pattern NODE { ... }`, `pattern before { ... }` "
                    "or `pattern after { ... }`",
                )
                continue
            self.check_layer_body(item.body, set(), ())
            for stmt in item.body:
                skel.layers.append(sk.Layer(target, stmt, item.span))

    def check_layer_body(self, body, params: set[str], formals) -> None:
        for f in formals:
            if f.default is not None:
                self._check_expr(f.default, "decl", set())
        scope = set(params)
        for stmt in body:
            if isinstance(stmt, ast.Let):
                self._check_expr(stmt.value, "query", scope)
                scope.add(stmt.name.name)
                continue
            where = getattr(stmt, "where", None)
            if where is not None:
                self._check_expr(where, "query", scope)
            if isinstance(stmt, ast.UseStmt):
                name = stmt.action.name
                if not self.defs.known(name) and name not in BUILTIN_ACTIONS:
                    self.diags.error(
                        "E217",
                        f"unknown action `{name}`",
                        stmt.action.span,
                        hint=_suggest(name, list(self.defs.actions) + list(BUILTIN_ACTIONS))
                        or "define it with `action NAME { ... }` or import it "
                        "(e.g. `import std.actions`)",
                    )
            elif isinstance(stmt, ast.KnitStmt):
                name = stmt.yarn.name  # a yarn, or a definition's parameter naming one
                if name not in self.yarns and name not in scope:
                    self.diags.error(
                        "E228",
                        f"unknown yarn `{name}`",
                        stmt.yarn.span,
                        hint=_suggest(name, sorted(self.yarns))
                        or f"declare it: `yarn {name} {{ carrier: 5 }}`",
                    )
            elif isinstance(stmt, ast.BackingStmt):
                kind = stmt.kind.name
                if kind not in BACKINGS[1:INTARSIA]:
                    self.diags.error(
                        "E229",
                        f"unknown backing `{kind}`",
                        stmt.kind.span,
                        hint=(
                            "did you mean `birdseye`? (the yarns alternate on the back)"
                            if kind.startswith("altern")
                            else "intarsia is a statement of its own: `intarsia where Q`"
                            if kind == "intarsia"
                            else _suggest(kind, list(BACKINGS[1:INTARSIA]))
                        )
                        or "a jacquard backing is one of " + ", ".join(BACKINGS[1:INTARSIA]),
                    )
            elif isinstance(stmt, ast.ApplyStmt):
                self._check_apply(stmt, scope)
            elif isinstance(stmt, ast.GridStmt):
                self._check_expr(stmt.grid, "query", scope)
                if isinstance(stmt.grid, ast.Grid):
                    self._check_grid(stmt.grid, stmt.mode)

    def _check_apply(self, stmt: ast.ApplyStmt, scope: set[str]) -> None:
        name = stmt.pattern.name
        d = self.defs.patterns.get(name)
        for a in stmt.args:
            self._check_expr(a.value if isinstance(a, ast.KwArg) else a, "query", scope)
        if d is None and self.defs.known(name):
            return
        if d is None:
            self.diags.error(
                "E218",
                f"unknown pattern `{name}`",
                stmt.pattern.span,
                hint=_suggest(name, self.defs.patterns)
                or "define it with `pattern NAME(...) { ... }` or import it "
                "(e.g. `import std.stitches`)",
            )
            return
        formals = [p.name.name for p in d.params]
        positional = [a for a in stmt.args if not isinstance(a, ast.KwArg)]
        if len(positional) > len(formals):
            self.diags.error(
                "E219",
                f"`{name}` takes at most {len(formals)} argument(s), got {len(positional)}",
                stmt.span,
                notes=[Note("defined here", d.name.span)],
            )
            return
        given = set(formals[: len(positional)])
        for a in stmt.args:
            if isinstance(a, ast.KwArg):
                if a.name.name not in formals:
                    self.diags.error(
                        "E219",
                        f"`{name}` has no parameter `{a.name.name}`",
                        a.name.span,
                        hint=_suggest(a.name.name, formals)
                        or (
                            "its parameters: " + ", ".join(formals)
                            if formals
                            else f"`{name}` takes no parameters"
                        ),
                    )
                given.add(a.name.name)
        missing = [p.name.name for p in d.params if p.default is None and p.name.name not in given]
        if missing:
            self.diags.error(
                "E219",
                f"`{name}` needs a value for " + ", ".join(f"`{m}`" for m in missing),
                stmt.span,
                notes=[Note("defined here", d.name.span)],
            )

    def _check_grid(self, grid: ast.Grid, mode: str) -> None:
        for kind, cell in cell_problems(grid, mode, self.yarns):
            if kind == "unknown":
                self.diags.error(
                    "E220",
                    f"`{cell.text}` is not a pattern instruction or a yarn",
                    cell.span,
                    hint=_suggest(cell.text, [*INSTRUCTIONS, *sorted(self.yarns)])
                    or "use K P T M FR1 FR2 FL1 FL2 BR1 BR2 BL1 BL2 XR+ XR- XL+ "
                    "XL- S, a declared yarn, or `.` to leave a stitch as it is",
                )
            else:
                self.diags.error(
                    "E315",
                    "a stretched grid cannot hold crosses",
                    cell.span,
                    hint="scaling would tear cable pairs apart; use `tile` or `draw`",
                )

    def _check_expr(self, e: ast.Node, ctx: str, scope: set[str]) -> None:
        """Report unknown names in an expression of a layer (`query`), an action or a shaper."""
        if isinstance(e, ast.Call) and isinstance(e.func, ast.Name):
            fname = e.func.id
            table = {
                "query": QUERY_FUNCTIONS,
                "action": ACTION_FUNCTIONS,
                "shaper": SHAPER_FUNCTIONS,
                "decl": {},
            }[ctx]
            arity = table.get(fname) or BUILTINS.get(fname, (None, None))[1]
            if arity is None:
                self.diags.error(
                    "E201",
                    f"unknown function `{fname}`",
                    e.func.span,
                    hint=_suggest(fname, list(table) + list(BUILTINS)),
                )
            else:
                n = sum(1 for a in e.args if not isinstance(a, ast.KwArg))
                lo, hi = arity
                if not lo <= n <= hi:
                    want = str(lo) if lo == hi else f"{lo} to {hi}"
                    self.diags.error("E304", f"`{fname}` takes {want} argument(s), got {n}", e.span)
            inner = scope
            if fname == "filter":
                inner = scope | set(STITCH_FIELDS)
            for a in e.args:
                if isinstance(a, ast.KwArg):
                    self._check_expr(a.value, ctx, inner)
                elif isinstance(a, ast.Range):
                    for part in (a.start, a.stop, a.step):
                        if part is not None:
                            self._check_expr(part, ctx, inner | {"end"})
                else:
                    self._check_expr(a, ctx, inner)
            return
        if isinstance(e, ast.Name):
            allowed = set(scope)
            if ctx == "query":
                allowed |= set(QUERY_WORDS)
            elif ctx == "action":
                allowed |= set(ACTION_CONTEXT) | set(ACTION_WORDS)
            elif ctx == "shaper":
                allowed |= set(SHAPER_CONTEXT)
            if e.id not in allowed:
                self.diags.error(
                    "E221",
                    f"unknown name `{e.id}`",
                    e.span,
                    hint=_suggest(e.id, allowed) or self._name_hint(ctx),
                )
            return
        if isinstance(e, ast.PropRef):
            if ctx != "decl" and e.node is not None and e.node not in self.node_decls:
                self.diags.error(
                    "E211",
                    f"unknown node `{e.node}`",
                    e.span,
                    hint=_suggest(e.node, self.node_decls),
                )
            return
        if isinstance(e, ast.ParamRef):
            if e.name not in self.param_decls:
                self.diags.error(
                    "E403",
                    f"unknown parameter `#{e.name}`",
                    e.span,
                    hint=_suggest(e.name, self.param_decls),
                )
            return
        if isinstance(e, ast.Attr):
            self._check_expr(e.obj, ctx, scope)
            return
        for child in e.children():
            self._check_expr(child, ctx, scope)

    @staticmethod
    def _name_hint(ctx: str) -> str:
        if ctx == "query":
            return (
                "stitch fields (course, wale, ...) are readable inside `filter(...)`; "
                "bind other names with `let`"
            )
        if ctx == "action":
            return "available: " + ", ".join(ACTION_CONTEXT) + ", and names bound with `let`"
        if ctx == "shaper":
            return (
                "available: M, N (the shaper's parameters), `turn`, and names bound with "
                "`let` or a `for` loop"
            )
        return "bind names with `let` or a `for` loop"

    def _check_block(self, block: ast.Block, ctx: str, scope: set[str]) -> None:
        scope = set(scope)
        for stmt in block.stmts:
            if isinstance(stmt, ast.Let):
                self._check_expr(stmt.value, ctx, scope)
                scope.add(stmt.name.name)
            elif isinstance(stmt, ast.Assign):
                if stmt.name.name not in scope:
                    self.diags.error(
                        "E222",
                        f"`{stmt.name.name}` is assigned before `let`",
                        stmt.name.span,
                        hint=f"declare it first: `let {stmt.name.name} = ...`",
                    )
                    scope.add(stmt.name.name)
                self._check_expr(stmt.value, ctx, scope)
            elif isinstance(stmt, ast.If):
                self._check_expr(stmt.cond, ctx, scope)
                self._check_block(stmt.then, ctx, scope)
                orelse = stmt.orelse
                while isinstance(orelse, ast.If):
                    self._check_expr(orelse.cond, ctx, scope)
                    self._check_block(orelse.then, ctx, scope)
                    orelse = orelse.orelse
                if orelse is not None:
                    self._check_block(orelse, ctx, scope)
            elif isinstance(stmt, ast.For):
                self._check_expr(stmt.iter, ctx, scope)
                self._check_block(stmt.body, ctx, scope | {stmt.var.name})
            elif isinstance(stmt, ast.MapStmt):
                if ctx != "shaper":
                    self.diags.error(
                        "E223", "`->` mappings only appear in shaper programs", stmt.span
                    )
                self._check_expr(stmt.src, ctx, scope)
                self._check_expr(stmt.dst, ctx, scope)
            elif isinstance(stmt, ast.ExprStmt):
                self._check_expr(stmt.expr, ctx, scope)

    def check_action(self, d: ast.ActionDef) -> None:
        props = [i for i in d.items if isinstance(i, ast.Prop)]
        self._props_block(tuple(props), sk.ACTION_PROPS, "an action")
        steps: dict[str, ast.ActionStep] = {}
        for item in d.items:
            if isinstance(item, ast.ActionStep):
                if item.step in steps:
                    self.diags.error(
                        "E224",
                        f"step `{item.step}` is written twice",
                        item.span,
                        notes=[Note("first here", steps[item.step].span)],
                    )
                    continue
                steps[item.step] = item
                self._check_block(item.body, "action", set())
        if "main" not in steps:
            self.diags.error(
                "E225",
                f"action `{d.name.name}` has no `main` step",
                d.name.span,
                hint="`main { ... }` emits the operation that forms the stitch",
            )

    def check_shaper(self, d: ast.ShaperDef) -> None:
        self._check_block(d.body, "shaper", {p.name.name for p in d.params})
