"""Designs whose transfers once could not be planned (E602) compile, and the independent
machine knits them into the designed fabric (`tests/fabric.py`).

Each is a small, ordinary garment part: a crown that closes after a uniform decrease (it
failed over some lengths and not others, as the ring's fold drifted away from the closing
pairs), a leg joined to a wider foot (a spread), and a tank top's front and back joined at
the shoulder straps (the neckline's ending loops, not yet cast off, stood where the second
strap was laid out).
"""

from __future__ import annotations

import pytest

from fabric import assert_knits_as_designed
from knitc.driver import compile_source

CROWNS = {f"crown-{w}x{n}": f"tube crown {{ length: {n}  width: [0: {w}, 1: 4]  shaper: uniform }}\n"
          "crown.top closed\n" for w in (24, 30, 40) for n in (4, 5, 6, 7, 8)}
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
DESIGNS = {**CROWNS, "leg-into-wider-foot": LEG_FOOT, "tank-shoulders": TANK}


def build(src: str):
    r = compile_source(src, "t.knit", until="machine")
    assert [d.code for d in r.diagnostics if d.is_error] == [], r.diagnostics.render()
    return r


@pytest.mark.parametrize("name", sorted(DESIGNS))
def test_the_transfers_are_planned(name):
    assert build(DESIGNS[name]).program is not None


def test_they_knit_their_design_on_the_independent_machine():
    names = sorted(DESIGNS)
    assert_knits_as_designed([build(DESIGNS[n]) for n in names], names=names)
