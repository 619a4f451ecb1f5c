"""Set operations on integer arrays (stitch, course, node and needle numbers), for the passes.

They are numpy's `unique`, `union1d` and `setdiff1d` for the arrays knitc has: integers or
booleans, never masked. Since numpy 2.3, `np.unique` without index or count outputs asks
`numpy.ma` whether its argument is masked, and so imports `numpy.ma` (6.5 ms) at its first
call in a process: a seventh of the time knitc's own modules take to import, paid by every
compile. These sort and compare in the same few numpy calls without that question.
`tests/test_arrays.py` holds them to numpy's functions and checks that a compile leaves
`numpy.ma` unimported.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from numpy.typing import ArrayLike


def unique(a: ArrayLike) -> np.ndarray:
    """`np.unique(a)`: the distinct values of `a`, flattened, in increasing order."""
    s = np.sort(np.asarray(a), axis=None)
    if s.dtype.kind not in "biu":  # (floats: NaN, which numpy's unique folds into one)
        return np.unique(s)
    if s.size > 1:
        keep = np.empty(s.size, dtype=bool)
        keep[0] = True
        np.not_equal(s[1:], s[:-1], out=keep[1:])
        s = s[keep]
    return s


def union(a: ArrayLike, b: ArrayLike) -> np.ndarray:
    """`np.union1d(a, b)`: the distinct values of both, in increasing order."""
    return unique(np.concatenate((np.ravel(a), np.ravel(b))))


def difference(a: ArrayLike, b: ArrayLike) -> np.ndarray:
    """`np.setdiff1d(a, b)`: the distinct values of `a` not in `b`, in increasing order."""
    u = unique(a)
    return u[np.isin(u, unique(b), assume_unique=True, invert=True)]
