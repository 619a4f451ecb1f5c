"""The skeleton IR: typed shape primitives with concrete parameters, and their connections.

This is thesis ch. 5.2's skeleton after every `#param` and `@prop` has been evaluated and
checked: sheets/tubes, joints and splits with their interfaces, the connections between
interfaces (a networkx graph over interfaces and nodes), the yarn start of each connected
garment, machine settings, and the pattern layers and definitions that later passes apply.

`verify` checks the topology a designer can get wrong (double connections, incompatible
sizes, missing or duplicate yarn starts) and reports located diagnostics; `to_json` is the
stable dump behind `knitc --emit skeleton`.
"""

from __future__ import annotations

import math
from dataclasses import field
from typing import TYPE_CHECKING, Any, cast

from knitc.diagnostics import Diagnostics, Note
from knitc.frontend import ast
from knitc.lang.evaluate import Profile, Value, round_half_up
from knitc.limits import MAX_STITCHES  # noqa: F401  (where the resolver and tools look)
from knitc.records import record
from knitc.source import Span

if TYPE_CHECKING:
    import networkx as nx

# ---- property schemas -------------------------------------------------------------------------


@record(frozen=True)
class PropSpec:
    """What a property accepts. `kind` is one of: int, number, bool, string, choice, width,
    joint_layout, split_layout, carriers, shaper."""

    kind: str
    default: Any
    choices: tuple[str, ...] = ()
    min: float | None = None
    max: float | None = None
    doc: str = ""


GAUGES = ("full", "half")
INCREASES = ("kickback", "split")
CAST_ONS = ("interlock", "kickback", "tuck", "precast", "none")
CAST_OFFS = ("pickup", "direct", "reverse", "none")
SHAPERS = ("uniform", "center", "left", "right", "sides", "none")
ALIGNMENTS = ("center", "left", "right")
CLOSINGS = ("collapse", "zigzag", "zigzagreturn")


MACHINE_PROPS: dict[str, PropSpec] = {
    "model": PropSpec("string", "SWG091N2", doc="machine model, for the Knitout header"),
    "needles": PropSpec("int", 541, min=1, max=2000, doc="needles per bed"),
    "gauge": PropSpec("choice", "full", GAUGES, doc="default gauge of every node"),
    "racking": PropSpec(
        "int", 4, min=0, max=4, doc="largest racking the machine allows (SWG091N2: 4)"
    ),
    "carriers": PropSpec("carriers", (3,), doc="yarn carriers in use (1..10)"),
    "increase": PropSpec("choice", "kickback", INCREASES, doc="default increase type"),
    "cast_on": PropSpec("choice", "interlock", CAST_ONS, doc="default cast-on"),
    "cast_off": PropSpec("choice", "pickup", CAST_OFFS, doc="default cast-off"),
    "slice_shaping": PropSpec(
        "int",
        0,
        min=0,
        max=1000,
        doc="increases + decreases knitted per bed slice "
        "(0 = 2 on a flat slice, 4 on a tubular one)",
    ),
}

COMMON_PROPS: dict[str, PropSpec] = {
    "gauge": PropSpec("choice", None, GAUGES, doc="full or half gauge (default: machine's)"),
    "increase": PropSpec("choice", "auto", ("auto",) + INCREASES),
}

SHEET_PROPS: dict[str, PropSpec] = {
    **COMMON_PROPS,
    "type": PropSpec("choice", "flat", ("flat", "cylinder", "auto")),
    "length": PropSpec("int", 10, min=1, max=100_000, doc="number of courses"),
    "width": PropSpec("width", 10, min=1, max=5000, doc="stitches per bed, or a profile"),
    "shaper": PropSpec("shaper", "uniform", SHAPERS),
    "alignment": PropSpec("choice", "center", ALIGNMENTS),
}
TUBE_PROPS = {k: v for k, v in SHEET_PROPS.items() if k != "type"}

