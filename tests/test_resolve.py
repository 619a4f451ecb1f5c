"""Resolution (AST → skeleton IR) through `knitc.driver.compile_source`.

Parameters and `-D` overrides, `@prop` references, property schemas and defaults, machine
settings, interfaces, connections and their states, yarn starts, components and stdlib
imports. Size inference and the verifier's warnings are in test_skeleton.py.
"""

from __future__ import annotations

import pytest

from knitc.driver import compile_source
from knitc.frontend import skeleton as sk
from knitc.frontend.skeleton import ItfId
from knitc.lang.evaluate import Profile, Word


def compile_(text: str, defines=(), path: str = "t.knit"):
    return compile_source(text, path, defines=list(defines))


def codes(result) -> list[str]:
    return [d.code for d in result.diagnostics]


def errors(result) -> list[str]:
    return [d.code for d in result.diagnostics if d.is_error]


def ok(text: str, defines=(), path: str = "t.knit") -> sk.Skeleton:
    r = compile_(text, defines, path)
    assert not r.diagnostics.has_errors, r.diagnostics.render()
    assert r.skeleton is not None
    assert r.stage_reached == "skeleton"
    return r.skeleton


def itf(skel: sk.Skeleton, ref: str) -> sk.Interface:
    node, _, path = ref.partition(".")
    if path.startswith("branches["):
        path = "branches/" + path[len("branches[") : -1]
    return skel.interfaces[ItfId(node, path)]


# ---- parameters ----------------------------------------------------------------------------


def test_params_evaluated_in_any_order():
    skel = ok("param b = #a * 3 + 1\nparam a = 2\nparam c = round(#b / 2)\n")
    assert skel.params == {"b": 7, "a": 2, "c": 4}


def test_param_kinds():
    skel = ok(
        'param s = "txt"\nparam w = half\nparam l = [1, 2]\nparam p = [0: 1, 1: 3]\n'
        "param t = #l[1] > 1\n"
    )
    assert skel.params["s"] == "txt"
    assert skel.params["w"] == Word("half")
    assert skel.params["l"] == (1, 2)
    assert skel.params["p"] == Profile(((0.0, 1.0), (1.0, 3.0)))
    assert skel.params["t"] is True


def test_param_used_in_node():
    skel = ok("param len = 12\nparam w = 6\nsheet a { length: #len  width: #w + 1 }\n")
    a = skel.nodes["a"]
    assert a.props["length"] == 12
    assert a.props["width"] == Profile.constant(7)


@pytest.mark.parametrize(
    "text, code",
    [
        ("param a = #b\nparam b = #a\n", "E404"),
        ("param a = #a\n", "E404"),
        ("param a = #nope\n", "E403"),
        ("param a = 1\nparam a = 2\n", "E401"),
        ("sheet s {}\nparam a = @s.length\n", "E405"),
        ("param a = @length\n", "E405"),
        ("param a = 1 / 0\n", "E305"),
        ("param a = foo(1)\n", "E201"),
    ],
)
def test_param_errors(text, code):
    r = compile_(text)
    assert code in errors(r)


def test_param_cycle_reported_once():
    r = compile_("param a = #b\nparam b = #c\nparam c = #a\n")
    assert errors(r).count("E404") == 1
    msg = next(d.message for d in r.diagnostics if d.code == "E404")
    assert "#a" in msg and "#b" in msg and "#c" in msg


def test_param_error_does_not_crash_dependents():
    r = compile_("param a = 1 / 0\nparam b = #a + 1\n")
    assert errors(r) == ["E305"]


def test_define_number_overrides_and_propagates():
    text = "param a = 2\nparam b = #a * 2\nsheet s { width: #b }\n"
    skel = ok(text, ["a=5"])
    assert skel.params == {"a": 5, "b": 10}
    assert skel.nodes["s"].props["width"] == Profile.constant(10)
    assert ok(text).params == {"a": 2, "b": 4}


def test_define_is_an_expression():
    skel = ok("param a = 2\nparam b = 3\n", ["b=#a * 10 + 1"])
    assert skel.params["b"] == 21


