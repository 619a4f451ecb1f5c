"""knitc's own expression evaluator, driven through the real parser.

Every expression is written as source (`param x = EXPR`), parsed by the grammar and evaluated
by `knitc.lang.evaluate.Evaluator`, so these tests pin precedence and associativity as the
designer sees them, not just the evaluator's arithmetic.
"""

from __future__ import annotations

import math

import pytest

from knitc.frontend import ast
from knitc.frontend.parser import parse
from knitc.lang.evaluate import (
    EvalError,
    Evaluator,
    Profile,
    Word,
    round_half_up,
    show,
    type_name,
)

PARAMS = {"n": 4, "w": 10, "half_w": 5.5, "flag": True, "g": Word("half")}


def _param(name, span):
    if name not in PARAMS:
        raise EvalError("E403", f"unknown parameter `#{name}`", span)
    return PARAMS[name]


def _prop(node, prop, span):
    raise EvalError("E405", "no properties in these tests", span)


def expr_of(src: str) -> ast.Node:
    module = parse(f"param x = {src}", "t.knit")
    assert len(module.items) == 1
    decl = module.items[0]
    assert isinstance(decl, ast.ParamDecl)
    return decl.value


def ev(src: str):
    return Evaluator(_param, _prop).eval(expr_of(src))


def ev_error(src: str) -> EvalError:
    with pytest.raises(EvalError) as info:
        ev(src)
    return info.value


# ---- arithmetic and precedence -------------------------------------------------------------


@pytest.mark.parametrize(
    "src, expected",
    [
        ("1 + 2 * 3", 7),
        ("(1 + 2) * 3", 9),
        ("10 - 4 - 3", 3),  # left-associative
        ("100 / 10 / 5", 2),  # left-associative
        ("2 * 3 % 4", 2),  # * and % share a level, left to right
        ("2 + 3 % 2", 3),  # % binds tighter than +
        ("2 ^ 3 ^ 2", 512),  # ^ is right-associative
        ("-2 ^ 2", -4),  # unary minus binds looser than ^
        ("2 ^ -1", 0.5),
        ("-(2 + 3)", -5),
        ("--3", 3),
        ("2 * -3", -6),
        ("7 % 4", 3),
        ("7 / 2", 3.5),
        (".5 + 1.5e1", 15.5),
        ("#n * #w + 1", 41),
        ("#half_w * 2", 11.0),
    ],
)
def test_arithmetic_and_precedence(src, expected):
    got = ev(src)
    assert got == expected
    assert not isinstance(got, bool)


def test_exact_integer_division_stays_an_int():
    got = ev("6 / 3")
    assert got == 2 and isinstance(got, int)
    assert isinstance(ev("7 / 2"), float)
    assert isinstance(ev("6.0 / 3"), float)


def test_literal_kinds():
    assert ev('"a b"') == "a b"
    assert ev('"q\\"uote"') == 'q"uote'
    assert ev("half") == Word("half")
    assert ev("true") is True and ev("false") is False
    assert ev("[1, 2, 3]") == (1, 2, 3)
    assert ev("[]") == ()
    assert ev("(1, 2)") == (1, 2)
    assert ev("#g") == Word("half")


def test_list_indexing():
    assert ev("[10, 20, 30][1]") == 20
    assert ev("[10, 20, 30][-1]") == 30
    assert ev_error("[10, 20][2]").code == "E306"
    assert ev_error("[10, 20][true]").code == "E306"
    assert ev_error("3[0]").code == "E303"


# ---- round and the other builtins ----------------------------------------------------------


@pytest.mark.parametrize(
    "x, expected",
    [
        (2.5, 3),
        (3.5, 4),
        (0.5, 1),
        (1.5, 2),
        (-2.5, -2),
        (-0.5, 0),
        (-1.5, -1),
        (2.4999, 2),
        (2.5001, 3),
        (7, 7),
        (-7.6, -8),
    ],
)
def test_round_half_up(x, expected):
    # Python's round() rounds halves to even (round(2.5) == 2); knitc must not.
    assert round_half_up(x) == expected
    assert ev(f"round({x})") == expected