JOINT_PROPS: dict[str, PropSpec] = {
    **COMMON_PROPS,
    "rows": PropSpec("int", 10, min=1, max=10_000, doc="number of short rows"),
    "width": PropSpec("width", 5, min=1, max=5000, doc="short-row width, or a profile"),
    "alignment": PropSpec("choice", "center", ALIGNMENTS),
    "layout": PropSpec("joint_layout", "auto", min=0, max=1),
}

SPLIT_PROPS: dict[str, PropSpec] = {
    **COMMON_PROPS,
    "degree": PropSpec("int", 2, min=1, max=64, doc="number of branches"),
    "folded": PropSpec("bool", True),
    "alignment": PropSpec("choice", "uniform", ("uniform", "manual", "left", "right")),
    "layout": PropSpec("split_layout", "auto", min=0, max=1),
}

NODE_PROPS = {"sheet": SHEET_PROPS, "tube": TUBE_PROPS, "joint": JOINT_PROPS, "split": SPLIT_PROPS}

ITF_PROPS: dict[str, PropSpec] = {
    "cast_on": PropSpec("choice", "auto", ("auto",) + CAST_ONS),
    "cast_off": PropSpec("choice", "auto", ("auto",) + CAST_OFFS),
}

MAIN_YARN = "main"
"""The design's own yarn: every stitch no `knit` statement gives another yarn."""

YARN_PROPS: dict[str, PropSpec] = {
    "carrier": PropSpec(
        "int",
        None,
        min=1,
        max=10,
        doc="the carrier that holds the yarn (default: `main` takes the machine's first "
        "carrier, other yarns the next free one)",
    ),
    "carry_up": PropSpec(
        "int",
        8,
        min=0,
        max=1000,
        doc="courses the yarn may rest at the side between two of its stripes, carried up "
        "the edge; a longer rest ends the yarn and brings it in again (0: always)",
    ),
    "tuck_every": PropSpec(
        "int",
        0,
        min=0,
        max=100,
        doc="in fair isle, a float of the yarn is caught by a tuck every this many needles "
        "(0: never)",
    ),
    "plating": PropSpec(
        "int",
        0,
        min=0,
        max=10,
        doc="the carrier of a second yarn knitted together with this one, stitch for stitch "
        "(plating: both carriers in one carrier set); this yarn shows on the face (0: none)",
    ),
    "inlay": PropSpec(
        "int",
        0,
        min=0,
        max=100,
        doc="an inlay yarn: laid into the courses `knit` gives it, not knitted, caught by a "
        "tuck every this many needles on the course's new loops (0: a knitting yarn)",
    ),
    "colour": PropSpec(
        "string",
        "",
        doc="the yarn's colour as \"#rrggbb\", which a colour image's pixels are matched to "
        "(`main` without one is white)",
    ),
}

ACTION_PROPS: dict[str, PropSpec] = {
    "split_by_side": PropSpec("bool", False, doc="run the steps per bed side"),
    "transfer_back": PropSpec("bool", True, doc="return loops to their bed after each course"),
}


# ---- IR records ---------------------------------------------------------------------------


@record(frozen=True)
class MachineSettings:
    """The design's `machine { ... }` block, defaults filled in: what the pipeline is
    compiled for (not the machine model code generation emits for, `codegen.machine.Machine`,
    which is built from it)."""

    model: str
    needles: int
    gauge: str
    racking: int
    carriers: tuple[int, ...]
    increase: str
    cast_on: str
    cast_off: str
    slice_shaping: int = 0
    """Shaping allowed per bed slice (ch. 6.7.1); 0 = the thesis's 2 flat, 4 tubular."""
    span: Span | None = None


@record(frozen=True)
class ItfId:
    """An interface: a node name and a path (`bottom`, `top`, `base`, `branches/2`)."""

    node: str
    path: str

    def __str__(self) -> str:
        if self.path.startswith("branches/"):
            return f"{self.node}.branches[{self.path.split('/')[1]}]"
        return f"{self.node}.{self.path}"


