"""`knitc view`'s static pictures: the time-needle bed, the stitch charts and the shape.

Every shipped design and port draws all three (PNG at low resolution, to keep the suite
quick); the bed view's rows are the carriage passes knitc counts; and pixels are probed
where known stitches and operations are drawn (through the chart's own pixel map, and
the data transforms of the bed's and the shape's axes), so a view that draws the wrong
colour in the wrong place fails, not just one that crashes. Knitout input draws too.
"""

from __future__ import annotations

import io
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from knitc.backends.knitout import write_knitout
from knitc.cli import main
from knitc.codegen.machine import estimate_passes
from knitc.shaping.stitch_graph import INSTRUCTIONS
from knitc.view import bed, chart, figure, shape
from knitc.view.loops import loop_graph
from knitc.view.source import ViewInput, load

ROOT = Path(__file__).parent.parent
EXAMPLES = sorted((ROOT / "examples").glob("*.knit")) + sorted(
    (ROOT / "examples" / "knitskel").glob("*.knit")
)

PURL_SHEET = """\
sheet s { type: flat, length: 8, width: 10 }
start s.bottom
pattern s {
  set P where courses(4)
}
"""
"""A small sheet with one purl course (course 4) and knits elsewhere."""

TWO_TUBES = """\
tube a { length: 10, width: 6 }
tube b { length: 10, width: 6 }
start a.bottom
a.top -> b.bottom
b.top open
"""

HEADER = ";!knitout-2\n;;Machine: SWG091N2\n;;Gauge: 15\n;;Carriers: 1 2 3\n"
EMPTY_NEEDLE = HEADER + (
    "inhook 1\ntuck - f6 1\ntuck - f4 1\ntuck - f2 1\nreleasehook 1\n"
    "knit + f2 1\nknit + f3 1\nknit + f4 1\nknit + f6 1\n"
    "knit - f6 1\nknit - f4 1\nknit - f3 1\nknit - f2 1\n"
    "outhook 1\ndrop f2\ndrop f3\ndrop f4\ndrop f6\n"
)
"""A Knitout sheet whose second pass knits f3, which holds no loop (W802 at op 6)."""


def _load(path: str | Path) -> ViewInput:
    got = load(str(path))
    assert got.input is not None, got.diagnostics.render()
    return got.input


def _write(tmp_path: Path, text: str, name: str) -> Path:
    p = tmp_path / name
    p.write_text(text, encoding="utf-8")
    return p


def _png(data: bytes) -> Image.Image:
    assert data[:8] == b"\x89PNG\r\n\x1a\n"
    return Image.open(io.BytesIO(data)).convert("RGB")


def _pixel(fig, ax, x: float, y: float) -> tuple[int, int]:
    """The PNG pixel (column, row from the top) of data point (x, y) of `ax`."""
    px, py = ax.transData.transform((x, y))
    h = int(round(fig.get_figheight() * fig.dpi))
    return int(round(px)), int(round(h - py))


# ---- every example -------------------------------------------------------------------------


@pytest.mark.parametrize("path", EXAMPLES, ids=lambda p: str(p.relative_to(ROOT / "examples")))
def test_every_view_of_every_example(path: Path):
    inp = _load(path)
    b = bed.build(inp)
    assert b.passes == estimate_passes(inp.program.ops)
    assert b.rows == b.passes
    assert bed.build(inp, compact=True).rows <= b.passes
    svg = bed.render(inp, "svg").decode()
    assert svg.startswith("<?xml") and 'id="legend_1"' in svg
    for c in figure.OP_CATEGORIES:
        assert f">{c}<" in svg  # the legend names every kind of cell
    img = _png(bed.render(inp, "png", compact=True, dpi=30))
    assert img.size[0] > 100 and img.size[1] > 100
    img = _png(chart.render(inp, "png"))
    assert img.size[0] >= chart.MIN_WIDTH_PX
    for three_d in (False, True):
        img = _png(shape.render(inp, "png", three_d=three_d, dpi=30))
        arr = np.asarray(img)
        assert (arr != 255).any(axis=2).mean() > 0.02  # something is drawn


