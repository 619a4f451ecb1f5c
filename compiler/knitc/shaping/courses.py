"""The shaping pass's shared pieces: a built course (`Course`), the accumulator that
turns courses and wales into the stitch graph's arrays, ring geometry, and the state the
primitives read while they are built one after the other (`shaping.shape`)."""

from __future__ import annotations

from dataclasses import field

import numpy as np

from knitc import arrays
from knitc.diagnostics import Diagnostics
from knitc.frontend.skeleton import ItfId, PrimNode, Skeleton
from knitc.lang.evaluate import EvalError
from knitc.lang.interp import SHAPERS_BUDGET, StepPool
from knitc.records import record
from knitc.shaping import stitch_graph as sg

FRONT, BACK = 0, 1


@record
class Course:
    """A built course: stitch ids in yarn order with their bed and needle in the node frame."""

    id: int
    ids: np.ndarray
    side: np.ndarray
    needle: np.ndarray
    circular: bool
    collapsed: bool = False
    """A closed tube end: one stitch per needle pair, linked to both beds' loops."""

    @property
    def width(self) -> int:
        return int(self.ids.shape[0])

    def half(self, bed: int) -> np.ndarray:
        """Ids on one bed, in needle order (left to right)."""
        sel = self.side == bed
        ids, needles = self.ids[sel], self.needle[sel]
        return ids[np.argsort(needles, kind="stable")]

    def flat(self) -> np.ndarray:
        """All ids of a flat course, in needle order (left to right)."""
        return self.ids[np.argsort(self.needle, kind="stable")]

    def in_bed_order(self) -> np.ndarray:
        """The ids as they lie on the bed: a ring counter-clockwise (its yarn order), a flat
        course left to right (whichever way the yarn went), a flat course round a fold (an
        unfolded split's branch across the fold) along the fold, as it was laid out."""
        if self.circular or arrays.unique(self.side).size > 1:
            return self.ids
        return self.flat()

    @property
    def per_bed(self) -> int:
        return int(np.count_nonzero(self.side == FRONT)) if self.circular else self.width


@record
class Accumulator:
    """Accumulates courses and wales; `finish` turns them into the IR arrays."""

    node_names: list[str]
    spans: list
    rows: list[tuple[int, int, int, bool, int, int]] = field(default_factory=list)
    sides: list[np.ndarray] = field(default_factory=list)
    needles: list[np.ndarray] = field(default_factory=list)
    names: dict[int, tuple[str, ...]] = field(default_factory=dict)
    wale_src: list[np.ndarray] = field(default_factory=list)
    wale_dst: list[np.ndarray] = field(default_factory=list)
    n: int = 0

    def course(self, node: int, side, needle, circular: bool, kind: str, gauge: int) -> Course:
        side = np.asarray(side, dtype=np.int8)
        needle = np.asarray(needle, dtype=np.int32)
        count = int(side.shape[0])
        ids = np.arange(self.n, self.n + count, dtype=np.int32)
        cid = len(self.rows)
        self.rows.append((self.n, count, node, circular, sg.COURSE_KINDS.index(kind), gauge))
        self.sides.append(side)
        self.needles.append(needle)
        self.n += count
        return Course(cid, ids, side, needle, circular and count > 1)

    def wales(self, src, dst) -> None:
        src = np.asarray(src, dtype=np.int32)
        if src.size:
            self.wale_src.append(src)
            self.wale_dst.append(np.asarray(dst, dtype=np.int32))

    def name(self, course: Course, itf: ItfId) -> None:
        self.names[course.id] = self.names.get(course.id, ()) + (str(itf),)

    def finish(self) -> sg.StitchGraph:
        n = self.n
        table = np.array(self.rows, dtype=np.int64).reshape(-1, 6)
        start, length = table[:, 0].astype(np.int32), table[:, 1].astype(np.int32)
        n_courses = len(self.rows)
        course = np.repeat(np.arange(n_courses, dtype=np.int32), length)
        node_of_course = table[:, 2].astype(np.int32)
        circular = table[:, 3].astype(bool) & (length > 1)
        ids = np.arange(n, dtype=np.int32)
        first = start[course]
        end = first + length[course]
        cnext = ids + 1
        cprev = ids - 1
        last = cnext == end
        cnext[last] = np.where(circular[course[last]], first[last], sg.NONE)
        head = ids == first
        cprev[head] = np.where(circular[course[head]], end[head] - 1, sg.NONE)
        wale_next, wale_prev = sg.empty_pair(n), sg.empty_pair(n)
        if self.wale_src:
            s = np.concatenate(self.wale_src)
            d = np.concatenate(self.wale_dst)
            order = np.lexsort((d, s))
            _fill_slots(wale_next, s[order], d[order])
            order = np.lexsort((s, d))
            _fill_slots(wale_prev, d[order], s[order])
        empty8, empty32 = np.zeros(0, np.int8), np.zeros(0, np.int32)
        return sg.StitchGraph(
            node_names=self.node_names,
            spans=self.spans,
            node=node_of_course[course],
            course=course,
            side=np.concatenate(self.sides) if self.sides else empty8,
            needle=np.concatenate(self.needles) if self.needles else empty32,
            cprev=cprev.astype(np.int32),
            cnext=cnext.astype(np.int32),
            wale_prev=wale_prev,
            wale_next=wale_next,
            instr=np.zeros(n, np.uint8),
            action=np.full(n, -1, np.int16),
            span=node_of_course[course].copy(),
            course_start=start,
            course_len=length,
            course_node=node_of_course,
            course_circular=circular,
            course_kind=table[:, 4].astype(np.int8),
            course_gauge=table[:, 5].astype(np.int8),
            course_names=dict(self.names),
        )


