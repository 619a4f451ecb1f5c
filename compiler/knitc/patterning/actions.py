"""Stitch actions, pattern side: `use ACTION where Q` and the table of actions (the pre /
main / post programs that make a stitch are run at code generation, `codegen.actions` (thesis ch. 6.9.1; knitsketching's `Action.register`, seed-systems
§2.7).

An instruction (`set P`) says what a stitch looks like and leaves the machine operations to
the compiler; an action says which operations make it. That is how a designer reaches what
the 17 instructions do not name (a kickback knit, a split stitch, a purl that stays on the
back bed), in the knitc language rather than in the compiler.

Attaching (the pattern pass calls `attach`)
    `use NAME where Q` writes the action's id into `StitchGraph.action` for the selected
    stitches; later writes win, and `set` does not clear an action (the action replaces how
    the stitch is formed; a move or cross written with `set` still carries its loop after
    the course). `use knit` with the built-in `knit` resets the stitches to plain: no action
    and instruction K, so it undoes an earlier layer exactly.

Ids and built-ins
    `table(skel)` lists the design's actions (defined or imported) together with the
    built-in names knit, purl, tuck, miss, kickback, split, sorted by name; an id is an index
    into that list, both here and in code generation (`codegen.action_table`). A built-in
    name the design does not define is the definition of `std/actions.knit`, so `use purl`
    works without an import; a design's own definition of the name wins.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import field
from functools import lru_cache
from typing import overload

from knitc.diagnostics import Diagnostics
from knitc.frontend import ast
from knitc.frontend.names import BUILTIN_ACTIONS
from knitc.frontend.parser import parse_source
from knitc.lang.evaluate import EvalError, Evaluator, Value
from knitc.records import record
from knitc.resources import stdlib_module
from knitc.shaping.stitch_graph import INSTRUCTIONS
from knitc.source import SourceFile, Span

STD_MODULE = "std.actions"
STD_FILE = "<stdlib>/std/actions.knit"
"""The display name the resolver gives the module, so spans of built-ins look the same
whether the design imported them or not."""

STEP_BUDGET = 10_000
"""Statements one step of one stitch may execute: an action is a few operations; a step that
needs more has a runaway loop (E316)."""

ACTIONS_BUDGET = 50_000_000
"""Statements the action steps of all the stitches of a design may execute together (E316):
10,000 per step is little for one stitch and, over two million stitches, no bound at all."""

KNIT = INSTRUCTIONS.index("K")


# ---- the table of actions ---------------------------------------------------------------------


@record(frozen=True, eq=False)
class Program:
    """An action as code generation runs it: its steps and evaluated properties."""

    name: str
    defn: ast.ActionDef
    steps: Mapping[str, ast.Block]
    split_by_side: bool = False
    transfer_back: bool = True
    params: Mapping[str, Value] = field(default_factory=dict)
    builtin: bool = False
    """The stdlib's definition (imported or standing in for a built-in name)."""

    @property
    def transfers(self) -> bool:
        """Whether the action has steps around its knitting (`pre`, `post`), where loops
        are moved: a first course needs the needles facing such stitches free."""
        return "pre" in self.steps or "post" in self.steps

    @property
    def plain(self) -> bool:
        """The built-in `knit`: the stitch as code generation makes it without an action."""
        return self.builtin and self.name == "knit"


@lru_cache(maxsize=1)
def _std() -> tuple[SourceFile, dict[str, ast.ActionDef]]:
    text = stdlib_module(STD_MODULE).read_text(encoding="utf-8")
    source = SourceFile(STD_FILE, text)
    diags = Diagnostics()
    module = parse_source(source, diags)
    assert module is not None and not diags.has_errors, diags.render()
    defs = {i.name.name: i for i in module.items if isinstance(i, ast.ActionDef)}
    missing = set(BUILTIN_ACTIONS) - set(defs)
    assert not missing, f"{STD_FILE} lacks the built-in actions {sorted(missing)}"
    return source, defs


def std_source() -> SourceFile:
    """The source of `std/actions.knit`, for diagnostics inside a built-in action."""
    return _std()[0]


def builtin(name: str) -> ast.ActionDef:
    """The stdlib definition of a built-in action name."""
    return _std()[1][name]


def names(skel) -> list[str]:
    """The action names in id order: the design's and the built-ins, by name."""
    return sorted(set(skel.actions) | set(BUILTIN_ACTIONS))


class Table(Sequence[Program]):
    """The actions `StitchGraph.action` indexes (`codegen.action_table`), each made when code
    generation first asks for it: most designs knit no action, and the built-ins' program
    comes from parsing `std/actions.knit`, a second parse of every compile otherwise."""

    def __init__(self, skel) -> None:
        self._names = names(skel)
        self._defs = skel.actions
        self._params = dict(skel.params)
        self._made: dict[int, Program] = {}

    def __len__(self) -> int:
        return len(self._names)

    @overload
    def __getitem__(self, i: int) -> Program: ...

    @overload
    def __getitem__(self, i: slice) -> tuple[Program, ...]: ...

    def __getitem__(self, i: int | slice) -> Program | tuple[Program, ...]:
        if isinstance(i, slice):
            return tuple(self[k] for k in range(len(self))[i])
        k = range(len(self._names))[i]  # (IndexError as a tuple's, negative indices too)
        prog = self._made.get(k)
        if prog is None:
            n = self._names[k]
            prog = self._made[k] = _program(n, self._defs.get(n) or builtin(n), self._params)
        return prog


def table(skel) -> Table:
    """The actions `StitchGraph.action` indexes (`codegen.action_table`), made lazily."""
    return Table(skel)


def _program(name: str, defn: ast.ActionDef, params: Mapping[str, Value]) -> Program:
    steps = {i.step: i.body for i in defn.items if isinstance(i, ast.ActionStep)}
    props = {i.name.name: i.value for i in defn.items if isinstance(i, ast.Prop)}

    def param(n: str, span: Span) -> Value:
        if n in params:
            return params[n]
        raise EvalError("E403", f"unknown parameter `#{n}`", span)

    def prop(node, n: str, span: Span) -> Value:
        raise EvalError("E301", "node properties cannot be read in an action", span)

    def flag(key: str, default: bool) -> bool:
        if key not in props:
            return default
        try:  # the resolver checked the type and reported any error
            v = Evaluator(param, prop).eval(props[key])
        except EvalError:
            return default
        return v if isinstance(v, bool) else default

    return Program(
        name,
        defn,
        steps,
        flag("split_by_side", False),
        flag("transfer_back", True),
        params,
        defn.name.span.file == STD_FILE,
    )


# ---- attaching (pattern pass) -----------------------------------------------------------------


def attach(run, stmt: ast.UseStmt, node, env, within) -> None:
    """Attach the action `stmt` names to the stitches its query selects (`run` is the
    pattern pass's state: `run.select`, `run.action`, `run.instr`, `run.mark`)."""
    name = stmt.action.name
    ids = {n: i for i, n in enumerate(names(run.skel))}
    if name not in ids:
        return  # not an action: the resolver reported it (E217)
    mask = run.select(node, stmt.where, env, within)
    defn = run.skel.actions.get(name) or builtin(name)
    if name == "knit" and defn.name.span.file == STD_FILE:
        run.action[mask] = -1
        run.instr[mask] = KNIT
    else:
        run.action[mask] = ids[name]
    run.mark(mask, stmt.span)
