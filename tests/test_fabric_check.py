"""The fabric check itself: it finds what is wrong with a program that knits the wrong fabric.

A check that never fails proves nothing. Each case takes a design knitc compiles correctly,
breaks its machine program (or its design) the way a code-generation bug would, runs the
broken program on the independent machine and asserts that `tests/fabric.py` reports the
mismatch it should, at the stitch where it is. The unbroken programs are checked too: they
must have no mismatch at all.
"""

from __future__ import annotations

import dataclasses
import functools

import numpy as np
import pytest

from fabric import Fabric, Mismatch, check_fabric
from knitc.backends.knitout import write_knitout
from knitc.codegen.machine import MachineProgram, Op
from knitc.driver import Result, compile_source
from knitc.shaping.stitch_graph import INSTRUCTIONS
from oracle import run_oracle_on_text

SHEET = "sheet s { length: 6  width: 8 }\n"
TUBE = "tube t { length: 5  width: 6 }\n"
RIB = "import std.stitches (rib)\nsheet s { length: 6  width: 8 }\npattern s { apply rib(1, 1) }\n"
EYELET = "sheet s { length: 6  width: 8 }\npattern s { set FR1 where select(2, 3) }\n"
CLOSED = "machine { increase: kickback }\ntube t { length: 4  width: 5 }\nt.bottom closed\n"
STRIPS = (
    "tube t { length: 2  width: 4 }\nsplit s { degree: 2  folded: false }\n"
    "sheet a { type: flat  length: 3  width: 4 }\nsheet b { type: flat  length: 3  width: 4 }\n"
    "t.top -> s.base\ns.branches[0] -> a.bottom\ns.branches[1] -> b.bottom\n"
)


@functools.cache
def build(src: str) -> Result:
    r = compile_source(src, "t.knit", until="machine")
    assert r.program is not None, r.diagnostics.render()
    return r


def with_ops(r: Result, ops: list[Op]) -> Result:
    """`r` with another machine program (same machine, same header)."""
    prog = MachineProgram(r.program.machine, list(ops), position=r.program.position)
    return dataclasses.replace(r, program=prog)


def action_op(r: Result, s: int, kinds=("knit",)) -> int:
    """Index of the op of stitch `s` that its action pass made."""
    return next(
        i
        for i, o in enumerate(r.program.ops)
        if o.stitch == s and o.phase == "action" and o.kind in kinds
    )


def stitch_at(r: Result, course: int, pos: int) -> int:
    return int(r.graph.course_start[course]) + pos


# ---- the breakages --------------------------------------------------------------------------


def tuck_instead_of_knit(r: Result) -> tuple[Result, int]:
    """A knit in the middle of the sheet made as a tuck: its loop holds nothing (a hole)."""
    s = stitch_at(r, 3, 4)
    ops = list(r.program.ops)
    i = action_op(r, s)
    ops[i] = ops[i]._replace(kind="tuck")
    return with_ops(r, ops), s


def dropped_loop(r: Result) -> tuple[Result, int]:
    """A loop dropped before the next course knits through it (a ladder starts there)."""
    s = stitch_at(r, 2, 3)
    ops = list(r.program.ops)
    i = action_op(r, s)
    ops.insert(i + 1, Op("drop", needle=ops[i].needle, stitch=s))
    return with_ops(r, ops), s


def no_cast_off(r: Result) -> tuple[Result, int]:
    """The last course's loops dropped instead of bound off (the edge unravels)."""
    last = r.graph.n_courses - 1
    ends = set(r.graph.course_ids(last).tolist())
    ops = [
        o
        for o in r.program.ops
        if not (o.phase == "cast_off" or (o.phase == "yarn_end" and o.kind == "knit"))
    ]
    where = {o.stitch: o.needle for o in ops if o.stitch in ends and o.phase == "action"}
    outhook = next(i for i, o in enumerate(ops) if o.kind == "outhook")
    drops = [Op("drop", needle=n, stitch=s) for s, n in sorted(where.items())]
    return with_ops(r, ops[: outhook + 1] + drops + ops[outhook + 1 :]), min(ends)


