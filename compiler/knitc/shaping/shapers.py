"""Shapers: how the stitches of one course continue into the next (thesis ch. 5.4.1).

A shaper maps the smaller of two consecutive courses (M stitches) onto the larger (N
stitches, M <= N <= 2M); a decrease is the same mapping read backwards, and on a tube it
runs on each bed separately (the caller's business, as is choosing which course is which).
A mapping is a numpy int array `src` of length N: `src[j]` is the stitch of the smaller
course that stitch j of the larger course continues from. A valid mapping covers every
larger-course stitch once, is non-decreasing (wales never cross), and gives every
smaller-course stitch one or two consecutive stitches (two = an increase, or a decrease
read backwards).

* `uniform`, `center`, `left`, `right`, `sides` follow the original system's formulas
  (seed-systems §1.6; JavaScript's Math.round = round half up), vectorised, except where the
  original put every odd increase on one edge: `sides` gives the odd one of a course to the
  left edge when `turn` is 0 and to the right edge when it is 1.
* `turn` (0 or 1) is the shape pass's alternation: it flips each time a piece's width
  changes by an odd number of stitches on a bed, the same on a tube's two beds, so a piece
  shaped at both edges grows or shrinks at both alike: one course puts the odd increase on
  both sides of the left fold, the next odd one on both sides of the right fold (the
  original made all of them at the left fold). Both sides of a fold in the same course keep
  the seam line symmetric and grow the ring at one end, which the layout follows cheaply.
  User shapers read it as the name `turn`.
* `phase` (in [0, 1)) shifts `uniform`'s even spacing by a fraction of a stitch. At 0 it is
  the original's formula; the shape pass moves it by the golden ratio from one change of a
  piece to the next, so a piece that changes by a stitch or two per course spreads its
  increases evenly over the whole course instead of stacking them in one line, as a round
  yoke wants.
* `none` is not a mapping: it means "grid wales", each stitch continuing from the stitch on
  the same needle, which depends on the courses' alignment and offsets. The shape pass
  builds those wales itself; `shape("none", ...)` raises ValueError.
* A user `shaper NAME(M, N, ...) { ... }` is run by `knitc.lang.interp` with M and N bound to its
  first two parameters (further parameters take their defaults, evaluated in order, so a
  default may use M and N). It maps in one of two directions, fixed by the first split or
  merge it executes:
  - from the smaller course (the default): `i -> j` continues smaller-course stitch i into
    larger-course stitch j, `i -> (j, j + 1)` splits it into two (an increase);
  - from the larger course, for programs that describe decreases directly: `(a, a + 1) -> i`
    merges larger-course stitches a and a + 1 onto smaller-course stitch i, and then every
    `a -> i` maps larger-course stitch a onto i. The result is the same `src` array (it is
    indexed by the larger course anyway), so the caller never knows the difference.
  A program may not both split and merge. Every mapping is validated; a violation is an
  `EvalError` at the offending `->` (or at the shaper's name when something is missing).

Error codes: E318 a malformed mapping statement (not a stitch index, not two neighbours, a
split in a merging program), E319 an invalid mapping (out of range, a stitch mapped twice
or not at all, crossing wales, more than two per stitch), E310 a shaper without (M, N).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from functools import lru_cache

import numpy as np

from knitc import arrays
from knitc.frontend import ast
from knitc.lang.evaluate import EvalError, Value, round_half_up, show, type_name
from knitc.lang.interp import DEFAULT_BUDGET, Interpreter, StepPool, whole
from knitc.source import Span

PREDEFINED = ("uniform", "center", "left", "right", "sides")
"""Shapers computed here; `none` (grid wales) is handled by the shape pass."""


class MappingError(ValueError):
    """An invalid mapping; `pair` is the index of the offending wale, if there is one."""

    def __init__(self, message: str, pair: int | None = None, hint: str | None = None):
        super().__init__(message)
        self.message, self.pair, self.hint = message, pair, hint


def _check_domain(M: int, N: int) -> None:
    if not 0 <= M <= N <= 2 * M:
        raise ValueError(f"a shaper maps M onto N stitches with M <= N <= 2M, got M={M}, N={N}")


# ---- validation -------------------------------------------------------------------------------


def mapping_from_pairs(M: int, N: int, small, large) -> np.ndarray:
    """Validate wales (smaller-course stitch `small[k]`, larger-course stitch `large[k]`)
    and return the `src` array; raise `MappingError` naming the first offending wale."""
    small = np.asarray(small, dtype=np.int64).reshape(-1)
    large = np.asarray(large, dtype=np.int64).reshape(-1)
    bad = np.flatnonzero((small < 0) | (small >= M))
    if bad.size:
        k = int(bad[0])
        raise MappingError(
            f"stitch {small[k]} is outside the smaller course (M = {M}: stitches 0 to {M - 1})", k
        )
    bad = np.flatnonzero((large < 0) | (large >= N))
    if bad.size:
        k = int(bad[0])
        raise MappingError(
            f"stitch {large[k]} is outside the larger course (N = {N}: stitches 0 to {N - 1})", k
        )
    # The second wale (in order) onto an already mapped larger-course stitch is the culprit.
    _, first = np.unique(large, return_index=True)
    dup = arrays.difference(np.arange(large.size), first)
    if dup.size:
        k = int(dup[0])
        raise MappingError(
            f"stitch {large[k]} of the larger course is mapped twice",
            k,
            "each stitch of the larger course continues exactly one stitch",
        )
    if large.size < N:
        j = int(arrays.difference(np.arange(N), large)[0])
        raise MappingError(
            f"stitch {j} of the larger course is not mapped",
            None,
            f"every stitch 0 to {N - 1} of the larger course needs a source",
        )
    pair_of = np.empty(N, dtype=np.int64)
    pair_of[large] = np.arange(N)
    src = small[pair_of]
    counts = np.bincount(small, minlength=M)
    if M and counts.max() > 2:
        i = int(np.argmax(counts > 2))
        k = int(np.flatnonzero(small == i)[2])
        raise MappingError(
            f"stitch {i} of the smaller course continues into more than 2 stitches",
            k,
            "a stitch can split into at most two (one increase)",
        )
    if M and counts.min() == 0:
        i = int(np.argmin(counts))
        raise MappingError(
            f"stitch {i} of the smaller course maps nowhere, so its loop would be dropped",
            None,
            "map every stitch 0 to M - 1",
        )
    down = np.flatnonzero(np.diff(src) < 0)
    if down.size:
        j = int(down[0]) + 1
        k = int(max(pair_of[j - 1], pair_of[j]))
        raise MappingError(
            f"wales cross: stitch {src[j - 1]} continues into {j - 1} but stitch {src[j]} into {j}",
            k,
            "a shaper keeps the order of stitches: if i < i' then j <= j'",
        )
    return src


# ---- the predefined shapers (seed-systems §1.6) -----------------------------------------------


def _round_half_up(x: np.ndarray) -> np.ndarray:
    """`evaluate.round_half_up` (JavaScript's Math.round) on an array."""
    return np.floor(x + 0.5).astype(np.int64)


def _wales(i: np.ndarray, first: np.ndarray, split: np.ndarray):
    """Wales of "i -> first" plus "i -> first + 1" where `split` (the original's calls)."""
    return np.concatenate([i, i[split]]), np.concatenate([first, first[split] + 1])


def _uniform(M: int, N: int, phase: float = 0.0):
    i = np.arange(M, dtype=np.int64)
    r = N / M  # as the original: i * r, not i * N / M (they can round differently)
    if phase:  # the same spacing, shifted by a fraction of a stitch
        at = _round_half_up((np.arange(M + 1) + phase) * r)
        j = at - at[0]
        return _wales(i, j[:-1], j[1:] != j[:-1] + 1)
    j1 = _round_half_up(i * r)
    j2 = _round_half_up((i + 1) * r)
    return _wales(i, j1, j2 != j1 + 1)


def _center(M: int, N: int):
    i = np.arange(M, dtype=np.int64)
    d = N - M
    o1 = round_half_up(M / 2 - d / 2)
    o2 = o1 + d
    split = (i >= o1) & (i < o2)
    return _wales(i, np.where(i < o1, i, np.where(split, o1 + 2 * (i - o1), i + d)), split)


def _left(M: int, N: int):
    i = np.arange(M, dtype=np.int64)
    d = N - M
    split = i < d
    return _wales(i, np.where(split, 2 * i, i + d), split)


def _right(M: int, N: int):
    i = np.arange(M, dtype=np.int64)
    o = M - (N - M)
    split = i >= o
    return _wales(i, np.where(split, o + 2 * (i - o), i), split)


def _sides(M: int, N: int, turn: int = 0):
    i = np.arange(M, dtype=np.int64)
    d = N - M
    m1 = math.ceil(d / 2) if turn == 0 else d // 2
    m2 = d - m1
    k = M - 1 - i  # i counted from the right
    left, right = i < m1, k < m2
    first = np.where(left, 2 * i, np.where(right, N - 2 - 2 * k, 2 * m1 + i - m1))
    return _wales(i, first, left | right)


_FORMULAS: dict[str, Callable[[int, int], tuple[np.ndarray, np.ndarray]]] = {
    "uniform": _uniform,
    "center": _center,
    "left": _left,
    "right": _right,
    "sides": _sides,
}


def predefined_wales(
    name: str, M: int, N: int, turn: int = 0, phase: float = 0.0
) -> tuple[np.ndarray, np.ndarray]:
    """The (smaller, larger) wales of a predefined shaper, unvalidated, as the original
    emitted them: each source once in order, then the second wale of each split. `sides`
    reads `turn`, `uniform` `phase` (the module docstring); the others neither."""
    _check_domain(M, N)
    if M == 0:
        return np.zeros(0, np.int64), np.zeros(0, np.int64)
    if name == "sides":
        return _sides(M, N, turn)
    if name == "uniform":
        return _uniform(M, N, phase)
    return _FORMULAS[name](M, N)


@lru_cache(maxsize=4096)
def _predefined(name: str, M: int, N: int, turn: int, phase: float) -> np.ndarray:
    src = mapping_from_pairs(M, N, *predefined_wales(name, M, N, turn, phase))
    src.flags.writeable = False  # shared by every caller through the cache
    return src


# ---- user shaper programs ---------------------------------------------------------------------


class _Collector:
    """Turns the values of executed `->` statements into wales."""

    def __init__(self, M: int, N: int):
        self.M, self.N = M, N
        self.direction: str | None = None  # "split" (from smaller) or "merge" (from larger)
        self.first_span: Span | None = None
        self.plain: list[tuple[int, int, int]] = []  # (lhs, rhs, span index)
        self.wales: list[tuple[int, int, int]] = []  # (small, large, span index)
        self.spans: list[Span] = []

    def __call__(self, src: Value, dst: Value, span: Span) -> None:
        self.spans.append(span)
        n = len(self.spans) - 1
        if isinstance(src, tuple) and isinstance(dst, tuple):
            raise EvalError(
                "E318",
                "a mapping either splits (`i -> (j1, j2)`) or merges "
                "(`(i1, i2) -> j`), not both at once",
                span,
            )
        if isinstance(dst, tuple):
            i, (j1, j2) = _index(src, span), _pair(dst, span, "split")
            self._direction("split", span)
            self.wales += [(i, j1, n), (i, j2, n)]
        elif isinstance(src, tuple):
            (a1, a2), i = _pair(src, span, "merge"), _index(dst, span)
            self._direction("merge", span)
            self.wales += [(i, a1, n), (i, a2, n)]
        else:
            self.plain.append((_index(src, span), _index(dst, span), n))

    def _direction(self, kind: str, span: Span) -> None:
        if self.direction is None:
            self.direction, self.first_span = kind, span
        elif self.direction != kind:
            assert self.first_span is not None
            first = "splits" if self.direction == "split" else "merges"
            raise EvalError(
                "E318",
                f"this shaper already {first} (line {self.first_span.line}); "
                "a shaper maps either from the smaller course (`i -> j`, "
                "`i -> (j1, j2)`) or from the larger (`a -> i`, `(a1, a2) -> i`), "
                "not both",
                span,
                "write increases only: a decrease is the same mapping read backwards",
            )

    def pairs(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        if self.direction == "merge":
            rows = self.wales + [(b, a, n) for a, b, n in self.plain]
        else:
            rows = self.wales + self.plain
        rows.sort(key=lambda r: r[2])  # statement order, for "the second one" messages
        arr = np.array(rows, dtype=np.int64).reshape(-1, 3)
        return arr[:, 0], arr[:, 1], arr[:, 2]


def _index(v: Value, span: Span) -> int:
    i = whole(v)
    if i is None:
        what = show(v) if isinstance(v, int | float) and not isinstance(v, bool) else type_name(v)
        raise EvalError(
            "E318",
            f"a mapping needs stitch indices (whole numbers), got {what}",
            span,
            "round it with `floor`, `ceil` or `round`",
        )
    if abs(i) >= 2**31:  # no course comes near; checked before the wales become arrays
        raise EvalError("E318", f"stitch index {show(v)} is outside any course", span)
    return i


def _pair(v: tuple, span: Span, kind: str) -> tuple[int, int]:
    if len(v) != 2:
        raise EvalError("E318", f"a {kind} involves exactly two stitches, got {len(v)}", span)
    a, b = _index(v[0], span), _index(v[1], span)
    if b != a + 1:
        raise EvalError(
            "E318",
            f"a {kind} involves two neighbouring stitches, got ({a}, {b})",
            span,
            f"write ({a}, {a + 1})",
        )
    return a, b


def run_user_shaper(
    defn: ast.ShaperDef,
    M: int,
    N: int,
    *,
    param: Callable[[str, Span], Value] | None = None,
    prop: Callable[[str | None, str, Span], Value] | None = None,
    budget: int = DEFAULT_BUDGET,
    pool: StepPool | None = None,
    turn: int = 0,
) -> np.ndarray:
    """Run a user shaper for M -> N (M <= N <= 2M) and return its validated `src` array.

    `param`/`prop` resolve `#name` and `@prop` in the program (the evaluator's hooks);
    `turn` is bound to the name `turn` unless a parameter takes that name; `pool` holds the
    steps the design's shaper runs share.
    Raises `EvalError` located in the program; ValueError if M, N are out of domain.
    """
    _check_domain(M, N)
    name = defn.name.name
    if len(defn.params) < 2 or any(p.default is None for p in defn.params[2:]):
        raise EvalError(
            "E310",
            f"shaper `{name}` must take (M, N) and give defaults to any further parameters",
            defn.name.span,
        )
    collect = _Collector(M, N)
    interp = Interpreter(
        words=(),
        on_map=collect,
        param=param,
        prop=prop,
        budget=budget,
        pool=pool,
        what=f"shaper `{name}`",
    )
    bindings: dict[str, Value] = {
        "turn": turn,
        defn.params[0].name.name: M,
        defn.params[1].name.name: N,
    }
    for p in defn.params[2:]:
        assert p.default is not None
        bindings[p.name.name] = interp.evaluate(p.default, bindings)
    interp.run(defn.body, bindings)
    small, large, stmt = collect.pairs()
    try:
        return mapping_from_pairs(M, N, small, large)
    except MappingError as err:
        span = defn.name.span if err.pair is None else collect.spans[int(stmt[err.pair])]
        raise EvalError(
            "E319", f"shaper `{name}` for M = {M}, N = {N}: {err.message}", span, err.hint
        ) from None


# ---- the entry point --------------------------------------------------------------------------


def shape(
    shaper: str | ast.ShaperDef, M: int, N: int, *, turn: int = 0, phase: float = 0.0, **hooks
) -> np.ndarray:
    """The `src` array mapping M stitches onto N (M <= N <= 2M) for a predefined shaper name
    or a user `ShaperDef` (`hooks`: `param`, `prop`, `budget` of `run_user_shaper`); `turn`
    and `phase` are the shape pass's alternation (see the module docstring).

    Predefined mappings are cached by (name, M, N, turn, phase) and returned read-only.
    """
    if isinstance(shaper, ast.ShaperDef):
        return run_user_shaper(shaper, M, N, turn=turn, **hooks)
    if shaper == "none":
        raise ValueError(
            "shaper `none` has no mapping: its wales join stitches on the same "
            "needle (grid wales), which the shape pass builds from the layout"
        )
    if shaper not in _FORMULAS:
        raise ValueError(f"`{shaper}` is not a predefined shaper; pass its ShaperDef")
    _check_domain(M, N)
    return _predefined(
        shaper, M, N, turn if shaper == "sides" else 0, phase if shaper == "uniform" else 0.0
    )


def wales_between(prev_len: int, next_len: int, src: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The wales between consecutive courses as (previous index, next index) arrays, given
    `src = shape(..., min(prev_len, next_len), max(prev_len, next_len))`."""
    larger = np.arange(len(src), dtype=np.int64)
    if prev_len <= next_len:
        return np.asarray(src, dtype=np.int64), larger
    return larger, np.asarray(src, dtype=np.int64)
