"""Shaping: skeleton → stitch graph (thesis ch. 5.2 and 5.4.1).

Each primitive, in the order and direction chosen by `node_order.schedule_nodes`, becomes a run
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

from knitc.diagnostics import Diagnostics
from knitc.frontend.skeleton import ItfId, Skeleton
from knitc.shaping import stitch_graph as sg
from knitc.shaping.courses import (
    Accumulator,
    ShapeState,
)
from knitc.shaping.joint import build_joint
from knitc.shaping.node_order import schedule_nodes
from knitc.shaping.sheet import build_sheet
from knitc.shaping.split import build_split


def build_stitch_graph(skel: Skeleton, diags: Diagnostics) -> sg.StitchGraph | None:
    """Skeleton → stitch graph; None (with diagnostics) if the garment cannot be built."""
    order = schedule_nodes(skel, diags)
    if order is None:
        return None
    names = list(skel.nodes)
    acc = Accumulator(names, spans=[n.span for n in skel.nodes.values()])
    partner: dict[ItfId, ItfId] = {}
    for c in skel.connections:
        partner[c.a], partner[c.b] = c.b, c.a
    state = ShapeState(skel, acc, diags, partner)
    for visit in order:
        node = skel.nodes[visit.node]
        if node.kind in ("sheet", "tube"):
            build_sheet(state, node, visit)
        elif node.kind == "joint":
            build_joint(state, node, visit)
        else:
            build_split(state, node, visit)
        if state.failed:
            return None
    return acc.finish()