@record
class Interface:
    """One interface of a node (`cuff.top`): whether it is open, closed or connected,
    how it is cast on or off, and its size and sides once shape inference knows them."""

    id: ItfId
    state: str = "open"  # open | closed | connected
    closing: str | None = None  # for closed interfaces: collapse | zigzag | zigzagreturn
    cast_on: str = "auto"
    cast_off: str = "auto"
    size: int | None = None
    """Stitches on the interface course (both beds), once inferred."""
    sides: int | None = None
    """1 (one bed, flat) or 2 (both beds, tubular), once inferred."""
    span: Span | None = None
    """The statement that set its state, or the node that owns it."""


@record
class PrimNode:
    """A shape primitive with concrete parameters (thesis ch. 5.2, Table 5.1's primitives)."""

    name: str
    kind: str  # sheet | tube | joint | split
    props: dict[str, Value]
    span: Span
    prop_spans: dict[str, Span] = field(default_factory=dict)

    @property
    def interface_paths(self) -> list[str]:
        if self.kind == "split":
            return ["base"] + [f"branches/{i}" for i in range(int(cast(int, self.props["degree"])))]
        return ["bottom", "top"]

    @property
    def tubular(self) -> bool | None:
        """True for cylinders, False for flat sheets, None where inferred from neighbours."""
        if self.kind == "tube":
            return True
        if self.kind == "sheet":
            t = self.props["type"]
            return None if t == "auto" else t == "cylinder"
        return None


def stitch_estimate(nodes: dict[str, PrimNode]) -> dict[str, int]:
    """About how many stitches each sheet and tube will have (length × widest width × sides),
    from its properties alone: the budget check (E512) and the language server, which
    decides by it whether shaping is quick enough to run while the designer types."""
    sizes: dict[str, int] = {}
    for name, n in nodes.items():
        width = n.props.get("width")
        if n.kind in ("sheet", "tube") and isinstance(width, Profile):
            sides = 1 if n.tubular is False else 2
            sizes[name] = int(cast(int, n.props["length"])) * math.ceil(max(width.values())) * sides
    return sizes


@record(frozen=True)
class Connection:
    """`a -> b`: two interfaces that become one course of fabric."""

    a: ItfId
    b: ItfId
    span: Span


@record(frozen=True)
class YarnStart:
    """Where a garment's yarn starts: a `start` statement's interface, or, for a garment
    without one, inferred: its first interface that is not connected."""

    itf: ItfId
    inferred: bool
    span: Span | None


@record(frozen=True)
class Layer:
    """One pattern-layer statement, resolved but not yet applied (that is the pattern pass)."""

    target: str  # node name, or "before" / "after"
    stmt: ast.Node
    origin: Span


@record(frozen=True)
class Yarn:
    """A yarn of the design (`yarn red { ... }`); `main` always exists."""

    name: str
    carrier: int | None
    """Declared carrier, or None: code generation chooses one."""
    carry_up: int
    span: Span | None = None
    tuck_every: int = 0
    colour: str = ""
    """"#rrggbb", or "" (none): what a colour image's pixels are matched to."""
    plating: int | None = None
    """The carrier of the yarn knitted together with this one (`plating`), or None."""
    inlay: int = 0
    """An inlay yarn's catching distance in needles (`inlay`); 0: a knitting yarn."""


