"""Query evaluation (`where Q`, thesis Table 5.1): golden masks on small flat and tubular shapes.

Masks are drawn like a chart: the top row is the node's last course, each row lists the
course's stitches by wale (flat: left to right on the bed; tube: front left to right, then
back right to left), `#` = selected.
"""

from __future__ import annotations

import numpy as np
import pytest

from knitc.diagnostics import Diagnostics
from knitc.driver import compile_source
from knitc.patterning.query import QueryEnv, coords, evaluate_query

SHAPES = """
sheet s { width: 6  length: 5 }
tube t { width: 3  length: 4 }
start s.bottom
s.top open
start t.bottom
t.top open
"""


def compile_layers(body_s: str = "", body_t: str = "", shapes: str = SHAPES):
    src = shapes + f"pattern s {{\n{body_s}\n}}\npattern t {{\n{body_t}\n}}\n"
    r = compile_source(src, "t.knit", until="stitch-graph")
    assert not r.diagnostics.has_errors, list(r.diagnostics)
    return r


def chart(g, node: str, mask: np.ndarray) -> str:
    c = coords(g)
    rows = []
    for cid in range(g.n_courses):
        if g.node_names[int(g.course_node[cid])] != node:
            continue
        ids = g.course_ids(cid)
        ids = ids[np.argsort(c.wale[ids], kind="stable")]
        rows.append("".join("#" if mask[i] else "." for i in ids))
    return "\n".join(reversed(rows))


def run(query: str, node: str = "s", env: QueryEnv | None = None, shapes: str = SHAPES):
    body = f"set P where {query}"
    r = compile_layers(body if node == "s" else "", body if node == "t" else "", shapes)
    g = r.graph
    (layer,) = [la for la in r.skeleton.layers if la.target == node]
    d = Diagnostics()
    m = evaluate_query(g, g.node_names.index(node), layer.stmt.where, env, d)
    return g, m, d


def golden(query: str, node: str = "s") -> str:
    g, m, d = run(query, node)
    assert not list(d), list(d)
    return chart(g, node, m)


SHEET = [
    ("all()", "######\n" * 5),
    ("wales(0:2)", "###...\n" * 5),
    ("wales(-2:end)", "....##\n" * 5),
    ("wales(0:2:end)", "#.#.#.\n" * 5),
    ("wales(0.5:end)", "...###\n" * 5),
    ("wales(0:0.5)", "###...\n" * 5),
    ("wales(3)", "...#..\n" * 5),
    ("courses(1:end-1) - wales(-2:-1)", "......\n####..\n####..\n####..\n......"),
    ("courses(end)", "######\n......\n......\n......\n......"),
    ("select(0:1, 1:2)", "......\n......\n......\n.##...\n.##..."),
    ("wales(0:1).neighbors(1)", "..#...\n" * 5),
    ("courses(0).neighbors(0:2)", "......\n......\n######\n######\n######"),
    ("boundaries()", "######\n#....#\n#....#\n#....#\n######"),
    ("select(1:3, 1:4).boundaries()", "......\n.####.\n.#..#.\n.####.\n......"),
    ("filter(course == 2 and wale > 1)", "......\n......\n..####\n......\n......"),
    ("filter(wale % 3 == 0 or course_end - course == 0)", "######\n#..#..\n#..#..\n#..#..\n#..#.."),
    ('itf("bottom")', "......\n......\n......\n......\n######"),
    ('itf("s.top") or itf("bottom")', "######\n......\n......\n......\n######"),
    ("named()", "######\n......\n......\n......\n######"),
    ('shape("s") - shape("t")', "######\n" * 5),
    ('shape("t")', "......\n" * 5),
    ("side(back)", "......\n" * 5),
    ("not wales(1:end)", "#.....\n" * 5),
    ("wales(0:2) and courses(0:1) or courses(4)", "######\n......\n......\n###...\n###..."),
    ("wales(4:2)", "......\n" * 5),
    ("courses(0.5)", "......\n......\n######\n......\n......"),
    ("courses(-0.5:end)", "######\n######\n######\n......\n......"),
    ("wales(-0.2:end)", "....##\n" * 5),
]


@pytest.mark.parametrize(("query", "expected"), SHEET)
def test_flat_sheet_golden(query, expected):
    assert golden(query) == expected.strip()


