"""Machine time: knitc's programs cost the Shima no rows they do not need.

A DAT has one row per carriage pass. Rows beyond the program's passes come from the DAT's
own rules: a pass is cut where its stitch number, direction or carrier changes, and a
carrier that is not on the side a pass starts from needs a row of its own to get there (a
kickback). These tests hold knitc to programs that avoid the needless ones; `make bench`
reports the figures for every design (carriage passes, DAT rows, transfer rows).
"""

from __future__ import annotations

from pathlib import Path

import pytest

from knitc.backends.dat_write import SOFT_MISS, XFER_BF, XFER_FB, to_dat
from knitc.codegen.machine import estimate_passes
from knitc.driver import compile_file, compile_source
from knitc.shaping.intarsia import regions as intarsia_regions

REPO = Path(__file__).resolve().parent.parent
DESIGNS = sorted((REPO / "examples").glob("*.knit")) + sorted(
    (REPO / "examples" / "knitskel").glob("*.knit")
)


def rows(r) -> dict[str, int]:
    """DAT rows of a compiled design by what they do: knit (any stitch), xfer, move (a
    carrier moved alone)."""
    out = {"knit": 0, "xfer": 0, "move": 0}
    for p in to_dat(r.program).passes:
        codes = set(p.slots.values())
        out[
            "move" if codes <= {SOFT_MISS} else "xfer" if codes & {XFER_FB, XFER_BF} else "knit"
        ] += 1
    return out


def build(src: str):
    r = compile_source(src, "t.knit", until="machine")
    assert r.program is not None, r.diagnostics.render()
    return r


@pytest.mark.parametrize("path", DESIGNS, ids=lambda p: f"{p.parent.name}/{p.stem}")
def test_a_design_costs_few_rows_beyond_its_passes(path):
    # each yarn costs the DAT up to three rows that no Knitout pass stands for: the hook's
    # release (a pass of its own), the carriage's turn or carrier's move next to it, and the
    # yarn's removal; beyond those, at most 5% more rows than passes
    r = compile_file(str(path), until="machine")
    total = sum(rows(r).values())
    yarns = sum(1 for o in r.program.ops if o.kind in ("in", "inhook"))
    # a fair isle yarn moves its carrier to where its next course's stitches start, a row
    # of its own when they start beyond where it stopped: up to one per course it floats in
    # an intarsia course: each region's carrier hangs at its walls, where its neighbours'
    # passes end on their tuck joins, so the converter kicks it out of their way, and a
    # round's region that wraps around goes on rows of its own per bed: up to four rows a
    # region
    g = r.graph
    fair = 0
    if g is not None and g.colourwork and g.yarn is not None:
        band = g.intarsia_courses()
        regions = intarsia_regions(g) if band.any() else None
        for c in range(g.n_courses):
            ids = g.course_ids(c)
            if band[c] and regions is not None:
                fair += 4 * len(set(regions[ids].tolist()))
            else:
                fair += len(set(g.yarn[ids].tolist())) - 1
    assert total - 3 * yarns - fair <= 1.05 * estimate_passes(r.program.ops)


def test_a_yarn_start_needs_no_empty_pass_before_its_release():
    # a Shima releases the hook on a pass of its own in the hook's direction (leftward): a
    # catching zigzag that ended leftward needs an empty pass to turn the carriage first.
    # The glove's fingers start leftward: their zigzags end rightward (four tucks), and
    # only the three-tuck ones cost an empty pass
    r = compile_file(str(REPO / "examples" / "glove.knit"), until="machine")
    seq, zigzags, tucks = r.program.ops, [], None
    for o in seq:
        if o.kind == "inhook":
            tucks = []
        elif o.kind == "releasehook":
            zigzags.append(tucks)
            tucks = None
        elif tucks is not None and o.kind == "tuck":
            tucks.append(o.dir)
    assert all(z[0] == -1 and all(a == -b for a, b in zip(z, z[1:])) for z in zigzags)
    assert any(z[-1] == 1 for z in zigzags)
    empty = [
        p
        for p in to_dat(r.program).passes  # no yarn (R3), no hook action (R15)
        if p.get("R3") == 255 and p.get("R15") == 0 and set(p.slots.values()) <= {SOFT_MISS}
    ]
    assert len(empty) == sum(z[-1] == -1 for z in zigzags)


def test_a_half_gauge_rib_tube_moves_no_carrier_between_rounds():
    # at the fold a purl is knitted on the needle facing the last back stitch, beyond the
    # next round's first needle: the pass ends past it (a lead-out miss), so the carrier
    # needs no row of its own to get back (it needed two per round)
    def moves(length: int) -> int:
        return rows(
            build(
                "import std.stitches (rib)\n"
                f"tube t {{ length: {length}  width: 12  gauge: half }}\n"
                "pattern t { apply rib(1, 1) }\n"
            )
        )["move"]

    # the yarn's insertion, release and removal, and the bind-off: none per round
    assert moves(30) == moves(60) <= 8


def test_kickback_increases_move_no_carrier_on_their_own():
    # the kickback's carrier passes the needle in the pass (a miss), then tucks it coming
    # back: no carrier row before each kickback
    def moves(grow: int) -> int:
        return rows(
            build(
                "machine { increase: kickback }\n"
                f"tube t {{ length: 20  width: [0: 10, 1: {10 + grow}]  "
                "shaper: sides }\n"
            )
        )["move"]

    assert moves(10) == moves(0)


def test_loops_coming_back_from_the_sliders_make_one_row_per_bed():
    # a full-gauge tube shifting by one needle: the front loops wait on the back sliders and
    # the back loops on the front ones; each racking's returns go bed by bed, one row each
    r = build("tube t { length: 12  width: [0: 10, 1: 16]  shaper: left }\n")
    k = rows(r)
    assert k["xfer"] <= 1.05 * estimate_passes(
        [o for o in r.program.ops if o.kind in ("xfer", "rack")]
    )


def test_a_gauge_change_lays_its_new_loops_in_the_pass():
    # half gauge into full gauge doubles the loops: the new ones are tucked in the pass,
    # every other needle, not kicked back one by one (six rows each)
    r = build(
        "tube a { length: 3  width: 8  gauge: half }\ntube b { length: 3  width: 16 }\n"
        "a.top -> b.bottom\n"
    )
    assert sum(rows(r).values()) <= 1.1 * estimate_passes(r.program.ops)
    kicks = [o for o in r.program.ops if o.kind == "tuck" and o.phase == "action"]
    assert kicks and all(o.dir == 1 or o.dir == -1 for o in kicks)
