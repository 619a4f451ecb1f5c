"""The statement interpreter (`knitc.lang.interp`), driven through the real parser.

Every block is written as source inside `shaper t(M, N) { ... }` and run with
`Interpreter.run`, so these tests pin the semantics the designer sees: scoping of `let` and
assignment, `if / else if / else`, `for` over ranges and lists, host functions, mappings and
the step budget.
"""

from __future__ import annotations

import pytest

from knitc.frontend import ast
from knitc.frontend.parser import parse
from knitc.lang.evaluate import EvalError, Word
from knitc.lang.interp import DEFAULT_BUDGET, Host, Interpreter
from knitc.source import UNKNOWN_SPAN


def block_of(src: str) -> ast.Block:
    module = parse(f"shaper t(M, N) {{\n{src}\n}}", "t.knit")
    (defn,) = module.items
    assert isinstance(defn, ast.ShaperDef)
    return defn.body


def run(src: str, bindings=None, **kw) -> dict:
    kw.setdefault("words", ())
    return Interpreter(**kw).run(block_of(src), bindings)


def run_error(src: str, bindings=None, **kw) -> EvalError:
    with pytest.raises(EvalError) as info:
        run(src, bindings, **kw)
    return info.value


def line_of(err: EvalError) -> int:
    return err.span.line - 1  # the source starts on line 2 of the wrapper


# ---- let, assignment, scoping ----------------------------------------------------------------


def test_lists_of_booleans_are_not_lists_of_numbers():
    assert run(
        "let a = [1] == [true]\nlet b = range(2) == [0, true]\nlet c = range(2) == [0, 1]"
    ) == {
        "a": False,
        "b": False,
        "c": True,
    }


def test_let_and_assign():
    assert run("let x = 1\nx = x + 2\nlet y = x * 10") == {"x": 3, "y": 30}


def test_bindings_are_visible_and_returned():
    assert run("let d = N - M", {"M": 4, "N": 6}) == {"M": 4, "N": 6, "d": 2}


def test_assignment_updates_the_outer_binding():
    out = run("let s = 0\nfor i in range(5) { s = s + i }")
    assert out["s"] == 10


def test_let_in_a_block_does_not_leak():
    out = run("let x = 1\nif true { let x = 2\nlet y = 3 }")
    assert out == {"x": 1}


def test_let_in_a_block_shadows_then_assignment_hits_the_inner_one():
    out = run("let x = 1\nif true { let x = 2\nx = 5 }\nlet y = x")
    assert out == {"x": 1, "y": 1}


def test_let_rebinds_in_the_same_scope():
    assert run("let x = 1\nlet x = x + 1") == {"x": 2}


def test_let_inside_a_loop_is_fresh_each_iteration():
    out = run("let s = 0\nfor i in range(3) { let k = i * 2\ns = s + k }")
    assert out == {"s": 6}


def test_assignment_before_let():
    err = run_error("x = 1")
    assert err.code == "E222" and "`x`" in err.message and line_of(err) == 1


def test_assignment_to_a_block_local_after_the_block():
    err = run_error("if true { let x = 1 }\nx = 2")
    assert err.code == "E222" and line_of(err) == 2


def test_constants_are_readable_not_assignable():
    assert run("let n = needle + 1", constants={"needle": 4}) == {"n": 5}
    err = run_error("needle = 3", constants={"needle": 4})
    assert err.code == "E317"
    # but they can be shadowed by `let`
    assert run("let needle = 3\nneedle = needle + 1", constants={"needle": 4}) == {"needle": 4}


def test_unknown_name_with_suggestion():
    err = run_error("let count = 1\nlet y = cuont + 1")
    assert err.code == "E221" and "cuont" in err.message and "count" in (err.hint or "")


def test_words_when_allowed():
    assert run("let s = left", words=("left", "right")) == {"s": Word("left")}
    assert run("let s = anything", words=None) == {"s": Word("anything")}
    assert run_error("let s = up", words=("left",)).code == "E221"


# ---- if / else if / else --------------------------------------------------------------------


