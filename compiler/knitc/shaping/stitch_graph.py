"""The stitch graph IR: every stitch, its course and wale connections (thesis ch. 3.3.2).

Stored as parallel numpy arrays, not Python objects, so a garment of a million stitches is a
few tens of megabytes and passes can be vectorised. Stitch ids are dense (0..N-1) and every
course owns a contiguous id range, in knitting-schedule order, so "earlier course" means
"knitted earlier" and a course is a slice.

Conventions:
- course order within a course is the yarn order: flat courses run left to right on their
  bed; tubular courses run left to right on the front bed, then right to left on the back
  (counter-clockwise seen from above), and are cyclic;
- `wale_prev` / `wale_next` hold up to two ids each (-1 = none): an increase is one stitch
  with two next wales, a decrease one stitch with two previous wales;
- `instr` holds the pattern instruction (index into `INSTRUCTIONS`, 0 = K), `action` a stitch
  action id (-1 = the instruction's own lowering), `origin` the pattern statement that wrote them (for diagnostics).
"""

from __future__ import annotations

from dataclasses import field
from typing import Any

import numpy as np

from knitc.records import record
from knitc.source import Span

INSTRUCTIONS = (
    "K",
    "P",
    "T",
    "M",
    "FR1",
    "FR2",
    "FL1",
    "FL2",
    "BR1",
    "BR2",
    "BL1",
    "BL2",
    "XR+",
    "XR-",
    "XL+",
    "XL-",
    "S",
)
"""The 17 pattern instructions of thesis ch. 4.2, in the order of the original alphabet."""

COURSE_KINDS = ("regular", "short_row", "continuity", "interface")

BACKINGS = (
    "none",
    "float",
    "tubular",
    "birdseye",
    "pique",
    "horizontal",
    "vertical",
    "intarsia",
)
"""How the yarns of a course of several knit the stitches they do not show on (`backing
KIND where q`; thesis ch. 6.9.5, Fig. 6-44): `float` as fair isle, behind the front
stitches; from `tubular` to `vertical` (jacquard) they knit on the other bed, each back
needle by the yarns the kind chooses (`codegen.backing`); `intarsia` (`intarsia where q`,
ch. 6.9.6): they do not pass there at all, each region of one yarn has its own carrier."""

TWO_BED = BACKINGS.index("tubular")
"""Backings from this index up to `INTARSIA` knit on the other bed."""

INTARSIA = BACKINGS.index("intarsia")
JACQUARD = BACKINGS[TWO_BED:INTARSIA]
"""The two-bed backings' names."""


def two_bed(backing: np.ndarray) -> np.ndarray:
    """Per stitch: whether its backing is a jacquard one, knitted on the other bed."""
    return (backing >= TWO_BED) & (backing < INTARSIA)


NONE = -1