def test_define_word():
    skel = ok("param g = full\nsheet s { gauge: #g }\n", ["g=half"])
    assert skel.params["g"] == Word("half")
    assert skel.nodes["s"].props["gauge"] == "half"


def test_define_profile():
    skel = ok("param w = 3\nsheet s { width: #w }\n", ["w=[0: 4, 1: 8]"])
    assert skel.nodes["s"].props["width"] == Profile(((0.0, 4.0), (1.0, 8.0)))
    assert itf(skel, "s.bottom").size == 4
    assert itf(skel, "s.top").size == 8


def test_define_string_and_spaces():
    skel = ok('param m = "x"\nmachine { model: #m }\n', [' m = "SWG061N2" '])
    assert skel.machine.model == "SWG061N2"


def test_several_defines():
    skel = ok("param a = 1\nparam b = 2\n", ["a=10", "b=20"])
    assert skel.params == {"a": 10, "b": 20}


@pytest.mark.parametrize(
    "define, code",
    [
        ("nope=1", "E402"),
        ("1x=2", "E408"),
        ("a", "E408"),
        ("=3", "E408"),
        ("a=", "E408"),
        ("a=(", "E408"),
        ("a=1 sheet s {}", "E408"),
    ],
)
def test_bad_defines(define, code):
    r = compile_("param a = 1\n", [define])
    assert code in errors(r)


def test_define_of_undeclared_param_suggests():
    r = compile_("param finger_len = 1\n", ["finger_lne=2"])
    d = next(d for d in r.diagnostics if d.code == "E402")
    assert d.hint is not None and "finger_len" in d.hint


def test_define_with_bad_value_type_is_reported_at_use():
    r = compile_("param n = 3\nsheet s { length: #n }\n", ["n=half"])
    assert "E311" in errors(r)


# ---- @prop and @node.prop ------------------------------------------------------------------


def test_own_prop_reference():
    skel = ok("sheet a { length: 20  width: round(@length / 3) }\n")
    assert skel.nodes["a"].props["width"] == Profile.constant(7)


def test_other_node_prop_reference_forward_and_back():
    skel = ok("sheet b { length: @a.length + 1 }\nsheet a { length: 30  width: @b.length - 25 }\n")
    assert skel.nodes["a"].props["length"] == 30
    assert skel.nodes["b"].props["length"] == 31
    assert skel.nodes["a"].props["width"] == Profile.constant(6)


def test_prop_reference_to_default():
    skel = ok("sheet a {}\nsheet b { length: @a.length * 2  width: @a.width }\n")
    assert skel.nodes["b"].props["length"] == 20
    assert skel.nodes["b"].props["width"] == Profile.constant(10)


def test_prop_reference_reads_profile_and_constant_width():
    skel = ok(
        "tube a { width: [0: 4, 1: 8] }\ntube b { width: @a.width * 2 }\n"
        "tube c { width: 6 }\ntube d { length: @c.width + 1 }\n"
    )
    assert skel.nodes["b"].props["width"] == Profile(((0.0, 8.0), (1.0, 16.0)))
    # A constant width reads as a number through @refs.
    assert skel.nodes["d"].props["length"] == 7


def test_prop_reference_in_interface_block():
    skel = ok(
        "sheet a { length: 3 }\nsplit s { degree: 3 }\n"
        "tube x { width: 2 }\ntube y { width: 2 }\ntube z { width: 2 }\n"
        "s.branches[@a.length - 3] -> x.bottom\n"
        "s.branches[1] -> y.bottom\ns.branches[2] -> z.bottom\n"
    )
    assert itf(skel, "s.branches[0]").state == "connected"


@pytest.mark.parametrize(
    "text, code",
    [
        ("sheet a { length: @width  width: @length }\n", "E407"),
        ("sheet a { length: @b.length }\nsheet b { length: @a.length }\n", "E407"),
        ("sheet a { length: @nope.length }\n", "E211"),
        ("sheet a { length: @rows }\n", "E212"),
        ("sheet a {}\nsheet b { length: @a.degree }\n", "E212"),
        ("machine { needles: @length }\n", "E406"),
        ("sheet a {}\nsplit s { degree: 2 }\ns.branches[@degree] -> a.bottom\n", "E406"),
    ],
)
def test_prop_reference_errors(text, code):
    assert code in errors(compile_(text))


