"""The loops a machine program makes, as a stitch graph: what the chart and shape views of a
Knitout file (which has no design behind it) are drawn from.

A plain replay of the program: each needle holds a list of loops; a knit or split makes a
new loop pulled through the needle's loops (its parents: the wales below it), a tuck adds
a loop beside the old ones (it is pulled through by the next knit there), a transfer moves
a needle's loops, a drop lets them go. Each carriage pass (`bed.pass_rows`) that makes
loops is a course, its loops in the order they were made; each yarn (the first carrier of
the op) is a node, so the views colour and chart pieces by yarn. A loop pulled through
more than two loops keeps its first two as wales (the graph's limit), and a loop already
pulled through twice gains no further wale: the graph is a picture, not a fabric check
(tests/fabric.py is that).
"""

from __future__ import annotations

import numpy as np

from knitc.codegen.machine import MachineProgram, Needle
from knitc.records import record
from knitc.shaping.stitch_graph import INSTRUCTIONS, NONE, StitchGraph, empty_pair

_T = INSTRUCTIONS.index("T")


@record
class LoopGraph:
    """The graph, and per op of the program the loop it made (-1: none)."""

    graph: StitchGraph
    op_loop: np.ndarray


def loop_graph(prog: MachineProgram) -> LoopGraph:
    """Replay `prog` (see the module docstring)."""
    from knitc.view.bed import pass_rows

    ops = prog.ops
    prow = pass_rows(ops)
    held: dict[Needle, list[int]] = {}
    op_loop = np.full(len(ops), -1, np.int64)
    course: list[int] = []
    side: list[int] = []
    needle: list[int] = []
    yarn: list[int] = []
    tuck: list[bool] = []
    parents: list[tuple[int, ...]] = []
    for i, op in enumerate(ops):
        k = op.kind
        if k in ("knit", "tuck", "split"):
            assert op.needle is not None
            if not op.carriers:
                continue
            on = held.get(op.needle, [])
            new = len(course)
            course.append(int(prow[i]))
            side.append(0 if op.needle.is_front else 1)
            needle.append(op.needle.index)
            yarn.append(op.carriers[0])
            tuck.append(k == "tuck")
            op_loop[i] = new
            if k == "tuck":
                parents.append(())
                held[op.needle] = on + [new]
            else:
                parents.append(tuple(on))
                if k == "split" and op.needle2 is not None and on:
                    held.setdefault(op.needle2, []).extend(on)
                held[op.needle] = [new]
        elif k == "xfer" and op.needle is not None and op.needle2 is not None:
            moved = held.pop(op.needle, [])
            if moved:
                held.setdefault(op.needle2, []).extend(moved)
        elif k == "drop" and op.needle is not None:
            held.pop(op.needle, None)
    return LoopGraph(_graph(course, side, needle, yarn, tuck, parents), op_loop)


def _graph(
    course: list[int],
    side: list[int],
    needle: list[int],
    yarn: list[int],
    tuck: list[bool],
    parents: list[tuple[int, ...]],
) -> StitchGraph:
    n = len(course)
    pc = np.array(course, np.int64)
    # courses: runs of loops of one pass (loops are made in pass order, so runs are slices)
    starts = np.nonzero(np.r_[True, pc[1:] != pc[:-1]])[0] if n else np.zeros(0, np.int64)
    lens = np.diff(np.r_[starts, n]).astype(np.int32)
    cid = np.repeat(np.arange(starts.shape[0], dtype=np.int32), lens)
    yarns = sorted(set(yarn))
    node_of = {c: k for k, c in enumerate(yarns)}
    node = np.array([node_of[c] for c in yarn], np.int32)
    ids = np.arange(n, dtype=np.int32)
    first = np.zeros(n, bool)
    first[starts] = True
    last = np.zeros(n, bool)
    last[np.r_[starts[1:] - 1, n - 1].astype(np.int64) if n else []] = True
    cprev = np.where(first, NONE, ids - 1).astype(np.int32)
    cnext = np.where(last, NONE, ids + 1).astype(np.int32)
    wp, wn = empty_pair(n), empty_pair(n)
    for child, ps in enumerate(parents):
        k = 0
        for p in ps:
            if k == 2:
                break
            slot = 0 if wn[p, 0] == NONE else 1 if wn[p, 1] == NONE else -1
            if slot < 0:
                continue
            wn[p, slot] = child
            wp[child, k] = p
            k += 1
    instr = np.where(np.array(tuck, bool), _T, 0).astype(np.uint8)
    return StitchGraph(
        node_names=[f"yarn {c}" for c in yarns],
        spans=[],
        node=node,
        course=cid,
        side=np.array(side, np.int8),
        needle=np.array(needle, np.int32),
        cprev=cprev,
        cnext=cnext,
        wale_prev=wp,
        wale_next=wn,
        instr=instr,
        action=np.full(n, -1, np.int16),
        span=np.full(n, -1, np.int32),
        course_start=starts.astype(np.int32),
        course_len=lens,
        course_node=node[starts] if n else np.zeros(0, np.int32),
        course_circular=np.zeros(starts.shape[0], bool),
        course_kind=np.zeros(starts.shape[0], np.int8),
        course_gauge=np.ones(starts.shape[0], np.int8),
    )
