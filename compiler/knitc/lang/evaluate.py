"""knitc's own expression evaluator (never Python's `eval`).

Design parameters and node properties are expressions over numbers, booleans, strings,
words (bare names such as `half`), lists and piecewise-linear profiles. The original system
substituted text and handed it to JavaScript's eval; knitc evaluates the AST itself, so
that every failure is a located diagnostic, references are resolved through callbacks that
detect cycles, and `-D` overrides are parsed by the same grammar.
"""

from __future__ import annotations

import bisect
import difflib
import math
from collections.abc import Callable
from dataclasses import field

from knitc.frontend import ast
from knitc.lang import arith as _arith
from knitc.records import record
from knitc.source import Span


@record(frozen=True, slots=True)
class Word:
    """A bare name used as a value: an enum choice (`half`) or a definition name."""

    name: str

    def __str__(self) -> str:
        return self.name


@record(frozen=True, slots=True)
class Profile:
    """A piecewise-linear function of t in [0, 1], clamped to its end values outside.

    `at` finds its segment by bisection: a width profile is read once per course, and a
    profile of 20,000 points over 20,000 courses took 40 s when it was searched in order.
    """

    points: tuple[tuple[float, float], ...]
    _ts: tuple[float, ...] = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "_ts", tuple(t for t, _ in self.points))

    @staticmethod
    def constant(v: float) -> Profile:
        return Profile(((0.0, float(v)),))

    @property
    def is_constant(self) -> bool:
        return len({v for _, v in self.points}) == 1

    def at(self, t: float) -> float:
        pts = self.points
        if t <= pts[0][0]:
            return pts[0][1]
        i = bisect.bisect_left(self._ts, t)  # the first point at or after t: t0 < t <= t1
        if i == len(pts):
            return pts[-1][1]
        (t0, v0), (t1, v1) = pts[i - 1], pts[i]
        return v0 + (v1 - v0) * (t - t0) / (t1 - t0)

    def map(self, fn: Callable[[float], float]) -> Profile:
        return Profile(tuple((t, fn(v)) for t, v in self.points))

    def values(self) -> list[float]:
        return [v for _, v in self.points]

    def to_json(self) -> object:
        if self.is_constant:
            return _num_json(self.points[0][1])
        return [[_num_json(t), _num_json(v)] for t, v in self.points]


def _num_json(x: float) -> int | float:
    return int(x) if float(x).is_integer() else x


Value = int | float | bool | str | Word | Profile | tuple | range  # range: `interp` only


def same_value(a: object, b: object) -> bool:
    """The language's `==`: Python's, except that a boolean never equals a number, also
    inside lists (`[1] == [true]` is false, as `1 == true` is). Lists are at most 100 deep
    (E320), so the recursion is bounded; ranges are lists of their numbers."""
    if isinstance(a, bool) or isinstance(b, bool):
        return type(a) is type(b) and a == b
    if isinstance(a, range) and isinstance(b, range):
        return a == b  # by value, without walking them
    if isinstance(a, tuple | range) and isinstance(b, tuple | range):
        return len(a) == len(b) and all(same_value(x, y) for x, y in zip(a, b, strict=True))
    return a == b


def type_name(v: object) -> str:
    if isinstance(v, bool):
        return "a boolean"
    if isinstance(v, int | float):
        return "a number"
    if isinstance(v, str):
        return "a string"
    if isinstance(v, Word):
        return f"the word `{v.name}`"
    if isinstance(v, Profile):
        return "a profile"
    if isinstance(v, tuple):
        return "a list"
    return "a value"


def show(v: object) -> str:
    """A value as the designer would write it, for messages: a number beyond 15 digits in
    the `1e+300` form (the limit of a number has 301 digits), a list cut short after
    `SHOW_ITEMS` items (a list may hold 100,000, and a message is read by a person)."""
    left = [SHOW_ITEMS]
    return _show(v, left)


SHOW_ITEMS = 20
"""Items of a list (nested ones included) that a message shows before `...`."""