@record
class Skeleton:
    """The skeleton IR: the design's shape primitives, their interfaces and connections,
    the yarn starts, and the pattern layers still to apply, all with their values resolved."""

    machine: MachineSettings
    params: dict[str, Value]
    nodes: dict[str, PrimNode]
    interfaces: dict[ItfId, Interface]
    connections: list[Connection]
    starts: list[YarnStart] = field(default_factory=list)
    layers: list[Layer] = field(default_factory=list)
    patterns: dict[str, ast.PatternDef] = field(default_factory=dict)
    actions: dict[str, ast.ActionDef] = field(default_factory=dict)
    shapers: dict[str, ast.ShaperDef] = field(default_factory=dict)
    tainted: set[str] = field(default_factory=set)
    """Nodes that already have errors; size checks skip them so errors don't cascade."""
    yarns: dict[str, Yarn] = field(default_factory=dict)
    """The design's yarns by name, `main` first (`yarn_list` numbers them)."""

    @property
    def yarn_list(self) -> list[Yarn]:
        """The yarns in order: a stitch's yarn is an index into this list (0: `main`)."""
        if not self.yarns:
            return [Yarn(MAIN_YARN, self.machine.carriers[0], YARN_PROPS["carry_up"].default)]
        return list(self.yarns.values())

    def graph(self) -> nx.MultiGraph:
        """Nodes and interfaces as one graph: node–interface edges and connection edges
        (for tools; networkx is imported only here, it costs a third of start-up)."""
        import networkx as nx

        g = nx.MultiGraph()
        for name in self.nodes:
            g.add_node(name, kind="node")
        for itf in self.interfaces.values():
            g.add_node(itf.id, kind="interface")
            g.add_edge(itf.id.node, itf.id, kind="owns")
        for c in self.connections:
            g.add_edge(c.a, c.b, kind="connection")
        return g

    def components(self) -> list[list[str]]:
        """Node names of each connected garment, in declaration order (a walk over the
        connections: every compile needs it, and importing a graph library for it would
        cost more than the rest of a small design's compile)."""
        linked: dict[str, set[str]] = {n: set() for n in self.nodes}
        for c in self.connections:
            if c.a.node in linked and c.b.node in linked:
                linked[c.a.node].add(c.b.node)
                linked[c.b.node].add(c.a.node)
        order = {n: i for i, n in enumerate(self.nodes)}
        seen: set[str] = set()
        comps = []
        for start in self.nodes:
            if start in seen:
                continue
            seen.add(start)
            comp, todo = [], [start]
            while todo:
                n = todo.pop()
                comp.append(n)
                todo.extend(m for m in linked[n] if m not in seen)
                seen.update(linked[n])
            comps.append(sorted(comp, key=order.__getitem__))
        return comps


# ---- sizes and sides ------------------------------------------------------------------------


def _width_at(node: PrimNode, t: float) -> int:
    w = node.props["width"]
    assert isinstance(w, Profile)
    return max(round_half_up(w.at(t)), 1)


