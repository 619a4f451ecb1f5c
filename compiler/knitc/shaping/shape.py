"""Shaping: skeleton → stitch graph (thesis ch. 5.2 and 5.4.1).

Each primitive, in the order and direction chosen by `flow.schedule_nodes`, becomes a run
of courses appended in knitting order, so stitch ids grow with time and every course is a
contiguous id range (see `shaping.stitch_graph`). Geometry lives in one frame per node: a course
is a list of (bed, needle) positions in yarn order; tubular courses are rings read
counter-clockwise (front left to right, back right to left, thesis ch. 6.6), flat courses
alternate direction.

- sheets and tubes: widths sampled from the profile at t = c / (length - 1) and rounded
  half up; consecutive courses linked by the node's shaper, front and back halves apart;
- connections: equal sizes share one course; equal needle spans in different gauges (and
  other mismatches) are spread, as the original did; closed ends collapse the back bed
  onto the front;
- joints: short rows centred on the layout column, with the original's direct and
  continuity bindings (extra stitches that carry the yarn to the next row) and grid wales;
- splits: branches laid side by side on the base ring; merges add a continuity course that
  carries the yarn from the last branch to the start of the base.

Work is vectorised per course; only joints and continuity walks loop in Python, over
columns of one node.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import cast

import numpy as np

from knitc.diagnostics import Diagnostics, Note
from knitc.frontend.skeleton import ItfId, PrimNode, Skeleton, binding
from knitc.lang.evaluate import EvalError, Profile, round_half_up
from knitc.shaping import stitch_graph as sg
from knitc.shaping.node_order import NodeVisit, schedule_nodes
from knitc.shaping.shapers import MappingError, wales_between
from knitc.shaping.shapers import shape as shaper_map

FRONT, BACK = 0, 1
GOLDEN = (5**0.5 - 1) / 2
"""Step of `uniform`'s phase between changes: successive phases fill [0, 1) evenly."""
PREDEFINED = ("uniform", "center", "left", "right", "sides")


@dataclass
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
        if self.circular or np.unique(self.side).size > 1:
            return self.ids
        return self.flat()

    @property
    def per_bed(self) -> int:
        return int(np.count_nonzero(self.side == FRONT)) if self.circular else self.width


@dataclass
class _Acc:
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


# ---- ring geometry -----------------------------------------------------------------------


