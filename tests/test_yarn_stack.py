"""The yarn-stack stage (`codegen.yarn_stack`, thesis Table 6.1): each stitch's front yarn and
the back yarns that miss, tuck or knit behind it, which code generation's yarn passes read.

Properties on random fair isle (with float catching), jacquard and inlaid designs, each
compiled to the end with every verifier on:

- the stacks verify, and say what the thesis' table says for each kind of course: in a fair
  isle part every other yarn of the part is behind every stitch it does not show on, once,
  missing or tucking; a jacquard stitch that gets a back layer is knitted behind; an inlay
  yarn is behind exactly the stitches it is laid over;
- float tucks sit on stitches knitted earlier in the part, with a course above, at least
  `tuck_every` needles apart along one bed;
- code generation does what the stacks say (and random float-catching designs knit as
  designed on the independent machine): a catching tuck on the needle of every float
  tuck, one back knit (or tuck, on an empty needle) per `knit` entry, and inlay tucks only
  where the stacks put them.

Then the verifier's own checks, the dump and the text form.
"""

from __future__ import annotations

import json

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from design_helpers import assert_random_designs_knit
from knitc.cli import main
from knitc.codegen import yarn_stack as stk
from knitc.driver import Result, compile_source
from knitc.scheduling import schedule as sc
from test_jacquard import jacquard
from test_plating import inlaid
from test_stripes import striped


def _compiled(text: str) -> Result:
    r = compile_source(text, "y.knit", until="machine", verify=True)
    assert r.program is not None and r.stacks is not None, text + r.diagnostics.render()
    assert stk.verify(r.graph, r.stacks) == []
    return r


def _by_yarn(r: Result, mode: int, inlay: bool = False) -> dict[int, list[int]]:
    """Yarn -> the stitches of its entries of `mode`."""
    y = r.stacks
    assert y is not None
    out: dict[int, list[int]] = {}
    sel = (y.mode == mode) & (y.inlay == inlay)
    for s, yarn in zip(y.stitch[sel].tolist(), y.yarn[sel].tolist(), strict=True):
        out.setdefault(yarn, []).append(s)
    return out


@st.composite
def caught(draw) -> tuple[str, int]:
    """A random striped or fair isle design whose yarns catch their floats every N needles."""
    n = draw(st.integers(1, 4))
    text = draw(striped(fair_isle=True))
    lines = [
        ln.replace(" }", f", tuck_every: {n} }}", 1) if ln.startswith("yarn ") else ln
        for ln in text.splitlines()
    ]
    return "\n".join(lines) + "\n", n


@settings(max_examples=40, derandomize=True, deadline=None)
@given(caught())
def test_fair_isle_stacks_float_every_other_yarn_and_catch_it_where_codegen_tucks(case):
    text, n = case
    r = _compiled(text)
    g, y, t, sched = r.graph, r.stacks, r.trace, r.schedule
    assert g is not None and y is not None and t is not None and sched is not None
    assert (y.front == g.yarn).all()
    assert not (y.mode == stk.KNIT).any() and not y.inlay.any()
    entries: dict[int, dict[int, int]] = {}
    for s, yarn, m in zip(y.stitch.tolist(), y.yarn.tolist(), y.mode.tolist(), strict=True):
        assert yarn not in entries.setdefault(s, {}), (s, yarn)
        entries[s][yarn] = m
    course_yarn = g.course_yarn()
    bed, needle = sc.knit_positions(sched, g.n_stitches)
    for part in stk.course_parts(g, t, sched):
        stitches = t.stitch[part]
        ys = g.yarn[stitches]
        base = int(course_yarn[g.course[stitches[0]]])
        if not (ys != base).any():
            assert not any(s in entries for s in stitches.tolist())
            continue
        order = [base] + sorted(set(ys.tolist()) - {base})
        for k, s in enumerate(stitches.tolist()):
            behind = entries.get(s, {})
            assert set(behind) == set(order) - {int(ys[k])}, (s, behind, text)
            for yarn, m in behind.items():
                if m != stk.TUCK:
                    continue
                assert g.wale_next[s, 0] >= 0
                # knitted in an earlier pass of the part (its front yarn comes first)
                assert order.index(int(ys[k])) < order.index(yarn), (s, yarn, text)
        for yarn in order:  # tucks along one bed at least n needles apart
            last: dict[int, int] = {}
            for s in stitches.tolist():
                if entries.get(s, {}).get(yarn) == stk.TUCK:
                    b = int(bed[s])
                    if b in last:
                        assert abs(int(needle[s]) - last[b]) >= n, (s, yarn, text)
                    last[b] = int(needle[s])
    # code generation catches every float where the stacks say: a tuck on the stitch's
    # needle after the stitch is knitted and before the stitch above it is
    assert r.program is not None
    knitted: dict[int, int] = {}  # stitch -> the index of the op that knits it
    catches: list[tuple[int, tuple[str, int]]] = []
    for i, op in enumerate(r.program.ops):
        if op.kind == "knit" and op.stitch >= 0:
            knitted.setdefault(op.stitch, i)
        elif op.kind == "tuck" and op.phase == "float_catch" and op.needle is not None:
            catches.append((i, (op.needle.bed, op.needle.index)))
    for stitches in _by_yarn(r, stk.TUCK).values():
        for s in stitches:
            here = ("fb"[int(bed[s])], int(needle[s]))
            lo, hi = knitted[s], knitted[int(g.wale_next[s, 0])]
            assert any(lo < i < hi and at == here for i, at in catches), (s, text)


