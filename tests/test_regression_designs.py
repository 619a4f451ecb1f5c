"""Designs that knitc once could not compile (E602: transfers it could not plan) or knitted
into the wrong fabric compile, and the independent machine knits them into the designed
fabric (`tests/fabric.py`).

Planning: a crown that closes after a uniform decrease (it failed over some lengths and not
others, as the ring's fold drifted away from the closing pairs), a leg joined to a wider
foot (a spread), a tank top's front and back joined at the shoulder straps (the neckline's
ending loops, not yet cast off, stood where the second strap was laid out), and tubes closed
by zigzag courses at either end.

Fabric: a flat piece closed into a tube (bound mirrored, its right end continuing at the
tube's front left), a tube opened into one flat piece by an unfolded split (its back half
was left unattached), and a closed tube start cast on by a precast (the precast loops on the
back stood in for the split loops that close the end).

Lace: a move between two stitches the layout put on opposite beds (a ring rolled between
them) was carried through the facing needle, on the target's own bed, and then transferred
within one bed (an internal error); the loop now goes straight across. The same for a B move,
whose loop is knitted on the facing needle: it goes back to its own needle first (it was an
internal error on half-gauge tubes after a shaped tube, on shaped cylinder sheets and on
full-gauge tubes). A loop carried onto the needle of a loop still waiting to go straight
across was taken along with it (three loops on one needle); it now lands after that loop
left. A ring the layout rotates between a course's two passes had its moves carried from the
needles the first pass knitted on (E602, or silently the wrong loops); they are carried from
where the second pass's layout put them. A B move in the first course knitted onto a
catching tuck's needle, which the yarn start then dropped.

Splits: a split gave a branch its base's sides (folded) or its base the sum of its
branches (unfolded) before the neighbour across a joint said otherwise, so the shape pass
met connections whose ends disagreed: a tubular branch of one stitch (a division by zero),
a flat base called tubular, a tubular base of an odd sum laid on too short a ring (a wale
going back in time). What the neighbours say now wins, and a tubular base inferred from
its branches holds whole rows on both beds.
"""

from __future__ import annotations

import pytest

from fabric import assert_knits_as_designed
from knitc.driver import compile_source

CROWNS = {
    f"crown-{w}x{n}": f"tube crown {{ length: {n}  width: [0: {w}, 1: 4]  shaper: uniform }}\n"
    "crown.top closed\n"
    for w in (24, 30, 40)
    for n in (4, 5, 6, 7, 8)
}
LEG_FOOT = """\
tube leg  { length: 40  width: 10 }
tube foot { length: 50  width: 12 }
leg.top -> foot.bottom
start leg.bottom
foot.top closed
"""
TANK = """\
machine { racking: 4 }
sheet front { type: flat  length: 20  width: 30 }
split fs { degree: 2  alignment: uniform }
sheet fl { type: flat  length: 10  width: 8 }
sheet fr { type: flat  length: 10  width: 8 }
sheet back { type: flat  length: 20  width: 30 }
split bs { degree: 2  alignment: uniform }
sheet bl { type: flat  length: 10  width: 8 }
sheet br { type: flat  length: 10  width: 8 }
front.top -> fs.base
fs.branches[0] -> fl.bottom
fs.branches[1] -> fr.bottom
back.top -> bs.base
bs.branches[0] -> bl.bottom
bs.branches[1] -> br.bottom
fl.top -> bl.top
fr.top -> br.top
start front.bottom
"""
ZIGZAGS = {
    f"zigzag-{mode}-{end}": f"tube t {{ length: 6  width: 4 }}\nt.{end} closed({mode})\n"
    for mode in ("zigzag", "zigzagreturn")
    for end in ("bottom", "top")
}
"""Tubes closed by a course alternating front and back needles: its cycle is the ring it
closes (its yarn order zigzags), and the bind-off of one moves each loop straight across."""
FLAT_INTO_TUBE = (
    "sheet a { type: flat  length: 4  width: 8 }\ntube b { length: 4  width: 4 }\n"
    "a.top -> b.bottom\n"
)
TUBE_OPENED = (
    "tube a { length: 4  width: 4 }\nsplit s { degree: 1  folded: false }\n"
    "sheet f { type: flat  length: 3  width: 8 }\na.top -> s.base\n"
    "s.branches[0] -> f.bottom\n"
)
PRECAST_CLOSED = "tube t { length: 6  width: 6 }\nt.bottom closed { cast_on: precast }\n"
LACE_ACROSS_THE_FOLD = """\
tube n1 { length: 4  width: 3 }
sheet n3 { length: 8  type: flat  width: [0: 6, 1: 14]  shaper: sides }
start n3.top
n1.top -> n3.bottom
pattern n1 { set FR1 where filter(wale % 3 == 1) }
"""
B_MOVE_ON_A_ROLLED_RING = """\
tube a { length: 6  width: [0: 6, 1: 10] }
tube b { length: 6  width: 5  gauge: half }
a.top -> b.bottom
pattern b { set BR1 where courses(0:2) }
"""
B_MOVE_ON_A_SHAPED_CYLINDER = """\
sheet s { type: cylinder  length: 4  width: [0: 4, 1: 8]  gauge: half }
pattern s { set BR1 where wales(2).inverse() }
"""
B_MOVE_ON_A_SHAPED_FULL_GAUGE_TUBE = """\
machine { racking: 3 }
tube a { length: 4  width: [0: 6, 0.5: 11, 1: 12]  shaper: sides }
tube b { length: 5  width: 12  gauge: half  shaper: sides }
a.top -> b.bottom
pattern a { set BR1 where filter(wale % 3 == 1) }
"""
LANDING_AFTER_THE_STRAIGHT_ACROSS_LOOP = """\
tube a { length: 6  width: [0: 6, 1: 10] }
tube b { length: 6  width: 5  gauge: half }
a.top -> b.bottom
pattern b { set BL2 where courses(0:2) }
"""
MOVES_ON_A_RING_ROTATED_BETWEEN_PASSES = """\
sheet s { type: cylinder  length: 8  width: [0: 6, 1: 11]  shaper: uniform  gauge: full }
pattern s { set FR1 where wales(1).inverse() }
"""
B_MOVES_IN_THE_FIRST_COURSE = """\
sheet s { type: cylinder  length: 3  width: [0: 6, 1: 8]  gauge: half }
pattern s { set BR1 where wales(2).inverse() }
"""
FLAT_JOINT_INTO_A_FOLDED_SPLIT = """\
machine { gauge: half }
split s { degree: 2  folded: true  alignment: right }
tube base { length: 3  width: 8  shaper: none }
s.base -> base.bottom
tube b0 { length: 1  width: 7  shaper: sides }
b0.top -> s.branches[0]
joint b1 { rows: 4  width: 1 }
sheet c1 { type: flat  length: 2  width: 1 }
c1.top -> b1.bottom
b1.top -> s.branches[1]
start b0.bottom
"""
FLAT_JOINT_INTO_AN_UNFOLDED_SPLIT = """\
machine { gauge: half }
split s { degree: 1  folded: false  alignment: right }
joint base { rows: 2  width: 1 }
sheet base2 { type: flat  length: 2  width: 1 }
base2.top -> base.bottom
base.top -> s.base
joint b0 { rows: 1  width: 1 }
sheet c0 { type: flat  length: 2  width: 1 }
s.branches[0] -> b0.bottom
b0.top -> c0.bottom
"""
ODD_UNFOLDED_BASE_THROUGH_A_JOINT = """\
split s { degree: 1  folded: false  alignment: left }
joint base { rows: 4  width: 1 }
tube base2 { length: 2  width: 3 }
s.base -> base.bottom
base.top -> base2.bottom
sheet b0 { type: flat  length: 3  width: [0: 4, 1: 3] }
b0.top -> s.branches[0]
start b0.bottom
"""
ODD_UNFOLDED_BASE = """\
split s { degree: 2  folded: false }
sheet b0 { type: flat  length: 3  width: 3 }
sheet b1 { type: flat  length: 3  width: 2 }
b0.top -> s.branches[0]
b1.top -> s.branches[1]
"""

