"""Hostile numbers in every slot a number enters: a located error or a compile, never a crash.

Issue 14's class "huge numbers, inf and nan": a value no machine can knit (10^400, a
20-digit bound, 1e999, nan from 1e999 - 1e999, a scale of 1e-320, a range of 10^300) must
be refused where it enters with a diagnostic that has a place in the source, or be harmless
(a range bound beyond the node clips to it). The table below feeds every hostile value into
every query argument, property, parameter, pattern argument, builtin, shaper statement and
action call; a test fails if the pipeline raises (exit 3 for a user) or reports an error
without a location. Then the specific crashes and limits, each pinned on its own.
"""

from __future__ import annotations

import pytest

from knitc.driver import compile_source
from knitc.frontend import ast
from knitc.frontend.parser import parse
from knitc.lang.evaluate import LIST_ITEMS, EvalError, show
from knitc.lang.interp import Interpreter

HOSTILE = (
    "0",
    "-1",
    "0.5",
    "12345678901234567890",
    "1e300",
    "-1e300",
    "1e-320",
    "10^400",
    "10^300 * 10^300",
    "1e999",
    "-1e999",
    "(1e999 - 1e999)",
    "0 * 1e999",
)
"""Numbers as a designer could write them: in range, fractional, huge, tiny, infinite, nan."""

SHEET = "sheet a { width: 10  length: 10 }\n"
SHAPED = "sheet a { length: 6  width: [0: 6, 1: 10]  shaper: s }\n"

QUERIES = (
    "courses(X)",
    "courses(0:X)",
    "courses(X:end)",
    "courses(0:X:end)",
    "courses(0:end * X)",
    "wales(X, front)",
    "select(X, 0:X)",
    "wales(0).neighbors(X)",
    "wales(0).neighbors(0:X)",
    "stitch_grid(X, 2)",
    'stitch_grid(2, X, y_align = "top")',
    'stitch_grid(X, X, x_align = "center", y_align = "middle")',
    "wale_grid(0:X)",
    "wale_grid(0:3, X)",
    "noise(X)",
    "noise(3, X)",
    "noise(3, seed = X)",
    'img("none.png", threshold = X)',
    "filter(course < X)",
    "filter(course * X > 1)",
    "filter(wale ^ X > 1)",
)
"""Every query argument that takes a number (X is replaced by the hostile value)."""

DESIGNS = (
    SHEET.replace("width: 10", "width: X"),
    SHEET.replace("length: 10", "length: X"),
    "sheet a { width: [0: X, 1: 10]  length: 10 }",
    "sheet a { width: [X: 3, 1: 10]  length: 10 }",
    "machine { needles: X }\n" + SHEET,
    "machine { racking: X }\n" + SHEET,
    "machine { carriers: [X] }\n" + SHEET,
    "machine { slice_shaping: X }\n" + SHEET,
    "tube p { length: 4  width: 6 }\nsplit s { degree: X }\np.top -> s.base",
    "tube p { length: 4  width: 6 }\nsplit s { degree: 2  layout: [0, X] }\np.top -> s.base",
    "tube p { length: 4  width: 6 }\nsplit s { degree: 2 }\ntube q { length: 4  width: 3 }\n"
    "p.top -> s.base\ns.branches[X] -> q.bottom",
    "tube p { length: 4  width: 6 }\njoint j { rows: X }\np.top -> j.bottom",
    "tube p { length: 4  width: 6 }\njoint j { rows: 2  width: X  layout: X }\np.top -> j.bottom",
    "param p = X\nsheet a { width: #p  length: 10 }",
    "param p = X\n" + SHEET + "pattern a { set P where courses(0:#p) or filter(wale < #p) }",
    "pattern q(n) { set P where courses(0:n) or filter(wale < n) }\n"
    + SHEET
    + "pattern a { apply q(X) }",
    "param p0 = X\nparam p1 = #p0 * #p0\nparam p2 = #p1 * #p1\n" + SHEET,
    "param p = [1, 2][X]\n" + SHEET,
) + tuple(
    f"param p = {call}\n" + SHEET
    for call in (
        "sqrt(X)",
        "floor(X)",
        "round(X)",
        "sin(X)",
        "min(X, 1)",
        "clamp(X, 0, 1)",
        "lerp(1e300, -1e300, X)",
    )
)
"""Properties, parameters, pattern arguments and builtins in declarations."""

SHAPERS = (
    "for i in range(X) { }",
    "let n = len(range(X))",
    "let r = range(X) let z = r[-1]",
    "let z = range(X) == range(X)",
    "for i in range(0, X, X) { }",
    "for i in range(M) { if i == 0 { i -> (X, X + 1) } else { i -> i } }",
    "let x = lerp(1e300, -1e300, X) for i in range(x) { }",
)
"""Statements of a shaper program (`s(M, N)`)."""

