"""The arithmetic of the knitc language: every evaluator's numbers go through here.

Parameters, properties and action programs are evaluated one value at a time
(`evaluate.Evaluator` and the interpreters built on it); a `filter` predicate is evaluated
over every stitch at once (`patterning.query`). A designer must get the same answer, and the
same error, from `#n / 0` in a property and in a filter, so each operator's rules are
written once, here, with a scalar form (exact Python integers, cheap per call: action
programs run per stitch) and a vectorised form (numpy, float64 so that no integer wraps
around) that `tests/test_arith.py` holds to the same results on random expressions.

The rules: `/` and `%` by zero are errors; `^` of a negative number to a fraction is not a
real number, and 0 to a negative power is a division by zero; a result whose magnitude
exceeds `LIMIT` is "too large" (no knitting quantity comes near it, and beyond it float64
loses whole numbers); an integer result above 2^53 becomes a float, as it would be in a
vector. Every one of these is `ArithError` with code E305; callers add the source span.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

LIMIT = 1e300
"""Largest magnitude a computed number may have."""

TOO_LARGE = "number too large: the limit is ±1e300"
"""The message of a result beyond `LIMIT`, which names the limit so the designer knows how
far off the number is."""

EXACT = 2**53
"""Integers beyond this are carried as floats (what float64 holds exactly)."""

ARITHMETIC = ("+", "-", "*", "/", "%", "^")
COMPARISONS = ("<", "<=", ">", ">=")


class ArithError(Exception):
    """A mistake in the numbers themselves (E305); the caller knows where it is written."""

    code = "E305"

    def __init__(self, message: str):
        super().__init__(message)
        self.message = message


# ---- one value at a time ----------------------------------------------------------------


def scalar(op: str, x: int | float, y: int | float) -> int | float | bool:
    """`x op y` for plain numbers (not booleans); ArithError on a mistake."""
    if op in COMPARISONS:
        return {"<": x < y, "<=": x <= y, ">": x > y, ">=": x >= y}[op]
    if op in ("/", "%") and y == 0:
        raise ArithError("division by zero")
    if op == "^":
        _check_power(x, y)
    try:
        if op == "+":
            r: int | float = x + y
        elif op == "-":
            r = x - y
        elif op == "*":
            r = x * y
        elif op == "/":
            q = x / y
            r = int(q) if isinstance(x, int) and isinstance(y, int) and q.is_integer() else q
        elif op == "%":
            r = x % y
        elif op == "^":
            r = x**y
        else:
            raise AssertionError(op)
    except (OverflowError, ZeroDivisionError):
        raise ArithError(TOO_LARGE) from None
    return bounded(r)


def negate(x: int | float) -> int | float:
    return bounded(-x)


def _check_power(x: float, y: float) -> None:
    if abs(y) > 1024 or (abs(x) > 1 and abs(y) * math.log10(abs(x)) > 300):
        raise ArithError(TOO_LARGE)
    if x < 0 and not float(y).is_integer():
        raise ArithError(f"{_show(x)} ^ {_show(y)} is not a real number")
    if x == 0 and y < 0:
        raise ArithError("division by zero")


def bounded(r: int | float) -> int | float:
    """`r` as the language carries it: an error beyond `LIMIT` or not finite (an infinity
    or a nan, which no quantity can be), a float if it is an integer beyond `EXACT`. Every
    number an evaluator computes outside `scalar` (a builtin's result) goes through here."""
    if isinstance(r, int):
        if abs(r) <= EXACT:
            return r
        if abs(r) > LIMIT:
            raise ArithError(TOO_LARGE)
        return float(r)
    if not math.isfinite(r) or abs(r) > LIMIT:
        raise ArithError(TOO_LARGE)
    return r


def _show(x: float) -> str:
    return str(int(x)) if float(x).is_integer() else repr(x)


# ---- every stitch at once ---------------------------------------------------------------


def vector(op: str, a: Any, b: Any) -> np.ndarray:
    """`a op b` elementwise over numbers and arrays of numbers; ArithError if any element
    is a mistake (the same mistakes `scalar` refuses)."""
    x = np.asarray(a, dtype=np.float64)
    y = np.asarray(b, dtype=np.float64)
    if op in COMPARISONS:
        return {"<": np.less, "<=": np.less_equal, ">": np.greater, ">=": np.greater_equal}[op](
            x, y
        )
    if op in ("/", "%") and np.any(y == 0):
        raise ArithError("division by zero")
    with np.errstate(all="ignore"):
        if op == "^":
            x, y = np.broadcast_arrays(x, y)
            big = (np.abs(y) > 1024) | (
                (np.abs(x) > 1)
                & (np.abs(y) * np.log10(np.where(np.abs(x) > 1, np.abs(x), 1.0)) > 300)
            )
            if np.any(big):
                raise ArithError(TOO_LARGE)
            bad = (x < 0) & (y != np.floor(y))
            if np.any(bad):
                i = int(np.argmax(bad))
                raise ArithError(
                    f"{_show(float(x.flat[i]))} ^ {_show(float(y.flat[i]))} is not a real number"
                )
            if np.any((x == 0) & (y < 0)):
                raise ArithError("division by zero")
            r = np.power(x, y)
        else:
            r = {"+": np.add, "-": np.subtract, "*": np.multiply, "/": np.true_divide, "%": np.mod}[
                op
            ](x, y)
    if not np.all(np.isfinite(r)) or np.any(np.abs(r) > LIMIT):
        raise ArithError(TOO_LARGE)
    return r