def test_the_bed_rows_are_the_carriage_passes_knitc_counts():
    inp = _load(ROOT / "examples" / "sweater.knit")
    rows = bed.pass_rows(inp.program.ops)
    assert rows.max() + 1 == estimate_passes(inp.program.ops) == inp.program.stats()["passes"]
    carriage = rows >= 0
    assert np.all(np.diff(rows[carriage]) >= 0)  # passes in program order
    compact = bed.build(inp, compact=True)
    assert compact.rows < compact.passes  # sleeves knit beside the body, not above it
    assert len(set(compact.row_of_pass.tolist())) < compact.passes


# ---- pixel probes -----------------------------------------------------------------------------


def test_chart_paints_the_purl_course_in_the_purl_colour(tmp_path: Path):
    inp = _load(_write(tmp_path, PURL_SHEET, "purl.knit"))
    g = inp.graph
    assert g is not None
    ch = chart.build(g)
    img = _png(chart.render(inp, "png"))
    purl = np.nonzero(g.instr == INSTRUCTIONS.index("P"))[0]
    knit = np.nonzero(g.instr == 0)[0]
    assert purl.size == 10 and len(set(ch.srow[purl].tolist())) == 1  # one row of the chart
    for s in purl:
        assert img.getpixel(ch.pixel(int(s))) == figure.rgb8(figure.INSTR_COLOURS["P"])
        # the symbol: a dot in the middle of the square
        mid = ch.cell // 2
        assert img.getpixel(ch.pixel(int(s), mid, mid)) != figure.rgb8(figure.INSTR_COLOURS["P"])
    for s in knit:
        assert img.getpixel(ch.pixel(int(s))) == figure.rgb8(figure.INSTR_COLOURS["K"])
    # course up: the purl row is above the first course and below the last
    first = knit[g.course[knit] == g.course.min()]
    last = knit[g.course[knit] == g.course.max()]
    assert ch.srow[last[0]] < ch.srow[purl[0]] < ch.srow[first[0]]


def test_bed_draws_the_purls_knit_in_the_purl_colour(tmp_path: Path):
    inp = _load(_write(tmp_path, PURL_SHEET, "purl.knit"))
    g = inp.graph
    assert g is not None
    fig, b, axes = bed.draw(inp)
    img = _png(figure.save(fig, "png", dpi=fig.dpi))
    ops = inp.program.ops
    purl = [
        i
        for i, op in enumerate(ops)
        if op.kind == "knit" and op.stitch >= 0 and g.instr[op.stitch] == INSTRUCTIONS.index("P")
    ]
    plain = [i for i, op in enumerate(ops) if op.kind == "knit" and op.phase == "action"]
    plain = [i for i in plain if g.instr[ops[i].stitch] == 0]
    assert purl and plain
    for i, colour in ((purl[0], "purl"), (plain[0], "knit")):
        op = ops[i]
        assert op.needle is not None
        k = int(b.op_bed[i])
        assert b.cells[k, b.op_row[i], b.op_col[i]] == figure.OP_CATEGORIES.index(colour) + 1
        xy = _pixel(fig, axes[k], op.needle.index, float(b.op_row[i]))
        assert img.getpixel(xy) == figure.rgb8(figure.OP_COLOURS[colour])