def knitted_as_designed_but_designed_otherwise(r: Result, instr: str) -> Result:
    """The same program held against a design whose instructions all say `instr`."""
    g = dataclasses.replace(r.graph, instr=np.full_like(r.graph.instr, INSTRUCTIONS.index(instr)))
    return dataclasses.replace(r, graph=g)


def open_start(r: Result) -> tuple[Result, int]:
    """A closed tube start knitted open: the tip's loops are not split onto the back, whose
    first round is kickback tucks on empty needles (the bug the check was written for)."""
    ops = list(r.program.ops)
    back = [s for s in r.graph.course_ids(1).tolist() if int(r.graph.side[s]) == 1]
    for i, o in enumerate(ops):
        if o.kind == "split":
            ops[i] = Op(
                "knit",
                o.dir,
                o.needle,
                None,
                o.carriers,
                stitch=o.stitch,
                span=o.span,
                phase=o.phase,
            )
        elif o.stitch in back and o.phase == "action" and o.kind == "knit":
            ops[i] = o._replace(kind="tuck", dir=-o.dir)
    return with_ops(r, ops), back[0]


CASES = {
    "clean sheet": lambda: (build(SHEET), None, set()),
    "clean tube": lambda: (build(TUBE), None, set()),
    "clean rib": lambda: (build(RIB), None, set()),
    "clean eyelet": lambda: (build(EYELET), None, set()),
    "clean closed start": lambda: (build(CLOSED), None, set()),
    "clean strips": lambda: (build(STRIPS), None, set()),
    "tuck instead of knit": lambda: (*tuck_instead_of_knit(build(SHEET)), {"parents"}),
    "dropped loop": lambda: (*dropped_loop(build(SHEET)), {"parents", "unattached"}),
    "no cast-off": lambda: (*no_cast_off(build(SHEET)), {"unattached"}),
    "knit where a purl is designed": lambda: (
        knitted_as_designed_but_designed_otherwise(build(SHEET), "P"),
        None,
        {"pull"},
    ),
    "purl where a knit is designed": lambda: (
        knitted_as_designed_but_designed_otherwise(build(RIB), "K"),
        None,
        {"pull"},
    ),
    "a lace move the design does not have": lambda: (
        knitted_as_designed_but_designed_otherwise(build(EYELET), "K"),
        None,
        {"parents"},
    ),
    "open closed start": lambda: (*open_start(build(CLOSED)), {"hole"}),
}


@functools.cache
def checked() -> dict[str, tuple[Result, list[Mismatch], int | None, set[str]]]:
    made = {name: case() for name, case in CASES.items()}
    reports = run_oracle_on_text(
        [write_knitout(r.program) for r, _, _ in made.values()], fabric=True
    )
    out = {}
    for (name, (r, s, kinds)), rep in zip(made.items(), reports, strict=True):
        assert rep.fabric is not None, rep.describe()
        out[name] = (r, check_fabric(r, Fabric.from_json(rep.fabric)), s, kinds)
    return out


@pytest.mark.parametrize("name", list(CASES))
def test_the_check_reports_what_is_broken_and_nothing_else(name):
    r, found, stitch, kinds = checked()[name]
    got = {m.kind for m in found}
    if not kinds:
        assert found == [], "\n".join(map(str, found))
        return
    assert kinds & got, f"expected {kinds}, got:\n" + "\n".join(map(str, found))
    if stitch is not None:  # and it is reported where it is, or on the next course's stitch
        near = {stitch} | {int(k) for k in r.graph.wale_next[stitch] if k >= 0}
        assert any(m.stitch in near for m in found if m.kind in kinds), "\n".join(map(str, found))


def test_a_tube_closed_two_to_one_before_a_flat_sheet_is_no_one_sided_seam():
    # W501: the tube's last course is closed onto one bed, so the seam is on that bed only,
    # as designed (make fuzz found the check calling it a one-sided seam).
    from fabric import assert_knits_as_designed

    r = build(
        "tube sleeve { length: 6  width: 5 }\nsheet flap { type: flat  length: 4  width: 5 }\n"
        "sleeve.top -> flap.bottom\nstart sleeve.bottom\n"
    )
    assert any(d.code == "W501" for d in r.diagnostics)
    assert_knits_as_designed([r])