def _show(v: object, left: list[int]) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int) and abs(v) >= 10**20:
        return f"{float(v):.6g}"
    if isinstance(v, float):
        return str(int(v)) if v.is_integer() and abs(v) < 1e15 else f"{v:.6g}"
    if isinstance(v, str):
        return f'"{v}"'
    if isinstance(v, Profile):
        return "[" + ", ".join(f"{show(t)}: {show(x)}" for t, x in v.points) + "]"
    if isinstance(v, tuple):
        parts = []
        for x in v:
            if left[0] <= 0:
                parts.append("...")
                break
            left[0] -= 1
            parts.append(_show(x, left))
        return "[" + ", ".join(parts) + "]"
    return str(v)


LIST_ITEMS = 100_000
"""Most items a list value may hold, counting the items of the lists inside it (each time
they occur): `[l, l]` in a loop doubles, and comparing or showing a list walks all of it."""

LIST_DEPTH = 100
"""Most levels of lists inside lists (as expressions nest at most 100 levels, E111)."""


class NestedList(tuple):
    """A list value that holds lists, knowing its `size` and `depth` (see `LIST_ITEMS`),
    so that building `[l, l]` is checked from its items' counts, never by walking `l`."""

    size: int
    depth: int


def list_measure(v: tuple) -> tuple[int, int]:
    """(size, depth) of a list value: items counted at every level, and levels of lists."""
    if isinstance(v, NestedList):
        return v.size, v.depth
    size, depth = len(v), 1
    stack = [(x, 2) for x in v if isinstance(x, tuple)]
    while stack:  # a list made elsewhere (a host value): walked once, without recursion
        x, d = stack.pop()
        if isinstance(x, NestedList):
            size, depth = size + x.size, max(depth, d + x.depth - 1)
            continue
        size, depth = size + len(x), max(depth, d)
        stack.extend((y, d + 1) for y in x if isinstance(y, tuple))
    return size, depth


def make_list(items: list[Value], span: Span) -> tuple:
    """The list value of `items` written at `span`; E320 beyond `LIST_ITEMS` or
    `LIST_DEPTH`, where the list is built (nothing after it has to walk a huge one)."""
    size, depth = len(items), 1
    for x in items:
        if isinstance(x, tuple):
            s, d = list_measure(x)
            size, depth = size + s, max(depth, d + 1)
    hint = "a list that holds itself twice (`l = [l, l]`) doubles each time; keep lists flat"
    if size > LIST_ITEMS:
        raise EvalError(
            "E320",
            f"this list holds {size:,} items, counting those of the lists inside it; "
            f"the limit is {LIST_ITEMS:,}",
            span,
            hint,
        )
    if depth > LIST_DEPTH:
        raise EvalError(
            "E320", f"this list nests {depth} lists deep; the limit is {LIST_DEPTH}", span, hint
        )
    if depth == 1:
        return tuple(items)
    out = NestedList(items)
    out.size, out.depth = size, depth
    return out


class EvalError(Exception):
    def __init__(self, code: str, message: str, span: Span, hint: str | None = None):
        super().__init__(message)
        self.code, self.message, self.span, self.hint = code, message, span, hint


def round_half_up(x: float) -> int:
    """JavaScript's Math.round, which the original system used for every course width."""
    return math.floor(x + 0.5)


BUILTINS: dict[str, tuple[Callable[..., int | float], tuple[int, int]]] = {
    "min": (lambda *a: min(a), (1, 64)),
    "max": (lambda *a: max(a), (1, 64)),
    "abs": (abs, (1, 1)),
    "round": (round_half_up, (1, 1)),
    "floor": (math.floor, (1, 1)),
    "ceil": (math.ceil, (1, 1)),
    "sqrt": (math.sqrt, (1, 1)),
    "sin": (math.sin, (1, 1)),
    "cos": (math.cos, (1, 1)),
    "clamp": (lambda x, lo, hi: max(lo, min(hi, x)), (3, 3)),
    "lerp": (lambda a, b, t: a + (b - a) * t, (3, 3)),
}
"""Pure numeric functions callable from declarations (and from every other scope)."""


