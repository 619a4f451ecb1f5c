"""Stitch actions (`patterning/actions.py`): `use ACTION where Q`, and pre / main / post programs
run at code generation. What each built-in action knits, the exact operations of a user
action, its context, `split_by_side` ordering, `transfer_back`, located runtime errors, and
that actions change nothing but how stitches are made. Every program that compiles here
also runs clean on the independent machine."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from fabric import assert_knits_as_designed
from knitc.codegen import actions
from knitc.diagnostics import Diagnostics
from knitc.driver import compile_source
from knitc.patterning import actions as pattern_actions
from knitc.patterning.pattern import apply_patterns
from knitc.patterning.query import QueryEnv, coords, evaluate_query
from knitc.shaping.shape import build_stitch_graph
from knitc.shaping.stitch_graph import INSTRUCTIONS

BUILTINS = ("knit", "purl", "purl_flat", "tuck", "miss", "kickback", "split")
SHEET = "sheet s {{ length: 7  width: 8 }}\npattern s {{ use {a} where {q} }}\n"
TUBE = "tube t {{ length: 7  width: 6  gauge: half }}\npattern t {{ use {a} where {q} }}\n"
ODD = "filter(wale % 2 == 1) and courses({c})"
FLAT_CHECK = "sheet s {{ length: 4  width: 4 }}\npattern s {{ use {a} where select(1, 1) }}\n"


def build(src: str, until: str = "machine"):
    r = compile_source(src, "t.knit", until=until)
    assert not r.diagnostics.has_errors, r.diagnostics.render()
    return r


def compiled_with_errors(src: str):
    r = compile_source(src, "t.knit", until="machine")
    assert r.diagnostics.has_errors
    return r


def design(template: str, action: str) -> str:
    # tucks and splits hold the old loop: on every other course, as a tuck fabric is knitted
    c = "1:2:5" if action in ("tuck", "split") else "1:end"
    head = "import std.actions (purl_flat)\n" if action == "purl_flat" else ""
    return head + template.format(a=action, q=ODD.format(c=c))


def stitch_ops(r, s: int, kinds=("knit", "tuck", "miss", "xfer", "split")):
    return [o for o in r.program if o.stitch == s and o.kind in kinds]


def selected(r) -> list[int]:
    return np.nonzero(r.graph.action >= 0)[0].tolist()


def direction(r, s: int) -> int:
    v = int(np.nonzero(r.trace.stitch == s)[0][0])
    return int(r.trace.dir[v]) or 1


def made_by(r, s: int, want: str) -> None:
    """The loop-making op of stitch `s` is what action `want` says."""
    ops = stitch_ops(r, s)
    home = "fb"[int(r.graph.side[s])]
    d = direction(r, s)
    if want == "knit":
        assert [(o.kind, o.needle.bed) for o in ops][:1] == [("knit", home)]
    elif want in ("purl", "purl_flat"):
        knit = next(o for o in ops if o.kind == "knit")
        assert knit.needle.bed != home and knit.dir == d  # knitted from the other bed
        first = ops[0]
        if want == "purl" or first.kind == "xfer":  # a purl_flat loop may be there already
            assert (first.kind, first.needle.bed, first.needle2) == ("xfer", home, knit.needle)
    elif want == "tuck":
        assert ops[0].kind == "tuck" and ops[0].dir == d and ops[0].needle.bed == home
    elif want == "miss":
        assert [o.kind for o in ops][:1] == ["miss"] and "knit" not in [
            o.kind for o in ops if o.needle.bed == home and o.dir == d
        ]
    elif want == "kickback":
        assert [(o.kind, o.dir) for o in ops][:2] == [("miss", d), ("knit", -d)]
    elif want == "split":
        assert ops[0].kind == "split" and ops[0].needle.bed == home
        back = next(o for o in ops if o.kind == "xfer")
        assert back.needle == ops[0].needle2 and back.needle2 == ops[0].needle


# ---- every built-in action, on a sheet and a half-gauge tube -------------------------------------


def test_builtin_actions_make_their_stitches_and_run_clean_on_the_machine():
    texts: list = []
    for a in BUILTINS:
        for template in (SHEET, TUBE):
            r = build(design(template, a))
            assert not [d for d in r.diagnostics if d.code.startswith(("E7", "W7"))]
            if a == "knit":  # the built-in knit resets to plain: no action id at all
                assert (r.graph.action < 0).all()
            else:
                assert selected(r)
                for s in selected(r):
                    made_by(r, s, a)
            texts.append(r)
    assert_knits_as_designed(texts)


@pytest.mark.parametrize(
    "machine", ["", "machine { cast_on: none }\n", "machine { cast_on: precast }\n"]
)
def test_actions_on_the_first_course_knit_through_the_cast_on(machine):
    # the first course's loops are the cast-on's (or none): a purl carries its cast-on loop
    # across, a split holds it
    texts = []
    for a, q in (("purl", "all()"), ("split", "courses(0)"), ("kickback", "courses(0)")):
        for shape in (
            "sheet s { length: 4  width: 5 }\n",
            "tube s { length: 4  width: 4  gauge: half }\n",
        ):
            r = build(machine + shape + f"pattern s {{ use {a} where {q} }}\n")
            first = [s for s in selected(r) if int(r.graph.wale_prev[s, 0]) < 0]
            assert first
            for s in first:
                kinds = [o.kind for o in stitch_ops(r, s)]
                if "none" in machine:  # empty needles: the loop is cast on by a tuck
                    assert "tuck" in kinds and "knit" not in kinds
                else:
                    assert {"purl": "xfer", "split": "split", "kickback": "miss"}[a] in kinds
            texts.append(r)
    assert_knits_as_designed(texts)


def test_builtins_need_no_import_and_a_design_may_redefine_them():
    assert {"purl", "split", "kickback"} <= set(
        pattern_actions.names(build("sheet s { length: 2  width: 2 }\n", "skeleton").skeleton)
    )
    own = (
        "action purl { main { tuck(dir, needle, carriers) } }\n"
        "sheet s { length: 4  width: 4 }\npattern s { use purl where select(1, 1) }\n"
    )
    r = build(own)
    [s] = selected(r)
    assert [o.kind for o in stitch_ops(r, s)] == ["tuck"]  # the design's, not the stdlib's


def test_ids_index_the_actions_sorted_by_name():
    src = (
        "action zz { main { tuck(dir, needle, carriers) } }\n"
        "action aa { main { miss(dir, needle, carriers) } }\n"
        "sheet s { length: 3  width: 4 }\n"
        "pattern s {\n  use zz where wales(0)\n  use aa where wales(1)\n"
        "  use purl where wales(2)\n}\n"
    )
    r = build(src)
    names = pattern_actions.names(r.skeleton)
    assert names == sorted(names) and names[0] == "aa"
    w = coords(r.graph).wale
    for wale, name in ((0, "zz"), (1, "aa"), (2, "purl")):
        assert set(r.graph.action[w == wale].tolist()) == {names.index(name)}
    assert (r.graph.action[w == 3] == -1).all()


# ---- a user action: exact operations and context -------------------------------------------------

USER = """action lean {
  split_by_side: true
  pre {
    xfer(needle, opposite)
  }
  main {
    miss(dir, needle, carriers)
    knit(dir, opposite, carriers)
  }
  post {
    xfer(opposite, needle)
  }
}
sheet s { length: 3  width: 3 }
pattern s { use lean where select(1, 1) }
"""


def test_a_user_action_emits_exactly_its_steps():
    r = build(USER)
    [s] = selected(r)
    d = "+" if direction(r, s) > 0 else "-"
    n = r.program.ops[next(i for i, o in enumerate(r.program) if o.stitch == s)].needle.index
    got = [str(o) for o in stitch_ops(r, s)]
    assert got == [f"xfer f{n} b{n}", f"miss {d} f{n} 3", f"knit {d} b{n} 3", f"xfer b{n} f{n}"]
    # the transfers are made at racking 0, the knit with the plain stitch number
    ops = list(r.program)
    at = [ops.index(o) for o in stitch_ops(r, s)]
    racks = [o.value for o in ops[: at[0]] if o.kind == "rack"]
    assert not racks or racks[-1] == 0
    numbers = [o.value for o in ops[: at[2]] if o.kind == "stitch_number"]
    assert numbers[-1] == 5  # the knit: the plain stitch number
    assert [o.value for o in ops[: at[0]] if o.kind == "stitch_number"][-1] == 0  # transfers
    assert_knits_as_designed([r])


def test_the_context_gives_position_stitch_fields_and_needles():
    src = """action ctx {
  main {
    if position % 2 == 0 and stitch.wale == needle.index - first and side == front {
      knit(dir, needle, carriers)
    } else {
      tuck(dir, needle, carriers)
    }
  }
}
sheet s { length: 4  width: 5 }
pattern s { use ctx where courses(1) }
"""
    # the sheet's wale 0 sits on some needle: learn it from a plain compile
    plain = build("sheet s { length: 4  width: 5 }\n")
    w0 = min(o.needle.index for o in plain.program if o.kind == "knit")
    r = build(src.replace("first", str(w0)))
    ids = [
        int(x)
        for x in r.trace.stitch
        if int(r.graph.course[x]) == int(r.graph.course[selected(r)[0]])
    ]
    assert sorted(ids) == sorted(selected(r))
    for i, s in enumerate(ids):
        assert [o.kind for o in stitch_ops(r, s)] == ["knit" if i % 2 == 0 else "tuck"]


def test_needle_values_move_and_compare():
    # knit on the needle to the right of the stitch's own? no: move the loop there and back
    src = """action hop {
  split_by_side: true
  pre {
    xfer(needle, opposite + 1)
  }
  main {
    knit(dir, opposite + 1, carriers)
  }
  post {
    xfer(opposite + 1, needle)
  }
}
sheet s { length: 3  width: 3 }
pattern s { use hop where select(1, 1) }
"""
    r = build(src)
    [s] = selected(r)
    xf = [o for o in stitch_ops(r, s) if o.kind == "xfer"]
    assert [(o.needle.bed, o.needle2.bed) for o in xf] == [("f", "b"), ("b", "f")]
    assert xf[0].needle2.index == xf[0].needle.index + 1 == xf[1].needle.index
    ops = list(r.program)
    rack = [o.value for o in ops[: ops.index(xf[0])] if o.kind == "rack"]
    assert rack and rack[-1] == -1  # front n faces back n + 1 at racking -1
    assert ops[-1].kind != "rack" and r.program.racking == 0  # and the machine unracks
    assert_knits_as_designed([r])


# ---- split_by_side ----------------------------------------------------------------------------


@pytest.mark.parametrize("split", [True, False])
def test_split_by_side_runs_each_bed_as_its_own_pass(split, monkeypatch):
    passes = []
    prepare = actions.prepare_pass

    def spy(gen, acts):
        parts = prepare(gen, acts)
        passes.append(
            (
                [a.stitch for a in acts],
                [[a.stitch for a in p] for p in parts],
                {a.stitch: gen.pos(a.stitch)[0] for a in acts},
                [a.stitch for a in acts if isinstance(a, actions.UserAction)],
            )
        )
        return parts

    monkeypatch.setattr(actions, "prepare_pass", spy)
    prop = "split_by_side: true" if split else ""
    # a growing tube: its passes start with a stitch of the other bed
    src = (
        f"action rev {{ {prop}\n  pre {{ xfer(needle, opposite) }}\n"
        "  main { knit(dir, opposite, carriers) }\n  post { xfer(opposite, needle) }\n}\n"
        "tube t { length: 6  width: [0: 4, 1: 8]  gauge: half }\n"
        "pattern t { use rev where courses(1:end) }\n"
    )
    r = build(src)
    ops = list(r.program)
    first_op = {}
    for i, o in enumerate(ops):
        first_op.setdefault(o.stitch, i)
    mixed = 0
    for k, (ids, parts, bed, users) in enumerate(passes):
        assert [s for p in parts for s in p] == ids
        if len({bed[s] for s in users}) < 2:
            continue
        mixed += 1
        # the pass's ops: its action pass's, up to the next pass's first (later transfers of
        # its loops belong to the alignment and shaping of the next slices)
        end = min(first_op[s] for s in passes[k + 1][0]) if k + 1 < len(passes) else len(ops)
        where = {
            s: [
                i
                for i, o in enumerate(ops[:end])
                if o.stitch == s and o.kind in ("xfer", "knit", "tuck") and o.phase == "action"
            ]
            for s in ids
        }
        if split:
            assert [len({bed[s] for s in p}) for p in parts] == [1] * len(parts) > [1]
            for p, q in zip(parts, parts[1:]):  # every op of a run before the next run's
                assert max(i for s in p for i in where[s]) < min(i for s in q for i in where[s])
        else:
            assert len(parts) == 1
            first_knit = min(i for s in users for i in where[s] if ops[i].kind == "knit")
            pre = [where[s][0] for s in users]  # each stitch's transfer to the other bed
            assert max(pre) < first_knit
    assert mixed >= 3
    assert_knits_as_designed([r])


# ---- transfer_back ----------------------------------------------------------------------------


def test_transfer_back_false_skips_the_post_step_while_the_wale_goes_on(monkeypatch):
    made = {}
    lower = actions.lower

    def spy(gen, ctx, s, d, pos):
        a = lower(gen, ctx, s, d, pos)
        made[s] = (a, gen)
        return a

    monkeypatch.setattr(actions, "lower", spy)
    r = build(
        "import std.actions (purl_flat)\nsheet s { length: 6  width: 4 }\n"
        "pattern s { use purl_flat where wales(1) and courses(1:end) }\n"
    )
    g = r.graph
    assert made and set(made) == set(selected(r))
    for s, (a, gen) in made.items():
        kid = int(g.wale_next[s, 0])
        goes_on = kid >= 0 and int(g.action[kid]) == int(g.action[s])
        assert actions.keeps_loop(gen, s) == goes_on
        assert len(a.post) == (1 if goes_on else 2)  # `finish` only, or the transfer too
    # and the loop really waits on the back bed: one transfer there, one home, for the
    # whole wale (the cast-off's own transfers aside)
    last = g.n_courses - 1
    xfers = [
        o
        for o in r.program
        if o.kind == "xfer"
        and 0 <= o.stitch
        and int(g.course[o.stitch]) < last
        and o.stitch in made
    ]
    assert len(xfers) == 1
    assert_knits_as_designed([r])


# ---- `use knit` and what actions never change ---------------------------------------------------


@st.composite
def shapes(draw) -> str:
    kind = draw(st.sampled_from(["sheet", "tube"]))
    length = draw(st.integers(2, 5))
    w0 = draw(st.integers(4, 7))
    w1 = w0 + draw(st.integers(-2, 2))
    width = str(w0) if draw(st.booleans()) else f"[0: {w0}, 1: {w1}]"
    props = draw(st.sampled_from(["", "gauge: half", "increase: split"]))
    machine = draw(st.sampled_from(["", "machine { cast_on: tuck }\n"]))
    return f"{machine}{kind} x {{ length: {length}  width: {width}  {props} }}\n"


QUERIES = (
    "all()",
    "courses(0)",
    "courses(1:end)",
    "wales(0:2)",
    "filter(wale % 2 == 0)",
    "side(back)",
    "courses(-1)",
)


@settings(max_examples=25, deadline=None)
@given(shapes(), st.lists(st.sampled_from(QUERIES), min_size=1, max_size=3))
def test_plain_actions_give_the_machine_program_of_no_action(shape, queries):
    plain = build(shape)
    want = [(str(o), o.stitch) for o in plain.program]
    own = "action plain { main { knit(dir, needle, carriers) } }\n"
    for src in (
        shape + "pattern x {\n" + "".join(f"  use knit where {q}\n" for q in queries) + "}\n",
        # a purl layer undone by `use knit`
        shape + "pattern x {\n  set P\n  use purl\n  use knit\n}\n",
        # a user action that knits: the same operations as the built-in lowering
        own
        + shape
        + "pattern x {\n"
        + "".join(f"  use plain where {q}\n" for q in queries)
        + "}\n",
    ):
        r = build(src)
        assert [(str(o), o.stitch) for o in r.program] == want


@settings(max_examples=30, deadline=None)
@given(
    shapes(),
    st.lists(
        st.tuples(st.sampled_from(BUILTINS + ("own",)), st.sampled_from(QUERIES)),
        min_size=1,
        max_size=4,
    ),
)
def test_use_never_creates_or_deletes_stitches(shape, uses):
    src = (
        "import std.actions (purl_flat)\naction own { main { tuck(dir, needle, carriers) } }\n"
        + shape
        + "pattern x {\n"
        + "".join(f"  use {a} where {q}\n" for a, q in uses)
        + "}\n"
    )
    r = build(src, "skeleton")
    diags = Diagnostics()
    raw = build_stitch_graph(r.skeleton, diags)
    out = apply_patterns(r.skeleton, raw, diags)
    assert not diags.has_errors, diags.render()
    assert out.n_stitches == raw.n_stitches
    for name in (
        "node",
        "course",
        "side",
        "needle",
        "cprev",
        "cnext",
        "wale_prev",
        "wale_next",
        "course_start",
        "course_len",
    ):
        assert np.array_equal(getattr(out, name), getattr(raw, name)), name
    # the last `use` of each stitch wins; the built-in knit resets to plain
    names = pattern_actions.names(r.skeleton)
    want = np.full(raw.n_stitches, -1)
    instr = raw.instr.copy()
    assert len(r.skeleton.layers) == len(uses)  # one layer entry per statement, in order
    for (a, _), layer in zip(uses, r.skeleton.layers, strict=True):
        sel = evaluate_query(raw, 0, layer.stmt.where, QueryEnv(), Diagnostics())
        want[sel] = -1 if a == "knit" else names.index(a)
        if a == "knit":
            instr[sel] = INSTRUCTIONS.index("K")
    assert np.array_equal(out.action, want)
    assert np.array_equal(out.instr, instr)


# ---- runtime errors ---------------------------------------------------------------------------


def _user(body: str, props: str = "", shape: str = "sheet s { length: 3  width: 3 }") -> str:
    return (
        f"action bad {{ {props}\n  {body}\n}}\n{shape}\npattern s {{ use bad where courses(1) }}\n"
    )


@pytest.mark.parametrize(
    "body, code",
    [
        ("main { knit(dir, needle + 1000, carriers) }", "E722"),
        (
            "pre { xfer(needle, opposite + 7) }\n  main { knit(dir, opposite + 7, carriers) }\n"
            "  post { xfer(opposite + 7, needle) }",
            "E721",
        ),
        ("main { knit(needle) }", "E723"),
        ("main { knit(dir, 3, carriers) }", "E723"),
        ("pre { xfer(needle, needle + 1) }\n  main { knit(dir, needle, carriers) }", "E724"),
        ("main { knit(dir, needle, 7) }", "E725"),
        ("pre { xfer(needle + 1, opposite) }\n  main { knit(dir, needle, carriers) }", "E720"),
        ("main { split(dir, needle, opposite, carriers) }", "E726"),
        ("main { knit(dir, needle, carriers)\n  tuck(dir, needle + 1, carriers) }", "E726"),
        ("main { for i in range(100000) { let x = i }\n  knit(dir, needle, carriers) }", "E316"),
        ("main { knit(dir, needle, carriers, sideways = 1) }", "E304"),
        ("main { knit(dir, needle.colour, carriers) }", "E303"),
    ],
)
def test_runtime_mistakes_are_located_errors(body, code):
    r = compiled_with_errors(_user(body))
    errors = [d for d in r.diagnostics if d.is_error]
    assert [d.code for d in errors] == [code], r.diagnostics.render()  # one, not one per stitch
    [e] = errors
    src = _user(body)
    use_line = src.count("\n", 0, src.index("pattern s")) + 1
    assert e.span is not None and e.span.file == "t.knit" and e.span.line < use_line - 1
    assert [n.span.line for n in e.notes] == [use_line]
    assert "action `bad`" in e.message


@pytest.mark.parametrize(
    "body, code, shown",
    [
        ("main { knit(dir, needle + 0.5, carriers) }", "E723", "got f"),
        ("main { knit(dir, needle + len(needle) - 2, carriers) }", "E303", "got a value"),
        ("main { knit(dir, needle + needle[0], carriers) }", "E303", "index"),
        ("main { for x in needle { let y = x }\n  knit(dir, needle, carriers) }", "E303", ""),
    ],
)
def test_a_needle_is_a_value_not_a_list(body, code, shown):
    # the machine's Needle is a named tuple, and the evaluators take tuples for lists: the
    # action language must still see a needle as one value (`f2`, not `["f", 2]`)
    r = compiled_with_errors(_user(body))
    [e] = [d for d in r.diagnostics if d.is_error]
    assert e.code == code, r.diagnostics.render()
    assert shown in e.message and '["f"' not in e.message and "['f'" not in e.message


def test_a_purl_on_a_full_gauge_tube_is_an_error_at_the_stdlib_line_and_the_use():
    src = "tube t { length: 4  width: 6 }\npattern t { use purl where courses(1) }\n"
    r = compiled_with_errors(src)
    [e] = [d for d in r.diagnostics if d.is_error]
    assert e.code == "E720" and e.span.file == pattern_actions.STD_FILE
    assert "half" in (e.hint or "")
    assert [n.span.line for n in e.notes] == [2]
    assert "xfer(needle, opposite)" in r.diagnostics.render()  # the stdlib source is shown


def test_actions_on_increases_warn_at_the_use():
    src = (
        "sheet s { length: 5  width: [0: 4, 1: 8] }\n"
        "pattern s { use kickback where courses(1:end) }\n"
    )
    r = build(src)
    [w] = [d for d in r.diagnostics if d.code == "W720"]
    assert w.span.line == 2 and "increase" in w.message
    assert_knits_as_designed([r])