def test_shape_colours_each_piece_by_node(tmp_path: Path):
    inp = _load(_write(tmp_path, TWO_TUBES, "two.knit"))
    g = inp.graph
    assert g is not None
    fig, ax, xy = shape.draw(inp)
    img = _png(figure.save(fig, "png", dpi=fig.dpi))
    q = shape.faces(g)
    front = q[g.side[q[:, 0]] == 0]
    for v in (0, 1):
        mine = front[g.node[front[:, 0]] == v]
        assert mine.size
        quad = mine[mine.shape[0] // 2]
        centre = xy[quad].mean(axis=0)
        got = img.getpixel(_pixel(fig, ax, *centre))
        assert got == figure.rgb8(figure.NODE_COLOURS[v])
    # tube b is knitted onto a's top: it is drawn above it
    assert xy[g.node == 1, 1].mean() > xy[g.node == 0, 1].mean()


def test_hazards_are_marked_where_they_happen(tmp_path: Path):
    inp = _load(_write(tmp_path, EMPTY_NEEDLE, "empty_needle.k"))
    assert [f.code for f in inp.findings] == ["W802"]
    op = inp.findings[0].op
    assert str(inp.program.ops[op]) == "knit + f3 1"
    fig, b, axes = bed.draw(inp)
    img = _png(figure.save(fig, "png", dpi=fig.dpi))
    r, gr, bl = img.getpixel(_pixel(fig, axes[0], 3, float(b.op_row[op])))
    assert r > 180 and gr < 90 and bl < 90  # the red cross over the cell
    svg = bed.render(inp, "svg").decode()
    assert "hazard (1: W802)" in svg
    # the chart outlines the loop that knit made
    lg = loop_graph(inp.program)
    s = int(lg.op_loop[op])
    ch = chart.build(lg.graph, rows_by_depth=True)
    img = _png(chart.render(inp, "png"))
    x, y = ch.pixel(s, 0, 0)
    # a ring half a square out from it, its own square left readable
    assert img.getpixel((x - ch.cell // 2, y + ch.cell // 2)) == figure.rgb8(figure.HAZARD_COLOUR)
    assert img.getpixel((x + 1, y + 1)) == figure.rgb8(figure.INSTR_COLOURS["K"])
    # and the shape circles it
    assert "hazard (1: W802)" in shape.render(inp, "svg").decode()


# ---- Knitout input --------------------------------------------------------------------------


def test_knitout_input_draws_every_view(tmp_path: Path):
    design = _load(ROOT / "examples" / "sheet.knit")
    k = _write(tmp_path, write_knitout(design.program), "sheet.k")
    inp = _load(k)
    assert inp.graph is None and not inp.from_design
    b = bed.build(inp)
    assert b.passes == bed.build(design).passes
    assert not (b.cells == figure.OP_CATEGORIES.index("purl") + 1).any()  # no instructions
    assert 'id="legend_1"' in bed.render(inp, "svg").decode()
    _png(chart.render(inp, "png"))
    _png(shape.render(inp, "png", dpi=30))
    _png(shape.render(inp, "png", three_d=True, dpi=30))
    # the loops of the program are the design's stitches (and the cast-on's)
    lg = loop_graph(inp.program)
    assert lg.graph.n_stitches >= design.graph.n_stitches  # type: ignore[union-attr]
    wn = lg.graph.wale_next
    src, slot = np.nonzero(wn >= 0)
    assert np.all(lg.graph.course[wn[src, slot]] > lg.graph.course[src])  # wales go up


def test_the_cli_writes_each_view(tmp_path: Path, capsys):
    design = _write(tmp_path, TWO_TUBES, "two.knit")
    for flags, name in (
        (["--bed"], "bed.svg"),
        (["--bed", "--compact"], "compact.png"),
        (["--chart"], "chart.png"),
        (["--shape"], "shape.svg"),
        (["--shape", "--3d"], "shape3.png"),
    ):
        out = tmp_path / name
        assert main(["view", str(design), *flags, "-o", str(out)]) == 0
        data = out.read_bytes()
        assert data.startswith(b"<?xml" if name.endswith(".svg") else b"\x89PNG")
    assert main(["view", str(design), "--bed", "-o", str(tmp_path / "bed.txt")]) == 1
    assert "E930" in capsys.readouterr().err


def test_svg_output_is_deterministic(tmp_path: Path):
    inp = _load(_write(tmp_path, TWO_TUBES, "two.knit"))
    for render in (bed.render, chart.render, shape.render):
        a, b = render(inp, "svg"), render(inp, "svg")
        assert a == b
        assert b"<dc:date>" not in a


def test_version_does_not_import_matplotlib():
    code = (
        "import sys\nfrom knitc.cli import main\ntry:\n    main(['--version'])\n"
        "except SystemExit:\n    pass\nprint('matplotlib' in sys.modules)\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip().splitlines()[-1] == "False"


# ---- the force layout -------------------------------------------------------------------------


def test_layout_keeps_stitches_a_stitch_apart(tmp_path: Path):
    inp = _load(_write(tmp_path, TWO_TUBES, "two.knit"))
    g = inp.graph
    assert g is not None
    for three_d in (False, True):
        pos = shape.layout(g, three_d, schedule=inp.schedule)
        assert pos.shape == (g.n_stitches, 3 if three_d else 2)
        assert np.isfinite(pos).all()
        assert np.array_equal(pos, shape.layout(g, three_d, schedule=inp.schedule))
        i, j, d, _ = shape.springs(g)
        length = np.linalg.norm(pos[i] - pos[j], axis=1)
        assert np.abs(length / d - 1).mean() < 0.05
    # in 3-D a tube's round is a ring of its circumference
    pos = shape.layout(g, True, schedule=inp.schedule)
    c = g.n_courses // 4
    ring = pos[g.course_ids(c)]
    radius = np.linalg.norm(ring - ring.mean(axis=0), axis=1)
    assert abs(radius.mean() - g.course_len[c] / (2 * np.pi)) < 0.25
    # without a schedule (another tool's graph) it lays out too
    assert np.isfinite(shape.layout(g)).all()


def test_layout_turns_the_sock_at_its_heel():
    inp = _load(ROOT / "examples" / "sock.knit")
    g = inp.graph
    assert g is not None
    pos = shape.layout(g, True, schedule=inp.schedule)
    names = g.node_names

    def axis(node: str) -> np.ndarray:
        m = g.node == names.index(node)
        first = g.course[m].min()
        last = g.course[m].max()
        a = pos[m & (g.course == first)].mean(axis=0)
        b = pos[m & (g.course == last)].mean(axis=0)
        return (b - a) / np.linalg.norm(b - a)

    angle = np.degrees(np.arccos(np.clip(axis("leg") @ axis("foot"), -1, 1)))
    assert angle > 30  # the foot goes off at an angle to the leg


def test_chart_fills_the_stitches_of_another_yarn_with_its_colour(tmp_path: Path):
    text = (
        "yarn red { carrier: 5 }\nyarn wool { carrier: 6 }\n"
        "sheet s { length: 9, width: 8 }\n"
        "pattern s {\n  knit red where courses(2:3)\n  knit wool where courses(6)\n}\n"
    )
    inp = _load(_write(tmp_path, text, "stripes.knit"))
    g = inp.graph
    assert g is not None and g.yarn is not None
    ch = chart.build(g)
    img = _png(chart.render(inp, "png"))
    red, wool = (np.nonzero(g.yarn == g.yarn_names.index(n))[0] for n in ("red", "wool"))
    assert red.size == 16 and wool.size == 8
    for s in red:  # a yarn named for a colour is drawn in it
        assert img.getpixel(ch.pixel(int(s))) == (255, 0, 0)
    for s in wool:  # another, in the palette's colour for the design's second other yarn
        assert img.getpixel(ch.pixel(int(s))) == figure.rgb8(figure.YARN_PALETTE[1])
    for s in np.nonzero(g.yarn == 0)[0]:
        assert img.getpixel(ch.pixel(int(s))) == figure.rgb8(figure.INSTR_COLOURS["K"])