@record
class StitchGraph:
    """Stitches as arrays; courses as contiguous id ranges. See the module docstring."""

    node_names: list[str]
    spans: list[Span]
    # per stitch
    node: np.ndarray  # int32: index into node_names
    course: np.ndarray  # int32: course id
    side: np.ndarray  # int8: 0 front, 1 back
    needle: np.ndarray  # int32: needle index hint within the node's layout
    cprev: np.ndarray  # int32: previous stitch along the yarn order of the course
    cnext: np.ndarray  # int32: next stitch along the course
    wale_prev: np.ndarray  # int32 (N, 2)
    wale_next: np.ndarray  # int32 (N, 2)
    instr: np.ndarray  # uint8
    action: np.ndarray  # int16
    span: np.ndarray  # int32: index into spans (the declaration that made the stitch)
    # per course
    course_start: np.ndarray  # int32
    course_len: np.ndarray  # int32
    course_node: np.ndarray  # int32
    course_circular: np.ndarray  # bool
    course_kind: np.ndarray  # int8: index into COURSE_KINDS
    course_gauge: np.ndarray  # int8: 1 full, 2 half
    course_names: dict[int, tuple[str, ...]] = field(default_factory=dict)
    """Interface names of a course, e.g. ("cuff.bottom",) or ("palm.top", "hand.base")."""
    origin: np.ndarray | None = None
    """int32 per stitch: index into `spans` of the pattern statement that last wrote the
    stitch's `instr` or `action` (-1: none). Pattern warnings point at that line, not at the
    node the stitch belongs to. A statement inside applied definitions is kept as its span
    with the `apply` statements it was expanded from as parents (`Span.parent`), so a
    warning can point at the designer's line with notes into the definitions
    (`diagnostics.at_designer`)."""

    yarn: np.ndarray | None = None
    """int8 per stitch: the yarn that knits it, an index into `yarn_names` (0: the design's
    own yarn, `main`); set by `knit YARN where ...` pattern statements."""
    yarn_names: tuple[str, ...] = ("main",)
    yarn_origin: np.ndarray | None = None
    """int32 per stitch: index into `spans` of the `knit YARN` statement that gave the
    stitch its yarn (-1: none); a fair isle yarn's knits point at it."""

    backing: np.ndarray | None = None
    """int8 per stitch: its course's jacquard backing, an index into `BACKINGS` (0: none);
    set by `backing KIND where ...` pattern statements. None when no statement sets one."""
    backing_origin: np.ndarray | None = None
    """int32 per stitch: index into `spans` of the `backing` statement that set its backing
    (-1: none): the backing's ops point at it."""
    inlay: np.ndarray | None = None
    """int8 per stitch: the inlay yarn laid into its course over it (an index into
    `yarn_names`, 0: none); set by `knit YARN where ...` for a yarn with `inlay`. None when
    no statement lays one."""
    inlay_origin: np.ndarray | None = None
    """int32 per stitch: index into `spans` of the `knit` statement that laid its inlay."""

    def __post_init__(self) -> None:
        if self.origin is None:
            self.origin = np.full(self.node.shape[0], NONE, np.int32)
        if self.yarn is None:
            self.yarn = np.zeros(self.node.shape[0], np.int8)

    @property
    def colourwork(self) -> bool:
        """Whether any stitch is knitted with another yarn than `main`."""
        assert self.yarn is not None
        return bool(self.yarn.any())

    def course_yarn(self) -> np.ndarray:
        """int8 per course: the yarn that carries it (its stitches' yarn). In a course of
        several yarns (fair isle) it is the yarn that carried the node's course before, if
        it knits here too, so a band does not hand the course from yarn to yarn; else the
        one knitting most of it (the lowest on a tie). The others float behind and knit
        their own stitches in passes of their own. An intarsia course (`backing`
        INTARSIA) is carried by no yarn of the design: it is `len(yarn_names)`, a yarn of
        its own for the tracer and the stripes pass, so the yarn of the courses below it
        rests at the side meanwhile (each region has a carrier of its own,
        `shaping.intarsia`)."""
        assert self.yarn is not None
        out = self.yarn[self.course_start].copy() if self.n_stitches else self.yarn[:0]
        first = np.repeat(out, self.course_len)
        mixed = np.zeros(self.n_courses, bool)
        mixed[self.course[self.yarn != first]] = True
        last: dict[int, int] = {}  # node -> the yarn of its last course
        for c in range(self.n_courses):
            node = int(self.course_node[c])
            if mixed[c]:
                counts = np.bincount(self.yarn[self.course_ids(c)])
                before = last.get(node, -1)
                keep = 0 <= before < counts.size and counts[before] > 0
                out[c] = before if keep else int(np.argmax(counts))
            if self.course_len[c]:
                last[node] = int(out[c])
        band = self.intarsia_courses()
        if band.any():
            out[band] = len(self.yarn_names)
        return out

    def intarsia_courses(self) -> np.ndarray:
        """bool per course: an intarsia course, one with a stitch an `intarsia` statement
        selected and stitches of more than one yarn (on one yarn there is nothing for the
        regions to keep apart: it is knitted as any course)."""
        out = np.zeros(self.n_courses, bool)
        if self.backing is None or self.yarn is None or self.n_stitches == 0:
            return out
        out[self.course[self.backing == INTARSIA]] = True
        first = np.repeat(self.yarn[self.course_start], self.course_len)
        several = np.zeros(self.n_courses, bool)
        several[self.course[self.yarn != first]] = True
        return out & several

    def node_courses(self) -> np.ndarray:
        """int64 per course: its index among its node's courses in knitting order (a
        backing's course count, and an intarsia round's direction, start at the node's
        first course; another node's courses knitted between do not count)."""
        seen: dict[int, int] = {}
        out = np.zeros(self.n_courses, np.int64)
        for c, node in enumerate(self.course_node.tolist()):
            out[c] = seen.get(node, 0)
            seen[node] = out[c] + 1
        return out

    @property
    def n_stitches(self) -> int:
        return int(self.node.shape[0])

    @property
    def n_courses(self) -> int:
        return int(self.course_start.shape[0])

    def course_ids(self, c: int) -> np.ndarray:
        s = int(self.course_start[c])
        return np.arange(s, s + int(self.course_len[c]), dtype=np.int32)

    def stats(self) -> dict[str, Any]:
        counts = np.bincount(self.instr, minlength=len(INSTRUCTIONS))
        return {
            "stitches": self.n_stitches,
            "courses": self.n_courses,
            "nodes": len(self.node_names),
            "instructions": {INSTRUCTIONS[i]: int(c) for i, c in enumerate(counts) if c},
        }


