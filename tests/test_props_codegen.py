"""Property tests of layout and code generation over generated garments.

Every generated program that reaches the machine stage must give a program that is
structurally valid (`machine.verify`), that knitc's own simulation finds no error in, and
that knits every stitch of the stitch graph. A sample of them also runs through the
independent machine (tests/oracle.py). Programs the code generator declines with its
located E602 (moves beyond the racking limit) are counted, not failed; programs the
shape pass rejects are filtered as in test_props_shape.py.
"""

from __future__ import annotations

from hypothesis import event, given, settings

from fabric import assert_knits_as_designed
from knitc.codegen.machine import verify as verify_machine
from knitc.codegen.simulate import simulate
from knitc.driver import compile_source
from test_props_resolve import Program, programs
from test_props_shape import SETTINGS, compile_graph


def _compile(prog: Program):
    compile_graph(prog)  # the shape-pass filters, then the whole pipeline
    r = compile_source(prog.text, "gen.knit", defines=prog.defines, until="machine")
    errors = {d.code for d in r.diagnostics if d.is_error}
    if r.program is None:
        assert errors == {"E602"}, r.diagnostics.render()
        event("declined: E602")
        return None
    assert not errors, r.diagnostics.render()
    event("compiled")
    return r


def backward_steps(program) -> list[str]:
    """Knits of one carrier in one direction, one after the other, that go against that
    direction: the carriage would have to turn back between them. A direction taken from
    the design instead of the needles (a ring laid out rotated) makes them. (Tucks are left
    out: a kickback tucks against the carriage on purpose.)"""
    out, last, rack = [], None, 0.0
    for i, op in enumerate(program.ops):
        if op.kind == "rack":
            rack = float(op.value)
        if op.kind not in ("knit", "split"):
            if op.kind in ("xfer", "drop", "miss", "in", "inhook", "out", "outhook"):
                last = None
            continue
        here = op.needle.position(rack)
        if last is not None and last[0] == (op.carriers, op.dir) and (here - last[1]) * op.dir < 0:
            out.append(f"op {i}: {op} after {last[2]}")
        last = ((op.carriers, op.dir), here, str(op))
    return out


@SETTINGS
@given(programs())
def test_generated_programs_compile_to_valid_machine_programs(prog):
    r = _compile(prog)
    if r is None:
        return
    assert verify_machine(r.program) == []
    assert [f for f in simulate(r.program) if f.is_error] == []
    assert backward_steps(r.program) == []
    # every stitch forms a loop; the sibling of a split increase is the split's old loop and
    # is visited by a miss (knitsketching's SPLIT + MISS)
    knitted = {op.stitch for op in r.program if op.kind in ("knit", "tuck", "split", "miss")}
    assert knitted >= set(range(r.graph.n_stitches))


def test_a_sample_of_generated_programs_knits_its_design_on_the_independent_machine():
    results = []

    @settings(SETTINGS, max_examples=20)
    @given(programs())
    def collect(prog):
        r = _compile(prog)
        if r is not None and len(results) < 12:
            results.append(r)

    collect()
    assert results, "no generated program reached Knitout"
    assert_knits_as_designed(results)