def test_prop_in_machine_block():
    skel = ok("sheet a { length: 300 }\nmachine { needles: @a.length * 2 }\n")
    assert skel.machine.needles == 600


# ---- property checks --------------------------------------------------------------------------


@pytest.mark.parametrize(
    "text, code",
    [
        ("sheet a { length: 2.5 }", "E311"),
        ("sheet a { length: 0 }", "E313"),
        ("sheet a { length: 100001 }", "E313"),
        ("sheet a { width: 0 }", "E313"),
        ("sheet a { width: [0: 4, 1: 0] }", "E313"),
        ("sheet a { width: half }", "E311"),
        ("sheet a { width: true }", "E311"),
        ("sheet a { gauge: third }", "E312"),
        ("sheet a { gauge: 1 }", "E311"),
        ("sheet a { type: round }", "E312"),
        ("sheet a { shaper: wiggle }", "E312"),
        ("sheet a { colour: 1 }", "E307"),
        ("tube a { type: flat }", "E307"),
        ("sheet a { length: 3  length: 4 }", "E308"),
        ("split s { folded: 1 }", "E311"),
        ("split s { degree: 0 }", "E313"),
        ("split s { degree: 65 }", "E313"),
        ("split s { degree: 2  layout: [0.5] }", "E309"),
        ("split s { layout: [0.2, 1.5] }", "E313"),
        ("joint j { layout: 2 }", "E313"),
        ("joint j { layout: center }", "E311"),
        ("joint j { rows: -1 }", "E313"),
        ("tube a { width: 0 }", "E313"),
        ("machine { racking: 9 }", "E313"),
        ("machine { racking: 5 }", "E313"),  # beyond SWG091N2, which k2dat would refuse
        ("machine { carriers: [] }", "E311"),
        ("machine { carriers: [1, 1] }", "E311"),
        ("machine { carriers: [11] }", "E313"),
        ("machine { carriers: [1.5] }", "E311"),
        ("machine { model: 3 }", "E311"),
        ("machine { gauge: tiny }", "E312"),
        ("machine { bed: 2 }", "E307"),
        ("machine {}\nmachine {}", "E314"),
    ],
)
def test_property_errors(text, code):
    assert code in errors(compile_(text))


@pytest.mark.parametrize(
    "text",
    [
        "joint j { layout: 1e999 - 1e999 }\ntube a {}\na.top -> j.bottom\n",
        "split s { layout: [0.5, 1e999 * 0] }\ntube a {}\ntube b {}\n"
        "s.branches[0] -> a.bottom\ns.branches[1] -> b.bottom\n",
    ],
)
def test_nan_is_out_of_range(text):
    # an infinite literal is refused where it is written (E110), so no nan is ever computed
    assert {"E110", "E305", "E311", "E313"} & set(errors(compile_(text)))


def test_misspelt_property_suggestion():
    r = compile_("sheet a { lenght: 3 }")
    d = next(d for d in r.diagnostics if d.code == "E307")
    assert d.hint == "did you mean `length`?"


def test_tube_type_hint():
    r = compile_("tube a { type: flat }")
    d = next(d for d in r.diagnostics if d.code == "E307")
    assert "cylinder" in d.hint


def test_bad_property_replaced_by_default():
    r = compile_("sheet a { length: 0  width: 4 }")
    assert errors(r) == ["E313"]
    assert r.skeleton.nodes["a"].props["length"] == 10
    assert r.skeleton.nodes["a"].props["width"] == Profile.constant(4)


def test_every_independent_error_reported():
    r = compile_("sheet a { length: 0  gauge: third  colour: 1 }")
    assert sorted(errors(r)) == ["E307", "E312", "E313"]


def test_whole_number_floats_accepted_as_ints():
    skel = ok("sheet a { length: 6 / 2 * 4.0 }")
    assert skel.nodes["a"].props["length"] == 12
    assert isinstance(skel.nodes["a"].props["length"], int)


