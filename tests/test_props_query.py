"""Properties of query evaluation: set-algebra laws, domain containment, range sugar."""

from __future__ import annotations

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from knitc.diagnostics import Diagnostics
from knitc.driver import compile_source
from knitc.frontend import ast
from knitc.patterning.query import coords, evaluate_query

SRC = """
sheet s { width: [0: 7, 1: 11]  length: 9 }
tube t { width: [0: 4, 1: 6]  length: 8 }
start s.bottom
s.top open
start t.bottom
t.top open
"""
_R = compile_source(SRC, "t.knit", until="stitch-graph")
assert not _R.diagnostics.has_errors, list(_R.diagnostics)
G = _R.graph
C = coords(G)


def N(v):  # noqa: N802 - a number literal, negative ones as the parser builds them
    return ast.Unary(op="-", operand=ast.Number(value=-v)) if v < 0 else ast.Number(value=v)


def call(name, *args):
    return ast.Call(func=ast.Name(id=name), args=tuple(args))


END = ast.Name(id="end")
bounds = st.one_of(
    st.integers(-12, 12).map(N),
    st.sampled_from([0.25, 0.5, 0.75]).map(N),
    st.just(END),
    st.integers(0, 5).map(lambda k: ast.Binary("-", END, N(k))),
)
ranges = st.builds(
    lambda a, b, s: ast.Range(a, b, None if s == 1 else N(s)), bounds, bounds, st.integers(1, 3)
)
sides = st.sampled_from(["front", "back"]).map(lambda s: ast.Name(id=s))
atoms = st.one_of(
    st.just(call("all")),
    st.just(call("boundaries")),
    st.just(call("named")),
    ranges.map(lambda r: call("wales", r)),
    ranges.map(lambda r: call("courses", r)),
    st.builds(lambda r, s: call("wales", r, s), ranges, sides),
    st.builds(lambda a, b: call("select", a, b), ranges, ranges),
    sides.map(lambda s: call("side", s)),
    st.integers(2, 4).map(
        lambda k: call("filter", ast.Binary("==", ast.Binary("%", ast.Name(id="wale"), N(k)), N(0)))
    ),
)
queries = st.recursive(
    atoms,
    lambda q: st.one_of(
        st.builds(lambda a, b, op: ast.Binary(op, a, b), q, q, st.sampled_from(["or", "and", "-"])),
        q.map(lambda a: ast.Unary("not", a)),
        st.builds(
            lambda a, k: ast.Call(func=ast.Attr(a, ast.Ident(name="neighbors")), args=(N(k),)),
            q,
            st.integers(1, 2),
        ),
        q.map(lambda a: ast.Call(func=ast.Attr(a, ast.Ident(name="boundaries")), args=())),
    ),
    max_leaves=6,
)
nodes = st.sampled_from([0, 1, None])


def ev(node, q):
    d = Diagnostics()
    m = evaluate_query(G, node, q, None, d)
    assert not list(d), list(d)
    assert m.dtype == bool and m.shape == (G.n_stitches,)
    return m


def domain(node):
    return np.ones(G.n_stitches, bool) if node is None else G.node == node


@settings(max_examples=60, deadline=None)
@given(nodes, queries, queries)
def test_set_algebra_laws(node, a, b):
    A, B = ev(node, a), ev(node, b)
    dom = domain(node)
    assert not (A & ~dom).any() and not (B & ~dom).any()
    assert np.array_equal(ev(node, ast.Binary("or", a, b)), ev(node, ast.Binary("or", b, a)))
    assert np.array_equal(ev(node, ast.Binary("and", a, b)), A & B)
    assert np.array_equal(ev(node, ast.Unary("not", ast.Unary("not", a))), A)
    assert np.array_equal(
        ev(node, ast.Binary("-", a, b)), ev(node, ast.Binary("and", a, ast.Unary("not", b)))
    )
    assert np.array_equal(
        ev(node, ast.Unary("not", ast.Binary("or", a, b))),
        ev(node, ast.Binary("and", ast.Unary("not", a), ast.Unary("not", b))),
    )
    assert np.array_equal(ev(node, ast.Unary("not", a)), dom & ~A)


