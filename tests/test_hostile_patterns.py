"""Pattern layers that blow up: `let` chains and `apply` trees are bounded, never a crash.

Issue 14's "deep nesting" and "blow-ups" classes in the pattern pass: a `let` that names
itself through an earlier binding was a RecursionError; forty `let`s each naming the one
before twice were evaluated 2^40 times (a hang); a definition applying the next one twice,
30 deep, expanded 2^30 times within the depth limit. The work is bounded by counts (calls
of the evaluator, applications), not by a clock.
"""

from __future__ import annotations

import pytest

from knitc.driver import compile_source
from knitc.patterning import pattern, query
from knitc.shaping.stitch_graph import INSTRUCTIONS

SHEET = "sheet a { width: 10  length: 10 }\n"


def _compile(body: str, defs: str = ""):
    return compile_source(
        SHEET + defs + f"pattern a {{\n{body}\n}}\n", "t.knit", until="stitch-graph"
    )


def _errors(r) -> list[tuple[str, str, int]]:
    return [(d.code, d.message, d.span.line) for d in r.diagnostics if d.is_error]


def _purls(r) -> int:
    return int((r.graph.instr == INSTRUCTIONS.index("P")).sum())


def _chain(n: int, op: str = "or", first: str = "courses(0)") -> str:
    lets = " ".join(f"let s{i + 1} = s{i} {op} s{i}" for i in range(n))
    return f"let s0 = {first} {lets}"


@pytest.fixture
def query_calls(monkeypatch) -> list[int]:
    """How many selections the evaluator computes (`_Eval._query` and `_Eval._frame`)."""
    calls = [0]
    for name in ("_query", "_frame"):
        inner = getattr(query._Eval, name)

        def counted(self, q, _inner=inner):
            calls[0] += 1
            return _inner(self, q)

        monkeypatch.setattr(query._Eval, name, counted)
    return calls


def test_a_let_that_names_its_earlier_binding_grows_it():
    # `s` in the second `let` looked up the second `let` itself: a RecursionError (exit 3)
    r = _compile("let s = courses(0)\nlet s = s or wales(0)\nset P where s")
    assert not _errors(r)
    assert _purls(r) == 10 + 10 - 1


def test_each_let_is_evaluated_once_per_query(query_calls):
    # forty doublings were 2^40 evaluations of `courses(0)`
    r = _compile(_chain(40) + " set P where s40")
    assert not _errors(r) and _purls(r) == 10
    assert query_calls[0] < 200


def test_frames_of_lets_are_evaluated_once_per_query(query_calls):
    r = _compile(_chain(40, "and", "wale_grid()") + ' tile """\nP .\n""" where s40')
    assert not _errors(r) and _purls(r) == 50
    assert query_calls[0] < 400


def test_a_let_chain_up_to_the_limit_evaluates_without_python_recursion_trouble():
    # 99 levels of `let`s nest 199 selections: under MAX_NESTING, and far from Python's stack
    assert query.MAX_NESTING == 200
    r = _compile(_chain(99) + " set P where s99")
    assert not _errors(r) and _purls(r) == 10


@pytest.mark.parametrize(
    "chain",
    [
        _chain(400),
        _chain(400, "and", "wale_grid()"),
        _chain(0) + " " + " ".join(f"let s{i + 1} = s{i}.neighbors(1)" for i in range(400)),
    ],
    ids=["or", "frames", "neighbors"],
)
def test_a_let_chain_beyond_the_limit_is_e708_at_the_selection(chain: str):
    last = "s400"
    r = _compile(chain + f"\nset P where {last}")
    assert _errors(r) == [
        (
            "E708",
            "this selection nests more than 200 levels deep, counting the `let`s it names",
            4,
        )
    ]


def test_a_tree_of_applies_is_e707_once_it_has_applied_the_limit(monkeypatch):
    defs = "".join(f"pattern p{i}() {{ apply p{i + 1}() apply p{i + 1}() }}\n" for i in range(30))
    defs += "pattern p30() { set P }\n"
    monkeypatch.setattr(pattern, "MAX_APPLIES", 500)  # the bound, not its size, is the point
    runs: list[pattern._Run] = []
    real = pattern._Run.__post_init__

    def keep(self):
        runs.append(self)
        real(self)

    monkeypatch.setattr(pattern._Run, "__post_init__", keep)
    r = _compile("apply p0()", defs)
    assert _errors(r) == [("E707", "the design applies patterns more than 500 times", 34)]
    # past the limit, an `apply` returns before expanding: only the statements left in the
    # definitions being expanded (two per level) are still visited
    assert runs[0].applied <= 500 + 2 * pattern.MAX_DEPTH
