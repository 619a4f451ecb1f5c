"""Drawn layers (`draw` / `stretch` / `tile GRID where Q`) and the drawn queries (`stretch`,
`tile`, `img`, `noise`, `wale_grid`, `stitch_grid`): where a chart lands, that it follows
the shape when parameters change, the laws of tiling, stretching and noise, located errors,
and programs with drawn layers running clean on the independent machine.

Instructions are read right after the pattern pass (`patterned`), before later passes
lower moves and edges.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from fabric import assert_knits_as_designed
from golden import assert_golden
from knitc.diagnostics import Diagnostics
from knitc.driver import compile_source
from knitc.frontend import ast
from knitc.patterning import raster
from knitc.patterning.query import QueryEnv, coords, evaluate_frame, evaluate_query
from knitc.shaping.stitch_graph import INSTRUCTIONS
from test_query_golden import GOLDEN, LEGEND_LINE, chart, patterned

K, P, T, M = (INSTRUCTIONS.index(m) for m in ("K", "P", "T", "M"))
FR1, FL1 = INSTRUCTIONS.index("FR1"), INSTRUCTIONS.index("FL1")


def sheet(width, length, body, extra=""):
    return (
        f"{extra}sheet s {{ width: {width}  length: {length} }}\nstart s.bottom\n"
        f"s.top open\npattern s {{\n{body}\n}}\n"
    )


def grid_of(g, node="s"):
    """{(course, wale): instruction} of a node."""
    c = coords(g)
    own = np.nonzero(g.node == g.node_names.index(node))[0]
    return {(int(c.course[i]), int(c.wale[i])): int(g.instr[i]) for i in own}


# ---- placement -----------------------------------------------------------------------------

DIAMOND = '''"""
    . P .
    P T P
    . P M
  """'''


def test_draw_is_centred_in_the_selection_and_read_like_a_chart():
    g, d = patterned(sheet(12, 10, f"  draw {DIAMOND} where courses(2:end)"), "t.knit")
    assert not list(d)
    got = grid_of(g)
    # 8 courses x 12 wales selected: the 3 x 3 chart starts at course 2 + (8 - 3) // 2 = 4
    # and wale (12 - 3) // 2 = 4; its last row is the first course
    want = {(4, 5): P, (4, 6): M, (5, 4): P, (5, 5): T, (5, 6): P, (6, 5): P}
    for (cr, w), v in got.items():
        assert v == want.get((cr, w), K), (cr, w)


def test_draw_centres_each_course_of_a_shaped_piece():
    # on a piece narrowing evenly, every course is centred on its own wales
    g, d = patterned(sheet("[0: 15, 1: 9]", 9, '  draw """\n P\n P\n P\n P\n P\n """'), "t.knit")
    assert not list(d)
    c = coords(g)
    p = np.nonzero(g.instr == P)[0]
    assert sorted(c.course[p].tolist()) == [2, 3, 4, 5, 6]
    assert np.array_equal(c.wale[p], c.wale_end[p] // 2)


@pytest.mark.parametrize("length", [20, 41])
def test_a_drawing_follows_a_longer_sleeve(length):
    src = (
        "param len = 20\ntube sleeve { width: 10  length: #len }\nstart sleeve.bottom\n"
        "sleeve.top open\npattern sleeve {\n"
        f"  draw {DIAMOND} where side(front) and courses(0.25:0.75)\n"
        '  tile """\n P K K\n """ where side(back) and courses(0.5:end)\n}\n'
    )
    g, d = patterned(src, "t.knit", defines=(f"len={length}",))
    assert not list(d)
    got = grid_of(g, "sleeve")
    lo, hi = int(np.ceil(0.25 * (length - 1))), int(np.floor(0.75 * (length - 1)))
    r0 = lo + (hi - lo + 1 - 3) // 2  # centred rows; front wales 0..9, cols (10 - 3) // 2
    want = {(r0, 4): P, (r0, 5): M, (r0 + 1, 3): P, (r0 + 1, 4): T, (r0 + 1, 5): P, (r0 + 2, 4): P}
    t0 = int(np.ceil(0.5 * (length - 1)))
    for (cr, w), v in got.items():
        if w < 10:
            assert v == want.get((cr, w), K), (cr, w)
        else:  # the back, in yarn order: wales 10..19 from its (yarn-order) first stitch
            assert v == (P if cr >= t0 and (w - 10) % 3 == 0 else K), (cr, w)


@pytest.mark.parametrize("width", [11, 16])
def test_tile_starts_at_the_selection_corner(width):
    src = sheet(
        "#w", 12, '  tile """\n K T\n P M\n P K\n """ where select(5:end, 3:end)', "param w = 8\n"
    )
    g, d = patterned(src, "t.knit", defines=(f"w={width}",))
    assert not list(d)
    chart_ = [[K, T], [P, M], [P, K]]
    for (cr, w), v in grid_of(g).items():
        if cr < 5 or w < 3:
            assert v == K
        else:
            assert v == chart_[2 - (cr - 5) % 3][(w - 3) % 2], (cr, w)


def test_stretch_scales_onto_the_bounding_box():
    g, d = patterned(
        sheet(12, 10, '  stretch """\n P K\n K T\n """ where select(2:7, 4:11)'), "t.knit"
    )
    assert not list(d)
    for (cr, w), v in grid_of(g).items():
        if not (2 <= cr <= 7 and 4 <= w <= 11):
            want = K
        elif cr <= 4:
            want = K if w <= 7 else T
        else:
            want = P if w <= 7 else K
        assert v == want, (cr, w)


def test_a_drawing_inside_a_pattern_definition_is_placed_on_the_callers_selection():
    body = "  apply motif() where select(4:9, 2:7)\n"
    defs = 'pattern motif() {\n  set P\n  tile """\n K . K\n """\n}\n'
    g, d = patterned(sheet(12, 12, body, defs), "t.knit")
    assert not list(d)
    for (cr, w), v in grid_of(g).items():
        inside = 4 <= cr <= 9 and 2 <= w <= 7
        assert v == ((K if (w - 2) % 3 != 1 else P) if inside else K), (cr, w)


def test_stdlib_eyelets_write_the_lace_chart():
    src = sheet(16, 12, "  apply eyelets() where courses(2:end)", "import std.stitches\n")
    g, d = patterned(src, "t.knit")
    assert not list(d)
    got = grid_of(g)
    # the chart's last row (course 2): `. . FR1 . . FL1 . .`, its 4th row from the bottom
    # (course 5): `. FL1 . . . FR1 .`
    for w in range(16):
        assert got[(2, w)] == {2: FR1, 5: FL1}.get(w % 8, K)
        assert got[(3, w)] == {2: M, 5: M}.get(w % 8, K)
        assert got[(6, w)] == {1: FL1, 6: FR1}.get(w % 8, K)
    assert got[(10, 2)] == FR1  # 8 courses later it repeats


def test_wale_grid_keeps_a_motif_on_its_wales_through_shaping():
    src = sheet("[0: 16, 1: 8]", 14, '  let g = """\n P K K\n """\n  tile g where wale_grid()')
    g, d = patterned(src, "t.knit")
    assert not list(d)
    r = compile_source(src, "t.knit", until="skeleton")
    fr = evaluate_frame(
        g,
        0,
        r.skeleton.layers[-1].stmt.where,
        QueryEnv(lets={"g": r.skeleton.layers[0].stmt.value}),
        Diagnostics(),
    )
    on, col, row = fr.mask, fr.col, fr.row
    c = coords(g)
    ids = np.nonzero(on & (row > 0))[0]
    assert ids.size > 100
    for s in ids.tolist():  # every grid stitch continues a wale of the grid's row below
        prev = [int(p) for p in g.wale_prev[s] if p >= 0 and on[p]]
        assert any(col[p] == col[s] and row[p] == row[s] - 1 for p in prev), s
        assert g.instr[s] == (P if col[s] % 3 == 0 else K)
    for cid in range(g.n_courses):  # a regular grid: one stitch per column in a course
        cols = col[g.course_ids(cid)][on[g.course_ids(cid)]]
        assert len(set(cols.tolist())) == cols.size
    # course/wale coordinates shear on this piece: some purl wale drifts off its column
    drift = [
        s
        for s in range(g.n_stitches)
        if g.wale_prev[s, 0] >= 0 and c.wale[s] % 3 == 0 and c.wale[g.wale_prev[s, 0]] % 3 != 0
    ]
    assert drift


def test_stitch_grid_alignments():
    src = sheet(20, 12, 'set P where select(5, 10).stitch_grid(5, 3, "right", "top")')
    g, d = patterned(src, "t.knit")
    assert not list(d)
    got = {k for k, v in grid_of(g).items() if v == P}
    assert got == {(cr, w) for cr in (3, 4, 5) for w in range(6, 11)}
    g, d = patterned(src.replace('"right", "top"', 'y_align = "middle"'), "t.knit")
    assert {k for k, v in grid_of(g).items() if v == P} == {
        (cr, w) for cr in (4, 5, 6) for w in range(10, 15)
    }


# ---- laws (hypothesis) ---------------------------------------------------------------------

_SRC = """
sheet s { width: [0: 9, 1: 13]  length: 12 }
tube t { width: 7  length: 10 }
start s.bottom
s.top open
start t.bottom
t.top open
"""
_R = compile_source(_SRC, "t.knit", until="stitch-graph")
G = _R.graph
C = coords(G)


def _n(v):
    return ast.Number(value=v)


def _call(name, *args):
    return ast.Call(func=ast.Name(id=name), args=tuple(args))


def _grid(cells):
    return ast.Grid(rows=tuple(tuple(ast.GridCell(text=t) for t in row) for row in cells))


def _ev(node, q):
    d = Diagnostics()
    m = evaluate_query(G, node, q, None, d)
    assert not list(d), list(d)
    return m


charts = st.integers(1, 4).flatmap(
    lambda w: st.lists(
        st.lists(st.sampled_from(["x", "."]), min_size=w, max_size=w), min_size=1, max_size=4
    )
)
boxes = st.tuples(st.integers(0, 4), st.integers(0, 4), st.integers(5, 11), st.integers(5, 13))
nodes = st.sampled_from([0, 1])


def _select(box):
    c0, w0, c1, w1 = box
    return _call("select", ast.Range(_n(c0), _n(c1), None), ast.Range(_n(w0), _n(w1), None))


@settings(max_examples=60, deadline=None)
@given(nodes, charts, boxes)
def test_tiling_is_periodic(node, cells, box):
    sel = _ev(node, _select(box))
    m = _ev(node, _call("tile", _grid(cells), _select(box)))
    assert not (m & ~sel).any()
    rows, cols = len(cells), len(cells[0])
    at = {(int(C.course[i]), int(C.wale[i])): i for i in np.nonzero(sel)[0]}
    c0 = min(k[0] for k in at)
    w0 = min(k[1] for k in at)
    for (cr, w), i in at.items():
        for other in ((cr + rows, w), (cr, w + cols)):
            if other in at:
                assert m[i] == m[at[other]]
        # and the corner holds the chart's bottom-left cell
        if (cr, w) == (c0, w0):
            assert m[i] == (cells[-1][0] == "x")


@settings(max_examples=40, deadline=None)
@given(nodes, boxes, st.sampled_from(["stretch", "tile"]))
def test_a_one_cell_grid_covers_the_whole_selection(node, box, how):
    sel = _select(box)
    assert np.array_equal(_ev(node, _call(how, _grid([["x"]]), sel)), _ev(node, sel))
    assert not _ev(node, _call(how, _grid([["."]]), sel)).any()


@settings(max_examples=40, deadline=None)
@given(nodes, st.floats(0.5, 8), st.integers(-(2**40), 2**40), st.floats(0.1, 0.9))
def test_noise_is_deterministic_and_monotone_in_the_threshold(node, scale, seed, threshold):
    q = _call("noise", _n(scale), _n(threshold), _n(seed))
    a = _ev(node, q)
    assert np.array_equal(a, _ev(node, q))
    higher = _ev(node, _call("noise", _n(scale), _n(min(threshold + 0.1, 1)), _n(seed)))
    assert not (higher & ~a).any()


@settings(max_examples=40, deadline=None)
@given(st.integers(-(2**40), 2**40), st.integers(1, 2**40))
def test_noise_changes_with_the_seed(seed, delta):
    def noise(s):
        return _ev(0, _call("noise", _n(2.5), _n(0.5), _n(s)))

    assert not np.array_equal(noise(seed), noise(seed + delta))


def test_noise_changes_with_the_seed_everywhere():
    masks = {_ev(0, _call("noise", _n(3), _n(0.5), _n(s))).tobytes() for s in range(8)}
    assert len(masks) == 8
    v = raster.simplex2(np.linspace(0, 40, 4001), np.linspace(3, 11, 4001), raster.permutation(5))
    assert -1.0 <= v.min() < -0.3 and 0.3 < v.max() <= 1.0


# ---- errors --------------------------------------------------------------------------------


def _diags(src, path):
    r = compile_source(src, path, until="skeleton")
    if r.diagnostics.has_errors:
        return list(r.diagnostics)
    _, d = patterned(src, path)
    return list(d)


@pytest.mark.parametrize(
    ("body", "code", "at"),
    [
        ('  let g = """\n K Q\n """\n  tile g', "E220", "Q"),
        ('  let g = """\n K XR+\n """\n  stretch g', "E315", "XR+"),
        ('  let g = """\n K P\n P\n """\n  draw g', "E716", "P\n"),
        ("  let g = wales(0)\n  tile g", "E710", "g\n"),
        ('  draw img("m.png")', "E718", "img"),
        ("  set P where tile(wales(0))", "E710", "wales(0))"),
        ('  set P where img("nope.png")', "E713", '"nope.png"'),
        ('  set P where img("t.knit")', "E713", '"t.knit"'),
        ('  set P where img("x.png", "q")', "E714", '"q"'),
        ('  set P where img("x.png", "a", 3)', "E714", "3)"),
        ("  set P where stitch_grid(0, 3)", "E715", "0,"),
        ('  set P where stitch_grid(3, 3, "up")', "E715", '"up"'),
        ("  set P where wale_grid(0:end, 1.5)", "E715", "1.5"),
        ("  set P where noise(0)", "E717", "0)"),
        ("  set P where noise(2, seed = 0.5)", "E717", "0.5"),
        ("  set P where noise(2, colour = 1)", "E703", "colour"),
        ('  set P where courses(0).tile("""\n x\n """, all())', "E703", "all()"),
    ],
)
def test_errors_are_located(body, code, at, tmp_path):
    design = tmp_path / "t.knit"
    src = sheet(6, 5, body)
    design.write_text(src)
    diags = _diags(src, str(design))
    (diag,) = [x for x in diags if x.is_error]
    assert diag.code == code, diags
    assert src[diag.span.start :].startswith(at), (src[diag.span.start : diag.span.start + 20], at)


def test_images_resolve_relative_to_the_design_and_pick_channels(tmp_path):
    from PIL import Image

    (tmp_path / "art").mkdir()
    im = Image.new("RGB", (2, 1), (255, 255, 255))
    im.putpixel((0, 0), (0, 0, 0))  # left half black: dark, low luminance, low red
    im.save(tmp_path / "art" / "half.jpg", quality=100)
    base = sheet(6, 2, "  set P where img(ARGS)")
    for args, left in (
        ('"art/half.jpg"', True),
        ('"art/half.jpg", "l"', False),
        ('"art/half.jpg", "r", 0.9', False),
        ('"art/half.jpg", "a"', True),
    ):
        g, d = patterned(base.replace("ARGS", args), str(tmp_path / "d.knit"))
        assert not list(d)
        got = grid_of(g)
        for (_, w), v in got.items():
            on = (w < 3) == left or args.endswith('"a"')
            assert v == (P if on else K), (args, w)


def test_a_drawing_larger_than_its_selection_warns_and_is_clipped():
    g, d = patterned(sheet(4, 6, f"  draw {DIAMOND} where courses(0:1)"), "t.knit")
    (w,) = list(d)
    assert w.code == "W710" and not w.is_error and w.span.line == 5
    got = grid_of(g)
    # 2 courses under a 3-row chart: its rows start (2 - 3) // 2 = -1 courses up, so the
    # chart's upper two rows land; its 3 columns start at wale (4 - 3) // 2 = 0
    assert [got[(0, x)] for x in range(4)] == [P, T, P, K]
    assert [got[(1, x)] for x in range(4)] == [K, P, K, K]


# ---- drawn-layer goldens -------------------------------------------------------------------

LAYERS = {
    "draw": 'draw """\n    . P P P .\n    P T . T P\n    P . M . P\n    . P P P .\n  """'
    " where courses(4:end - 2)",
    "stretch": 'stretch """\n    P K K\n    K T K\n    K K M\n  """ where select(2:27, 5:24)',
    "tile": 'tile """\n    K FR1 M   M   FL1\n    K K   M   M   K\n    K K   FL1 FR1 K\n'
    '    XR+ XL- K K K\n  """ where courses(1:end - 1)',
}


