"""An interpreter for knitc statement blocks: shaper programs and action steps.

A block is `let`, assignment, `if / else if / else`, `for x in LIST`, calls and (in shapers)
mappings `a -> b`. Expressions are evaluated by `knitc.lang.evaluate.Evaluator`, extended here
with local variables, the builtins `range` and `len`, and *host functions* supplied by the
caller (an action's `knit(...)`, `xfer(...)`). The interpreter owns no knitting semantics:
mappings go to the caller's `on_map(src, dst, span)` and host calls to the caller's
functions, so the same machinery runs shapers, actions and whatever comes next.

Scoping is lexical: every block is a scope; `let` binds in the current scope (rebinding or
shadowing is allowed), an assignment updates the innermost existing binding. A `for` body
gets a fresh scope per iteration holding the loop variable. Bare names that are not bound
are an error, except for the caller's `words` (enum words such as `left` or `front`), which
evaluate to `Word`s; with `words=None` every unbound name is a word, as in declarations.

There is no `while` and no recursion, so programs always end, but `range(10^12)` would not
end soon: every statement and every loop iteration costs one step, and a run that exceeds
its budget stops with E316 at the loop that ran away. A `for` whose length alone exceeds
the remaining budget fails before its first iteration.

Error codes: the evaluator's E3xx codes and, new here, E316 (step budget exceeded) and E317
(assignment to a name provided by the context). Runtime counterparts of the resolver's
checks keep the resolver's codes: E201 unknown function, E221 unknown name, E222 assignment
before `let`, E223 a mapping outside a shaper, E304 wrong arguments.
"""

from __future__ import annotations

import difflib
from collections.abc import Callable, Collection, Mapping

from knitc.frontend import ast
from knitc.lang import arith
from knitc.lang.evaluate import (
    BUILTINS,
    EvalError,
    Evaluator,
    Value,
    Word,
    list_measure,
    same_value,
    show,
    type_name,
)
from knitc.records import record
from knitc.source import UNKNOWN_SPAN, Span

DEFAULT_BUDGET = 10_000_000
"""Statements plus loop iterations one run may execute."""

SHAPERS_BUDGET = 50_000_000
"""Statements plus loop iterations all the shaper runs of one design may execute together
(a `StepPool`): a shaper runs once per (M, N) pair its node's courses need."""


class StepPool:
    """Steps that many runs share, on top of each run's own budget: a design's shaper runs
    once per (M, N) its courses need, and 10,000,000 steps per run over thousands of pairs
    would not end soon. `what` names the runs in messages ("the design's shapers")."""

    def __init__(self, total: int, what: str):
        self.total, self.left, self.what = total, total, what


LOCAL_BUILTINS = {"range": (1, 3), "len": (1, 1)}
"""Functions of statement blocks on top of `evaluate.BUILTINS`, with their arity."""


@record(frozen=True, slots=True)
class Host:
    """A host function with its arity; `span=True` passes the call's span as `span=`.

    A plain callable is accepted wherever a `Host` is, with any arity and no span. A host
    function reports a mistake by raising `EvalError`; one raised with `UNKNOWN_SPAN` is
    relocated to the call.
    """

    fn: Callable[..., object]
    min_args: int = 0
    max_args: int | None = None
    span: bool = False


class _Scope:
    __slots__ = ("vars", "parent", "readonly")

    def __init__(
        self, parent: _Scope | None, vars: dict[str, Value] | None = None, readonly: bool = False
    ):
        self.vars = vars if vars is not None else {}
        self.parent = parent
        self.readonly = readonly

    def find(self, name: str) -> _Scope | None:
        s: _Scope | None = self
        while s is not None:
            if name in s.vars:
                return s
            s = s.parent
        return None

    def visible(self) -> set[str]:
        out: set[str] = set()
        s: _Scope | None = self
        while s is not None:
            out |= set(s.vars)
            s = s.parent
        return out


def _no_param(name: str, span: Span) -> Value:
    raise EvalError("E301", f"`#{name}` cannot be read here", span)


def _no_prop(node: str | None, prop: str, span: Span) -> Value:
    where = f"@{node}.{prop}" if node else f"@{prop}"
    raise EvalError("E301", f"`{where}` cannot be read here", span)