def test_string_choice_accepted():
    skel = ok('sheet a { gauge: "half" }')
    assert skel.nodes["a"].props["gauge"] == "half"


# ---- defaults ----------------------------------------------------------------------------------


@pytest.mark.parametrize("kind", ["sheet", "tube", "joint", "split"])
def test_defaults_follow_the_schema(kind):
    text = f"{kind} n {{}}\n"
    if kind in ("joint", "split"):
        # give it sizes so the verifier has nothing to say
        text += "tube a { width: 10 }\ntube b { width: 10 }\ntube c { width: 5 }\n"
        text += "tube d { width: 5 }\n"
        text += (
            "a.top -> n.bottom\nn.top -> b.bottom\n"
            if kind == "joint"
            else "n.base -> a.bottom\nn.branches[0] -> c.top\nn.branches[1] -> d.top\n"
        )
    r = compile_(text)
    assert not r.diagnostics.has_errors, r.diagnostics.render()
    props = r.skeleton.nodes["n"].props
    schema = sk.NODE_PROPS[kind]
    assert set(schema) <= set(props)
    for name, spec in schema.items():
        expected = spec.default
        if name == "gauge":
            expected = sk.MACHINE_PROPS["gauge"].default
        elif name == "increase":
            expected = sk.MACHINE_PROPS["increase"].default
        elif spec.kind == "width":
            expected = Profile.constant(spec.default)
        assert props[name] == expected, name
    if kind == "tube":
        assert props["type"] == "cylinder"
    assert set(props) == set(schema) | ({"type"} if kind == "tube" else set())


def test_schema_defaults_documented_values():
    assert sk.SHEET_PROPS["length"].default == 10
    assert sk.SHEET_PROPS["width"].default == 10
    assert sk.SHEET_PROPS["type"].default == "flat"
    assert sk.JOINT_PROPS["width"].default == 5
    assert sk.JOINT_PROPS["rows"].default == 10
    assert sk.SPLIT_PROPS["degree"].default == 2
    assert sk.SPLIT_PROPS["folded"].default is True
    assert "type" not in sk.TUBE_PROPS


def test_machine_defaults():
    skel = ok("sheet a {}")
    m = skel.machine
    assert (
        m.model,
        m.needles,
        m.gauge,
        m.racking,
        m.carriers,
        m.increase,
        m.cast_on,
        m.cast_off,
    ) == ("SWG091N2", 541, "full", 4, (3,), "kickback", "interlock", "pickup")
    assert m.span is None


def test_machine_settings_and_node_defaults_from_machine():
    skel = ok(
        "machine { gauge: half  increase: split  needles: 300  carriers: [1, 2]\n"
        '  model: "X"  racking: 2  cast_on: tuck  cast_off: direct }\n'
        "sheet a {}\nsheet b { gauge: full  increase: kickback }\n"
        "sheet c { increase: auto }\n"
    )
    m = skel.machine
    assert (
        m.model,
        m.needles,
        m.gauge,
        m.racking,
        m.carriers,
        m.increase,
        m.cast_on,
        m.cast_off,
    ) == ("X", 300, "half", 2, (1, 2), "split", "tuck", "direct")
    assert m.span is not None
    assert skel.nodes["a"].props["gauge"] == "half"
    assert skel.nodes["a"].props["increase"] == "split"
    assert skel.nodes["b"].props["gauge"] == "full"
    assert skel.nodes["b"].props["increase"] == "kickback"
    assert skel.nodes["c"].props["increase"] == "split"


def test_single_carrier_number():
    assert ok("machine { carriers: 4 }").machine.carriers == (4,)


def test_tube_is_a_cylinder():
    skel = ok("tube t { width: 6 }\nsheet s { width: 6 }\nsheet c { type: cylinder  width: 6 }")
    assert skel.nodes["t"].props["type"] == "cylinder"
    assert skel.nodes["t"].tubular is True
    assert skel.nodes["s"].tubular is False
    assert skel.nodes["c"].tubular is True
    assert itf(skel, "t.bottom").sides == 2 and itf(skel, "t.bottom").size == 12
    assert itf(skel, "c.top").sides == 2 and itf(skel, "c.top").size == 12
    assert itf(skel, "s.top").sides == 1 and itf(skel, "s.top").size == 6


