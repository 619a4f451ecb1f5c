"""Joints (thesis ch. 5.4.1): short rows centred on the layout column, with the original's
direct and continuity bindings and grid wales."""

from __future__ import annotations

from typing import cast

import numpy as np

from knitc import arrays
from knitc.frontend.skeleton import ItfId, PrimNode
from knitc.lang.evaluate import Profile, round_half_up
from knitc.shaping.courses import (
    Course,
    ShapeState,
    course_columns,
    incoming,
    ring,
    ring_index,
)
from knitc.shaping.node_order import NodeVisit


def build_joint(state: ShapeState, node: PrimNode, visit: NodeVisit) -> None:
    acc, skel = state.acc, state.skel
    idx = acc.node_names.index(node.name)
    entry, exit_ = visit.entries[0], visit.exits[0]
    bottom = incoming(state, node, entry)
    tubular = state.tubular(node, entry)
    gauge = state.gauge(node)
    itf = skel.interfaces[ItfId(node.name, entry)]
    if bottom is not None:  # the course the joint continues decides its shape
        if not bottom.circular and arrays.unique(bottom.side).size > 1:
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
    cols_of = course_columns(bottom, per_bed, tubular)

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
            c, seen = y, set(cur)
            while c != far:
                c = step(c, d)
                assert c is not None  # `far` lies ahead in direction d, on the bed
                if c in seen:  # a full round: extending it would knit a column twice
                    state.diags.error(
                        "E532",
                        f"the short rows of joint `{node.name}` cannot go on after a row "
                        "all the way round: it ends inside the next row",
                        node.prop_spans.get("width", node.span),
                        hint="keep the short rows narrower than the course (a row as wide "
                        "as the ring is a plain course: put it in the tube before the joint)",
                    )
                    state.failed = True
                    return
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
        [course_columns(bottom, per_bed, tubular)]
        + [ring_index(b.side, b.needle, per_bed, tubular) for b in built[1:]]
    )
    order = np.lexsort((all_ids, all_cols))
    ids_sorted, cols_sorted = all_ids[order], all_cols[order]
    same = cols_sorted[1:] == cols_sorted[:-1]
    acc.wales(ids_sorted[:-1][same], ids_sorted[1:][same])
    acc.name(top, ItfId(node.name, exit_))
    state.exit_course[ItfId(node.name, exit_)] = top
    state.yarn_end[node.name] = top