class Evaluator:
    """Evaluates declaration-level expressions.

    `param(name, span)` and `prop(node, name, span)` resolve `#name` and `@[node.]name`;
    the caller implements them (with memoisation and cycle detection). Bare names evaluate
    to `Word`s, which property checks turn into enum choices or definition names.
    """

    def __init__(
        self, param: Callable[[str, Span], Value], prop: Callable[[str | None, str, Span], Value]
    ):
        self.param = param
        self.prop = prop

    def eval(self, e: ast.Node) -> Value:
        method = getattr(self, "_" + type(e).__name__, None)
        if method is None:
            raise EvalError("E301", f"{_describe(e)} cannot be used here", e.span)
        return method(e)

    # -- atoms
    def _Number(self, e: ast.Number) -> Value:
        return e.value

    def _String(self, e: ast.String) -> Value:
        return e.value

    def _Bool(self, e: ast.Bool) -> Value:
        return e.value

    def _Name(self, e: ast.Name) -> Value:
        return Word(e.id)

    def _ParamRef(self, e: ast.ParamRef) -> Value:
        return self.param(e.name, e.span)

    def _PropRef(self, e: ast.PropRef) -> Value:
        return self.prop(e.node, e.prop, e.span)

    def _ListExpr(self, e: ast.ListExpr) -> Value:
        return make_list([self.eval(i) for i in e.items], e.span)

    def _Profile(self, e: ast.Profile) -> Value:
        pts: list[tuple[float, float]] = []
        for p in e.points:
            t = self._number(p.t, "a profile position")
            v = self._number(p.value, "a profile value")
            if not 0 <= t <= 1:
                raise EvalError(
                    "E302",
                    f"profile position {show(t)} is outside [0, 1]",
                    p.t.span,
                    "positions are fractions of the node's length: 0 is the first "
                    "course, 1 the last",
                )
            if pts and t < pts[-1][0]:
                raise EvalError(
                    "E302",
                    "profile positions must increase",
                    p.t.span,
                    "write the points in order, e.g. [0: 20, 0.5: 15, 1: 12]",
                )
            pts.append((float(t), float(v)))
        return Profile(tuple(pts))

    # -- operators
    def _Unary(self, e: ast.Unary) -> Value:
        v = self.eval(e.operand)
        if e.op == "not":
            if not isinstance(v, bool):
                raise EvalError("E303", f"`not` needs a boolean, got {type_name(v)}", e.span)
            return not v
        if isinstance(v, Profile):
            return v.map(lambda x: -x)
        return _arith.negate(self._as_number(v, e.operand.span, "`-`"))

    def _Binary(self, e: ast.Binary) -> Value:
        if e.op in ("and", "or"):
            a = self.eval(e.left)
            if not isinstance(a, bool):
                raise EvalError("E303", f"`{e.op}` needs booleans, got {type_name(a)}", e.left.span)
            if (e.op == "and" and not a) or (e.op == "or" and a):
                return a
            b = self.eval(e.right)
            if not isinstance(b, bool):
                raise EvalError(
                    "E303", f"`{e.op}` needs booleans, got {type_name(b)}", e.right.span
                )
            return b
        a, b = self.eval(e.left), self.eval(e.right)
        if e.op in ("==", "!="):
            same = same_value(a, b)
            return same if e.op == "==" else not same
        if isinstance(a, Profile) or isinstance(b, Profile):
            return self._profile_arith(e, a, b)
        x = self._as_number(a, e.left.span, f"`{e.op}`")
        y = self._as_number(b, e.right.span, f"`{e.op}`")
        return arith(e.op, x, y, e.right.span)

    def _profile_arith(self, e: ast.Binary, a: Value, b: Value) -> Value:
        if isinstance(a, Profile) and isinstance(b, Profile):
            raise EvalError(
                "E303",
                f"cannot combine two profiles with `{e.op}`",
                e.span,
                "scale or shift one profile by a number instead",
            )
        if e.op not in "+-*/":
            raise EvalError("E303", f"`{e.op}` does not apply to a profile", e.span)
        if isinstance(a, Profile):
            y = self._as_number(b, e.right.span, f"`{e.op}`")
            return a.map(lambda x: arith(e.op, x, y, e.right.span))
        x = self._as_number(a, e.left.span, f"`{e.op}`")
        assert isinstance(b, Profile)
        return b.map(lambda v: arith(e.op, x, v, e.right.span))

    def _Call(self, e: ast.Call) -> Value:
        if not isinstance(e.func, ast.Name) or e.func.id not in BUILTINS:
            name = e.func.id if isinstance(e.func, ast.Name) else None
            close = difflib.get_close_matches(name or "", list(BUILTINS), n=1, cutoff=0.6)
            raise EvalError(
                "E201",
                f"unknown function `{name}`" if name else "only named functions can be called",
                e.func.span,
                f"did you mean `{close[0]}`?"
                if close
                else "available here: " + ", ".join(sorted(BUILTINS)),
            )
        fn, (lo, hi) = BUILTINS[e.func.id]
        args = []
        for a in e.args:
            if isinstance(a, ast.Range | ast.KwArg):
                raise EvalError("E304", f"`{e.func.id}` takes plain arguments", a.span)
            args.append(self._as_number(self.eval(a), a.span, f"`{e.func.id}`"))
        if not lo <= len(args) <= hi:
            want = str(lo) if lo == hi else f"{lo} or more"
            raise EvalError(
                "E304", f"`{e.func.id}` takes {want} argument(s), got {len(args)}", e.span
            )
        try:
            result = fn(*args)
        except (ValueError, OverflowError):
            raise EvalError(
                "E305",
                f"`{e.func.id}` is undefined for " + ", ".join(show(a) for a in args),
                e.span,
            ) from None
        try:  # `lerp(1e300, -1e300, 3)` overflows to infinity without an exception
            return _arith.bounded(result)
        except _arith.ArithError as exc:
            raise EvalError(exc.code, f"`{e.func.id}`: {exc.message}", e.span) from None

    def _TupleExpr(self, e: ast.TupleExpr) -> Value:
        return make_list([self.eval(i) for i in e.items], e.span)

    def _Index(self, e: ast.Index) -> Value:
        obj = self.eval(e.obj)
        i = self.eval(e.index)
        if not isinstance(obj, tuple):
            raise EvalError("E303", f"cannot index {type_name(obj)}", e.obj.span)
        if not isinstance(i, int) or isinstance(i, bool) or not -len(obj) <= i < len(obj):
            raise EvalError(
                "E306", f"index {show(i)} is out of range for a list of {len(obj)}", e.index.span
            )
        return obj[i]

    # -- helpers
    def _as_number(self, v: Value, span: Span, what: str) -> int | float:
        if isinstance(v, bool) or not isinstance(v, int | float):
            raise EvalError("E303", f"{what} needs a number, got {type_name(v)}", span)
        return v

    def _number(self, e: ast.Node, what: str) -> int | float:
        return self._as_number(self.eval(e), e.span, what)


def arith(op: str, x: float, y: float, span: Span) -> int | float | bool:
    """`x op y` by the language's one arithmetic (`knitc.lang.arith`), located at `span`."""
    try:
        return _arith.scalar(op, x, y)
    except _arith.ArithError as exc:
        raise EvalError(exc.code, exc.message, span) from None


def _describe(e: ast.Node) -> str:
    return {
        "Grid": "a drawn grid",
        "Range": "a range",
        "KwArg": "a keyword argument",
        "Attr": "attribute access",
        "TupleExpr": "a tuple",
    }.get(type(e).__name__, type(e).__name__)