def test_reserved_and_duplicate_node_names():
    assert "E210" in errors(compile_("sheet before {}"))
    assert "E209" in errors(compile_("sheet a {}\ntube a {}"))


# ---- interfaces --------------------------------------------------------------------------------


def test_interfaces_per_kind():
    skel = ok(
        "sheet a { width: 4 }\ntube b { width: 2 }\njoint j {}\n"
        "split s { degree: 3  folded: false }\n"
        "sheet x { width: 1 }\nsheet y { width: 1 }\nsheet z { width: 2 }\n"
        "a.top -> j.bottom\nj.top -> s.base\n"
        "s.branches[0] -> x.bottom\ns.branches[1] -> y.bottom\ns.branches[2] -> z.bottom\n"
    )
    assert skel.nodes["a"].interface_paths == ["bottom", "top"]
    assert skel.nodes["b"].interface_paths == ["bottom", "top"]
    assert skel.nodes["j"].interface_paths == ["bottom", "top"]
    assert skel.nodes["s"].interface_paths == ["base", "branches/0", "branches/1", "branches/2"]
    expected = {ItfId(n, p) for n in "abjxyz" for p in ("bottom", "top")}
    expected |= {ItfId("s", p) for p in ("base", "branches/0", "branches/1", "branches/2")}
    assert set(skel.interfaces) == expected
    assert str(ItfId("s", "branches/2")) == "s.branches[2]"
    assert str(ItfId("a", "top")) == "a.top"
    for i in skel.interfaces.values():
        assert i.cast_on == "auto" and i.cast_off == "auto"


def test_split_degree_from_param():
    skel = ok(
        "param d = 4\nsplit s { degree: #d }\n"
        + "".join(f"tube t{i} {{ width: 2 }}\ns.branches[{i}] -> t{i}.bottom\n" for i in range(4))
    )
    assert len([i for i in skel.interfaces if i.node == "s"]) == 5


@pytest.mark.parametrize(
    "stmt, code",
    [
        ("s.branches -> a.bottom", "E213"),
        ("s.branches[2] -> a.bottom", "E214"),
        ("s.branches[-1] -> a.bottom", "E214"),
        ("s.branches[0.5] -> a.bottom", "E214"),
        ("s.branches[half] -> a.bottom", "E214"),
        ("s.branches[1 / 0] -> a.bottom", "E305"),
        ("s.top -> a.bottom", "E215"),
        ("a.base -> s.base", "E215"),
        ("a.top[0] -> s.base", "E215"),
        ("a.side -> s.base", "E215"),
        ("nope.top -> a.bottom", "E211"),
        ("start nope.top", "E211"),
        ("nope.top closed", "E211"),
    ],
)
def test_bad_interface_references(stmt, code):
    r = compile_("sheet a {}\nsplit s {}\n" + stmt + "\n")
    assert code in errors(r)


def test_interface_typo_suggestion():
    r = compile_("sheet a {}\na.bottm closed\n")
    d = next(d for d in r.diagnostics if d.code == "E215")
    assert d.hint == "did you mean `bottom`?"


# ---- connections and interface states ------------------------------------------------------


def test_connection_marks_both_ends_connected():
    skel = ok("tube a { width: 3 }\ntube b { width: 3 }\nb.bottom -> a.top\n")
    assert len(skel.connections) == 1
    c = skel.connections[0]
    assert (c.a, c.b) == (ItfId("b", "bottom"), ItfId("a", "top"))
    assert itf(skel, "a.top").state == "connected"
    assert itf(skel, "b.bottom").state == "connected"
    assert itf(skel, "a.bottom").state == "open"
    assert itf(skel, "b.top").state == "open"


def test_connection_before_declarations():
    skel = ok("a.top -> b.bottom\ntube a { width: 3 }\ntube b { width: 3 }\n")
    assert itf(skel, "a.top").state == "connected"