@pytest.mark.parametrize(
    "src, expected",
    [
        ("min(3, 1, 2)", 1),
        ("max(3, 1, 2)", 3),
        ("max(7)", 7),
        ("abs(-4)", 4),
        ("floor(2.7)", 2),
        ("floor(-2.2)", -3),
        ("ceil(2.1)", 3),
        ("sqrt(16)", 4.0),
        ("clamp(15, 0, 10)", 10),
        ("clamp(-5, 0, 10)", 0),
        ("clamp(5, 0, 10)", 5),
        ("lerp(10, 20, 0.25)", 12.5),
        ("round(#w / 3)", 3),
        ("min(#n, #w) + max(1, 2)", 6),
    ],
)
def test_builtins(src, expected):
    assert ev(src) == pytest.approx(expected)


def test_trig_builtins():
    assert ev("sin(0)") == 0
    assert ev("cos(0)") == 1


@pytest.mark.parametrize(
    "src",
    [
        "min()",
        "max()",
        "abs()",
        "abs(1, 2)",
        "round()",
        "round(1, 2)",
        "floor(1, 2)",
        "sqrt(1, 2)",
        "clamp(1, 2)",
        "clamp(1, 2, 3, 4)",
        "lerp(1)",
    ],
)
def test_builtin_arity_errors(src):
    err = ev_error(src)
    assert err.code == "E304"
    assert "argument" in err.message


def test_builtin_argument_kinds():
    assert ev_error("min(a = 1)").code == "E304"
    assert ev_error("min(1 : 2)").code == "E304"
    assert ev_error("abs(true)").code == "E303"
    assert ev_error('max(1, "2")').code == "E303"


def test_unknown_function():
    err = ev_error("median(1, 2)")
    assert err.code == "E201"
    assert "median" in err.message
    assert err.hint


def test_builtin_failures_are_eval_errors():
    assert ev_error("sqrt(-1)").code == "E305"
    # no literal or arithmetic makes inf any more (E110, E305); a builtin's own overflow
    # is caught on its result
    err = ev_error("lerp(1e300, -1e300, 1e300)")
    assert err.code == "E305" and "limit is ±1e300" in err.message


# ---- division by zero ----------------------------------------------------------------------


@pytest.mark.parametrize("src", ["1 / 0", "1 % 0", "#w / (#n - 4)", "0 ^ -1", "1.5 / 0.0"])
def test_division_by_zero(src):
    err = ev_error(src)
    assert err.code == "E305"


def test_division_by_zero_span_points_at_divisor():
    err = ev_error("10 / (#n - 4)")
    # `param x = 10 / (#n - 4)`: the divisor `(#n - 4)` starts at column 16 (or 17 inside).
    assert err.span.file == "t.knit"
    assert err.span.column >= 16


# ---- comparisons and booleans --------------------------------------------------------------


@pytest.mark.parametrize(
    "src, expected",
    [
        ("1 < 2", True),
        ("2 < 1", False),
        ("2 <= 2", True),
        ("3 > 4", False),
        ("3 >= 3", True),
        ("1 == 1", True),
        ("1 == 2", False),
        ("1 != 2", True),
        ("1 == 1.0", True),
        ('"a" == "a"', True),
        ('"a" != "b"', True),
        ("half == half", True),
        ("half == full", False),
        ("[1, 2] == [1, 2]", True),
        ("[1, 2] == [2, 1]", False),
        ("1 + 2 < 4", True),
        ("not 1 < 2", False),
        ("true or false and false", True),  # and binds tighter than or
        ("(true or false) and false", False),
        ("not true or true", True),  # not binds tighter than or
        ("not (true or true)", False),
        ("#flag and #n == 4", True),
    ],
)
def test_comparisons_and_booleans(src, expected):
    assert ev(src) is expected


def test_boolean_short_circuit():
    # The right operand is not evaluated, so its division by zero never happens.
    assert ev("false and 1 / 0 == 1") is False
    assert ev("true or 1 / 0 == 1") is True