DESIGNS = {
    **CROWNS,
    **ZIGZAGS,
    "leg-into-wider-foot": LEG_FOOT,
    "tank-shoulders": TANK,
    "flat-into-tube": FLAT_INTO_TUBE,
    "tube-opened-flat": TUBE_OPENED,
    "tube-opened-flat-knitted-back": TUBE_OPENED.replace("a.top", "a.bottom"),
    "closed-start-precast": PRECAST_CLOSED,
    "closed-start-precast-half": "machine { gauge: half }\n" + PRECAST_CLOSED,
    "lace-move-across-the-rolled-fold": LACE_ACROSS_THE_FOLD,
    "b-move-on-a-rolled-half-gauge-ring": B_MOVE_ON_A_ROLLED_RING,
    "b-move-on-a-shaped-cylinder-sheet": B_MOVE_ON_A_SHAPED_CYLINDER,
    "b-move-on-a-shaped-full-gauge-tube": B_MOVE_ON_A_SHAPED_FULL_GAUGE_TUBE,
    "move-lands-after-the-straight-across-loop": LANDING_AFTER_THE_STRAIGHT_ACROSS_LOOP,
    "moves-on-a-ring-rotated-between-passes": MOVES_ON_A_RING_ROTATED_BETWEEN_PASSES,
    "b-moves-in-the-first-course": B_MOVES_IN_THE_FIRST_COURSE,
    "b-moves-on-a-folded-merge": "machine { gauge: half }\n"
    "split s { degree: 1  folded: true }\ntube base { length: 2  width: [0: 6, 1: 10] }\n"
    "s.base -> base.bottom\ntube b0 { length: 3  width: 5 }\nb0.top -> s.branches[0]\n"
    "pattern before { set BL2 }\n",
    "flat-joint-into-a-folded-split": FLAT_JOINT_INTO_A_FOLDED_SPLIT,
    "flat-joint-into-an-unfolded-split": FLAT_JOINT_INTO_AN_UNFOLDED_SPLIT,
    "odd-unfolded-base-through-a-joint": ODD_UNFOLDED_BASE_THROUGH_A_JOINT,
    "odd-unfolded-base": ODD_UNFOLDED_BASE,
}


def build(src: str):
    r = compile_source(src, "t.knit", until="machine")
    assert [d.code for d in r.diagnostics if d.is_error] == [], r.diagnostics.render()
    return r


@pytest.mark.parametrize("name", sorted(DESIGNS))
def test_it_compiles(name):
    assert build(DESIGNS[name]).program is not None


def test_they_knit_their_design_on_the_independent_machine():
    names = sorted(DESIGNS)
    assert_knits_as_designed([build(DESIGNS[n]) for n in names], names=names)