@pytest.mark.parametrize(
    "stmt, state, closing",
    [
        ("a.bottom closed", "closed", "collapse"),
        ("a.bottom closed(collapse)", "closed", "collapse"),
        ("a.bottom closed(zigzag)", "closed", "zigzag"),
        ("a.bottom closed(zigzagreturn)", "closed", "zigzagreturn"),
        ("a.bottom open", "open", None),
        ("a.bottom { cast_on: tuck }", "open", None),
    ],
)
def test_interface_states_and_closing(stmt, state, closing):
    skel = ok("tube a { width: 3 }\n" + stmt + "\n")
    i = itf(skel, "a.bottom")
    assert (i.state, i.closing) == (state, closing)
    assert itf(skel, "a.top").state == "open"


def test_reopened_interface_has_no_closing():
    skel = ok("tube a { width: 3 }\na.top closed\na.top open\n")
    assert itf(skel, "a.top").state == "open"
    assert itf(skel, "a.top").closing is None


def test_unknown_closing_mode():
    r = compile_("tube a { width: 3 }\na.bottom closed(zigzg)\n")
    d = next(d for d in r.diagnostics if d.code == "E312")
    assert d.hint == "did you mean `zigzag`?"


def test_cast_on_and_cast_off():
    skel = ok(
        "tube a { width: 3 }\n"
        "a.bottom { cast_on: tuck }\n"
        "a.top closed(zigzag) { cast_off: direct }\n"
    )
    b, t = itf(skel, "a.bottom"), itf(skel, "a.top")
    assert (b.state, b.cast_on, b.cast_off) == ("open", "tuck", "auto")
    assert (t.state, t.closing, t.cast_on, t.cast_off) == ("closed", "zigzag", "auto", "direct")


def test_cast_on_from_param():
    skel = ok("param c = precast\ntube a { width: 3 }\na.bottom open { cast_on: #c }\n")
    assert itf(skel, "a.bottom").cast_on == "precast"


@pytest.mark.parametrize(
    "block, code",
    [
        ("{ cast_on: glue }", "E312"),
        ("{ cast_of: pickup }", "E307"),
        ("{ cast_on: tuck  cast_on: tuck }", "E308"),
        ("{ cast_on: @length }", "E406"),
        ("{ cast_on: 3 }", "E311"),
    ],
)
def test_interface_block_errors(block, code):
    assert code in errors(compile_("tube a { width: 3 }\na.bottom " + block + "\n"))


@pytest.mark.parametrize(
    "text, code",
    [
        (
            "tube a {width: 3}\ntube b {width: 3}\ntube c {width: 3}\n"
            "a.top -> b.bottom\na.top -> c.bottom\n",
            "E501",
        ),
        ("tube a {width: 3}\ntube b {width: 3}\nb.bottom closed\na.top -> b.bottom\n", "E502"),
        ("tube a {width: 3}\ntube b {width: 3}\na.top -> b.bottom\nb.bottom closed\n", "E502"),
        ("tube a {width: 3}\na.top -> a.bottom\n", "E503"),
        ("tube a {width: 3}\na.top -> a.top\n", "E503"),
    ],
)
def test_connection_errors(text, code):
    assert code in errors(compile_(text))


def test_double_connection_keeps_the_first():
    r = compile_(
        "tube a {width: 3}\ntube b {width: 3}\ntube c {width: 3}\n"
        "a.top -> b.bottom\na.top -> c.bottom\n"
    )
    assert errors(r) == ["E501"]
    d = r.diagnostics.items[0]
    assert d.notes and d.notes[0].span.line == 4
    skel = r.skeleton
    assert [(str(c.a), str(c.b)) for c in skel.connections] == [("a.top", "b.bottom")]
    assert itf(skel, "c.bottom").state == "open"


# ---- yarn starts and components -------------------------------------------------------------


def test_declared_start():
    skel = ok("tube a { width: 3 }\ntube b { width: 3 }\na.top -> b.bottom\nstart b.top\n")
    assert len(skel.starts) == 1
    s = skel.starts[0]
    assert s.itf == ItfId("b", "top") and s.inferred is False and s.span is not None


