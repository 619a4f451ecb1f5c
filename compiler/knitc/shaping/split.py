"""Splits and merges: branches laid side by side on the base ring (folded or flat), and
the continuity course that carries the yarn from the last branch of a merge to its base."""

from __future__ import annotations

from typing import cast

import numpy as np

from knitc.frontend.skeleton import ItfId, PrimNode
from knitc.lang.evaluate import round_half_up
from knitc.shaping.courses import (
    Course,
    ShapeState,
    branch_frame,
    grid_wales,
    in_yarn_order,
    incoming,
    ring,
    ring_index,
    spread_wales,
)
from knitc.shaping.node_order import NodeVisit


def _branch_layout(
    state: ShapeState, node: PrimNode, base_per_bed: int, tubular: bool
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


def _layout_fits(
    state: ShapeState, node: PrimNode, layout: list[tuple[int, int, bool, bool]], base_per_bed: int
) -> bool:
    """Whether every branch lies on the base and no two share a stitch of it; else E534 at
    the `layout` property (only a designer's list can break this: `alignment` spreads the
    branches inside the base, which E504 made large enough). A folded branch or one of a
    flat base must end within the base's width per bed; an unfolded branch follows the ring
    around the base and may wrap past its start, but never onto another branch. Without the
    check a branch past the end had wales going back in time and two branches on one
    stitch gave it more than two wales (internal errors of the stitch graph)."""
    owner: dict[int, int] = {}
    for i, (off, w, _tub, around) in enumerate(layout):
        span = base_per_bed * (2 if around else 1)
        message, hint = None, "start each branch after the end of the one before it"
        if w > span or (not around and off + w > span):
            message = (
                f"branch {i} of split `{node.name}` ({w} stitches per bed from stitch {off}) "
                f"runs past the end of its base ({span} per bed)"
            )
            hint = f"start it at most {max(span - w, 0) / span:.3g} along the base"
        else:
            cols = (off + np.arange(w)) % span
            hit = next((int(c) for c in cols.tolist() if c in owner), None)
            if hit is not None:
                message = (
                    f"branches {owner[hit]} and {i} of split `{node.name}` both lie on "
                    f"stitch {hit} of its base"
                )
            owner.update(dict.fromkeys(cols.tolist(), i))
        if message is not None:
            state.diags.error(
                "E534",
                message,
                node.prop_spans.get("layout", node.span),
                hint=f"{hint}, or leave out `layout` to spread the branches evenly",
            )
            state.failed = True
            return False
    return True


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


def build_split(state: ShapeState, node: PrimNode, visit: NodeVisit) -> None:
    acc, skel = state.acc, state.skel
    idx = acc.node_names.index(node.name)
    gauge = state.gauge(node)
    tubular = state.tubular(node, "base")
    base_itf = skel.interfaces[ItfId(node.name, "base")]
    base_per_bed = (base_itf.size or 0) // (2 if tubular else 1)
    layout = _branch_layout(state, node, base_per_bed, tubular)
    if not _layout_fits(state, node, layout, base_per_bed):
        return
    paths = [f"branches/{i}" for i in range(len(layout))]

    if visit.entries == ("base",):
        base = incoming(state, node, "base")
        expected = base_per_bed * (2 if tubular else 1)
        if base is not None and (base.circular != tubular or base.width != expected):
            # the producer's course does not fit the base ring: spread it onto one that does
            side, needle = ring(base_per_bed, tubular)
            own = acc.course(idx, side, needle, tubular, "interface", gauge)
            spread_wales(acc, base, own)
            base = own
        if base is None:
            side, needle = ring(base_per_bed, tubular)
            base = acc.course(idx, side, needle, tubular, "interface", gauge)
        acc.name(base, ItfId(node.name, "base"))
        frame = branch_frame(base, base_per_bed, tubular)
        for path, (off, w, tub, around) in zip(paths, layout, strict=True):
            side, needle = _branch_positions(off, w, tub, around, base_per_bed)
            br = acc.course(idx, side, needle, tub, "interface", gauge)
            grid_wales(acc, frame, br)
            acc.name(br, ItfId(node.name, path))
            state.exit_course[ItfId(node.name, path)] = br
        state.yarn_end[node.name] = state.exit_course[ItfId(node.name, paths[0])]
        return

    # a merge: every branch is knitted; gather them on the base ring
    branch_courses: list[Course] = []
    for path, (off, w, tub, around) in zip(paths, layout, strict=True):
        prev = incoming(state, node, path)
        side, needle = _branch_positions(off, w, tub, around, base_per_bed)
        if prev is not None and (prev.circular != tub or prev.width != side.size):
            # the producer's course does not fit the branch (flat into tube or sizes
            # differ): give the branch its own course, spread from the producer's
            own = acc.course(idx, side, needle, tub, "interface", gauge)
            spread_wales(acc, prev, own)
            prev = own
        if prev is None:
            prev = acc.course(idx, side, needle, tub, "interface", gauge)
            frame_course = prev
        else:
            frame_course = Course(prev.id, in_yarn_order(prev, tub), side, needle, tub)
        acc.name(prev, ItfId(node.name, path))
        branch_courses.append(frame_course)
    last_producer = None
    for path in paths:
        other = state.partner.get(ItfId(node.name, path))
        if other is not None and other.node in state.yarn_end:
            last_producer = path
    last_idx = paths.index(last_producer) if last_producer else len(paths) - 1
    last = branch_courses[last_idx]
    knitted_last = incoming(state, node, paths[last_idx])
    end_id = int(knitted_last.ids[-1]) if knitted_last is not None else int(last.ids[-1])
    hit = np.nonzero(last.ids == end_id)[0]
    at = int(hit[0]) if hit.size else last.width - 1  # a spread branch: its own course
    y = int(ring_index(last.side[at : at + 1], last.needle[at : at + 1], base_per_bed, tubular)[0])
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
    all_pos = np.concatenate([ring_index(c.side, c.needle, base_per_bed, tubular) for c in courses])
    order = np.lexsort((all_ids, all_pos))
    ids_sorted, pos_sorted = all_ids[order], all_pos[order]
    same = pos_sorted[1:] == pos_sorted[:-1]
    acc.wales(ids_sorted[:-1][same], ids_sorted[1:][same])
    acc.name(base, ItfId(node.name, "base"))
    state.exit_course[ItfId(node.name, "base")] = base
    state.yarn_end[node.name] = base