def ring(width: int, tubular: bool, offset: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """(side, needle) of ring positions 0.. of a course of `width` stitches per bed."""
    k = np.arange(width, dtype=np.int32)
    if not tubular:
        return np.zeros(width, np.int8), k + offset
    return (
        np.concatenate([np.zeros(width, np.int8), np.ones(width, np.int8)]),
        np.concatenate([k, k[::-1]]) + offset,
    )


def _ring_index(side: np.ndarray, needle: np.ndarray, width: int, tubular: bool) -> np.ndarray:
    """Inverse of `ring`: ring positions of (side, needle) on a ring `width` per bed."""
    if not tubular:
        return needle.astype(np.int64)
    return np.where(side == FRONT, needle, 2 * width - 1 - needle).astype(np.int64)


def _grid_wales(acc: _Acc, a: Course, b: Course) -> None:
    """Wales between stitches on the same (bed, needle)."""
    for bed in (FRONT, BACK):
        sa, sb = a.side == bed, b.side == bed
        _common, ia, ib = np.intersect1d(a.needle[sa], b.needle[sb], return_indices=True)
        if ia.size:
            acc.wales(a.ids[sa][ia], b.ids[sb][ib])


# ---- the pass --------------------------------------------------------------------------------


@dataclass
class _State:
    skel: Skeleton
    acc: _Acc
    diags: Diagnostics
    partner: dict[ItfId, ItfId]
    exit_course: dict[ItfId, Course] = field(default_factory=dict)
    user_maps: dict[tuple[str, int, int, int], np.ndarray] = field(default_factory=dict)
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


def build_stitch_graph(skel: Skeleton, diags: Diagnostics) -> sg.StitchGraph | None:
    """Skeleton → stitch graph; None (with diagnostics) if the garment cannot be built."""
    order = schedule_nodes(skel, diags)
    if order is None:
        return None
    names = list(skel.nodes)
    acc = _Acc(names, spans=[n.span for n in skel.nodes.values()])
    partner: dict[ItfId, ItfId] = {}
    for c in skel.connections:
        partner[c.a], partner[c.b] = c.b, c.a
    state = _State(skel, acc, diags, partner)
    for visit in order:
        node = skel.nodes[visit.node]
        if node.kind in ("sheet", "tube"):
            _sheet(state, node, visit)
        elif node.kind == "joint":
            _joint(state, node, visit)
        else:
            _split(state, node, visit)
        if state.failed:
            return None
    return acc.finish()


def _incoming(state: _State, node: PrimNode, path: str) -> Course | None:
    other = state.partner.get(ItfId(node.name, path))
    return state.exit_course.get(other) if other is not None else None


def _span_of(state: _State, node: PrimNode, course: Course) -> int:
    return course.per_bed * state.gauge(node)


# -- sheets and tubes


def _widths(node: PrimNode, count: int, reverse: bool) -> list[int]:
    prof = node.props["width"]
    assert isinstance(prof, Profile)
    ts = [c / (count - 1) if count > 1 else 0.0 for c in range(count)]
    if reverse and count > 1:
        ts = [1 - t for t in ts]
    return [max(round_half_up(prof.at(t)), 1) for t in ts]


def _offset(alignment: str, width: int, max_width: int) -> int:
    if alignment == "left":
        return 0
    if alignment == "right":
        return max_width - width
    return round_half_up((max_width - width) / 2)


def _sheet(state: _State, node: PrimNode, visit: NodeVisit) -> None:
    acc, skel = state.acc, state.skel
    idx = acc.node_names.index(node.name)
    entry, exit_ = visit.entries[0], visit.exits[0]
    tubular = state.tubular(node, entry)
    gauge = state.gauge(node)
    length = int(cast(float, node.props["length"]))
    widths = _widths(node, length, reverse=entry == "top")
    itf_in = skel.interfaces[ItfId(node.name, entry)]
    itf_out = skel.interfaces[ItfId(node.name, exit_)]
    # A closed end keeps the width of the course next to it: closing already halves the
    # course, and also decreasing there would stack up to four loops on one needle.
    if itf_in.state == "closed" and tubular and length > 1:
        widths[0] = widths[1]
    # A tube whose exit meets a course of half its size (same gauge) is closed, then merged
    # (the original's 2:1 rule).
    partner_out = state.partner.get(ItfId(node.name, exit_))
    close_out = itf_out.state == "closed" or (
        partner_out is not None
        and tubular
        and binding(skel, ItfId(node.name, exit_), partner_out) == "close"
        and cast(int, itf_out.size) > cast(int, skel.interfaces[partner_out].size)
    )
    if close_out and tubular and length > 1:
        widths[-1] = widths[-2]
    max_w = max(widths)
    alignment = str(node.props.get("alignment", "center"))
    prev = _incoming(state, node, entry)
    # a flat piece continues on the bed of the flat course it grows from (an unfolded
    # split's branch may lie on the back bed)
    flat_side = (
        BACK
        if prev is not None
        and not tubular
        and not prev.circular
        and prev.width
        and bool((prev.side == BACK).all())
        else FRONT
    )
    direction = 1
    courses: list[Course] = []
    for c, w in enumerate(widths):
        off = _offset(alignment, w, max_w)
        closes_here = (c == 0 and itf_in.state == "closed") or (c == length - 1 and close_out)
        if (
            c == 0
            and prev is not None
            and prev.circular == tubular
            and not closes_here
            and prev.per_bed == w
            and state.gauge(node) == _gauge_of(state, prev)
        ):
            cur = prev  # the connection's course is shared with the producer
        else:
            side, needle = ring(w, tubular, off)
            if not tubular:
                side = np.full(w, flat_side, np.int8)
                if direction < 0:
                    needle = needle[::-1]
            at_in, at_out = c == 0, c == length - 1
            closed = (at_in and itf_in.state == "closed") or (at_out and close_out)
            closing = (itf_in if at_in and itf_in.state == "closed" else itf_out).closing
            if closed and tubular and closing in ("zigzag", "zigzagreturn"):
                cur = _zigzag(state, idx, w, off, gauge, closing == "zigzagreturn")
            elif closed and tubular:
                cur = _collapsed(state, idx, w, off, gauge, first=c == 0)
            else:
                kind = "interface" if c in (0, length - 1) else "regular"
                cur = acc.course(idx, side, needle, tubular, kind, gauge)
            if c == 0:
                if (
                    prev is not None
                    and cur.collapsed
                    and prev.circular
                    and prev.per_bed == cur.width
                ):
                    _link(state, node, prev, cur)
                elif prev is not None:
                    _spread(acc, prev, cur)
            else:
                _link(state, node, courses[-1], cur)
                if state.failed:
                    return
        if c == 0:
            acc.name(cur, ItfId(node.name, entry))
        courses.append(cur)
        direction = -direction
    last = courses[-1]
    acc.name(last, ItfId(node.name, exit_))
    state.exit_course[ItfId(node.name, exit_)] = last
    state.yarn_end[node.name] = last


def _gauge_of(state: _State, course: Course) -> int:
    return int(state.acc.rows[course.id][5])


def _collapsed(state: _State, idx: int, w: int, off: int, gauge: int, first: bool) -> Course:
    """A closed tube end: the back bed merged onto the front, one stitch per needle pair.

    Recorded as a flat course whose stitches carry both beds' wales (thesis ch. 5.2,
    `collapse`); `_link` pairs front k and back k with stitch k.
    """
    needle = np.arange(w, dtype=np.int32) + off
    if first:  # end on the left, where the tube's first course begins
        needle = needle[::-1]
    course = state.acc.course(idx, np.zeros(w, np.int8), needle, False, "interface", gauge)
    course.collapsed = True
    return course


def _zigzag(state: _State, idx: int, w: int, off: int, gauge: int, ret: bool) -> Course:
    """A closed tube end knitted as one flat course alternating front and back needles
    (`closed(zigzag)`), or the same read back (`closed(zigzagreturn)`): no loops merge, the
    end is closed by the yarn crossing between the beds."""
    k = np.arange(w, dtype=np.int32) + off
    side = np.tile(np.array([0, 1], np.int8), w)
    needle = np.repeat(k, 2)
    if ret:
        side, needle = side[::-1], needle[::-1]
    return state.acc.course(idx, side, needle, False, "interface", gauge)


def _link(state: _State, node: PrimNode, a: Course, b: Course) -> None:
    """Wales between consecutive courses of one sheet or tube."""
    acc = state.acc
    bed: int | None
    key: tuple[str, int] | tuple[str, int, int, int]
    if (b.collapsed and a.circular) or (a.collapsed and b.circular):
        full, flat = (a, b) if b.collapsed else (b, a)
        for bed in (FRONT, BACK):
            half = full.half(bed)
            if half.size != flat.width:
                raise AssertionError("collapsed course width mismatch")
            if flat is b:
                acc.wales(half, flat.ids[np.argsort(flat.needle, kind="stable")])
            else:
                acc.wales(flat.ids[np.argsort(flat.needle, kind="stable")], half)
        return
    shaper = node.props.get("shaper", "uniform")
    if shaper == "none":
        _grid_wales(acc, a, b)
        return
    program = None if shaper in PREDEFINED else state.skel.shapers.get(str(shaper))
    for bed in (FRONT, BACK) if a.circular or b.circular else (None,):
        # two flat courses are linked whole, whichever bed each lies on
        ha, hb = (
            (a.half(bed), b.half(bed)) if bed is not None else (a.in_bed_order(), b.in_bed_order())
        )
        m, n = ha.size, hb.size
        if m == 0 or n == 0:
            continue
        small, large = min(m, n), max(m, n)
        if large > 2 * small:
            state.diags.error(
                "E530",
                f"`{node.name}` changes from {m} to {n} stitches per bed between two "
                "courses; a course can at most double or halve",
                node.prop_spans.get("width", node.span),
                hint="lengthen the node or soften its width profile",
            )
            state.failed = True
            return
        # the odd stitch of a change goes to alternating edges (both beds alike: a tube's
        # fold gets the increase on its front and back side in the same course, a clean
        # seam line that grows the ring at one end); even spacing moves on at each change
        key = (node.name, FRONT if bed is None else bed)
        odd, k = state.odd_changes.get(key, 0), state.changes.get(key, 0)
        turn = odd % 2
        phase = (k * GOLDEN) % 1.0
        if large != small:
            state.changes[key] = k + 1
            state.odd_changes[key] = odd + (large - small) % 2
        try:
            if program is None:
                src = shaper_map(str(shaper), small, large, turn=turn, phase=phase)
            else:
                key = (str(shaper), small, large, turn)
                if key not in state.user_maps:  # courses repeat: run each (M, N) once
                    state.user_maps[key] = shaper_map(
                        program, small, large, turn=turn, param=state.param
                    )
                src = state.user_maps[key]
        except EvalError as err:
            state.diags.error(
                err.code,
                err.message,
                err.span,
                hint=err.hint,
                notes=[Note(f"used by `{node.name}`", node.prop_spans.get("shaper", node.span))],
            )
            state.failed = True
            return
        except (MappingError, ValueError) as err:
            state.diags.error(
                "E531",
                f"shaper `{shaper}` failed for {small} → {large} "
                f"stitches: {getattr(err, 'message', err)}",
                node.prop_spans.get("shaper", node.span),
            )
            state.failed = True
            return
        prev, nxt = wales_between(m, n, src)
        acc.wales(ha[prev], hb[nxt])


def _spread(acc: _Acc, a: Course, b: Course) -> None:
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


# -- joints (short rows)


def _joint(state: _State, node: PrimNode, visit: NodeVisit) -> None:
    acc, skel = state.acc, state.skel
    idx = acc.node_names.index(node.name)
    entry, exit_ = visit.entries[0], visit.exits[0]
    bottom = _incoming(state, node, entry)
    tubular = state.tubular(node, entry)
    gauge = state.gauge(node)
    itf = skel.interfaces[ItfId(node.name, entry)]
    if bottom is not None:  # the course the joint continues decides its shape
        if not bottom.circular and np.unique(bottom.side).size > 1:
            state.diags.error(
                "E533",
                f"joint `{node.name}` cannot continue a course closed "
                "across both beds (a zigzag closing)",
                node.span,
                hint="put at least one course of a tube between the closing and the short rows",
            )
            state.failed = True
            return
        tubular = bottom.circular
        per_bed = bottom.per_bed
    else:
        per_bed = (itf.size or 0) // (2 if tubular else 1)
        side, needle = ring(per_bed, tubular)
        bottom = acc.course(idx, side, needle, tubular, "interface", gauge)
    acc.name(bottom, ItfId(node.name, entry))
    G = per_bed * (2 if tubular else 1)
    cols_of = _cols(bottom, per_bed, tubular)

    rows = int(cast(float, node.props["rows"]))
    prof = node.props["width"]
    assert isinstance(prof, Profile)
    layout = node.props.get("layout", "auto")
    pos = (0.25 if tubular else 0.5) if layout == "auto" else float(cast(float, layout))
    center = round_half_up(pos * (G - 1))
    alignment = str(node.props.get("alignment", "center"))
    short: list[list[int]] = []
    for r in range(rows):
        t = r / (rows - 1) if rows > 1 else 0.0
        w = min(max(round_half_up(prof.at(t)), 1), G)
        if alignment == "left":
            lo = center
        elif alignment == "right":
            lo = center - w + 1
        else:
            lo = center - w // 2
        if not tubular:  # a flat short row cannot wrap round the edge: keep it on the bed
            lo = min(max(lo, 0), G - w)
        elif w == G:  # a full round: start it just after where the yarn arrives
            lo = int(cols_of[-1]) + 1
        short.append([(lo + c) % G for c in range(w)])

    def step(c: int, d: int) -> int | None:
        nxt = c + d
        if tubular:
            return nxt % G
        return nxt if 0 <= nxt < G else None

    # yarn after the bottom course: its last stitch, moving on in its yarn direction
    y = int(cols_of[-1])
    d = 1 if bottom.width < 2 or (int(cols_of[-1]) - int(cols_of[-2])) % (G or 1) == 1 else -1
    seqs: list[list[int]] = []
    # bottom -> first short row: walk to the nearer end of the row
    first = short[0]
    ends = (first[0], first[-1])
    best: tuple[int, list[int], int] | None = None
    inside = set(first) - set(ends)
    if y in ends:  # the yarn is already at an end of the first short row
        best = (d, [], y)
    walk: list[int] | None
    cols: list[int] | None
    c: int | None
    for direction, inclusive in ((d, False), (-d, True)):
        if best is not None and not best[1]:
            break
        walk, c = ([y] if inclusive else []), y
        for _ in range(G + 1):
            c = step(c, direction)
            if c is None or c in inside:  # off the bed, or through the row itself
                walk = None
                break
            if c in ends:
                break
            walk.append(c)
        if walk is not None and (best is None or len(walk) < len(best[1])):
            assert c is not None  # `walk` is None if a step returned None
            best = (direction, walk, c)
    lead: list[int] = []  # a continuity course before the first row (yarn inside it)
    if y in inside:
        # the yarn arrives inside the first row: knit along the row to its end first, then
        # turn into the row (the original's direct binding, ch. 5.4)
        for direction in (d, -d):
            cols, c = [], y
            for _ in range(G + 1):
                c = step(c, direction)
                if c is None:
                    cols = None
                    break
                cols.append(c)
                if c in ends:
                    break
            if cols is not None and cols and cols[-1] in ends:
                lead = cols
                best = (direction, [], cols[-1])
                break
    if best is None or (y in inside and not lead):
        state.diags.error(
            "E532",
            f"the short rows of joint `{node.name}` cannot start where the yarn "
            "arrives from the course below",
            node.prop_spans.get("layout", node.span),
            hint="short rows must be narrower than the course and away from where the "
            "previous course ends: change `layout` or `width`",
        )
        state.failed = True
        return
    direction, walk, reached = best
    row = first if reached == first[0] else first[::-1]
    seqs.append(walk + row)
    d = 1 if len(row) < 2 else (1 if step(row[0], 1) == row[1] else -1)
    for nxt in short[1:]:
        cur = seqs[-1]
        y = cur[-1]
        ends = (nxt[0], nxt[-1])
        if y in ends:  # direct: turn onto the next row
            seqs.append(nxt if y == nxt[0] else nxt[::-1])
        elif y in nxt:  # extend the current row along the next until its end
            far = nxt[-1] if d > 0 else nxt[0]
            c = y
            while c != far:
                c = step(c, d)
                assert c is not None  # `far` lies ahead in direction d, on the bed
                cur.append(c)
            seqs.append(nxt[::-1] if far == nxt[-1] else nxt)
        else:  # walk back along the current row to the next row's end
            ext, i = [], len(cur) - 1
            while i >= 0 and cur[i] not in ends:
                ext.append(cur[i])
                i -= 1
            reached = cur[i] if i >= 0 else ends[0]
            body = nxt if reached == nxt[0] else nxt[::-1]
            seqs.append(ext + body)
        s = seqs[-1]
        d = 1 if len(s) < 2 else (1 if step(s[-2], 1) == s[-1] else -1)

    # last short row -> top: a continuity course along the top ring to its first stitch
    y = seqs[-1][-1]
    top_cols = list(range(G))
    if tubular:
        cont = [(y + k) % G for k in range((0 - y) % G)]
        top_order = top_cols
    else:
        left, right = list(range(y, 0, -1)), list(range(y, G - 1))
        cont = left if len(left) <= len(right) else right
        top_order = top_cols if len(left) <= len(right) else top_cols[::-1]

    def course_at(cols: list[int], kind: str) -> Course:
        arr = np.asarray(cols, dtype=np.int64)
        if tubular:
            side = (arr >= per_bed).astype(np.int8)
            needle = np.where(arr < per_bed, arr, 2 * per_bed - 1 - arr)
        else:
            side, needle = np.zeros(arr.size, np.int8), arr
        return acc.course(idx, side, needle, False, kind, gauge)

    built = [bottom]
    if lead:
        built.append(course_at(lead, "continuity"))
    for s in seqs:
        built.append(course_at(s, "short_row"))
    if cont:
        built.append(course_at(cont, "continuity"))
    arr = np.asarray(top_order)
    if tubular:
        top = acc.course(
            idx,
            (arr >= per_bed).astype(np.int8),
            np.where(arr < per_bed, arr, 2 * per_bed - 1 - arr),
            True,
            "interface",
            gauge,
        )
    else:
        top = acc.course(idx, np.zeros(G, np.int8), arr, False, "interface", gauge)
    built.append(top)
    # grid wales: each column links its stitches in knitting order
    all_ids = np.concatenate([b.ids for b in built])
    all_cols = np.concatenate(
        [_cols(bottom, per_bed, tubular)]
        + [_ring_index(b.side, b.needle, per_bed, tubular) for b in built[1:]]
    )
    order = np.lexsort((all_ids, all_cols))
    ids_sorted, cols_sorted = all_ids[order], all_cols[order]
    same = cols_sorted[1:] == cols_sorted[:-1]
    acc.wales(ids_sorted[:-1][same], ids_sorted[1:][same])
    acc.name(top, ItfId(node.name, exit_))
    state.exit_course[ItfId(node.name, exit_)] = top
    state.yarn_end[node.name] = top


# -- splits and merges


def _branch_layout(
    state: _State, node: PrimNode, base_per_bed: int, tubular: bool
) -> list[tuple[int, int, bool, bool]]:
    """(offset on the base ring, per-bed width, tubular, laid around the ring) of every
    branch: a flat branch of an unfolded split lies along the base ring from its offset."""
    skel = state.skel
    degree = int(cast(int, node.props["degree"]))
    itfs = [skel.interfaces[ItfId(node.name, f"branches/{i}")] for i in range(degree)]
    tubes = [
        (itf.sides or (2 if tubular and node.props["folded"] else 1)) == 2 and tubular
        for itf in itfs
    ]  # on a flat base every branch lies flat
    # flat branches of a tubular base lie around its ring, folded or not; an unfolded split
    # opens the tube, so all its branches are flat (a tube joined to one closes it again)
    folded = bool(node.props["folded"]) and (not tubular or all(tubes))
    unfolded = tubular and not folded
    if unfolded:
        tubes = [False] * degree
    sizes = [(itf.size or 0) // (2 if tub else 1) for itf, tub in zip(itfs, tubes, strict=True)]
    span = base_per_bed * (2 if unfolded else 1)
    layout = node.props.get("layout", "auto")
    if isinstance(layout, tuple):
        positions = [layout[min(i, len(layout) - 1)] for i in range(degree)]
    else:
        total = sum(sizes)
        alignment = str(node.props.get("alignment", "uniform"))
        if alignment == "left":
            positions = [sum(sizes[:i]) / span for i in range(degree)]
        elif alignment == "right":
            positions = [1 - sum(sizes[i:]) / span for i in range(degree)]
        else:
            gaps = degree - 1 if folded else degree
            margin = (span - total) / gaps if gaps else 0
            positions = [sum(sizes[k] + margin for k in range(i)) / span for i in range(degree)]
        positions = [min(max(p, 0.0), 1.0) if degree > 1 else 0.0 for p in positions]
    return [
        (round_half_up(positions[i] * span), sizes[i], tubes[i], unfolded) for i in range(degree)
    ]


def _branch_positions(
    off: int, width: int, tubular: bool, around: bool, base_per_bed: int
) -> tuple[np.ndarray, np.ndarray]:
    """(side, needle) of a branch's stitches in yarn order, in the base's frame. A flat
    branch of an unfolded split follows the base ring from its offset: front left to right,
    then round the fold onto the back right to left (a branch in the back half lies on the
    back bed, one across the fold on both beds, as the tube cut open there)."""
    if tubular:
        return ring(width, True, off)
    k = np.arange(width, dtype=np.int32)
    if around:
        j = (off + k) % (2 * base_per_bed)
        back = j >= base_per_bed
        return back.astype(np.int8), np.where(back, 2 * base_per_bed - 1 - j, j).astype(np.int32)
    return np.zeros(width, np.int8), (off + k).astype(np.int32)


def _split(state: _State, node: PrimNode, visit: NodeVisit) -> None:
    acc, skel = state.acc, state.skel
    idx = acc.node_names.index(node.name)
    gauge = state.gauge(node)
    tubular = state.tubular(node, "base")
    base_itf = skel.interfaces[ItfId(node.name, "base")]
    base_per_bed = (base_itf.size or 0) // (2 if tubular else 1)
    layout = _branch_layout(state, node, base_per_bed, tubular)
    paths = [f"branches/{i}" for i in range(len(layout))]

    if visit.entries == ("base",):
        base = _incoming(state, node, "base")
        expected = base_per_bed * (2 if tubular else 1)
        if base is not None and (base.circular != tubular or base.width != expected):
            # the producer's course does not fit the base ring: spread it onto one that does
            side, needle = ring(base_per_bed, tubular)
            own = acc.course(idx, side, needle, tubular, "interface", gauge)
            _spread(acc, base, own)
            base = own
        if base is None:
            side, needle = ring(base_per_bed, tubular)
            base = acc.course(idx, side, needle, tubular, "interface", gauge)
        acc.name(base, ItfId(node.name, "base"))
        frame = _frame(base, base_per_bed, tubular)
        for path, (off, w, tub, around) in zip(paths, layout, strict=True):
            side, needle = _branch_positions(off, w, tub, around, base_per_bed)
            br = acc.course(idx, side, needle, tub, "interface", gauge)
            _grid_wales(acc, frame, br)
            acc.name(br, ItfId(node.name, path))
            state.exit_course[ItfId(node.name, path)] = br
        state.yarn_end[node.name] = state.exit_course[ItfId(node.name, paths[0])]
        return

    # a merge: every branch is knitted; gather them on the base ring
    branch_courses: list[Course] = []
    for path, (off, w, tub, around) in zip(paths, layout, strict=True):
        prev = _incoming(state, node, path)
        side, needle = _branch_positions(off, w, tub, around, base_per_bed)
        if prev is not None and (prev.circular != tub or prev.width != side.size):
            # the producer's course does not fit the branch (flat into tube or sizes
            # differ): give the branch its own course, spread from the producer's
            own = acc.course(idx, side, needle, tub, "interface", gauge)
            _spread(acc, prev, own)
            prev = own
        if prev is None:
            prev = acc.course(idx, side, needle, tub, "interface", gauge)
            frame_course = prev
        else:
            frame_course = Course(prev.id, _in_yarn_order(prev, tub), side, needle, tub)
        acc.name(prev, ItfId(node.name, path))
        branch_courses.append(frame_course)
    last_producer = None
    for path in paths:
        other = state.partner.get(ItfId(node.name, path))
        if other is not None and other.node in state.yarn_end:
            last_producer = path
    last_idx = paths.index(last_producer) if last_producer else len(paths) - 1
    last = branch_courses[last_idx]
    knitted_last = _incoming(state, node, paths[last_idx])
    end_id = int(knitted_last.ids[-1]) if knitted_last is not None else int(last.ids[-1])
    hit = np.nonzero(last.ids == end_id)[0]
    at = int(hit[0]) if hit.size else last.width - 1  # a spread branch: its own course
    y = int(_ring_index(last.side[at : at + 1], last.needle[at : at + 1], base_per_bed, tubular)[0])
    G = base_per_bed * (2 if tubular else 1)
    if tubular:
        cont_cols = [(y + k) % G for k in range(1, (0 - y) % G)]
    else:
        cont_cols = list(range(y - 1, 0, -1)) if y > 0 else []
    courses = list(branch_courses)
    if cont_cols:
        arr = np.asarray(cont_cols)
        side = (arr >= base_per_bed).astype(np.int8) if tubular else np.zeros(arr.size, np.int8)
        needle = np.where(arr < base_per_bed, arr, 2 * base_per_bed - 1 - arr) if tubular else arr
        courses.append(acc.course(idx, side, needle, False, "continuity", gauge))
    side, needle = ring(base_per_bed, tubular)
    base = acc.course(idx, side, needle, tubular, "interface", gauge)
    courses.append(base)
    # wales by position, in knitting order, from branches via continuity to the base
    all_ids = np.concatenate([c.ids for c in courses])
    all_pos = np.concatenate(
        [_ring_index(c.side, c.needle, base_per_bed, tubular) for c in courses]
    )
    order = np.lexsort((all_ids, all_pos))
    ids_sorted, pos_sorted = all_ids[order], all_pos[order]
    same = pos_sorted[1:] == pos_sorted[:-1]
    acc.wales(ids_sorted[:-1][same], ids_sorted[1:][same])
    acc.name(base, ItfId(node.name, "base"))
    state.exit_course[ItfId(node.name, "base")] = base
    state.yarn_end[node.name] = base


def _cols(course: Course, per_bed: int, tubular: bool) -> np.ndarray:
    """Ring positions of a course's stitches (in its yarn order), ignoring its offset."""
    needle = course.needle - (int(course.needle.min()) if course.width else 0)
    return _ring_index(course.side, needle, per_bed, tubular)


def _in_yarn_order(course: Course, tubular: bool) -> np.ndarray:
    """A producer's course ids ordered like `ring` lays positions (front L→R, back R→L); a
    flat course in bed order (`Course.in_bed_order`)."""
    if not tubular:
        return course.in_bed_order()
    return np.concatenate([course.half(FRONT), course.half(BACK)[::-1]])


def _frame(base: Course, per_bed: int, tubular: bool) -> Course:
    """The base course re-expressed in ring positions 0.. (its own needles may be offset)."""
    ids = _in_yarn_order(base, tubular)
    side, needle = ring(per_bed, tubular)
    return Course(base.id, ids, side, needle, tubular)