def test_start_on_closed_interface():
    skel = ok("tube a { width: 3 }\na.bottom closed\nstart a.bottom\n")
    assert skel.starts[0].itf == ItfId("a", "bottom")


def test_inferred_start_is_first_free_interface_in_declaration_order():
    # b is declared first; its bottom is connected, so its top is the first free interface,
    # although a.bottom is the "beginning" of the chain.
    skel = ok("tube b { width: 3 }\ntube a { width: 3 }\na.top -> b.bottom\n")
    assert len(skel.starts) == 1
    s = skel.starts[0]
    assert s.itf == ItfId("b", "top") and s.inferred is True and s.span is None


def test_inferred_start_counts_closed_interfaces_as_free():
    skel = ok("tube a { width: 3 }\ntube b { width: 3 }\na.top -> b.bottom\na.bottom closed\n")
    assert skel.starts[0].itf == ItfId("a", "bottom")


def test_inferred_start_on_a_split():
    skel = ok(
        "split s { degree: 2 }\ntube a { width: 2 }\ntube b { width: 2 }\n"
        "tube c { width: 4 }\nc.top -> s.base\ns.branches[1] -> b.bottom\n"
        "a.bottom -> s.branches[0]\n"
    )
    # s has no free interface; a.top is the first free one in declaration order.
    assert [s.itf for s in skel.starts] == [ItfId("a", "top")]


def test_components_and_one_start_each():
    skel = ok(
        "tube a { width: 3 }\ntube x { width: 3 }\ntube b { width: 3 }\n"
        "tube y { width: 3 }\nsheet lone {}\n"
        "a.top -> b.bottom\ny.bottom -> x.top\nstart y.top\n"
    )
    assert skel.components() == [["a", "b"], ["x", "y"], ["lone"]]
    assert [(str(s.itf), s.inferred) for s in skel.starts] == [
        ("a.bottom", True),
        ("y.top", False),
        ("lone.bottom", True),
    ]


@pytest.mark.parametrize(
    "text, code",
    [
        ("tube a {width: 3}\ntube b {width: 3}\na.top -> b.bottom\nstart a.top\n", "E506"),
        (
            "tube a {width: 3}\ntube b {width: 3}\na.top -> b.bottom\nstart a.bottom\nstart b.top\n",
            "E507",
        ),
        ("tube a {width: 3}\ntube b {width: 3}\na.top -> b.bottom\nb.top -> a.bottom\n", "E508"),
    ],
)
def test_start_errors(text, code):
    assert code in errors(compile_(text))


def test_start_in_each_of_two_garments_is_fine():
    skel = ok("tube a {width: 3}\ntube b {width: 3}\nstart a.top\nstart b.bottom\n")
    assert [str(s.itf) for s in skel.starts] == ["a.top", "b.bottom"]
    assert not any(s.inferred for s in skel.starts)


def test_graph_view():
    skel = ok("tube a { width: 3 }\ntube b { width: 3 }\na.top -> b.bottom\n")
    g = skel.graph()
    assert set(g.nodes) == {"a", "b"} | set(skel.interfaces)
    kinds = sorted(d["kind"] for _, _, d in g.edges(data=True))
    assert kinds == ["connection"] + ["owns"] * 4


# ---- imports ---------------------------------------------------------------------------------


def test_import_whole_stdlib_module():
    skel = ok("import std.stitches\n")
    assert {"rib", "seed", "garter", "basket", "eyelets", "cable", "tuck_stitch"} <= set(
        skel.patterns
    )
    assert not skel.actions and not skel.shapers


def test_import_selected_names():
    skel = ok(
        "import std.stitches (rib, seed)\nimport std.actions (purl)\nimport std.shapers (edges)\n"
    )
    assert set(skel.patterns) == {"rib", "seed"}
    assert set(skel.actions) == {"purl"}
    assert set(skel.shapers) == {"edges"}


def test_import_every_std_module():
    skel = ok("import std.stitches\nimport std.actions\nimport std.shapers\n")
    assert {"knit", "purl", "purl_flat", "tuck", "miss", "kickback"} <= set(skel.actions)
    assert {"zigzag", "edges"} <= set(skel.shapers)