def empty_pair(n: int) -> np.ndarray:
    return np.full((n, 2), NONE, dtype=np.int32)


# ---- verifier ---------------------------------------------------------------------------------


def verify(g: StitchGraph) -> list[str]:
    """Structural invariants; returns human-readable violations (empty = valid).

    These are compiler invariants, not designer mistakes: a violation is an internal error.
    """
    problems: list[str] = []
    n = g.n_stitches
    ids = np.arange(n, dtype=np.int32)

    # Courses tile the id space contiguously and agree with the per-stitch course array.
    ends = g.course_start + g.course_len
    if g.n_courses and (
        g.course_start[0] != 0 or ends[-1] != n or np.any(g.course_start[1:] != ends[:-1])
    ):
        problems.append("courses do not tile the stitch ids contiguously")
    expected = np.repeat(np.arange(g.n_courses, dtype=np.int32), g.course_len)
    if expected.shape != g.course.shape or np.any(expected != g.course):
        problems.append("per-stitch course ids disagree with the course table")
        return problems

    # Course neighbours: prev/next are mutual, stay within the course, and form a path or cycle.
    for name, arr, other in (("cnext", g.cnext, g.cprev), ("cprev", g.cprev, g.cnext)):
        has = arr >= 0
        if np.any(arr[has] >= n):
            problems.append(f"{name} points outside the graph")
            continue
        if np.any(other[arr[has]] != ids[has]):
            bad = int(ids[has][other[arr[has]] != ids[has]][0])
            problems.append(f"course links of stitch {bad} are not mutual")
        if np.any(g.course[arr[has]] != g.course[has]):
            problems.append(f"{name} links stitches of different courses")

    # Wales: mutual, forward in knitting time, at most two each way, 1->2 and 2->1 only.
    for name, fwd, back in (
        ("wale_next", g.wale_next, g.wale_prev),
        ("wale_prev", g.wale_prev, g.wale_next),
    ):
        src, slot = np.nonzero(fwd >= 0)
        dst = fwd[src, slot]
        if np.any(dst >= n):
            problems.append(f"{name} points outside the graph")
            continue
        mutual = (back[dst, 0] == src) | (back[dst, 1] == src)
        if not np.all(mutual):
            problems.append(f"{name} of stitch {int(src[~mutual][0])} is not mutual")
        if name == "wale_next" and np.any(g.course[dst] <= g.course[src]):
            bad = int(src[g.course[dst] <= g.course[src]][0])
            problems.append(f"wale of stitch {bad} does not go forward in knitting time")
    n_next = (g.wale_next >= 0).sum(axis=1)
    n_prev = (g.wale_prev >= 0).sum(axis=1)
    inc = np.nonzero(n_next == 2)[0]
    if inc.size and np.any(n_prev[g.wale_next[inc].ravel()] != 1):
        problems.append("an increase child has more than one previous wale (2->2 link)")
    dec = np.nonzero(n_prev == 2)[0]
    if dec.size and np.any(n_next[g.wale_prev[dec].ravel()] != 1):
        problems.append("a decrease parent has more than one next wale (2->2 link)")
    for arr in (g.wale_next, g.wale_prev):
        dup = (arr[:, 0] >= 0) & (arr[:, 0] == arr[:, 1])
        if np.any(dup):
            problems.append(f"stitch {int(ids[dup][0])} lists the same wale twice")
    if (
        g.yarn is not None
        and g.yarn.size
        and (int(g.yarn.min()) < 0 or int(g.yarn.max()) >= len(g.yarn_names))
    ):
        problems.append("a stitch's yarn is not one of the graph's yarns")
    if g.inlay is not None and (
        g.inlay.shape != (n,)
        or (n and (int(g.inlay.min()) < 0 or int(g.inlay.max()) >= len(g.yarn_names)))
    ):
        problems.append("the inlay array is not one of the graph's yarns per stitch")
    if g.backing is not None:
        if g.backing.shape != (n,):
            problems.append("the backing array is not one value per stitch")
        elif n and (int(g.backing.min()) < 0 or int(g.backing.max()) >= len(BACKINGS)):
            problems.append("a stitch's backing is not one of BACKINGS")
    return problems