def infer_sizes(skel: Skeleton) -> None:
    """Fill `Interface.sides` and `Interface.size` from the primitives and across connections.

    Sheets fix their own sizes; joints carry the same size on both interfaces; splits get
    branch sizes from their neighbours and a base that holds all branches (ch. 5.2). The
    propagation runs to a fixed point, so chains of joints and splits resolve in any order.
    """
    itfs = skel.interfaces
    partner: dict[ItfId, ItfId] = {}
    for c in skel.connections:
        partner.setdefault(c.a, c.b)
        partner.setdefault(c.b, c.a)

    for node in skel.nodes.values():
        tub = node.tubular
        if node.kind in ("sheet", "tube") and tub is not None:
            # one course: both ends are that course
            one = int(cast(float, node.props["length"])) == 1
            for path, t in (("bottom", 0.0), ("top", 0.0 if one else 1.0)):
                itf = itfs[ItfId(node.name, path)]
                itf.sides = 2 if tub else 1
                itf.size = _width_at(node, t) * itf.sides

    # What the neighbours say wins over what a split infers for itself (its base holding
    # the sum of its branches, a folded split's sides on its branches, an unfolded one's
    # tubular base): those only fill in what nothing else fixes. The other order let a
    # split give a branch the base's sides, or a tubular base an odd sum, before the
    # neighbour on the other side (through a joint) said otherwise, and the shape pass got
    # a connection whose two ends disagree (internal errors).
    changed, splits = True, False
    while changed or not splits:
        splits = not changed
        changed = False

        def set_(itf: Interface, size: int | None, sides: int | None) -> None:
            nonlocal changed
            if itf.size is None and size is not None:
                itf.size = size
                changed = True
            if itf.sides is None and sides is not None:
                itf.sides = sides
                changed = True

        for ka, kb in partner.items():
            ia, ib = itfs.get(ka), itfs.get(kb)
            if ia is not None and ib is not None:
                set_(ia, ib.size, ib.sides)
        for node in skel.nodes.values():
            paths = [itfs[ItfId(node.name, p)] for p in node.interface_paths]
            if node.kind == "joint":
                bot, top = paths
                set_(bot, top.size, top.sides)
                set_(top, bot.size, bot.sides)
            elif node.kind == "split" and splits:
                base, branches = paths[0], paths[1:]
                if all(b.size is not None for b in branches):
                    all_sides = {b.sides for b in branches}
                    folded_sides = all_sides.pop() if len(all_sides) == 1 else None
                    total = sum(b.size for b in branches if b.size is not None)
                    if (base.sides or (folded_sides if node.props["folded"] else 2)) == 2:
                        total += total % 2  # a tubular base holds whole rows on both beds
                    set_(base, total, folded_sides if node.props["folded"] else None)
                unknown = [b for b in branches if b.size is None]
                if base.size is not None and len(unknown) == 1 and unknown[0].state != "connected":
                    rest = base.size - sum(b.size for b in branches if b.size is not None)
                    if rest > 0:  # an open branch takes what the others leave (original)
                        set_(unknown[0], rest, None)
                if base.sides is not None and node.props["folded"]:
                    for b in branches:
                        set_(b, None, base.sides)
                if not node.props["folded"]:
                    for b in branches:
                        set_(b, None, 1)
                    set_(base, None, 2)
            elif node.kind == "sheet" and node.tubular is None:
                bot, top = paths
                sides = bot.sides or top.sides
                one = int(cast(float, node.props["length"])) == 1
                if sides is not None:
                    for p, t in ((bot, 0.0), (top, 0.0 if one else 1.0)):
                        set_(p, _width_at(node, t) * sides, sides)


def binding(skel: Skeleton, a: ItfId, b: ItfId) -> str:
    """How a connection joins its two courses (thesis ch. 5.2, the original's rules):
    `merge` (one shared course), `close` (the larger, tubular side is closed 2:1, then
    merged), `gauge` (different gauges with equal counts or equal needle spans), `spread`
    (anything else: up to two wales per stitch, extras without), or `unknown` sizes.
    The verifier warns from it and the shape pass builds from it."""
    ia, ib = skel.interfaces[a], skel.interfaces[b]
    if ia.size is None or ib.size is None:
        return "unknown"
    ga = 2 if skel.nodes[a.node].props.get("gauge") == "half" else 1
    gb = 2 if skel.nodes[b.node].props.get("gauge") == "half" else 1
    if ga != gb:
        return "gauge" if ia.size == ib.size or ia.size * ga == ib.size * gb else "spread"
    if ia.size == ib.size:
        return "merge"
    big, small = (ia, ib) if ia.size > ib.size else (ib, ia)
    assert big.size is not None and small.size is not None  # checked above
    return "close" if big.size == 2 * small.size and big.sides == 2 else "spread"


# ---- verifier -----------------------------------------------------------------------------


