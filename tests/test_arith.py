"""The scalar and the vectorised evaluators share one arithmetic and agree on it.

A random expression over numbers and a parameter `#w` is evaluated two ways: by the
parameter evaluator once per value of `#w`, and by the filter evaluator once with `#w`
an array of those values (as a stitch field is). Both must give the same numbers, or both refuse
with the same code.
"""

from __future__ import annotations

import math

import numpy as np
from hypothesis import given
from hypothesis import strategies as st

from knitc.diagnostics import Diagnostics
from knitc.driver import compile_source
from knitc.frontend import ast
from knitc.frontend.resolve import parse_define
from knitc.lang import arith
from knitc.lang.evaluate import EvalError, Evaluator
from knitc.patterning.query import QueryEnv, QueryError, _Eval

G = compile_source("sheet s { length: 1  width: 7 }\n", "s.knit", until="stitch-graph").graph
WALES = list(range(-3, 4))

numbers = st.one_of(
    st.integers(-40, 40).map(str), st.sampled_from(["0.5", "2.25", "1000", "0", "1e3"])
)
leaf = st.one_of(numbers, st.just("#w"), st.sampled_from(["true", "false"]))


def _tree(children):
    ops = st.sampled_from(arith.ARITHMETIC + arith.COMPARISONS + ("==", "!="))
    return st.one_of(
        st.tuples(children, ops, children).map(lambda t: f"({t[0]} {t[1]} {t[2]})"),
        st.tuples(st.sampled_from(["-", "not "]), children).map(lambda t: f"({t[0]}{t[1]})"),
    )


expressions = st.recursive(leaf, _tree, max_leaves=8)


def _parse(text: str) -> ast.Node:
    diags = Diagnostics()
    got = parse_define(f"e={text}", diags)
    assert got is not None and not diags.has_errors, text
    return got[1]


def _scalar(e: ast.Node, w: int) -> object:
    ev = Evaluator(param=lambda name, span: w, prop=lambda n, p, span: 0)
    try:
        return ev.eval(e)
    except EvalError as err:
        return err.code


def _vector(e: ast.Node) -> object:
    ev = _Eval(G, 0, QueryEnv(params={"w": np.array(WALES)}), None, None)
    try:
        return np.broadcast_to(np.asarray(ev.pred(e), dtype=np.float64), (len(WALES),))
    except QueryError as err:
        return err.code


@given(expressions)
def test_scalar_and_vector_agree(text):
    e = _parse(text)
    per_stitch = [_scalar(e, w) for w in WALES]
    together = _vector(e)
    codes = {r for r in per_stitch if isinstance(r, str)}
    if codes:
        assert together in codes, (text, per_stitch, together)
        return
    assert not isinstance(together, str), (text, per_stitch, together)
    for i, r in enumerate(per_stitch):
        assert math.isclose(float(r), float(together[i]), rel_tol=1e-12, abs_tol=1e-12), (
            text,
            i,
            r,
            together[i],
        )


def test_the_examples_of_the_issue_are_located_errors_not_crashes():
    for text, code in [
        ("#w ^ (0 - 1) > 0", "E305"),
        ("2 ^ 5000 > #w", "E305"),
        ("#w / 0 > 1", "E305"),
        ("#w % (#w - #w) > 1", "E305"),
    ]:
        assert _vector(_parse(text)) == code, text
    assert _scalar(_parse("1 / 0"), 0) == "E305"
    assert _scalar(_parse("2 ^ 5000"), 0) == "E305"


def test_integers_stay_exact_up_to_float64s_whole_numbers():
    assert arith.scalar("*", 3, 4) == 12 and isinstance(arith.scalar("*", 3, 4), int)
    assert arith.scalar("/", 6, 3) == 2 and isinstance(arith.scalar("/", 6, 3), int)
    assert isinstance(arith.scalar("*", 2**40, 2**20), float)