@pytest.mark.parametrize("shape", ["sheet", "tube"])
@pytest.mark.parametrize("mode", list(LAYERS))
def test_drawn_layer_golden(mode, shape):
    kind = (
        "sheet s { width: 30  length: 30 }"
        if shape == "sheet"
        else "tube s { width: 15  length: 30 }"
    )
    src = f"{kind}\nstart s.bottom\ns.top open\npattern s {{\n  {LAYERS[mode]}\n}}\n"
    g, d = patterned(src, "t.knit")
    assert not list(d)
    out = f"# {LAYERS[mode]}\n# on a 30 x 30 {shape}\n{LEGEND_LINE}\n{chart(g, 's')}\n"
    assert_golden(GOLDEN / f"layer_{mode}.{shape}.txt", out, f"`{mode}` on the {shape}")


# ---- end to end ----------------------------------------------------------------------------

ORACLE_DESIGNS = [
    sheet(
        14,
        16,
        '  draw """\n . P .\n P P P\n . P .\n """ where courses(2:end - 2)\n'
        '  tile """\n T K\n K K\n """ where select(1:5, 0:3)\n'
        '  stretch """\n P K\n K P\n """ where select(9:end - 2, 8:end)',
    ),
    "tube t { width: 8  length: 14  gauge: half }\nstart t.bottom\nt.top open\npattern t {\n"
    '  tile """\n P K K\n """ where wale_grid() and courses(1:end - 1)\n'
    '  draw """\n M .\n T M\n """ where side(back) and courses(3:end - 3)\n'
    "  set P where noise(3, 0.7, 2) and courses(1:end - 1)\n}\n",
]


def test_drawn_layers_knit_their_design_on_the_independent_machine():
    results = []
    for src in ORACLE_DESIGNS:
        r = compile_source(src, "t.knit", until="machine")
        assert not r.diagnostics.has_errors, r.diagnostics.render()
        assert (r.graph.instr != K).sum() > 10
        results.append(r)
    assert_knits_as_designed(results, names=ORACLE_DESIGNS)