def length(v: tuple | range | str) -> int:
    """`len(v)`, also of a range longer than the machine's integers (`range(10^300)`, whose
    Python `len` raises OverflowError): a loop over it must fail on the budget, not crash."""
    if isinstance(v, range):
        step = v.step
        return max(0, (v.stop - v.start + step - (1 if step > 0 else -1)) // step)
    return len(v)


def whole(v: object) -> int | None:
    """`v` as an int if it is a whole number (an int or an integral float), else None."""
    if isinstance(v, bool):
        return None
    if isinstance(v, int):
        return v
    if isinstance(v, float) and v.is_integer():
        return int(v)
    return None


class Interpreter(Evaluator):
    """Runs statement blocks; one instance may run many blocks (each with its own budget).

    `functions`: host functions by name (callables or `Host`s). `constants`: names the
    context provides (an action's `needle`, ...), readable everywhere, not assignable.
    `words`: bare names that evaluate to `Word`s when not bound (None: all of them).
    `on_map(src, dst, span)`: receives the values of every `a -> b`; without it a mapping
    is an error. `param`/`prop`: the evaluator's hooks for `#name` and `@prop`.
    `what` names the program in messages, e.g. "shaper `edges`".
    """

    def __init__(
        self,
        *,
        functions: Mapping[str, Host | Callable[..., object]] | None = None,
        constants: Mapping[str, Value] | None = None,
        words: Collection[str] | None = None,
        on_map: Callable[[Value, Value, Span], None] | None = None,
        param: Callable[[str, Span], Value] | None = None,
        prop: Callable[[str | None, str, Span], Value] | None = None,
        budget: int = DEFAULT_BUDGET,
        pool: StepPool | None = None,
        what: str = "the program",
    ):
        super().__init__(param or _no_param, prop or _no_prop)
        self.functions: dict[str, Host] = {
            k: v if isinstance(v, Host) else Host(v) for k, v in (functions or {}).items()
        }
        self.words = None if words is None else frozenset(words)
        self.on_map = on_map
        self.budget = budget
        self.pool = pool
        self._limit = budget
        """This run's budget: `budget`, or what is left of the `pool` if that is less."""
        self.what = what
        self._constants = _Scope(None, dict(constants or {}), readonly=True)
        self._scope = self._constants
        self._steps = 0
        self._loops: list[tuple[ast.For, int]] = []

    # -- entry points
    def run(
        self, block: ast.Block, bindings: Mapping[str, Value] | None = None
    ) -> dict[str, Value]:
        """Execute `block` with `bindings` in scope; returns its top-level variables."""
        self._steps = 0
        self._loops = []
        self._limit = self.budget if self.pool is None else min(self.budget, self.pool.left)
        top = _Scope(self._constants, dict(bindings or {}))
        saved, self._scope = self._scope, top
        try:
            self._stmts(block.stmts)
        finally:
            self._scope = saved
            if self.pool is not None:
                self.pool.left -= self._steps
        return top.vars

    def evaluate(self, e: ast.Node, bindings: Mapping[str, Value] | None = None) -> Value:
        """Evaluate one expression with `bindings` (and the constants) in scope."""
        saved = self._scope
        self._scope = _Scope(self._constants, dict(bindings or {}))
        try:
            return self.eval(e)
        finally:
            self._scope = saved

    # -- statements
    def _stmts(self, stmts: tuple[ast.Stmt, ...]) -> None:
        for stmt in stmts:
            self._tick(stmt)
            method = getattr(self, "_exec_" + type(stmt).__name__, None)
            if method is None:
                raise EvalError("E301", f"{type(stmt).__name__} cannot be used here", stmt.span)
            method(stmt)

    def _block(self, block: ast.Block) -> None:
        saved, self._scope = self._scope, _Scope(self._scope)
        try:
            self._stmts(block.stmts)
        finally:
            self._scope = saved

    def _exec_Let(self, s: ast.Let) -> None:
        self._scope.vars[s.name.name] = self.eval(s.value)

    def _exec_Assign(self, s: ast.Assign) -> None:
        name = s.name.name
        value = self.eval(s.value)
        owner = self._scope.find(name)
        if owner is None:
            raise EvalError(
                "E222",
                f"`{name}` is assigned before `let`",
                s.name.span,
                f"declare it first: `let {name} = ...`",
            )
        if owner.readonly:
            raise EvalError(
                "E317",
                f"`{name}` is provided by the context and cannot be assigned",
                s.name.span,
                f"work on a copy: `let my_{name} = {name}`",
            )
        owner.vars[name] = value

    def _exec_If(self, s: ast.If) -> None:
        node: ast.If | ast.Block | None = s
        while isinstance(node, ast.If):
            cond = self.eval(node.cond)
            if not isinstance(cond, bool):
                raise EvalError(
                    "E303",
                    f"`if` needs a boolean, got {type_name(cond)}",
                    node.cond.span,
                    "compare it, e.g. `if i < d { ... }`",
                )
            if cond:
                self._block(node.then)
                return
            node = node.orelse
        if node is not None:
            self._block(node)

    def _exec_For(self, s: ast.For) -> None:
        items = self.eval(s.iter)
        if not isinstance(items, tuple | range):
            raise EvalError(
                "E303",
                f"`for` needs a list or a range, got {type_name(items)}",
                s.iter.span,
                "loop over `range(n)` or a list `[a, b, c]`",
            )
        n = length(items)
        self._loops.append((s, n))
        saved = self._scope
        try:
            if n > self._limit - self._steps:  # each iteration costs a step: fail now
                self._out_of_steps(s)
            for x in items:
                self._tick(s)
                self._scope = _Scope(saved, {s.var.name: x})
                self._stmts(s.body.stmts)
        finally:
            self._scope = saved
            self._loops.pop()

    def _exec_MapStmt(self, s: ast.MapStmt) -> None:
        if self.on_map is None:
            raise EvalError("E223", "`->` mappings only appear in shaper programs", s.span)
        self.on_map(self.eval(s.src), self.eval(s.dst), s.span)

    def _exec_ExprStmt(self, s: ast.ExprStmt) -> None:
        self.eval(s.expr)

    # -- the step budget
    def _tick(self, stmt: ast.Node, cost: int = 1) -> None:
        self._steps += cost
        if self._steps > self._limit:
            self._out_of_steps(stmt)

    def _charge_lists(self, e: ast.Node, *values: Value) -> None:
        """Comparing lists walks them: a step per item (nested ones included), so that a
        loop comparing a 100,000-item list cannot outlast the budget by its comparisons."""
        cost = sum(list_measure(v)[0] for v in values if isinstance(v, tuple))
        if cost:
            self._tick(e, cost)

    def _out_of_steps(self, stmt: ast.Node) -> None:
        if self._limit < self.budget and self.pool is not None:
            message = (
                f"{self.what} did not finish: {self.pool.what} may run "
                f"{self.pool.total:,} steps in all"
            )
        else:
            message = f"{self.what} did not finish within {self.budget:,} steps"
        if self._loops:
            # Blame the longest active loop (the outermost one on ties): without `while` or
            # recursion, only a loop can run away.
            loop, n = max(self._loops, key=lambda ln: ln[1])
            raise EvalError(
                "E316",
                message,
                loop.span,
                f"this loop runs {n:,} times; is its bound right?"
                if n < 10**15
                else f"this loop runs {show(n)} times; is its bound right?",
            )
        raise EvalError("E316", message, stmt.span)

    # -- expressions
    def _Name(self, e: ast.Name) -> Value:
        owner = self._scope.find(e.id)
        if owner is not None:
            return owner.vars[e.id]
        if self.words is None or e.id in self.words:
            return Word(e.id)
        options = self._scope.visible() | set(self.words)
        close = difflib.get_close_matches(e.id, sorted(options), n=1, cutoff=0.6)
        raise EvalError(
            "E221",
            f"unknown name `{e.id}`",
            e.span,
            f"did you mean `{close[0]}`?" if close else "bind names with `let` or a `for` loop",
        )

    def _Call(self, e: ast.Call) -> Value:
        name = e.func.id if isinstance(e.func, ast.Name) else None
        if name is not None and name in self.functions:
            return self._host_call(name, self.functions[name], e)
        if name == "range":
            return self._range(e)
        if name == "len":
            return self._len(e)
        if name is not None and name in BUILTINS:
            return super()._Call(e)
        known = sorted(set(self.functions) | set(LOCAL_BUILTINS) | set(BUILTINS))
        close = difflib.get_close_matches(name or "", known, n=1, cutoff=0.6)
        raise EvalError(
            "E201",
            f"unknown function `{name}`" if name else "only named functions can be called",
            e.func.span,
            f"did you mean `{close[0]}`?" if close else "available here: " + ", ".join(known),
        )

    def _plain_args(self, name: str, e: ast.Call, lo: int, hi: int) -> list[Value]:
        args = []
        for a in e.args:
            if isinstance(a, ast.Range | ast.KwArg):
                raise EvalError("E304", f"`{name}` takes plain arguments", a.span)
            args.append(self.eval(a))
        if not lo <= len(args) <= hi:
            want = str(lo) if lo == hi else f"{lo} to {hi}"
            raise EvalError("E304", f"`{name}` takes {want} argument(s), got {len(args)}", e.span)
        return args

    def _range(self, e: ast.Call) -> Value:
        args = self._plain_args("range", e, 1, 3)
        ints = []
        for a, v in zip(e.args, args):
            i = whole(v)
            if i is None:
                raise EvalError(
                    "E303",
                    f"`range` needs whole numbers, got {show(v)}"
                    if isinstance(v, int | float) and not isinstance(v, bool)
                    else f"`range` needs whole numbers, got {type_name(v)}",
                    a.span,
                    "round it with `floor`, `ceil` or `round`",
                )
            ints.append(i)
        if len(ints) == 3 and ints[2] == 0:
            raise EvalError("E305", "`range` step cannot be zero", e.args[2].span)
        return range(*ints)

    def _len(self, e: ast.Call) -> Value:
        (v,) = self._plain_args("len", e, 1, 1)
        if not isinstance(v, tuple | range | str):
            raise EvalError(
                "E303",
                f"`len` needs a list, a range or a string, got {type_name(v)}",
                e.args[0].span,
            )
        try:  # a range's length may exceed the limit of a number
            return arith.bounded(length(v))
        except arith.ArithError as exc:
            raise EvalError(exc.code, f"`len`: {exc.message}", e.span) from None

    def _host_call(self, name: str, host: Host, e: ast.Call) -> Value:
        args: list[Value] = []
        kwargs: dict[str, Value | Span] = {}
        for a in e.args:
            if isinstance(a, ast.KwArg):
                if a.name.name in kwargs:
                    raise EvalError("E304", f"argument `{a.name.name}` is given twice", a.name.span)
                kwargs[a.name.name] = self.eval(a.value)
            elif isinstance(a, ast.Range):
                raise EvalError("E304", f"`{name}` does not take ranges", a.span)
            else:
                args.append(self.eval(a))
        hi = host.max_args
        if len(args) < host.min_args or (hi is not None and len(args) > hi):
            want = (
                str(hi)
                if hi == host.min_args
                else f"{host.min_args} to {hi}"
                if hi is not None
                else f"at least {host.min_args}"
            )
            raise EvalError("E304", f"`{name}` takes {want} argument(s), got {len(args)}", e.span)
        if host.span:
            kwargs["span"] = e.span
        try:
            return host.fn(*args, **kwargs)  # type: ignore[return-value]
        except EvalError as err:
            if err.span == UNKNOWN_SPAN:
                err.span = e.span
            raise

    def _Index(self, e: ast.Index) -> Value:
        # Not delegated: the base would evaluate `e.obj` a second time (host calls twice).
        obj = self.eval(e.obj)
        if not isinstance(obj, tuple | range):
            raise EvalError("E303", f"cannot index {type_name(obj)}", e.obj.span)
        i = self.eval(e.index)
        n = length(obj)
        if not isinstance(i, int) or isinstance(i, bool) or not -n <= i < n:
            raise EvalError(
                "E306", f"index {show(i)} is out of range for a list of {show(n)}", e.index.span
            )
        return obj[i]

    def _Binary(self, e: ast.Binary) -> Value:
        if e.op in ("==", "!="):
            a, b = self.eval(e.left), self.eval(e.right)
            self._charge_lists(e, a, b)
            if isinstance(a, range) and isinstance(b, range):
                same = a == b  # by value, without walking them
            elif isinstance(a, range) or isinstance(b, range):
                # A range is a lazy list: it equals the list of the same numbers (the list's
                # length bounds the walk; its items were charged above).
                same = (
                    isinstance(a, tuple | range)
                    and isinstance(b, tuple | range)
                    and length(a) == length(b)
                    and all(same_value(x, y) for x, y in zip(a, b))
                )
            else:
                same = same_value(a, b)
            return same if e.op == "==" else not same
        return super()._Binary(e)