ACTIONS = (
    "rack(X)",
    "knit(X)",
    "knit(dir, needle + X)",
    "knit(dir, needle, [X])",
    "xfer(needle, opposite + X)",
    "drop(needle - X)",
    "split(dir, needle, needle + X)",
    "for i in range(X) { knit(dir) }",
)
"""Machine operations of an action's `main` step."""


def _located_or_clean(src: str, until: str) -> None:
    r = compile_source(src, "t.knit", until=until)
    unlocated = [d for d in r.diagnostics if d.is_error and d.span is None]
    assert not unlocated, [f"{d.code} {d.message}" for d in unlocated]


def _cases(templates: tuple[str, ...], wrap) -> list:
    return [
        pytest.param(wrap(t.replace("X", v)), id=f"{t}|{v}") for t in templates for v in HOSTILE
    ]


@pytest.mark.parametrize(
    "src", _cases(QUERIES, lambda q: SHEET + f"pattern a {{ set P where {q} }}")
)
def test_query_arguments(src: str) -> None:
    _located_or_clean(src, "stitch-graph")


@pytest.mark.parametrize(
    "src",
    _cases(
        ("wales(0).neighbors(X)", "stitch_grid(X, 2)", "wale_grid(0:3, X)"),
        lambda q: f"tube a {{ width: 6  length: 8 }}\npattern a {{ set P where {q} }}",
    ),
)
def test_query_arguments_on_a_tube(src: str) -> None:
    _located_or_clean(src, "stitch-graph")


@pytest.mark.parametrize("src", _cases(DESIGNS, lambda d: d))
def test_declarations(src: str) -> None:
    _located_or_clean(src, "stitch-graph")


@pytest.mark.parametrize("src", _cases(SHAPERS, lambda b: SHAPED + f"shaper s(M, N) {{ {b} }}"))
def test_shaper_statements(src: str) -> None:
    _located_or_clean(src, "stitch-graph")


@pytest.mark.parametrize(
    "src",
    [
        pytest.param(
            SHEET
            + f"action x {{ main {{ {t.replace('X', v)} }} }}\n"
            + "pattern a { use x where courses(2) and wales(3) }",
            id=f"{t}|{v}",
        )
        for t in ACTIONS
        for v in ("12345678901234567890", "10^400", "1e999", "(1e999 - 1e999)", "1e300")
    ],
)
def test_action_calls(src: str) -> None:
    _located_or_clean(src, "machine")


@pytest.mark.parametrize("define", ["p=1e999", "p=10^400", "p=(1e999 - 1e999)", "p=1e300"])
def test_a_define_goes_through_the_same_checks(define: str) -> None:
    r = compile_source("param p = 3\nsheet a { width: #p  length: 10 }", "t.knit", defines=[define])
    assert r.diagnostics.has_errors  # the -D value, not a crash or a silent infinity


# ---- the crashes and limits one by one ------------------------------------------------------


def _errors(src: str, until: str = "stitch-graph") -> list[tuple[str, str, int, int]]:
    r = compile_source(src, "t.knit", until=until)
    return [(d.code, d.message, d.span.line, d.span.column) for d in r.diagnostics if d.is_error]


def test_a_huge_query_argument_is_too_large_at_its_place_with_the_limit():
    # was E702 "a range bound is ..." although a noise scale is not a range
    (err,) = _errors(SHEET + "pattern a { set P where noise(10^400) }")
    assert err == ("E305", "number too large: the limit is ±1e300", 2, 31)


def test_a_number_argument_that_is_not_arithmetic_says_so():
    (err,) = _errors(SHEET + 'pattern a { set P where noise("big") }')
    assert err[0] == "E703" and err[1].startswith("a number argument is a number")


def test_range_bounds_take_the_whole_arithmetic():
    r = compile_source(
        SHEET + "pattern a { set P where courses(0:2^2) and wales(7 % 4) }", "t.knit"
    )
    assert r.ok


def test_a_bound_beyond_the_node_clips():
    # courses(0:12345678901234567890) selects every course: the language clips ranges
    assert not _errors(SHEET + "pattern a { set P where courses(0:12345678901234567890) }")


@pytest.mark.parametrize("align", ["top", "middle"])
def test_a_grid_taller_than_any_wale_is_cut_to_the_graph(align: str):
    # the anchor row of a 10^300-tall grid did not fit an int64 (OverflowError, exit 3)
    q = f'stitch_grid(2, 1e300, y_align = "{align}") and stitch_grid(2, 10, y_align = "{align}")'
    assert not _errors(SHEET + f"pattern a {{ set P where {q} }}")


def test_a_noise_scale_too_small_for_whole_coordinates_is_e717():
    # 1e-320 made the noise coordinates infinite; the noise was not deterministic
    (err,) = _errors(SHEET + "pattern a { set P where noise(1e-320) }")
    assert err[0] == "E717" and "at least 0.000001" in err[1]