@pytest.mark.parametrize("x, expected", [(1, "a"), (5, "b"), (7, "c"), (9, "d")])
def test_else_if_chain(x, expected):
    src = """
let r = 0
if x < 3 { r = 1 } else if x < 6 { r = 2 } else if x == 7 { r = 3 } else { r = 4 }
"""
    out = run(src, {"x": x})
    assert out["r"] == {"a": 1, "b": 2, "c": 3, "d": 4}[expected]


def test_only_the_taken_branch_runs():
    calls = []
    run(
        "if true { f(1) } else { f(2) }\nif false { f(3) } else if true { f(4) } else { f(5) }",
        functions={"f": calls.append},
    )
    assert calls == [1, 4]


def test_if_needs_a_boolean():
    err = run_error("if 1 { }")
    assert err.code == "E303" and "boolean" in err.message


# ---- for -------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "expr, expected",
    [
        ("range(4)", [0, 1, 2, 3]),
        ("range(2, 5)", [2, 3, 4]),
        ("range(10, 0, -3)", [10, 7, 4, 1]),
        ("range(0)", []),
        ("range(3, 1)", []),
        ("[5, 1, 4]", [5, 1, 4]),
        ("[]", []),
        ("range(N / 2)", [0, 1, 2]),  # 6 / 2 is the whole number 3
    ],
)
def test_for_iterates(expr, expected):
    seen = []
    run(f"for i in {expr} {{ f(i) }}", {"N": 6}, functions={"f": seen.append})
    assert seen == expected


def test_nested_loops_and_loop_variable_scope():
    seen = []
    out = run(
        "for i in range(2) { for j in [i, i + 10] { f(i * 100 + j) } }",
        functions={"f": seen.append},
    )
    assert seen == [0, 10, 101, 111] and out == {}


def test_assigning_the_loop_variable_does_not_change_the_iteration():
    seen = []
    run("for i in range(3) { i = i * 10\nf(i) }", functions={"f": seen.append})
    assert seen == [0, 10, 20]


@pytest.mark.parametrize(
    "src, code",
    [
        ("for i in 3 { }", "E303"),
        ("for i in range(2.5) { }", "E303"),
        ("for i in range(0, 4, 0) { }", "E305"),
        ("for i in range() { }", "E304"),
        ("for i in range(1, 2, 3, 4) { }", "E304"),
    ],
)
def test_for_errors(src, code):
    assert run_error(src).code == code


def test_range_and_len_as_values():
    out = run(
        "let r = range(2, 6)\nlet n = len(r)\nlet x = r[1]\nlet m = len([1, 2, 3])"
        "\nlet same = range(3) == [0, 1, 2]\nlet differ = range(3) != [0, 1]"
    )
    assert out["n"] == 4 and out["x"] == 3 and out["m"] == 3
    assert out["same"] is True and out["differ"] is True


def test_builtins_see_locals():
    assert run("let a = 2.5\nlet b = round(a) + max(a, 7) + floor(a)")["b"] == 3 + 7 + 2


# ---- host functions --------------------------------------------------------------------------


def test_host_functions_positional_and_keyword():
    log = []
    run(
        "knit(dir, 3)\nxfer(1, to = 2)",
        words=("dir",),
        functions={
            "knit": lambda *a: log.append(("knit", a)),
            "xfer": lambda a, to: log.append(("xfer", a, to)),
        },
    )
    assert log == [("knit", (Word("dir"), 3)), ("xfer", 1, 2)]


def test_host_function_return_value():
    assert run("let x = twice(21)", functions={"twice": lambda v: 2 * v}) == {"x": 42}


def test_host_arity_is_checked():
    host = Host(lambda a, b: None, min_args=2, max_args=2)
    err = run_error("xfer(1)", functions={"xfer": host})
    assert err.code == "E304" and "2 argument" in err.message


def test_host_receives_the_call_span():
    spans = []
    run("let a = 1\nop(a)", functions={"op": Host(lambda a, span: spans.append(span), span=True)})
    assert len(spans) == 1 and spans[0].line == 3