def verify(skel: Skeleton, diags: Diagnostics) -> None:
    """Check the skeleton's topology; report located errors and warnings."""
    seen: dict[ItfId, Connection] = {}
    valid: list[Connection] = []
    for c in skel.connections:
        bad = False
        for end in (c.a, c.b):
            if end in seen:
                first = seen[end]
                diags.error(
                    "E501",
                    f"interface `{end}` is connected twice",
                    c.span,
                    notes=[Note("first connected here", first.span)],
                    hint="each interface joins at most one other; use a split to join several",
                )
                bad = True
            elif skel.interfaces[end].state == "closed":
                diags.error(
                    "E502",
                    f"interface `{end}` is closed and cannot be connected",
                    c.span,
                    notes=[Note("closed here", skel.interfaces[end].span)],
                )
                bad = True
        if c.a == c.b or c.a.node == c.b.node:
            diags.error(
                "E503",
                f"`{c.a}` and `{c.b}` belong to the same node",
                c.span,
                hint="a node cannot be connected to itself",
            )
            bad = True
        for end in (c.a, c.b):
            seen.setdefault(end, c)
        if not bad:
            valid.append(c)
            skel.interfaces[c.a].state = skel.interfaces[c.b].state = "connected"
    skel.connections = valid

    infer_sizes(skel)
    for c in valid:
        a, b = skel.interfaces[c.a], skel.interfaces[c.b]
        if a.size is None or b.size is None:
            continue
        if c.a.node in skel.tainted or c.b.node in skel.tainted:
            continue
        kind = binding(skel, c.a, c.b)
        if kind == "spread" and skel.nodes[c.a.node].props.get("gauge") != skel.nodes[
            c.b.node
        ].props.get("gauge"):
            diags.warning(
                "W502",
                f"width mismatch across a gauge change: `{a.id}` and "
                f"`{b.id}` have neither the same stitches ({a.size}, {b.size}) nor "
                "the same needle span",
                c.span,
                hint="across a gauge change, a half-gauge side needs the same "
                "stitches or half those of the full-gauge side",
            )
        elif kind == "close":
            big, small = (a, b) if a.size > b.size else (b, a)
            diags.warning(
                "W501",
                f"`{big.id}` has {big.size} stitches and `{small.id}` has "
                f"{small.size}: the tube is closed 2:1 before the merge",
                c.span,
                hint="make both sides the same size to merge them stitch by stitch",
            )
        elif kind == "spread":
            diags.warning(
                "W502",
                f"size mismatch: `{a.id}` has {a.size} stitches, `{b.id}` "
                f"has {b.size}; the extra stitches are spread without wales",
                c.span,
                hint="make both sides the same size, or put a sheet with a width "
                "profile between them to shape the transition",
            )

    for node in skel.nodes.values():
        if node.name in skel.tainted:
            continue
        paths = [skel.interfaces[ItfId(node.name, p)] for p in node.interface_paths]
        if node.kind == "split":
            base, branches = paths[0], paths[1:]
            if base.size is not None and all(b.size is not None for b in branches):
                total = sum(b.size for b in branches if b.size is not None)
                if total > base.size:
                    diags.error(
                        "E504",
                        f"the branches of split `{node.name}` need {total} "
                        f"stitches but its base has {base.size}",
                        node.span,
                        hint="widen the node at the base or narrow the branches",
                    )
        if node.kind == "joint":
            bot, top = paths
            if bot.size is not None and top.size is not None and bot.size != top.size:
                diags.error(
                    "E509",
                    f"joint `{node.name}` joins {bot.size} stitches at its "
                    f"bottom to {top.size} at its top",
                    node.span,
                    hint="short rows keep the course size: make both neighbours the "
                    "same size, and shape with a sheet's width profile instead",
                )
        if node.kind == "sheet" and node.tubular is None and paths[0].sides is None:
            diags.error(
                "E510",
                f"cannot tell whether `{node.name}` is flat or tubular",
                node.span,
                hint="connect it to a flat or tubular neighbour, or set "
                "`type: flat` or `type: cylinder`",
            )
            continue
        for itf in paths:
            if itf.size is None and node.kind in ("joint", "split"):
                diags.error(
                    "E505",
                    f"cannot infer the size of `{itf.id}`",
                    node.span,
                    hint=f"connect `{itf.id}` to a sheet or tube, which fixes its size",
                )
                break
            if itf.state == "closed" and itf.sides == 1:
                diags.warning(
                    "W503",
                    f"closing the flat interface `{itf.id}` has no effect",
                    itf.span,
                    hint="only tubular interfaces are closed; a flat edge is cast off",
                )

    _check_starts(skel, diags)


