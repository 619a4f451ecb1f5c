"""Sheets and tubes (thesis ch. 5.2): widths sampled from the profile, closed ends, and
the linking of consecutive courses by the node's shaper (`link`)."""

from __future__ import annotations

from typing import cast

import numpy as np

from knitc.diagnostics import Note
from knitc.frontend.skeleton import ItfId, PrimNode, binding
from knitc.lang.evaluate import EvalError, Profile, round_half_up
from knitc.shaping.courses import (
    BACK,
    FRONT,
    Course,
    ShapeState,
    grid_wales,
    incoming,
    ring,
    spread_wales,
)
from knitc.shaping.node_order import NodeVisit
from knitc.shaping.shapers import MappingError, wales_between
from knitc.shaping.shapers import shape as shaper_map

GOLDEN = (5**0.5 - 1) / 2
"""Step of `uniform`'s phase between changes: successive phases fill [0, 1) evenly."""


PREDEFINED = ("uniform", "center", "left", "right", "sides")


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


def build_sheet(state: ShapeState, node: PrimNode, visit: NodeVisit) -> None:
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
    prev = incoming(state, node, entry)
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
                    spread_wales(acc, prev, cur)
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


def _gauge_of(state: ShapeState, course: Course) -> int:
    return int(state.acc.rows[course.id][5])


def _collapsed(state: ShapeState, idx: int, w: int, off: int, gauge: int, first: bool) -> Course:
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


def _zigzag(state: ShapeState, idx: int, w: int, off: int, gauge: int, ret: bool) -> Course:
    """A closed tube end knitted as one flat course alternating front and back needles
    (`closed(zigzag)`), or the same read back (`closed(zigzagreturn)`): no loops merge, the
    end is closed by the yarn crossing between the beds."""
    k = np.arange(w, dtype=np.int32) + off
    side = np.tile(np.array([0, 1], np.int8), w)
    needle = np.repeat(k, 2)
    if ret:
        side, needle = side[::-1], needle[::-1]
    return state.acc.course(idx, side, needle, False, "interface", gauge)


def _link(state: ShapeState, node: PrimNode, a: Course, b: Course) -> None:
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
        grid_wales(acc, a, b)
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
                        program,
                        small,
                        large,
                        turn=turn,
                        param=state.param,
                        pool=state.shaper_steps,
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