# ---- stable JSON --------------------------------------------------------------------------


def to_json(g: StitchGraph, *, stitches: bool = True) -> dict[str, Any]:
    """The dump of `knitc --emit stitch-graph`: stats first, then courses and stitches."""
    out: dict[str, Any] = {"stats": g.stats(), "nodes": list(g.node_names)}
    out["courses"] = [
        {
            "id": c,
            "node": g.node_names[int(g.course_node[c])],
            "start": int(g.course_start[c]),
            "len": int(g.course_len[c]),
            "circular": bool(g.course_circular[c]),
            "kind": COURSE_KINDS[int(g.course_kind[c])],
            "gauge": int(g.course_gauge[c]),
            **({"names": list(g.course_names[c])} if c in g.course_names else {}),
        }
        for c in range(g.n_courses)
    ]
    if stitches:

        def pairs(a: np.ndarray) -> list[list[int]]:
            return [[int(x) for x in row if x >= 0] for row in a]

        wn, wp = pairs(g.wale_next), pairs(g.wale_prev)
        assert g.origin is not None and g.yarn is not None  # filled in by __post_init__
        out["stitches"] = [
            {
                "id": i,
                "course": int(g.course[i]),
                "pos": i - int(g.course_start[int(g.course[i])]),
                "side": int(g.side[i]),
                "needle": int(g.needle[i]),
                "prev": int(g.cprev[i]),
                "next": int(g.cnext[i]),
                "wale_prev": wp[i],
                "wale_next": wn[i],
                "instr": INSTRUCTIONS[int(g.instr[i])],
                "action": int(g.action[i]),
                "span": g.spans[int(g.span[i])].to_json(),
                **({"origin": g.spans[int(g.origin[i])].to_json()} if g.origin[i] >= 0 else {}),
                **({"yarn": g.yarn_names[int(g.yarn[i])]} if g.yarn[i] else {}),
                **(
                    {"backing": BACKINGS[int(g.backing[i])]}
                    if g.backing is not None and g.backing[i]
                    else {}
                ),
                **(
                    {"inlay": g.yarn_names[int(g.inlay[i])]}
                    if g.inlay is not None and g.inlay[i]
                    else {}
                ),
            }
            for i in range(g.n_stitches)
        ]
    return out