def test_imported_definitions_are_usable():
    skel = ok(
        "import std.stitches (rib)\nimport std.actions (purl)\n"
        "import std.shapers (zigzag)\n"
        "tube a { width: [0: 6, 1: 8]  shaper: zigzag }\n"
        "pattern a {\n  apply rib(2, 2) where courses(0 : 3)\n  use purl where "
        "courses(4)\n}\n"
    )
    assert skel.nodes["a"].props["shaper"] == "zigzag"
    assert [lay.target for lay in skel.layers] == ["a", "a"]


def test_pattern_without_import_is_unknown():
    r = compile_("tube a { width: 6 }\npattern a { apply rib(1, 1) }\n")
    assert "E218" in errors(r)


@pytest.mark.parametrize(
    "text, code",
    [
        ("import std.stiches\n", "E202"),
        ("import std.stitches (ribb)\n", "E208"),
        ('import "no/such/file.knit"\n', "E203"),
    ],
)
def test_import_errors(text, code):
    assert code in errors(compile_(text))


def test_same_definition_imported_twice_is_fine():
    skel = ok("import std.stitches (rib)\nimport std.stitches\n")
    assert "rib" in skel.patterns


def test_two_imports_of_one_name(tmp_path):
    (tmp_path / "mine.knit").write_text("pattern rib() { set K }\n", encoding="utf-8")
    r = compile_(
        'import std.stitches (rib)\nimport "mine.knit"\n', path=str(tmp_path / "main.knit")
    )
    assert "E204" in errors(r)


def test_unknown_stdlib_module_suggestion():
    r = compile_("import std.stiches\n")
    d = next(d for d in r.diagnostics if d.code == "E202")
    assert "std.stitches" in d.hint


def test_file_import_relative_to_importer(tmp_path):
    (tmp_path / "parts").mkdir()
    (tmp_path / "parts" / "lace.knit").write_text(
        "pattern holes() { set FR1 where filter(wale % 4 == 0) }\n", encoding="utf-8"
    )
    main = tmp_path / "main.knit"
    skel = ok(
        'import "parts/lace.knit"\ntube a { width: 6 }\npattern a { apply holes() }\n',
        path=str(main),
    )
    assert set(skel.patterns) == {"holes"}


def test_file_import_of_garment_parts_is_rejected(tmp_path):
    (tmp_path / "bad.knit").write_text("sheet a {}\n", encoding="utf-8")
    r = compile_('import "bad.knit"\n', path=str(tmp_path / "main.knit"))
    assert "E207" in errors(r)


def test_import_cycle(tmp_path):
    (tmp_path / "a.knit").write_text('import "b.knit"\npattern pa() { set K }\n', encoding="utf-8")
    (tmp_path / "b.knit").write_text('import "a.knit"\npattern pb() { set P }\n', encoding="utf-8")
    r = compile_('import "a.knit"\n', path=str(tmp_path / "main.knit"))
    assert "E206" in errors(r)


def test_local_definition_shadows_import():
    skel = ok("import std.stitches (rib)\npattern rib(k) { set K }\n")
    assert [p.name.name for p in skel.patterns["rib"].params] == ["k"]


def test_local_definition_twice():
    assert "E205" in errors(compile_("pattern p() { set K }\npattern p() { set P }\n"))


def test_a_selective_import_brings_what_the_definition_applies(tmp_path):
    """`import "m.knit" (outer)` makes `outer`'s own `apply inner()` work, although
    `inner` was not named (definitions share one namespace)."""
    (tmp_path / "m.knit").write_text(
        "pattern inner() { set P }\npattern outer() { apply inner() where courses(0) }\n"
    )
    main = tmp_path / "main.knit"
    main.write_text(
        'import "m.knit" (outer)\nsheet s { length: 3  width: 4 }\npattern s { apply outer() }\n'
    )
    r = compile_source(main.read_text(), str(main), until="stitch-graph")
    assert not r.diagnostics.has_errors, r.diagnostics.render()
    assert int((r.graph.instr == 1).sum()) == 4  # course 0 purled through `inner`