def test_host_errors_are_located_at_the_call():
    def bad(x):
        raise EvalError("E330", "no such needle", UNKNOWN_SPAN)

    err = run_error("let a = 1\nop(a)", functions={"op": bad})
    assert err.code == "E330" and line_of(err) == 2


def test_unknown_function():
    err = run_error("knti(1)", functions={"knit": print})
    assert err.code == "E201" and "knit" in (err.hint or "")


def test_host_is_called_once_per_evaluation():
    n = []
    out = run("let x = [10, 20][count()]", functions={"count": lambda: n.append(1) or 1})
    assert out == {"x": 20} and len(n) == 1


# ---- mappings --------------------------------------------------------------------------------


def test_map_statements_go_to_the_callback():
    maps = []
    run(
        "for i in range(2) { i -> (2 * i, 2 * i + 1) }\n(0, 1) -> 5\n3 -> 4",
        on_map=lambda s, d, span: maps.append((s, d, span.line)),
    )
    assert maps == [(0, (0, 1), 2), (1, (2, 3), 2), ((0, 1), 5, 3), (3, 4, 4)]


def test_map_without_callback():
    assert run_error("1 -> 2").code == "E223"


# ---- hooks and the step budget ---------------------------------------------------------------


def test_param_hook_and_default_refusal():
    assert run("let x = #w + 1", param=lambda name, span: {"w": 9}[name]) == {"x": 10}
    assert run_error("let x = #w").code == "E301"


def test_evaluate_one_expression():
    interp = Interpreter(words=())
    e = block_of("let x = N - M").stmts[0].value
    assert interp.evaluate(e, {"M": 2, "N": 7}) == 5


def test_default_budget_is_ten_million():
    assert DEFAULT_BUDGET == 10_000_000


def test_runaway_loop_fails_before_starting():
    err = run_error("let s = 0\nfor i in range(10 ^ 12) { s = s + 1 }")
    assert err.code == "E316" and line_of(err) == 2
    assert "10,000,000 steps" in err.message


def test_nested_runaway_blames_the_longest_loop():
    src = "for i in range(50) {\n  for j in range(400) {\n    let k = i + j\n  }\n}"
    err = run_error(src, budget=2_000)
    assert err.code == "E316" and line_of(err) == 2 and "400" in (err.hint or "")


def test_budget_counts_statements_and_iterations():
    src = "for i in range(10) { let a = i }"  # 1 (for) + 10 iterations + 10 lets
    assert run(src, budget=21) == {}
    assert run_error(src, budget=20).code == "E316"


def test_each_run_has_its_own_budget():
    interp = Interpreter(words=(), budget=25)
    body = block_of("for i in range(10) { let a = i }")
    for _ in range(5):
        interp.run(body)


def test_errors_from_expressions_keep_their_codes():
    assert run_error("let x = 1 / 0").code == "E305"
    assert run_error("let x = [1, 2][5]").code == "E306"
    assert run_error("let x = 1 + true").code == "E303"


def test_length_of_a_range_is_len_also_beyond_the_machine_integers():
    # `len` of range(10^300) raises OverflowError in Python; `length` computes it
    from knitc.lang.interp import length

    for start in range(-4, 5):
        for stop in range(-4, 5):
            for step in (-3, -2, -1, 1, 2, 3):
                r = range(start, stop, step)
                assert length(r) == len(r), r
    assert length(range(10**300)) == 10**300
    assert length(range(0, 10**300, 10**299)) == 10


def test_a_step_pool_is_shared_by_the_runs_that_hold_it():
    # a shaper runs once per (M, N): a budget per run alone does not bound a design
    from knitc.lang.interp import StepPool

    pool = StepPool(250, "the design's shapers")
    block = block_of("for i in range(100) { }")
    first = Interpreter(words=(), pool=pool, budget=1000)
    first.run(block)
    first.run(block)  # 2 x 101 steps: 48 left
    assert pool.left == 250 - 2 * 101
    with pytest.raises(EvalError) as info:
        Interpreter(words=(), pool=pool, budget=1000).run(block)
    err = info.value
    assert err.code == "E316" and "250 steps in all" in err.message and line_of(err) == 1