@settings(max_examples=2, derandomize=True, deadline=None)
@given(st.lists(caught(), min_size=4, max_size=4))
def test_random_float_catching_designs_knit_as_designed(cases):
    """Four random designs at a time, their floats caught where the stacks say, on the
    independent machine with the fabric check (jacquard and inlaid ones are held to it in
    test_jacquard and test_plating)."""
    assert_random_designs_knit([text for text, _ in cases], "c")


@settings(max_examples=25, derandomize=True, deadline=None)
@given(jacquard())
def test_jacquard_stacks_knit_behind_every_backed_stitch_and_codegen_knits_each(text):
    r = _compiled(text)
    y, g = r.stacks, r.graph
    assert y is not None and g is not None and r.program is not None
    knit = y.mode == stk.KNIT
    behind = np.zeros(g.n_stitches, bool)
    behind[y.stitch[knit]] = True
    assert (behind == y.backed).all()
    # each region yarn is in the stack of every backed stitch, knitting or floating behind
    # (the front yarn only where it knits behind its own stitch)
    regions = stk.region_yarns(g)
    for s in np.nonzero(y.backed)[0].tolist():
        lo, hi = np.searchsorted(y.stitch, [s, s + 1])
        yarns = y.yarn[lo:hi].tolist()
        assert len(set(yarns)) == len(yarns)
        assert set(yarns) | {int(y.front[s])} == set(regions[int(g.node[s])]), (s, text)
    back_ops = [
        op
        for op in r.program.ops
        if op.phase == "backing" and op.kind in ("knit", "tuck") and op.stitch >= 0
    ]
    assert len(back_ops) == int(knit.sum()), text


@settings(max_examples=25, derandomize=True, deadline=None)
@given(inlaid())
def test_an_inlay_yarn_is_behind_its_stitches_and_tucks_only_where_its_stack_says(case):
    text, n = case
    r = _compiled(text)
    y, g = r.stacks, r.graph
    assert y is not None and g is not None and g.inlay is not None and r.program is not None
    laid = y.stitch[y.inlay]
    assert sorted(laid.tolist()) == np.nonzero(g.inlay)[0].tolist()
    tucks = set(y.stitch[y.inlay & (y.mode == stk.TUCK)].tolist())
    for s in tucks:
        assert (s - int(g.course_start[g.course[s]])) % n == 0
    made = {
        op.stitch
        for op in r.program.ops
        if 9 in op.carriers and op.kind == "tuck" and op.phase == "float_catch" and op.stitch >= 0
    }
    assert made <= tucks, text
    assert bool(made) == bool(tucks), text  # (a tuck is skipped only on a loaded needle)


# ---- the verifier, the dump -------------------------------------------------------------------

SCARF = """\
yarn pine { carrier: 5 }
sheet s { length: 6, width: 8 }
pattern s {
  knit pine where courses(1:4) and filter(wale % 2 == 0)
  backing birdseye where courses(1:4)
}
"""


def test_the_verifier_finds_a_broken_stack():
    r = _compiled(SCARF)
    y, g = r.stacks, r.graph
    assert y is not None and g is not None
    knit = np.nonzero(y.mode == stk.KNIT)[0]
    assert knit.size
    keep = np.ones(y.n_entries, bool)
    keep[knit[0]] = False
    dropped = stk.YarnStacks(
        y.front, y.stitch[keep], y.yarn[keep], y.mode[keep], y.inlay[keep], y.backed
    )
    assert "a backed stitch with no back knit" in stk.verify(g, dropped)
    shown = y.mode.copy()
    shown[y.yarn == y.front[y.stitch]] = stk.MISS
    odd = stk.YarnStacks(y.front, y.stitch, y.yarn, shown, y.inlay, y.backed)
    assert "a stitch's front yarn floats or tucks behind it" in stk.verify(g, odd)
    turned = stk.YarnStacks(y.front, y.stitch[::-1], y.yarn[::-1], y.mode, y.inlay, y.backed)
    assert any("sorted" in p for p in stk.verify(g, turned))


def test_a_one_yarn_design_has_front_yarns_only():
    r = _compiled("tube t { length: 4, width: 6 }\n")
    assert r.stacks is not None and r.stacks.n_entries == 0
    assert not r.stacks.front.any()


def test_the_dump_lists_each_stitch_with_back_yarns(tmp_path, capsys):
    src = tmp_path / "scarf.knit"
    src.write_text(SCARF)
    assert main(["--emit", "yarn-stack", str(src)]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["yarns"] == ["main", "pine"]
    assert doc["stats"]["front_yarns"] == ["main", "pine"]
    assert doc["stats"]["knit"] > 0 and doc["stats"]["inlay"] == 0
    first = doc["stacks"][0]
    assert set(first) == {"stitch", "front", "back"}
    assert {b["mode"] for s in doc["stacks"] for b in s["back"]} <= {"miss", "tuck", "knit"}
    assert main(["--emit", "yarn-stack", "--format", "text", str(src)]) == 0
    text = capsys.readouterr().out
    assert text.startswith("stats ") and "mode=knit" in text
