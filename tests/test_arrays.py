"""`knitc.arrays` against numpy's set operations, and what it is for: a compile that never
imports `numpy.ma` (6.5 ms of start-up, see the module's docstring)."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
from hypothesis import given
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from knitc import arrays

REPO = Path(__file__).resolve().parent.parent

_INTS = hnp.arrays(
    dtype=st.sampled_from([np.int32, np.int64, np.uint8, np.bool_]),
    shape=hnp.array_shapes(min_dims=0, max_dims=2, min_side=0, max_side=6),
)
_SMALL = hnp.arrays(
    dtype=st.sampled_from([np.int32, np.int64]),
    shape=hnp.array_shapes(min_dims=0, max_dims=2, min_side=0, max_side=6),
    elements=st.integers(-4, 4),
)


def _same(a: np.ndarray, b: np.ndarray) -> None:
    assert a.dtype == b.dtype and a.shape == b.shape
    assert np.array_equal(a, b, equal_nan=a.dtype.kind == "f")


@given(_INTS)
def test_unique_is_numpys(a):
    _same(arrays.unique(a), np.unique(a))


@given(hnp.arrays(np.float64, st.integers(0, 8), elements=st.sampled_from([0.0, 1.5, np.nan])))
def test_unique_of_floats_is_numpys(a):
    _same(arrays.unique(a), np.unique(a))


@given(_SMALL, _SMALL)
def test_union_and_difference_are_numpys(a, b):
    _same(arrays.union(a, b), np.union1d(a, b))
    _same(arrays.difference(a, b), np.setdiff1d(a, b))


def test_a_compile_does_not_import_numpy_ma():
    """Each design's compile, in a fresh process, leaves `numpy.ma` out of `sys.modules`
    (unless the design needs scipy, which imports it itself: the sweater's shaping)."""
    code = (
        "import sys\n"
        "from knitc.driver import compile_file\n"
        "compile_file(sys.argv[1], until='machine')\n"
        "print('numpy.ma' in sys.modules and 'scipy' not in sys.modules)\n"
    )
    env = {k: v for k, v in os.environ.items() if k != "KNITC_VERIFY"}  # (a plain compile:
    # the IR verifiers that --verify-each adds take rows of arrays apart with numpy's unique)
    for path in sorted((REPO / "examples").rglob("*.knit")):
        run = subprocess.run(
            [sys.executable, "-c", code, str(path)],
            capture_output=True,
            text=True,
            check=True,
            env=env,
        )
        assert run.stdout.strip() == "False", path
