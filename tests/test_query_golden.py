"""Golden per-stitch instruction dumps of every query on a 30 x 30 flat sheet and a 30 x 30
tube (the spirit of thesis Fig. 5-14).

Each case compiles `pattern NODE { set P where QUERY }` and dumps the node's instructions as
a chart (`chart` below: the top row is the node's last course; a tube's row is its front
bed left to right, `|`, then its back bed in yarn order, right to left on the bed), one
file per query and shape in `tests/golden/query/`. After an intended change, regenerate
with

    KNITC_UPDATE_GOLDEN=1 python -m pytest tests/test_query_golden.py

and review `git diff tests/golden/query` before committing.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from golden import assert_golden
from knitc.diagnostics import Diagnostics
from knitc.driver import compile_source
from knitc.patterning.pattern import apply_patterns
from knitc.patterning.query import coords
from knitc.shaping.shape import build_stitch_graph
from knitc.shaping.stitch_graph import INSTRUCTIONS

GOLDEN = Path(__file__).resolve().parent / "golden" / "query"

SHAPES = {
    "sheet": "sheet s { width: 30  length: 30 }\nstart s.bottom\ns.top open\n",
    "tube": "tube s { width: 15  length: 30 }\nstart s.bottom\ns.top open\n",
}

MOTIF = '''let motif = """
    x . . x
    . x x .
    x x . .
  """'''

QUERIES = {
    "all": "all()",
    "filter": "filter((course + 2 * wale) % 7 < 2)",
    "wales": "wales(0.25:0.5) or wales(-2:end) or wales(0:2:6, back)",
    "courses": "courses(1:3:end - 4) or courses(-0.2:end)",
    "select": "select(5:12, 20:end) or select(0:3, 0:4, back)",
    "side": "side(back) or wales(0:2, front)",
    "neighbors": "select(10, 10).neighbors(2:3)",
    "boundaries": "boundaries() or select(8:20, 8:20).boundaries()",
    "named": "named()",
    "shape": 'shape("s") - courses(10:20)',
    "itf": 'itf("top") or itf("s.bottom")',
    "inverse": "select(3:end - 3, 3:end - 3).inverse()",
    "stretch": "stretch(motif, select(4:25, 3:26))",
    "tile": "tile(motif, courses(3:end))",
    "img": 'img("motif.png") or courses(0)',
    "noise": "noise(5, 0.6, 7)",
    "wale_grid": "tile(motif, courses(4).wale_grid(2:17, 12))",
    "stitch_grid": 'select(6, 20).stitch_grid(9, 7, "center").tile(motif)',
    "set_algebra": "(wales(0:9) or courses(20:end)) - select(25:end, 5:7) and not side(back)",
}

LEGEND = {
    "K": ".",
    "P": "-",
    "T": "t",
    "M": "m",
    "FR1": "r",
    "FR2": "R",
    "FL1": "l",
    "FL2": "L",
    "BR1": "b",
    "BR2": "B",
    "BL1": "d",
    "BL2": "D",
    "XR+": "X",
    "XR-": "x",
    "XL+": "Y",
    "XL-": "y",
    "S": "s",
}
assert set(LEGEND) == set(INSTRUCTIONS) and len(set(LEGEND.values())) == len(LEGEND)
LEGEND_LINE = "# " + " ".join(f"{v}={k}" for k, v in LEGEND.items())


def chart(g, node: str) -> str:
    """The node's instructions, last course on top; a tube row is `front|back`."""
    c = coords(g)
    rows = []
    for cid in range(g.n_courses):
        if g.node_names[int(g.course_node[cid])] != node:
            continue
        ids = g.course_ids(cid)
        ids = ids[np.argsort(c.wale[ids], kind="stable")]
        cells = [LEGEND[INSTRUCTIONS[int(g.instr[i])]] for i in ids]
        if g.course_circular[cid]:
            k = int((g.side[ids] == 0).sum())
            cells.insert(k, "|")
        rows.append("".join(cells))
    return "\n".join(reversed(rows))


def write_motif_png(folder: Path) -> None:
    """A 6 x 4 image: an arrow of dark pixels on a transparent background."""
    from PIL import Image

    px = ["..##..", ".####.", "######", "..##.."]
    im = Image.new("RGBA", (6, 4), (0, 0, 0, 0))
    for y, line in enumerate(px):
        for x, ch in enumerate(line):
            if ch == "#":
                im.putpixel((x, y), (20, 20, 20, 255))
    im.save(folder / "motif.png")


def patterned(src: str, path: str, defines: tuple[str, ...] = ()):
    """The stitch graph right after the pattern pass (before later passes rewire it), and
    the diagnostics."""
    r = compile_source(src, path, defines=list(defines), until="skeleton")
    assert not r.diagnostics.has_errors, r.diagnostics.render()
    d = Diagnostics()
    g = apply_patterns(r.skeleton, build_stitch_graph(r.skeleton, d), d)
    return g, d


def dump(shape: str, query: str, folder: Path) -> str:
    src = SHAPES[shape] + f"pattern s {{\n  {MOTIF}\n  set P where {query}\n}}\n"
    g, d = patterned(src, str(folder / "design.knit"))
    assert not list(d), d.render()
    assert int((g.node == 0).sum()) == 900
    return f"# set P where {query}\n# on a 30 x 30 {shape}\n{LEGEND_LINE}\n" + chart(g, "s") + "\n"


@pytest.mark.parametrize("shape", list(SHAPES))
@pytest.mark.parametrize("name", list(QUERIES))
def test_query_golden(name, shape, tmp_path):
    write_motif_png(tmp_path)
    out = dump(shape, QUERIES[name], tmp_path)
    assert_golden(GOLDEN / f"{name}.{shape}.txt", out, f"`{QUERIES[name]}` on the {shape}")


def test_every_query_function_has_a_golden():
    from knitc.frontend.names import QUERY_FUNCTIONS

    written = " ".join(QUERIES.values())
    missing = [f for f in QUERY_FUNCTIONS if f + "(" not in written]
    assert not missing