def _fill_slots(pair: np.ndarray, key: np.ndarray, val: np.ndarray) -> None:
    """pair[key, slot] = val: slot 0 for a key's first value, 1 for its second."""
    if not key.size:
        return
    dup = np.zeros(key.shape, dtype=bool)
    dup[1:] = key[1:] == key[:-1]
    if np.any(dup[1:] & dup[:-1]):
        raise AssertionError("a stitch would get more than two wales")
    pair[key, dup.astype(np.int64)] = val


def ring(width: int, tubular: bool, offset: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """(side, needle) of ring positions 0.. of a course of `width` stitches per bed."""
    k = np.arange(width, dtype=np.int32)
    if not tubular:
        return np.zeros(width, np.int8), k + offset
    return (
        np.concatenate([np.zeros(width, np.int8), np.ones(width, np.int8)]),
        np.concatenate([k, k[::-1]]) + offset,
    )


def ring_index(side: np.ndarray, needle: np.ndarray, width: int, tubular: bool) -> np.ndarray:
    """Inverse of `ring`: ring positions of (side, needle) on a ring `width` per bed."""
    if not tubular:
        return needle.astype(np.int64)
    return np.where(side == FRONT, needle, 2 * width - 1 - needle).astype(np.int64)


def grid_wales(acc: Accumulator, a: Course, b: Course) -> None:
    """Wales between stitches on the same (bed, needle)."""
    for bed in (FRONT, BACK):
        sa, sb = a.side == bed, b.side == bed
        _common, ia, ib = np.intersect1d(a.needle[sa], b.needle[sb], return_indices=True)
        if ia.size:
            acc.wales(a.ids[sa][ia], b.ids[sb][ib])


@record
class ShapeState:
    skel: Skeleton
    acc: Accumulator
    diags: Diagnostics
    partner: dict[ItfId, ItfId]
    exit_course: dict[ItfId, Course] = field(default_factory=dict)
    user_maps: dict[tuple[str, int, int, int], np.ndarray] = field(default_factory=dict)
    shaper_steps: StepPool = field(
        default_factory=lambda: StepPool(SHAPERS_BUDGET, "the design's shaper programs")
    )
    """The steps every run of a user shaper in the design shares (`lang.interp.StepPool`)."""
    odd_changes: dict[tuple[str, int], int] = field(default_factory=dict)
    """(node, bed) -> how many of its course changes so far were by an odd number of stitches:
    the shapers' `turn` alternates with it (`shaping.shapers`)."""
    changes: dict[tuple[str, int], int] = field(default_factory=dict)
    """(node, bed) -> how many of its course changes so far changed the width at all:
    `uniform`'s phase moves with it."""
    yarn_end: dict[str, Course] = field(default_factory=dict)
    """The last course a node knitted (where its yarn is), for continuity walks."""
    failed: bool = False

    def param(self, name: str, span):
        """`#name` inside a user shaper: the resolved design parameter."""
        if name not in self.skel.params:
            raise EvalError("E403", f"unknown parameter `#{name}`", span)
        return self.skel.params[name]

    def gauge(self, node: PrimNode) -> int:
        return 2 if node.props["gauge"] == "half" else 1

    def tubular(self, node: PrimNode, path: str) -> bool:
        sides = self.skel.interfaces[ItfId(node.name, path)].sides
        if sides is None:
            return bool(node.tubular)
        return sides == 2


def incoming(state: ShapeState, node: PrimNode, path: str) -> Course | None:
    other = state.partner.get(ItfId(node.name, path))
    return state.exit_course.get(other) if other is not None else None


def span_of(state: ShapeState, node: PrimNode, course: Course) -> int:
    return course.per_bed * state.gauge(node)


def spread_wales(acc: Accumulator, a: Course, b: Course) -> None:
    """Bind two courses of different sizes: each stitch of the smaller course takes up to
    two consecutive stitches of the larger one (the original's spread with factor = the
    size ratio, capped at two so every link stays an increase or a decrease).

    The groups start at the course's first stitch. The original started a pair one stitch
    earlier (`round(-f / 2)`), which wraps round the course: on a flat course the first
    stitch took the last one's loop, a wale across the whole piece, and on a ring every pair
    at a fold straddled it, so the finer ring had to be laid out rotated against the coarser
    one (wristband2 slid 6-7 needles at each gauge change).

    Both courses are read in bed order (`Course.in_bed_order`), not yarn order: a flat
    course knitted right to left bound in yarn order to a ring would be mirrored, its right
    end continuing at the ring's front left, which no transfers can make."""
    m, n = a.width, b.width
    a_ids, b_ids = a.in_bed_order(), b.in_bed_order()
    if m == n:
        acc.wales(a_ids, b_ids)
        return
    small, large = (a_ids, b_ids) if m < n else (b_ids, a_ids)
    f = min(max(large.size // small.size, 1), 2)
    k = np.arange(small.size * f)
    big = k % large.size
    sml = k // f
    # keep each large stitch at most once
    _, first = np.unique(big, return_index=True)
    big, sml = big[np.sort(first)], sml[np.sort(first)]
    if m < n:
        acc.wales(small[sml], large[big])
    else:
        acc.wales(large[big], small[sml])


def course_columns(course: Course, per_bed: int, tubular: bool) -> np.ndarray:
    """Ring positions of a course's stitches (in its yarn order), ignoring its offset."""
    needle = course.needle - (int(course.needle.min()) if course.width else 0)
    return ring_index(course.side, needle, per_bed, tubular)


def in_yarn_order(course: Course, tubular: bool) -> np.ndarray:
    """A producer's course ids ordered like `ring` lays positions (front L→R, back R→L); a
    flat course in bed order (`Course.in_bed_order`)."""
    if not tubular:
        return course.in_bed_order()
    return np.concatenate([course.half(FRONT), course.half(BACK)[::-1]])


def branch_frame(base: Course, per_bed: int, tubular: bool) -> Course:
    """The base course re-expressed in ring positions 0.. (its own needles may be offset)."""
    ids = in_yarn_order(base, tubular)
    side, needle = ring(per_bed, tubular)
    return Course(base.id, ids, side, needle, tubular)
