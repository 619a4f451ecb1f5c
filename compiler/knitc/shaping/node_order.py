"""Node scheduling: which way each primitive is knitted, and in which order.

The yarn start fixes the direction of its node; every connection then forces its neighbour:
a neighbour entered at an interface flows out of its other side, a split entered at its
base splits into its branches, and a split entered at a branch is a merge, so its other
branches must flow *into* it. Those branches are knitted first, from their own free ends,
with their own yarns (thesis ch. 5.4; the original schedules the same way).

The order is a depth-first walk of the resulting flow DAG from each start that knits a
node's missing producers just before it, so a branch is completed before its merge and the
main yarn runs on whenever it can.
"""

from __future__ import annotations

from collections import deque

from knitc.diagnostics import Diagnostics, Note
from knitc.frontend.skeleton import ItfId, PrimNode, Skeleton
from knitc.records import record


@record(frozen=True)
class NodeVisit:
    """One primitive in knitting order, with the interfaces fabric enters and leaves by."""

    node: str
    entries: tuple[str, ...]
    exits: tuple[str, ...]
    new_yarn: bool
    """A yarn starts at this node (its entries are free interfaces: cast-on or start)."""


def _other_side(node: PrimNode, path: str) -> tuple[tuple[str, ...], tuple[str, ...]]:
    """(entries, exits) when fabric enters `node` at `path`."""
    if node.kind == "split":
        branches = tuple(p for p in node.interface_paths if p != "base")
        if path == "base":
            return ("base",), branches
        return branches, ("base",)
    other = "top" if path == "bottom" else "bottom"
    return (path,), (other,)


def _exiting_at(node: PrimNode, path: str) -> tuple[tuple[str, ...], tuple[str, ...]]:
    """(entries, exits) when fabric must leave `node` at `path`."""
    if node.kind == "split":
        branches = tuple(p for p in node.interface_paths if p != "base")
        if path == "base":
            return branches, ("base",)
        return ("base",), branches
    other = "top" if path == "bottom" else "bottom"
    return (other,), (path,)


def schedule_nodes(skel: Skeleton, diags: Diagnostics) -> list[NodeVisit] | None:
    """Orient every node and order them; None (with errors) if the garment is unknittable."""
    partner: dict[ItfId, ItfId] = {}
    for c in skel.connections:
        partner[c.a], partner[c.b] = c.b, c.a
    orient: dict[str, tuple[tuple[str, ...], tuple[str, ...]]] = {}
    why: dict[str, ItfId] = {}
    ok = True

    for start in skel.starts:
        root = skel.nodes[start.itf.node]
        if root.name in orient:
            continue
        queue: deque[tuple[str, tuple[tuple[str, ...], tuple[str, ...]], ItfId]] = deque()
        queue.append((root.name, _other_side(root, start.itf.path), start.itf))
        while queue:
            name, flow, cause = queue.popleft()
            if name in orient:
                if orient[name] != flow:
                    ok = False
                    diags.error(
                        "E520",
                        f"`{name}` would have to be knitted in two directions",
                        skel.nodes[name].span,
                        notes=[
                            Note(f"fabric arrives from `{why[name]}`"),
                            Note(f"and from `{cause}`"),
                        ],
                        hint="a sheet or joint is knitted from one interface to the other; "
                        "join several pieces with a split",
                    )
                continue
            orient[name] = flow
            why[name] = cause
            entries, exits = flow
            for path in exits:
                other = partner.get(ItfId(name, path))
                if other is not None:
                    queue.append(
                        (
                            other.node,
                            _other_side(skel.nodes[other.node], other.path),
                            ItfId(name, path),
                        )
                    )
            for path in entries:
                other = partner.get(ItfId(name, path))
                if other is not None:
                    queue.append(
                        (
                            other.node,
                            _exiting_at(skel.nodes[other.node], other.path),
                            ItfId(name, path),
                        )
                    )
    if not ok:
        return None

    producers: dict[str, list[str]] = {n: [] for n in orient}
    consumers: dict[str, list[str]] = {n: [] for n in orient}
    for name, (_entries, exits) in orient.items():
        for path in exits:
            other = partner.get(ItfId(name, path))
            if other is not None:
                consumers[name].append(other.node)
                producers[other.node].append(name)

    order: list[NodeVisit] = []
    done: set[str] = set()
    active: set[str] = set()

    def visit(name: str) -> None:
        if name in done:
            return
        if name in active:
            raise _Cycle(name)
        active.add(name)
        for p in producers[name]:
            visit(p)
        entries, exits = orient[name]
        new_yarn = not producers[name]
        order.append(NodeVisit(name, entries, exits, new_yarn))
        done.add(name)
        active.discard(name)
        for c in consumers[name]:
            if c not in active and all(p in done for p in producers[c]):
                visit(c)

    try:
        for start in skel.starts:
            visit(start.itf.node)
            for name in list(orient):  # anything reachable only through merges
                if name not in done:
                    visit(name)
    except _Cycle as cyc:
        diags.error(
            "E521",
            f"the connections through `{cyc.node}` form a loop; the garment "
            "cannot be knitted in one order",
            skel.nodes[cyc.node].span,
            hint="knitted fabric grows in one direction: remove the connection that "
            "closes the loop",
        )
        return None
    return order


class _Cycle(Exception):
    def __init__(self, node: str):
        super().__init__(node)
        self.node = node
