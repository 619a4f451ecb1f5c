"""Shapers (`knitc.shaping.shapers`): the predefined formulas of the original system, user
shaper programs, and the validator they share.

The table is the original system's verified output (seed-systems §1.6: "each target lists
its source"); the properties are checked over 1 <= M <= 200, M <= N <= 2M.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from knitc.frontend import ast
from knitc.frontend.parser import parse
from knitc.lang.evaluate import EvalError, round_half_up
from knitc.resources import stdlib_module
from knitc.shaping.shapers import (
    PREDEFINED,
    MappingError,
    mapping_from_pairs,
    predefined_wales,
    run_user_shaper,
    shape,
    wales_between,
)


def seq(text: str) -> list[int]:
    return [int(x) for x in text.split(",")]


TABLE = {
    "uniform": {
        (4, 5): "0,1,1,2,3",
        (4, 6): "0,0,1,2,2,3",
        (5, 7): "0,1,1,2,3,3,4",
        (10, 13): "0,1,1,2,3,4,4,5,6,7,8,8,9",
    },
    "center": {
        (4, 5): "0,1,2,2,3",
        (4, 6): "0,1,1,2,2,3",
        (5, 7): "0,1,2,2,3,3,4",
        (10, 13): "0,1,2,3,4,4,5,5,6,6,7,8,9",
    },
    # the table abbreviates with "…"; the elided stitches map straight up
    "left": {
        (4, 5): "0,0,1,2,3",
        (4, 6): "0,0,1,1,2,3",
        (5, 7): "0,0,1,1,2,3,4",
        (10, 13): "0,0,1,1,2,2,3,4,5,6,7,8,9",
    },
    "right": {
        (4, 5): "0,1,2,3,3",
        (4, 6): "0,1,2,2,3,3",
        (5, 7): "0,1,2,3,3,4,4",
        (10, 13): "0,1,2,3,4,5,6,7,7,8,8,9,9",
    },
    "sides": {
        (4, 5): "0,0,1,2,3",
        (4, 6): "0,0,1,2,3,3",
        (5, 7): "0,0,1,2,3,4,4",
        (10, 13): "0,0,1,1,2,3,4,5,6,7,8,9,9",
    },
}

sizes = st.integers(1, 200).flatmap(lambda m: st.tuples(st.just(m), st.integers(m, 2 * m)))


def check_valid(src: np.ndarray, M: int, N: int) -> None:
    """An independent statement of validity, on the src array alone."""
    assert src.shape == (N,) and src.dtype.kind == "i"
    if N:
        assert src[0] == 0 and src[-1] == M - 1
        steps = np.diff(src)
        assert ((steps == 0) | (steps == 1)).all()  # monotone, no stitch skipped
        assert np.bincount(src, minlength=M).max() <= 2


def mirror(src: np.ndarray, M: int) -> np.ndarray:
    return M - 1 - src[::-1]


# ---- the predefined shapers ------------------------------------------------------------------


@pytest.mark.parametrize(
    "name, M, N, expected",
    [(name, M, N, text) for name, row in TABLE.items() for (M, N), text in row.items()],
)
def test_verified_table(name, M, N, expected):
    assert shape(name, M, N).tolist() == seq(expected)
    assert len(seq(expected)) == N


@pytest.mark.parametrize("name", PREDEFINED)
@pytest.mark.parametrize("M", [0, 1, 2, 3, 7, 50, 201])
def test_equal_sizes_are_the_identity(name, M):
    assert shape(name, M, M).tolist() == list(range(M))


def _reference(name: str, M: int, N: int) -> list[int]:
    """The formulas of seed-systems §1.6 transliterated one stitch at a time, as the
    original ran them (mapTo / splitInto calls), with scalar round-half-up."""
    out = [-1] * N
    d = N - M

    def map_to(i, j):
        out[j] = i

    def split_into(i, j1, j2):
        out[j1] = out[j2] = i

    for i in range(M):
        if name == "uniform":
            r = N / M
            j1, j2 = round_half_up(i * r), round_half_up((i + 1) * r)
            map_to(i, j1) if j2 == j1 + 1 else split_into(i, j1, j1 + 1)
        elif name == "center":
            o1 = round_half_up(M / 2 - d / 2)
            o2 = o1 + d
            if i < o1:
                map_to(i, i)
            elif i < o2:
                split_into(i, o1 + 2 * (i - o1), o1 + 2 * (i - o1) + 1)
            else:
                map_to(i, i + d)
        elif name == "left":
            split_into(i, 2 * i, 2 * i + 1) if i < d else map_to(i, i + d)
        elif name == "right":
            o = M - d
            split_into(i, o + 2 * (i - o), o + 2 * (i - o) + 1) if i >= o else map_to(i, i)
        elif name == "sides":
            m1 = math.ceil(d / 2)
            m2 = d - m1
            n1 = 2 * m1
            j = M - 1 - i
            if i < m1:
                split_into(i, 2 * i, 2 * i + 1)
            elif j < m2:
                split_into(i, N - 1 - 2 * j, N - 2 - 2 * j)
            else:
                map_to(i, n1 + i - m1)
    assert -1 not in out
    return out


@settings(max_examples=300, deadline=None)
@given(sizes, st.sampled_from(PREDEFINED))
def test_predefined_are_valid_and_match_the_scalar_formulas(mn, name):
    M, N = mn
    src = shape(name, M, N)
    # the validator shared with user programs accepts the original's wales ...
    assert mapping_from_pairs(M, N, *predefined_wales(name, M, N)).tolist() == src.tolist()
    check_valid(src, M, N)
    # ... and the vectorised formulas agree with a stitch-by-stitch transliteration
    assert src.tolist() == _reference(name, M, N)


def test_uniform_rounds_in_floating_point_like_the_original():
    # 21 * (34 / 28) is 25.499999999999996 in doubles (exactly 25.5): the original, and knitc,
    # round it down, so stitch 21 splits rather than stitch 20.
    src = shape("uniform", 28, 34)
    assert src[24:28].tolist() == [20, 21, 21, 22]
    assert src.tolist() == _reference("uniform", 28, 34)


@settings(max_examples=300, deadline=None)
@given(sizes)
def test_left_and_right_are_mirror_images(mn):
    M, N = mn
    assert shape("right", M, N).tolist() == mirror(shape("left", M, N), M).tolist()


@settings(max_examples=300, deadline=None)
@given(sizes)
def test_center_is_symmetric_up_to_rounding(mn):
    M, N = mn
    c = shape("center", M, N)
    m = mirror(c, M)
    assert np.abs(c - m).max(initial=0) <= 1
    if (M - (N - M)) % 2 == 0:  # the increases can sit exactly in the middle
        assert c.tolist() == m.tolist()


@settings(max_examples=300, deadline=None)
@given(sizes)
def test_sides_is_symmetric_when_the_increases_are_even(mn):
    M, N = mn
    s = shape("sides", M, N)
    if (N - M) % 2 == 0:
        assert s.tolist() == mirror(s, M).tolist()
    # the left edge takes the odd increase
    splits = np.flatnonzero(np.bincount(s, minlength=M) == 2)
    left = int(np.sum(splits < M / 2))
    assert left == math.ceil((N - M) / 2)


def test_predefined_results_are_cached_and_read_only():
    a = shape("center", 30, 41)
    assert shape("center", 30, 41) is a
    with pytest.raises(ValueError):
        a[0] = 3


@pytest.mark.parametrize("M, N", [(4, 9), (5, 4), (-1, 0), (0, 1)])
def test_out_of_domain(M, N):
    with pytest.raises(ValueError, match="M <= N <= 2M"):
        shape("uniform", M, N)


def test_none_and_unknown_names():
    with pytest.raises(ValueError, match="grid wales"):
        shape("none", 4, 5)
    with pytest.raises(ValueError, match="not a predefined shaper"):
        shape("edges", 4, 5)


def test_wales_between_reads_decreases_backwards():
    src = shape("left", 4, 6)  # 0,0,1,1,2,3
    prev, nxt = wales_between(4, 6, src)
    assert list(zip(prev.tolist(), nxt.tolist())) == [
        (0, 0),
        (0, 1),
        (1, 2),
        (1, 3),
        (2, 4),
        (3, 5),
    ]
    prev, nxt = wales_between(6, 4, src)
    assert list(zip(prev.tolist(), nxt.tolist())) == [
        (0, 0),
        (1, 0),
        (2, 1),
        (3, 1),
        (4, 2),
        (5, 3),
    ]


# ---- the validator ---------------------------------------------------------------------------


@pytest.mark.parametrize(
    "M, N, small, large, needle, pair",
    [
        (2, 3, [0, 0, 2], [0, 1, 2], "outside the smaller course", 2),
        (2, 3, [0, 0, 1], [0, 1, 3], "outside the larger course", 2),
        (2, 3, [0, 0, 1, 1], [0, 1, 1, 2], "mapped twice", 2),
        (2, 3, [0, 1], [0, 2], "stitch 1 of the larger course is not mapped", None),
        (2, 4, [0, 0, 0, 1], [0, 1, 2, 3], "more than 2", 2),
        (3, 3, [0, 0, 2], [0, 1, 2], "stitch 1 of the smaller course maps nowhere", None),
        (2, 2, [0, 1], [1, 0], "wales cross", 1),
    ],
)
def test_validator_names_the_offending_wale(M, N, small, large, needle, pair):
    with pytest.raises(MappingError) as info:
        mapping_from_pairs(M, N, small, large)
    assert needle in info.value.message and info.value.pair == pair


def test_validator_accepts_any_order():
    assert mapping_from_pairs(3, 4, [2, 0, 1, 1], [3, 0, 2, 1]).tolist() == [0, 1, 1, 2]
    assert mapping_from_pairs(0, 0, [], []).tolist() == []


# ---- user shaper programs --------------------------------------------------------------------


def stdlib_shapers() -> dict[str, ast.ShaperDef]:
    module = parse(stdlib_module("std.shapers").read_text(encoding="utf-8"), "shapers.knit")
    return {d.name.name: d for d in module.items if isinstance(d, ast.ShaperDef)}


STD = stdlib_shapers()


def shaper_of(src: str) -> ast.ShaperDef:
    (d,) = parse(src, "t.knit").items
    assert isinstance(d, ast.ShaperDef)
    return d


def test_stdlib_defines_the_documented_shapers():
    assert set(STD) == {"zigzag", "edges"}


@settings(max_examples=200, deadline=None)
@given(sizes, st.sampled_from([0, 1]))
def test_zigzag_is_valid_and_alternates(mn, turn):
    M, N = mn
    src = shape(STD["zigzag"], M, N, turn=turn)
    check_valid(src, M, N)
    expected = shape("left" if turn == 0 else "right", M, N)
    assert src.tolist() == expected.tolist()


@settings(max_examples=200, deadline=None)
@given(
    st.integers(2, 200).flatmap(lambda m: st.tuples(st.just(m), st.integers(m, 2 * m - 2))),
    st.sampled_from([0, 1]),
)
def test_edges_is_valid_over_its_domain(mn, turn):
    M, N = mn  # documented domain: N - M <= M - 2
    src = shape(STD["edges"], M, N, turn=turn)
    check_valid(src, M, N)
    # the selvedge stitches map straight up, into one stitch each
    assert src[:2].tolist() == [0, 1] and src[-2:].tolist() == [M - 2, M - 1]


@settings(max_examples=200, deadline=None)
@given(sizes)
def test_two_edge_shapers_give_the_odd_increase_to_the_edge_turn_names(mn):
    # turn 1 is turn 0 seen in a mirror: the odd increase changes edge, nothing else does
    M, N = mn
    assert shape("sides", M, N, turn=1).tolist() == mirror(shape("sides", M, N), M).tolist()
    if N - M <= M - 2:
        assert (
            shape(STD["edges"], M, N, turn=1).tolist()
            == mirror(shape(STD["edges"], M, N), M).tolist()
        )


@settings(max_examples=300, deadline=None)
@given(sizes, st.floats(0, 1, exclude_max=True))
def test_uniform_with_a_phase_is_valid_and_keeps_its_spacing(mn, phase):
    M, N = mn
    src = shape("uniform", M, N, phase=phase)
    check_valid(src, M, N)
    # as many increases as without a phase, at most one apart from evenly spaced
    split = np.flatnonzero(np.bincount(src, minlength=M) == 2)
    assert split.size == N - M
    if split.size > 1:
        gaps = np.diff(split)
        assert gaps.max() - gaps.min() <= 1


def test_a_phase_moves_uniforms_increases_along_the_course():
    sites = {
        tuple(np.flatnonzero(np.bincount(shape("uniform", 20, 21, phase=p)) == 2))
        for p in (0.0, 0.25, 0.5, 0.75)
    }
    assert len(sites) == 4


def test_edges_outside_its_domain_is_a_located_error():
    with pytest.raises(EvalError) as info:
        shape(STD["edges"], 4, 8)
    assert info.value.code == "E319" and "M = 4, N = 8" in info.value.message


@pytest.mark.parametrize("M", [1, 2, 5, 40])
def test_user_shapers_identity(M):
    for d in STD.values():
        assert shape(d, M, M).tolist() == list(range(M))


def test_merges_describe_a_decrease_from_the_larger_course():
    dec = shaper_of("""shaper dec(M, N) {
  let d = N - M
  for i in range(M) {
    if i < d { (2 * i, 2 * i + 1) -> i } else { i + d -> i }
  }
}""")
    for M, N in [(4, 5), (4, 8), (10, 13), (7, 7)]:
        assert shape(dec, M, N).tolist() == shape("left", M, N).tolist()


def test_extra_parameters_take_defaults_and_see_m_and_n():
    d = shaper_of("""shaper off(M, N, k = N - M, unused = 3) {
  for i in range(M) { if i < k { i -> (2 * i, 2 * i + 1) } else { i -> i + k } }
}""")
    assert shape(d, 5, 7).tolist() == shape("left", 5, 7).tolist()


def test_design_parameters_reach_the_program():
    d = shaper_of("shaper p(M, N) { for i in range(M) { i -> i * #step } }")
    assert shape(d, 3, 3, param=lambda name, span: {"step": 1}[name]).tolist() == [0, 1, 2]
    with pytest.raises(EvalError) as info:
        shape(d, 3, 3)
    assert info.value.code == "E301"


def test_implicit_split_by_two_plain_maps_is_allowed():
    d = shaper_of("shaper two(M, N) { 0 -> 0\n0 -> 1\n1 -> 2 }")
    assert shape(d, 2, 3).tolist() == [0, 0, 1]


BAD = [
    # (program body, M, N, code, line of the error within the body or None = the name,
    #  text of the message)
    (
        "for i in range(M - 1) { i -> i }",
        3,
        3,
        "E319",
        None,
        "stitch 2 of the larger course is not mapped",
    ),
    ("0 -> 0\n1 -> 2\n2 -> 1", 3, 3, "E319", 3, "wales cross"),
    ("for i in range(M) { i -> i + 1 }", 3, 3, "E319", 1, "stitch 3 is outside the larger"),
    ("for i in range(M) { i - 1 -> i }", 3, 3, "E319", 1, "stitch -1 is outside the smaller"),
    ("for i in range(M) { i -> i }\n1 -> 1", 3, 3, "E319", 2, "mapped twice"),
    ("0 -> 0\n0 -> 1\n0 -> 2\n1 -> 3", 2, 4, "E319", 3, "more than 2"),
    ("0 -> 0\n2 -> 1\n2 -> 2", 3, 3, "E319", None, "stitch 1 of the smaller course maps"),
    (
        "for i in range(M) { i -> i / 2 }",
        3,
        3,
        "E318",
        1,
        "stitch indices (whole numbers), got 0.5",
    ),
    ("0 -> (0, 2)\n1 -> 1", 2, 3, "E318", 1, "neighbouring"),
    ("0 -> (0, 1, 2)", 1, 2, "E318", 1, "exactly two"),
    # (a statement starting with `(` cannot follow one ending in an expression: it would
    # continue it as a call, so the merge sits in a block)
    ("0 -> (0, 1)\nif true { (1, 2) -> 1 }", 2, 3, "E318", 2, "already splits"),
    ("(0, 1) -> (0, 1)", 2, 2, "E318", 1, "not both"),
    ("for i in range(M) { i -> true }", 2, 2, "E318", 1, "a boolean"),
    ("let s = 0\nfor i in range(10 ^ 9) { s = s + 1 }", 2, 2, "E316", 2, "did not finish"),
    ("for i in range(M) { i -> j }", 2, 2, "E221", 1, "unknown name `j`"),
]


@pytest.mark.parametrize("body, M, N, code, line, text", BAD)
def test_bad_user_shapers_give_located_errors(body, M, N, code, line, text):
    d = shaper_of(f"shaper bad(M, N) {{\n{body}\n}}")
    with pytest.raises(EvalError) as info:
        shape(d, M, N)
    err = info.value
    assert err.code == code and text in err.message, err.message
    if line is None:
        assert err.span == d.name.span
    else:
        assert err.span.line == line + 1


def test_infinite_loop_with_a_small_budget():
    d = shaper_of("shaper spin(M, N) {\nfor a in range(M) {\nfor b in range(10 ^ 6) { }\n}\n}")
    with pytest.raises(EvalError) as info:
        run_user_shaper(d, 3, 3, budget=100_000)
    assert info.value.code == "E316" and info.value.span.line == 3
    assert "shaper `spin`" in info.value.message


def test_shaper_without_m_and_n():
    d = shaper_of("shaper one(M) { 0 -> 0 }")
    with pytest.raises(EvalError) as info:
        shape(d, 1, 1)
    assert info.value.code == "E310" and info.value.span == d.name.span


def test_user_shaper_domain_is_checked_by_the_caller():
    with pytest.raises(ValueError):
        shape(STD["zigzag"], 5, 11)


def test_a_huge_mapped_index_is_located_not_an_overflow():
    from knitc.driver import compile_source

    src = (
        "shaper big(M, N) { for i in range(M) { i -> i + 10 ^ 30 } }\n"
        "tube t { length: 4  width: [0: 4, 1: 6]  shaper: big }\n"
    )
    r = compile_source(src, "big.knit", until="stitch-graph")
    assert [d.code for d in r.diagnostics] == ["E318"]
    assert r.diagnostics.sorted()[0].span.line == 1