@pytest.mark.parametrize(
    "src",
    [
        "1 and true",
        "true and 1",
        "false or 2",
        "not 1",
        'not "x"',
        '"a" < "b"',
        "1 + true",
        "true * 2",
        '1 + "a"',
        "half + 1",
        "-true",
        "[1] + 1",
    ],
)
def test_type_errors(src):
    assert ev_error(src).code == "E303"


def test_number_is_not_equal_to_boolean():
    assert ev("1 == true") is False
    assert ev("[1] == [true]") is False and ev("[[0]] != [[false]]") is True
    assert ev("[1, [2]] == [1, [2]]") is True and ev("[1] == [1.0]") is True


def test_negative_base_fractional_power_is_an_error():
    assert ev_error("(-8) ^ 0.5").code == "E305"


# ---- profiles ------------------------------------------------------------------------------


def test_profile_literal_and_interpolation():
    p = ev("[0: 10, 1: 20]")
    assert isinstance(p, Profile)
    assert p.points == ((0.0, 10.0), (1.0, 20.0))
    assert p.at(0) == 10
    assert p.at(0.5) == 15
    assert p.at(0.25) == 12.5
    assert p.at(1) == 20
    assert not p.is_constant


def test_profile_piecewise_interpolation():
    p = ev("[0: 10, 0.5: 30, 1: 20]")
    assert p.at(0.25) == pytest.approx(20)
    assert p.at(0.5) == 30
    assert p.at(0.75) == pytest.approx(25)
    # A step: two points at the same position.
    step = ev("[0: 1, 0.5: 1, 0.5: 9, 1: 9]")
    assert step.at(0.4) == 1
    assert step.at(0.6) == 9


def _at_by_scan(points, t):
    """The profile's meaning, searched point by point (what `Profile.at` bisects)."""
    if t <= points[0][0]:
        return points[0][1]
    for (t0, v0), (t1, v1) in zip(points, points[1:]):
        if t <= t1:
            return v0 if t1 == t0 else v0 + (v1 - v0) * (t - t0) / (t1 - t0)
    return points[-1][1]


def test_profile_bisection_agrees_with_the_scan():
    # `at` bisects (a 20,000-point width over 20,000 courses took 40 s scanned in order);
    # steps (repeated positions) and the ends must read as before
    import random

    rng = random.Random(14)
    for _ in range(2000):
        ts = sorted(
            rng.choice((0, 0.25, 0.5, 0.5, 1, rng.random())) for _ in range(rng.randint(1, 7))
        )
        points = tuple((float(t), float(rng.randint(1, 20))) for t in ts)
        p = Profile(points)
        for t in (-1, 0, 0.25, 0.5, 1, 2, rng.random(), *ts):
            assert p.at(t) == _at_by_scan(points, t), (points, t)


def test_profile_clamps_outside_its_range():
    p = ev("[0.2: 10, 0.8: 40]")
    assert p.at(-1) == 10
    assert p.at(0) == 10
    assert p.at(0.2) == 10
    assert p.at(0.5) == pytest.approx(25)
    assert p.at(0.8) == 40
    assert p.at(1) == 40
    assert p.at(5) == 40


def test_profile_with_param_points():
    p = ev("[0: #w, 1: #n * 2]")
    assert p.points == ((0.0, 10.0), (1.0, 8.0))


@pytest.mark.parametrize(
    "src, points",
    [
        ("[0: 10, 1: 20] * 2", ((0.0, 20.0), (1.0, 40.0))),
        ("2 * [0: 10, 1: 20]", ((0.0, 20.0), (1.0, 40.0))),
        ("[0: 10, 1: 20] / 2", ((0.0, 5.0), (1.0, 10.0))),
        ("[0: 10, 1: 20] + 1", ((0.0, 11.0), (1.0, 21.0))),
        ("1 + [0: 10, 1: 20]", ((0.0, 11.0), (1.0, 21.0))),
        ("[0: 10, 1: 20] - 1", ((0.0, 9.0), (1.0, 19.0))),
        ("30 - [0: 10, 1: 20]", ((0.0, 20.0), (1.0, 10.0))),  # operand order matters
        ("40 / [0: 10, 1: 20]", ((0.0, 4.0), (1.0, 2.0))),
        ("-[0: 10, 1: 20]", ((0.0, -10.0), (1.0, -20.0))),
    ],
)
def test_profile_scaled_and_shifted_by_numbers(src, points):
    p = ev(src)
    assert isinstance(p, Profile)
    assert [t for t, _ in p.points] == [t for t, _ in points]
    assert [v for _, v in p.points] == pytest.approx([v for _, v in points])