def test_a_builtin_that_overflows_is_too_large_at_the_call():
    # lerp's float arithmetic gave -inf without an exception, and -inf went on as a value
    (err,) = _errors("param p = lerp(1e300, -1e300, 1e300)\n" + SHEET)
    assert err[:2] == ("E305", "`lerp`: number too large: the limit is ±1e300")


def test_numbers_in_messages_stay_short():
    assert show(1e300) == "1e+300"
    assert show(10**300) == "1e+300"
    assert show(12345678901234567890) == "12345678901234567890"
    assert show(2.0) == "2"
    assert show(tuple(range(100))).endswith(", ...]")


def _shaper(body: str) -> ast.Block:
    (defn,) = parse(f"shaper t(M, N) {{\n{body}\n}}", "t.knit").items
    assert isinstance(defn, ast.ShaperDef)
    return defn.body


def _run_error(body: str, budget: int = 10_000_000) -> EvalError:
    with pytest.raises(EvalError) as info:
        Interpreter(words=(), budget=budget).run(_shaper(body))
    return info.value


def test_a_loop_over_a_range_beyond_the_machine_integers_is_the_budget():
    # len(range(10^300)) raised OverflowError (exit 3); the loop now fails on its length
    err = _run_error("for i in range(10^300) { }")
    assert err.code == "E316" and "1e+300 times" not in err.message


def test_len_and_indexing_of_a_huge_range():
    out = Interpreter(words=()).run(
        _shaper("let r = range(10^300)\nlet n = len(r)\nlet z = r[-1] == r[0]\nlet e = r == r")
    )
    assert out["n"] == 1e300 and out["z"] is False and out["e"] is True


def test_a_list_that_doubles_is_e320_where_it_is_built():
    # `[l, l]` 40 times: comparing or showing it walked 2^40 items (a hang)
    err = _run_error("let l = [0]\nfor i in range(40) { l = [l, l] }")
    assert err.code == "E320" and f"{LIST_ITEMS:,}" in err.message and err.span.line == 3


def test_lists_nested_too_deep_are_e320():
    # 5000 nested lists: comparing two of them was a RecursionError
    err = _run_error("let a = [1]\nfor i in range(5000) { a = [a] }\nlet z = a == a")
    assert err.code == "E320" and "100" in err.message


def test_comparing_big_lists_is_charged_to_the_budget():
    # 15 doublings is 65,534 items (under the limit); each comparison walks all of them
    body = "let l = [0]\nfor i in range(15) { l = [l, l] }\nfor i in range(100) { let z = l == l }"
    err = _run_error(body, budget=1_000_000)
    assert err.code == "E316"


def test_params_that_double_a_list_are_e320():
    params = "param p0 = [0]\n" + "".join(f"param p{i + 1} = [#p{i}, #p{i}]\n" for i in range(20))
    errs = _errors(params + SHEET)
    assert errs and all(code == "E320" for code, *_ in errs)


def test_the_shaper_runs_of_a_design_share_one_budget(monkeypatch):
    # 40 widths, each (M, N) run once, each under the budget of a run: together bounded
    import knitc.shaping.courses as courses

    monkeypatch.setattr(courses, "SHAPERS_BUDGET", 20_000)
    src = (
        "sheet a { length: 41  width: [0: 6, 1: 46]  shaper: s }\n"
        "shaper s(M, N) {\n  for i in range(1000) { }\n"
        "  for i in range(M) { if i < N - M { i -> (2 * i, 2 * i + 1) } else { i -> i + N - M } }\n}\n"
    )
    assert _errors(src) == [
        (
            "E316",
            "shaper `s` did not finish: the design's shaper programs may run 20,000 steps in all",
            3,
            3,
        )
    ]


def test_the_actions_of_a_design_share_one_budget(monkeypatch):
    # 10,000 steps per stitch's step is no bound over two million stitches
    import knitc.codegen.actions as codegen_actions

    monkeypatch.setattr(codegen_actions, "ACTIONS_BUDGET", 2_000)
    src = SHEET + "action x { main {\n  for i in range(100) { }\n  knit(dir)\n} }\n"
    src += "pattern a { use x }\n"
    errs = _errors(src, "machine")
    assert errs == [
        (
            "E316",
            "action `x` at f2: action `x` did not finish: "
            "the design's actions may run 2,000 steps in all",
            3,
            3,
        )
    ]


def test_a_needle_far_outside_the_machine_is_shown_short():
    src = SHEET + "action x { main { knit(dir, needle + 10^300) } }\n"
    src += "pattern a { use x where courses(2) and wales(3) }\n"
    ((code, message, _, _),) = _errors(src, "machine")
    assert code == "E722" and "needle f1e+300 is outside the machine" in message