TUBE = [
    ("wales(0:3)", "####..\n" * 4),
    ("side(back)", "...###\n" * 4),
    ("wales(0:1, front)", "##....\n" * 4),
    # the back bed's two leftmost needles are the last two stitches in yarn order
    ("wales(0:1, back)", "....##\n" * 4),
    ("select(0, -1:end, back)", "......\n......\n......\n...#.."),
    ("boundaries()", "######\n......\n......\n######"),
    # a tube course is cyclic: the first wale's ring-1 neighbours wrap to the last one
    ("wales(0).neighbors(1) and courses(1:2)", "......\n.#...#\n.#...#\n......"),
]


@pytest.mark.parametrize(("query", "expected"), TUBE)
def test_tube_golden(query, expected):
    assert golden(query, "t") == expected.strip()


BIG = """
sheet s { width: 30  length: 30 }
tube t { width: 15  length: 30 }
start s.bottom
s.top open
start t.bottom
t.top open
"""


@pytest.mark.parametrize("node", ["s", "t"])
def test_30x30_matches_coordinate_formula(node):
    g, m, d = run("select(0.5:end, 0:3) or courses(0:2:4)", node, shapes=BIG)
    assert not list(d)
    c = coords(g)
    own = g.node == g.node_names.index(node)
    assert int(own.sum()) == 900
    want = own & (((c.course >= 15) & (c.wale <= 3)) | np.isin(c.course, [0, 2, 4]))
    assert np.array_equal(m, want)
    assert int(m.sum()) == 15 * 4 + 3 * 30


def test_global_layer_sees_every_node():
    r = compile_layers()
    g = r.graph
    from knitc.frontend import ast

    q = ast.Call(func=ast.Name(id="wales"), args=(ast.Number(value=0),))
    d = Diagnostics()
    m = evaluate_query(g, None, q, None, d)
    # one stitch per course of both nodes: 5 sheet courses and 4 tube courses
    assert int(m.sum()) == 9 and not list(d)
    assert np.array_equal(evaluate_query(g, None, None, None, d), np.ones(g.n_stitches, bool))


def test_params_and_lets():
    r = compile_source(
        SHAPES.replace("start s", "param k = 2\nstart s", 1)
        + "pattern s {\n let a = wales(0)\n set P where a or courses(#k)\n}\n",
        "t.knit",
        until="stitch-graph",
    )
    assert not r.diagnostics.has_errors, list(r.diagnostics)
    g = r.graph
    let, st = r.skeleton.layers
    env = QueryEnv(params={"k": 2}, lets={"a": let.stmt.value})
    d = Diagnostics()
    m = evaluate_query(g, 0, st.stmt.where, env, d)
    assert not list(d)
    assert chart(g, "s", m) == "#.....\n#.....\n######\n#.....\n#....."
    env2 = QueryEnv(params={"k": 2}, lets={"a": m})  # a precomputed mask works too
    assert np.array_equal(evaluate_query(g, 0, st.stmt.where, env2, d), m)


@pytest.mark.parametrize(
    ("query", "code"),
    [
        ("wales(0:0:end)", "E702"),
        ("wales(0:1.5:end)", "E702"),
        ("neighbors(1)", "E701"),
        ("courses(0).wales(1)", "E701"),
        ('shape("nope")', "E705"),
        ("side(end)", "E703"),
        ("wales(0).neighbors(3:1)", "E702"),
        ("filter(wale / 0 > 1)", "E305"),  # the same code as anywhere else
        ("filter(wale ^ (0 - 1) > 0)", "E305"),
        ("filter(2 ^ 5000 > wale)", "E305"),
        ("filter(wale + (wale > 1) > 0)", "E303"),
        ("a", "E704"),
    ],
)
def test_errors_are_located_diagnostics(query, code):
    src = SHAPES + f"pattern s {{\n let a = all()\n set P where {query}\n}}\n"
    r = compile_source(src, "t.knit", until="stitch-graph")
    g = r.graph
    stmt = r.skeleton.layers[-1].stmt
    d = Diagnostics()
    m = evaluate_query(g, 0, stmt.where, QueryEnv(), d)  # `a` deliberately not bound
    (diag,) = list(d)
    assert diag.code == code and diag.is_error
    assert diag.span is not None and diag.span.line == stmt.where.span.line
    assert not m.any()