@pytest.mark.parametrize("op", ["+", "-", "*", "/"])
def test_combining_two_profiles_is_an_error(op):
    err = ev_error(f"[0: 1, 1: 2] {op} [0: 3, 1: 4]")
    assert err.code == "E303"
    assert "two profiles" in err.message


@pytest.mark.parametrize(
    "src", ["[0: 1, 1: 2] ^ 2", "[0: 1, 1: 2] % 2", "[0: 1, 1: 2] < 3", "[0: 1, 1: 2] + true"]
)
def test_other_profile_operations_are_errors(src):
    assert ev_error(src).code == "E303"


def test_profile_division_by_zero():
    assert ev_error("[0: 1, 1: 2] / 0").code == "E305"
    assert ev_error("1 / [0: 0, 1: 2]").code == "E305"


@pytest.mark.parametrize("src", ["[0: 1, 1.5: 2]", "[-0.1: 1, 1: 2]"])
def test_profile_positions_outside_unit_interval(src):
    err = ev_error(src)
    assert err.code == "E302"
    assert "outside" in err.message


def test_profile_positions_must_increase():
    err = ev_error("[0: 1, 0.8: 2, 0.5: 3]")
    assert err.code == "E302"
    assert "increase" in err.message


def test_profile_values_must_be_numbers():
    assert ev_error("[0: half, 1: 2]").code == "E303"
    assert ev_error("[0: 1, true: 2]").code == "E303"


def test_profile_mixed_with_plain_values_is_a_syntax_error():
    with pytest.raises(ValueError, match="E104"):
        parse("param x = [0: 1, 2]", "t.knit")


def test_profile_equality_and_json():
    assert ev("[0: 1, 1: 2] == [0: 1, 1: 2]") is True
    assert ev("[0: 1, 1: 2] == [0: 1, 1: 3]") is False
    c = Profile.constant(7)
    assert c.is_constant and c.at(0.3) == 7
    assert c.to_json() == 7  # a constant width reads as a number
    assert ev("[0: 4, 1: 4]").to_json() == 4
    assert ev("[0: 4, 1: 6.5]").to_json() == [[0, 4], [1, 6.5]]


# ---- references, helpers --------------------------------------------------------------------


def test_param_and_prop_callbacks():
    assert ev("#n") == 4
    assert ev_error("#nope").code == "E403"
    assert ev_error("@width").code == "E405"
    assert ev_error("@other.width").code == "E405"


def test_prop_ref_reaches_callback_with_node_and_prop():
    seen = []

    def prop(node, name, span):
        seen.append((node, name))
        return 3

    e = Evaluator(_param, prop)
    assert e.eval(expr_of("@length + @cuff.width")) == 6
    assert seen == [(None, "length"), ("cuff", "width")]


def test_constructs_that_are_not_values_here():
    assert ev_error("a.b").code == "E301"
    assert ev_error('"""K P"""').code == "E301"
    assert ev_error("half(1)").code == "E201"


def test_show_and_type_name():
    assert show(True) == "true"
    assert show(3.0) == "3"
    assert show("s") == '"s"'
    assert show(Profile(((0.0, 1.0), (1.0, 2.5)))) == "[0: 1, 1: 2.5]"
    assert show((1, Word("a"))) == "[1, a]"
    assert type_name(True) == "a boolean"
    assert type_name(1.5) == "a number"
    assert type_name(Word("x")) == "the word `x`"
    assert type_name(Profile.constant(1)) == "a profile"
    assert type_name(()) == "a list"


def test_round_half_up_never_uses_bankers_rounding():
    for k in range(-20, 20):
        x = k + 0.5
        assert round_half_up(x) == math.floor(x) + 1