@settings(max_examples=40, deadline=None)
@given(nodes, queries, st.integers(1, 2))
def test_neighbors_and_boundaries_shapes(node, a, k):
    A = ev(node, a)
    grown = ev(
        node, ast.Call(func=ast.Attr(a, ast.Ident(name="neighbors")), args=(ast.Range(N(0), N(k)),))
    )
    ring = ev(node, ast.Call(func=ast.Attr(a, ast.Ident(name="neighbors")), args=(N(k),)))
    assert np.array_equal(grown & ~A, ring) and not (ring & A).any()
    assert (A & ~grown).sum() == 0
    bnd = ev(node, ast.Call(func=ast.Attr(a, ast.Ident(name="boundaries")), args=()))
    assert not (bnd & ~A).any()
    assert A.any() == bnd.any()  # a non-empty finite selection always has a boundary


@settings(max_examples=60, deadline=None)
@given(nodes, st.integers(1, 8), st.integers(0, 4), st.sampled_from(["wales", "courses"]))
def test_negative_bounds_equal_explicit_end(node, k, j, kind):
    """`-k:-j-1` is `end-k+1 : end-j`, and `wales(-k)` is `wales(end-k+1)`."""
    neg = call(kind, ast.Range(N(-k), N(-j - 1)))
    explicit = call(kind, ast.Range(ast.Binary("-", END, N(k - 1)), ast.Binary("-", END, N(j))))
    assert np.array_equal(ev(node, neg), ev(node, explicit))
    assert np.array_equal(
        ev(node, call(kind, N(-k))), ev(node, call(kind, ast.Binary("-", END, N(k - 1))))
    )


@settings(max_examples=60, deadline=None)
@given(
    nodes,
    st.sampled_from([0.1, 0.25, 0.3, 0.5, 0.75, 0.9]),
    st.sampled_from([0.2, 0.5, 0.6, 0.95]),
    st.sampled_from(["wales", "courses"]),
)
def test_fraction_bounds_equal_explicit_indices(node, f, h, kind):
    idx, end = (C.wale, C.wale_end) if kind == "wales" else (C.course, C.course_end)
    lo = np.ceil(f * end - 1e-9)
    hi = np.floor(h * end + 1e-9)
    want = domain(node) & (idx >= lo) & (idx <= hi)
    assert np.array_equal(ev(node, call(kind, ast.Range(N(f), N(h)))), want)
    neg = ev(node, call(kind, ast.Range(N(-(1 - f)), N(h))))
    assert np.array_equal(neg, want)  # `-0.75` is the fraction 0.25 counted from the end
    # and with constant extents (the courses of one node), the explicit integer range agrees
    if kind == "courses" and node is not None:
        e = int(C.course_end[G.node == node][0])
        a, b = math.ceil(f * e - 1e-9), math.floor(h * e + 1e-9)
        assert np.array_equal(want, ev(node, call(kind, ast.Range(N(a), N(b)))))


@settings(max_examples=40, deadline=None)
@given(nodes, st.integers(0, 6), st.integers(1, 4))
def test_step_keeps_every_kth_from_start(node, a, s):
    got = ev(node, call("wales", ast.Range(N(a), END, N(s))))
    want = domain(node) & (C.wale >= a) & ((C.wale - a) % s == 0)
    assert np.array_equal(got, want)


def test_wales_partition_each_course():
    """Halves by fraction cover every course of both nodes; being inclusive, they share a
    stitch exactly where the middle of the course falls on a stitch (an odd length)."""
    left = ev(None, call("wales", ast.Range(N(0), N(0.5))))
    right = ev(None, call("wales", ast.Range(N(0.5), END)))
    assert (left | right).all()
    middle = (C.wale_end % 2 == 0) & (2 * C.wale == C.wale_end)
    assert np.array_equal(left & right, middle) and middle.any()