def _check_starts(skel: Skeleton, diags: Diagnostics) -> None:
    by_node: dict[str, list[YarnStart]] = {}
    for s in skel.starts:
        by_node.setdefault(s.itf.node, []).append(s)
        itf = skel.interfaces[s.itf]
        if itf.state == "connected":
            diags.error(
                "E506",
                f"the yarn cannot start at `{s.itf}`, which is connected",
                s.span,
                hint="start at an open or closed end of the garment",
            )
    starts: list[YarnStart] = []
    for comp in skel.components():
        declared = [s for n in comp for s in by_node.get(n, [])]
        if len(declared) > 1:
            for extra in declared[1:]:
                diags.error(
                    "E507",
                    "a second yarn start in the same garment",
                    extra.span,
                    notes=[Note("first start here", declared[0].span)],
                    hint="each connected garment has one yarn start",
                )
        if declared:
            starts.append(declared[0])
            continue
        free = [
            skel.interfaces[ItfId(n, p)]
            for n in comp
            for p in skel.nodes[n].interface_paths
            if skel.interfaces[ItfId(n, p)].state != "connected"
        ]
        if not free:
            diags.error(
                "E508",
                f"no place to start the yarn in the garment of `{comp[0]}`: "
                "every interface is connected",
                skel.nodes[comp[0]].span,
                hint="leave an interface open or closed, and `start` there",
            )
            continue
        starts.append(YarnStart(free[0].id, True, None))
    skel.starts = starts


# ---- stable JSON ------------------------------------------------------------------------------


def _value_json(v: Any) -> Any:
    if isinstance(v, Profile):
        return v.to_json()
    if isinstance(v, tuple):
        return [_value_json(x) for x in v]
    if isinstance(v, float) and v.is_integer():
        return int(v)
    if hasattr(v, "name") and not isinstance(v, str):
        return v.name
    return v


def to_json(skel: Skeleton) -> dict[str, Any]:
    """The stable dump of `knitc --emit skeleton` (keys sorted by the caller's encoder)."""
    from knitc.frontend.fmt import format_layer_stmt

    m = skel.machine
    return {
        "machine": {
            "model": m.model,
            "needles": m.needles,
            "gauge": m.gauge,
            "racking": m.racking,
            "carriers": list(m.carriers),
            "increase": m.increase,
            "cast_on": m.cast_on,
            "cast_off": m.cast_off,
        },
        "params": {k: _value_json(v) for k, v in skel.params.items()},
        **(
            {
                "yarns": [
                    {
                        "name": y.name,
                        "carrier": y.carrier,
                        "carry_up": y.carry_up,
                        "tuck_every": y.tuck_every,
                        **({"colour": y.colour} if y.colour else {}),
                        **({"plating": y.plating} if y.plating is not None else {}),
                        **({"inlay": y.inlay} if y.inlay else {}),
                    }
                    for y in skel.yarn_list
                ]
            }
            if len(skel.yarns) > 1 or any(y.span is not None for y in skel.yarns.values())
            else {}
        ),
        "nodes": [
            {
                "name": n.name,
                "kind": n.kind,
                "props": {k: _value_json(v) for k, v in n.props.items()},
                "interfaces": n.interface_paths,
                "span": n.span.to_json(),
            }
            for n in skel.nodes.values()
        ],
        "interfaces": [
            {
                "id": str(i.id),
                "node": i.id.node,
                "path": i.id.path,
                "state": i.state,
                "closing": i.closing,
                "cast_on": i.cast_on,
                "cast_off": i.cast_off,
                "size": i.size,
                "sides": i.sides,
            }
            for i in skel.interfaces.values()
        ],
        "connections": [
            {"a": str(c.a), "b": str(c.b), "span": c.span.to_json()} for c in skel.connections
        ],
        "starts": [{"interface": str(s.itf), "inferred": s.inferred} for s in skel.starts],
        "components": skel.components(),
        "layers": [
            {
                "target": lay.target,
                "stmt": format_layer_stmt(lay.stmt),
                "span": lay.stmt.span.to_json(),
            }
            for lay in skel.layers
        ],
        "definitions": {
            "patterns": sorted(skel.patterns),
            "actions": sorted(skel.actions),
            "shapers": sorted(skel.shapers),
        },
    }
