"""Code generation: traced yarn + layout → machine operations (thesis ch. 6.8).

Courses are knitted in trace order; each course is one slice of ch. 6.8 and runs the code
passes of ch. 6.8.1 in order:

1. shaping: every loop the course knits through is moved to its stitch's needle
   (`transfers.move`); an increase parent's loop goes to its nearer child. A carrier left
   inside the region the transfers span is first kicked out of it with a `miss`, so its
   yarn is not caught by the moving loops (ch. 6.8.2);
2. yarn start and cast-on (`casting`): a yarn that starts on empty needles is hooked in,
   caught and released, and a course of empty needles is cast on as its interface asks
   (`cast_on`, else the machine's); a yarn that starts on live loops is brought in with `in`;
3. action pass: each stitch's action, as pre / main / post steps (the thesis's modular action
   pass; user actions will plug in here): a knit through the loops on its needle, a tuck on
   an empty needle that no loop reaches (a partial cast-on, or the first course of
   `cast_on: none`), and for increases the node's `increase`: `kickback` (the child without
   its parent's loop is a tuck in the opposite direction, so the new loop is wrapped around
   its needle rather than laid in as a yarn-over) or `split` (the parent's loop is split:
   a new loop through it on its needle while the old loop goes to the facing needle and
   stands for the other child, which the carriage misses; knitsketching's SPLIT + MISS;
   the split's post step transfers the old loop on to the other child's needle);
4. cast-off of the stitches that end, as their interface asks (`cast_off`), then the catching
   tucks of a new yarn are dropped;
5. yarn end: the bind-off's tail, a kickback `miss` out of the fabric, `outhook`.

Each kind of pass sets its `x-stitch-number` (`casting.StitchNumbers`); short rows press
the fabric (`x-presser-mode auto`). Every operation keeps the stitch it came from; the span
is the stitch's declaration.
"""

from __future__ import annotations

from bisect import bisect_right
from collections import Counter
from collections.abc import Mapping, Sequence
from dataclasses import field
from functools import partial

import numpy as np

from knitc import arrays
from knitc.codegen import actions
from knitc.codegen import casting as cast
from knitc.codegen import yarn_stack as stk
from knitc.codegen.bed import BEDS, Bed, Pos, Unsupported
from knitc.codegen.bed import needle as needle_of
from knitc.codegen.machine import Machine, MachineProgram, racking_for
from knitc.codegen.steps import (
    Action,
    continues_in_place,
    empty_needle_number,
    run_actions,
    run_by_depth,
)
from knitc.codegen.transfers import move
from knitc.diagnostics import Diagnostics
from knitc.frontend import skeleton as sk
from knitc.patterning import actions as pattern_actions
from knitc.patterning.instructions import CROSSES, MOVES, cables, neighbour, origin_site, right_left
from knitc.records import record
from knitc.scheduling import schedule as sc
from knitc.scheduling import trace as tr
from knitc.shaping.stitch_graph import COURSE_KINDS, INSTRUCTIONS, StitchGraph, two_bed
from knitc.source import Span

SHORT_ROW = COURSE_KINDS.index("short_row")
PURL, STACK = INSTRUCTIONS.index("P"), INSTRUCTIONS.index("S")
REVERSED = [i for i, name in enumerate(INSTRUCTIONS) if name == "P" or name[0] == "B"]
"""Instructions knitted from the facing needle (`_purl`): a purl and the B moves."""
CARRIED = list(MOVES) + list(CROSSES)
"""Instructions whose loops `_carry` takes elsewhere after their course."""


# ---- options ----------------------------------------------------------------------------------


@record(frozen=True)
class CodegenOptions:
    """The fabrication choices code generation follows, resolved from the skeleton.

    An interface's own `cast_on` / `cast_off` wins over the machine's; `auto` interfaces are
    simply absent from the maps. Courses carry interface names (`StitchGraph.course_names`),
    which is how a course finds its setting.
    """

    cast_on: str = "interlock"
    cast_off: str = "pickup"
    increase: str = "kickback"
    interface_cast_on: Mapping[str, str] = field(default_factory=dict)
    interface_cast_off: Mapping[str, str] = field(default_factory=dict)
    interface_span: Mapping[str, Span] = field(default_factory=dict)
    node_increase: Mapping[str, str] = field(default_factory=dict)
    numbers: cast.StitchNumbers = cast.STITCH_NUMBERS
    actions: Sequence = ()
    """The design's actions and the built-ins, ready to run (`patterning.actions.Program`),
    indexed by `StitchGraph.action` (`action_table`: each made at its first use)."""
    yarn_carriers: Sequence[int | None] = ()
    """The carrier each of the design's yarns asked for (`StitchGraph.yarn` numbers them;
    None: any). The first is `main`'s, which takes the machine's carriers in order."""
    yarn_carry_up: Sequence[int] = ()
    """How many courses each yarn may rest at the side (`yarn { carry_up }`)."""
    yarn_tuck_every: Sequence[int] = ()
    """Each yarn's float catching in fair isle (`yarn { tuck_every }`; 0: none)."""
    yarn_plating: Sequence[int | None] = ()
    """Each yarn's plating carrier (`yarn { plating }`; None: none), knitted with it."""
    yarn_inlay: Sequence[int] = ()
    """Each yarn's inlay catching distance (`yarn { inlay }`; 0: a knitting yarn)."""
    yarn_spans: Sequence[Span | None] = ()
    """Each yarn's declaration (None: `main` undeclared), where its hazards are reported."""

    def cast_on_for(self, names: tuple[str, ...]) -> str:
        return next(
            (self.interface_cast_on[n] for n in names if n in self.interface_cast_on), self.cast_on
        )

    def cast_off_for(self, names: tuple[str, ...]) -> str:
        return next(
            (self.interface_cast_off[n] for n in names if n in self.interface_cast_off),
            self.cast_off,
        )

    def increase_for(self, node: str) -> str:
        inc = self.node_increase.get(node, "auto")
        return self.increase if inc == "auto" else inc


def options_from_skeleton(skel: sk.Skeleton) -> CodegenOptions:
    m = skel.machine
    itfs = skel.interfaces.values()
    return CodegenOptions(
        cast_on=m.cast_on,
        cast_off=m.cast_off,
        increase=m.increase,
        interface_cast_on={str(i.id): i.cast_on for i in itfs if i.cast_on != "auto"},
        interface_cast_off={str(i.id): i.cast_off for i in itfs if i.cast_off != "auto"},
        interface_span={str(i.id): i.span for i in itfs if i.span is not None},
        node_increase={
            name: str(n.props.get("increase", "auto")) for name, n in skel.nodes.items()
        },
        actions=action_table(skel),
        yarn_carriers=tuple(y.carrier for y in skel.yarn_list),
        yarn_carry_up=tuple(y.carry_up for y in skel.yarn_list),
        yarn_tuck_every=tuple(y.tuck_every for y in skel.yarn_list),
        yarn_plating=tuple(y.plating for y in skel.yarn_list),
        yarn_inlay=tuple(y.inlay for y in skel.yarn_list),
        yarn_spans=tuple(y.span for y in skel.yarn_list),
    )


def action_table(skel: sk.Skeleton) -> Sequence:
    """The actions (`patterning.actions.Program`) in the order `StitchGraph.action` numbers
    them: the design's and the built-in names, by name (`patterning.actions.table`)."""
    return pattern_actions.table(skel)


# ---- state ------------------------------------------------------------------------------------


@record
class _Gen:
    g: StitchGraph
    sched: sc.Schedule
    t: tr.Trace
    carriers: tuple[int, ...]
    bed: Bed
    opts: CodegenOptions
    diags: Diagnostics
    stacks: stk.YarnStacks
    """Each stitch's yarn stack (`codegen.yarn_stack`): what every yarn of a course part does
    at each of its stitches, read by the passes of several yarns."""
    where_span: Span | None = None
    """The span of the course being generated, for diagnostics."""
    carrier_of: dict[int, int] = field(default_factory=dict)
    """Yarns in action -> their carrier."""
    presser: str = "off"
    reverse_conflicts: Counter = field(default_factory=Counter)
    """Pattern statements (`g.origin`) -> reverse stitches knitted plain because the facing
    needle holds fabric (a full-gauge tube)."""
    course_needles: set[Pos] = field(default_factory=set)
    """Where the stitches of the course being knitted are knitted (set once per course)."""
    realigned: dict[int, Pos] = field(default_factory=dict)
    """Stitches of the course being knitted whose loops a later slice's layout moved (the
    alignment between a course's slices) -> where that layout put them, which is where
    the course's moves and crosses find them (`_carry`)."""
    fetch: set[int] = field(default_factory=set)
    """Siblings of closing splits in a later slice: they fetch the split's old loop."""
    split_fallbacks: Counter = field(default_factory=Counter)
    """Nodes -> split increases that had to use a kickback (no free needle to split to)."""
    warned: set[str] = field(default_factory=set)
    knit_bed: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int8))
    knit_needle: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int32))
    """Where the schedule knits each stitch (`schedule.knit_positions`)."""
    positions: list[Pos] = field(default_factory=list)
    """The same as (bed name, needle) pairs (`pos`)."""
    forks: set[int] = field(default_factory=set)
    """Stitches with two children: the parents of the increases (`_increases`)."""

    action_state: object = None
    """What `patterning.actions` computes once per program (its own business)."""
    carrying: np.ndarray = field(default_factory=lambda: np.zeros(0, bool))
    """Per course: whether moves or crosses carry loops after it (`_carry`)."""
    sides: tuple | None = None
    """`instructions.right_left(g)`, computed when a course first carries loops."""

    dirs: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int8))
    """Per visit, the carriage direction on the needles the schedule knits it on (the
    trace's is the design frame's: a rotated ring or a mirrored row reverses it)."""

    # colourwork (empty without it)
    free: list[int] = field(default_factory=list)
    """Carriers no yarn holds, in the order they are taken (`_run`'s list)."""
    course_yarn: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int8))
    """Per course, the design's yarn that carries it (`StitchGraph.course_yarn`)."""
    back_courses: dict[int, list[int]] = field(default_factory=dict)
    """The design's yarn -> the courses of several yarns where it floats behind another
    (fair isle), in order."""
    back: dict[int, int] = field(default_factory=dict)
    """The design's yarns in for fair isle courses, not held by a strand of the trace ->
    their carrier."""
    strand_yarn: dict[int, int] = field(default_factory=dict)
    """A strand of the trace (a yarn in action) -> the design's yarn it is."""
    caught: dict[int, int] = field(default_factory=dict)
    """A resting carrier -> the course its rest began or it was last caught into the edge."""
    jacquard: np.ndarray = field(default_factory=lambda: np.zeros(0, bool))
    """Per course: whether a stitch of it has a two-bed backing (`backing`)."""
    region_yarns: dict[int, list[int]] = field(default_factory=dict)
    """Node -> the yarns of its jacquard stitches, ascending: each knits every jacquard
    course of the node, its back needles at least."""
    intarsia: np.ndarray = field(default_factory=lambda: np.zeros(0, bool))
    """Per course: an intarsia course, knitted by the local yarns of its regions (`_intarsia_pass`)."""
    region_carrier: dict[int, int] = field(default_factory=dict)
    """The local yarns of intarsia regions in action (strands of the trace, tracing's R7)
    -> their carriers. They are not in `carrier_of`: no other course takes them, and a
    region's yarn is not caught into the edge while it waits."""
    join: tuple[int, int, int] | None = None
    """An intarsia tuck join waiting for the next slice (carrier, direction, the stitch whose
    statement it points at): the next run is tucked on once its slice is placed, so the
    tuck is where that slice's shaping left the loops."""
    round_parts: list[np.ndarray] = field(default_factory=list)
    """The slices of an intarsia round seen so far: it is knitted once all are placed."""
    backed_list: list[bool] = field(default_factory=list)
    kid_list: list[int] = field(default_factory=list)
    """`backed` and each stitch's child (or -1) as lists, for per-loop look-ups."""
    taken: list[tuple[int, int, int]] = field(default_factory=list)
    """(op index, carrier, design yarn): a carrier taken for a yarn from that op on
    (`_take_carrier`), so `_plate` knows whose each carrier's ops are."""
    catch: list[Pos] = field(default_factory=list)
    """The catching tucks of the yarn start being knitted (a cast-on's, or a jacquard yarn's
    brought in for its pass, `_back_carrier`): dropped once a pass holds the yarn."""
    backing_at: dict[Pos, int] = field(default_factory=dict)
    """Back needles holding a jacquard backing's loop -> the stitch it is behind."""

    def __post_init__(self) -> None:
        self.knit_bed, self.knit_needle = sc.knit_positions(self.sched, self.g.n_stitches)
        # (bed, needle) of every stitch as Python values, made once: `pos` is asked about
        # six times per stitch, and indexing numpy arrays one scalar at a time is slow
        self.positions = [
            (BEDS[b], n)
            for b, n in zip(self.knit_bed.tolist(), self.knit_needle.tolist(), strict=True)
        ]
        t = self.t
        self.dirs = sc.carriage_directions(
            self.sched, t.stitch, tr.sweeps(self.g, t.stitch, t.yarn)
        )
        g = self.g
        self.forks = set(np.nonzero((g.wale_next >= 0).sum(axis=1) == 2)[0].tolist())
        self.carrying = np.zeros(g.n_courses, bool)
        self.carrying[g.course[np.isin(g.instr, CARRIED)]] = True
        jacquard = two_bed(g.backing) if g.backing is not None else None
        if g.colourwork or (jacquard is not None and jacquard.any()):
            assert g.yarn is not None
            self.course_yarn = g.course_yarn()  # (stripes too: a new strand's yarn)
            other = g.yarn != np.repeat(self.course_yarn, g.course_len)
            back: dict[int, set[int]] = {}
            intarsia = self.course_yarn == len(g.yarn_names)
            if intarsia.any():  # (an intarsia course has no back yarns: `_intarsia_pass`)
                other &= ~intarsia[g.course]
                self.intarsia = intarsia
            for c in arrays.unique(g.course[other]).tolist():
                for y in set(g.yarn[g.course_ids(c)].tolist()) - {int(self.course_yarn[c])}:
                    back.setdefault(y, set()).add(c)
            if jacquard is not None and jacquard.any():
                self.jacquard = np.zeros(g.n_courses, bool)
                self.jacquard[g.course[jacquard]] = True
                self.region_yarns = stk.region_yarns(g)
                self.backed_list = self.stacks.backed.tolist()
                self.kid_list = g.wale_next.max(axis=1).tolist()
                for c in np.nonzero(self.jacquard)[0].tolist():
                    for y in self.region_yarns[int(g.course_node[c])]:
                        if y != int(self.course_yarn[c]):
                            back.setdefault(y, set()).add(c)
            self.back_courses = {y: sorted(cs) for y, cs in back.items()}
        if g.inlay is not None and g.inlay.any():  # an inlay yarn rests between its courses
            laid = g.inlay > 0
            for y in arrays.unique(g.inlay[laid]).tolist():
                cs = set(arrays.unique(g.course[laid & (g.inlay == y)]).tolist())
                self.back_courses[y] = sorted(cs | set(self.back_courses.get(y, [])))

    def pos(self, s: int) -> Pos:
        return self.positions[s]

    def ctx(self, carrier: int, s: int) -> cast.Ctx:
        return cast.Ctx(self.bed, carrier, self.opts.numbers, self.bed.span(int(s)))


def generate(
    g: StitchGraph,
    sched: sc.Schedule,
    t: tr.Trace,
    *,
    machine: Machine,
    carriers: tuple[int, ...],
    diags: Diagnostics,
    options: CodegenOptions | None = None,
    stacks: stk.YarnStacks | None = None,
) -> MachineProgram | None:
    """The machine program for the whole trace; None (with an error) if something cannot
    be knitted yet. `stacks`: the yarn stacks of the pipeline's `yarn-stack` stage (made
    here from the options when not given)."""
    prog = MachineProgram(machine)
    opts = options or CodegenOptions()
    if stacks is None:
        stacks = stk.stack_yarns(g, t, sched, opts.yarn_tuck_every, opts.yarn_inlay)
    assert stacks.front.shape[0] == g.n_stitches, "yarn stacks of another stitch graph"
    gen = _Gen(g, sched, t, carriers, Bed(g, prog, machine.racking_limit), opts, diags, stacks)
    try:
        _run(gen)
        _plate(gen)
    except Unsupported as exc:
        diags.error(
            "E602",
            f"cannot generate machine code: {exc}",
            gen.where_span,
            hint=exc.hint
            or "the transfer planner found no sequence of transfers within the "
            "machine's racking limit and free needles; allow more racking "
            "(`machine { racking: ... }`) or shape more gradually",
        )
        return None
    for origin, n in sorted(gen.reverse_conflicts.items()):
        span, notes = origin_site(g, origin)
        diags.warning(
            "W603",
            f"{n} reverse stitch(es) are knitted plain: the needle facing "
            "them holds another loop (on a full-gauge tube, the other side's "
            "fabric)",
            span,
            notes=notes,
            hint="knit this node in half gauge (`gauge: half`) to leave the "
            "facing needles empty for reverse stitches",
        )
    for node, n in sorted(gen.split_fallbacks.items()):
        ids = np.nonzero(g.node == node)[0]
        diags.warning(
            "W602",
            f"{n} split increase(s) of `{g.node_names[node]}` use a kickback "
            "increase: no needle on the other bed was free to split onto, or the "
            "yarn would have floated past two split stitches in a row",
            gen.bed.span(int(ids[0])) if ids.size else None,
            hint="split increases need the facing needle free: use half gauge, "
            "or `increase: kickback`",
        )
    return prog


def _plate(gen: _Gen) -> None:
    """A plated yarn's ops (`yarn { plating }`) with its plating carrier after its own in
    the carrier set (`knit + f5 5 6`: its yarn on the face, the plating yarn behind). Made
    on the finished program, from the log of which yarn took which carrier when.

    The inserting hook holds one yarn: a yarn started on the hook makes its catching tucks
    and its cast-on alone, and its plating yarn comes in (`in`) at its first knit, onto
    loops that hold it (a `miss` first parks it there: a carrier brought in is first used
    in the set it came in with). Any other yarn comes in with its plating (`in 5 6`).

    A stitch that a decrease stacks onto another is knitted by the face yarn alone (the
    plating yarn floats past it): two plated stitches on one needle would be four loops
    of yarn, and this way a decrease stacks two or three.

    The bind-off is knitted by the face yarn alone: each chain stitch draws the two yarns'
    loops into one, so the chain moves one loop onto the next needle's two (a plated chain
    would stack four); so is a jacquard back layer, which closes onto the plated stitches
    in front of it, and so are the catching tucks (a float's, a resting yarn's, an
    intarsia join), which ride on a plated stitch's two loops. Before the yarn's `outhook` the plating yarn goes out (`out`)."""
    plating = gen.opts.yarn_plating
    if not any(p is not None for p in plating):
        return
    prog = gen.bed.prog
    owner: dict[int, int] = {}  # carrier -> the design yarn holding it
    hooked: set[int] = set()  # carriers started on the hook: their plating is not in yet
    plated: dict[int, int] = {}  # the design yarn -> its carrier whose plating is in
    g = gen.g
    dec = np.nonzero((g.wale_prev >= 0).sum(axis=1) == 2)[0]
    stacked = set(g.wale_prev[dec].ravel().tolist()) - {-1}  # a decrease's parents
    log = iter(sorted(gen.taken))
    nxt = next(log, None)

    def partner(c: int) -> int | None:
        y = owner.get(c)
        return plating[y] if y is not None and y < len(plating) else None

    def plating_in(c: int) -> None:
        """The plating of carrier c comes in: its yarn's one plating carrier is taken."""
        y = owner[c]
        if plated.get(y, c) != c:
            gen.where_span = gen.opts.yarn_spans[y] if y < len(gen.opts.yarn_spans) else None
            raise Unsupported(
                f"yarn `{gen.g.yarn_names[y]}` is plated and would knit with two carriers "
                "at once (two intarsia regions, or two pieces side by side), but it has one "
                "plating carrier",
                hint="knit a plated yarn one piece and one region at a time, or declare a "
                "second yarn with a plating of its own",
            )
        plated[y] = c

    out: list = []
    for i, op in enumerate(prog.ops):
        while nxt is not None and nxt[0] <= i:
            owner[nxt[1]] = nxt[2]
            nxt = next(log, None)
        cs = op.carriers
        pairs = [(c, partner(c)) for c in cs]
        if not any(p is not None for _, p in pairs):
            out.append(op)
            continue
        kind = op.kind
        if kind == "inhook":
            hooked.update(cs)
            out.append(op)
        elif kind == "releasehook":
            out.append(op)
        elif kind == "in":
            for c, p in pairs:
                if p is not None:
                    plating_in(c)
            out.append(op._replace(carriers=cs + tuple(p for _, p in pairs if p is not None)))
        elif kind in ("outhook", "out"):
            gone = [(c, p) for c, p in pairs if p is not None and plated.get(owner[c]) == c]
            if gone:  # (a plating that came in goes out with its yarn)
                out.append(op._replace(kind="out", carriers=tuple(p for _, p in gone)))
            for c, _ in gone:
                del plated[owner[c]]
            hooked.difference_update(cs)
            out.append(op)
        elif op.phase in ("cast_off", "backing", "float_catch") or (  # (the face yarn alone)
            op.stitch >= 0 and op.phase == "action" and op.stitch in stacked
        ):
            out.append(op)
        else:
            if kind == "knit" and hooked & set(cs):  # the first knit: the plating comes in,
                # its first use alone (a miss that parks it where the knit starts), as a
                # carrier brought in must first be used in the set it came in with
                firsts = [c for c, p in pairs if p is not None and c in hooked]
                for c in firsts:
                    plating_in(c)
                ready = tuple(p for c, p in pairs if p is not None and c in hooked)
                out.append(op._replace(kind="in", carriers=ready, needle=None, dir=0))
                out.append(op._replace(kind="miss", dir=-op.dir, carriers=ready, stitch=-1))
                hooked.difference_update(cs)
            both: list[int] = []
            for c, p in pairs:
                both += [c] if p is None or c in hooked else [c, p]
            out.append(op._replace(carriers=tuple(both)))
    prog.ops[:] = out


def _node_span(gen: _Gen, node: int) -> Span | None:
    ids = np.nonzero(gen.g.node == node)[0]
    return gen.bed.span(int(ids[0])) if ids.size else None


def _run(gen: _Gen) -> None:
    """Courses in trace order, each cut where the schedule's slices begin: before each slice
    the shaping pass puts the loops where its layout wants them; a course's cast-on comes
    with its first part and its cast-off after its last."""
    g, t = gen.g, gen.t
    plates = {c for c in gen.opts.yarn_plating if c is not None}  # (no strand's own)
    every = range(1, gen.bed.prog.machine.carriers + 1)
    free = gen.free = list(dict.fromkeys(c for c in (*gen.carriers, *every) if c not in plates))
    slices = gen.sched.slices
    cuts, course_bounds = stk.part_cuts(g, t, gen.sched)
    placements = sc.placements(g, gen.sched)
    slice_starts = set(slices.visit.tolist())
    ci = 0  # index of the current course in course_bounds
    chunk = np.zeros(0, np.int64)
    primary: dict[int, int] = {}
    ctx: cast.Ctx | None
    carrier, ctx = -1, None
    for sub in np.split(np.arange(t.n_visits), cuts):
        if sub.size == 0:
            continue
        v0 = int(sub[0])
        ids = t.stitch[sub]
        gen.where_span = gen.bed.span(int(ids[0]))
        prog = gen.bed.prog
        if v0 in slice_starts:
            _, aligned, represented = next(placements)
            with prog.code_pass("alignment"):
                _place(gen, aligned, represented, int(ids[0]))
        if v0 == course_bounds[ci]:  # a course begins
            chunk = np.arange(course_bounds[ci], course_bounds[ci + 1])
            gen.course_needles = set(map(gen.positions.__getitem__, t.stitch[chunk].tolist()))
            gen.realigned = {}
            ci += 1
            primary = {}
            yarn = int(t.yarn[v0])
            # (an intarsia course's regions' local yarns come in in `_intarsia_pass`)
            local = bool(gen.intarsia.size and gen.intarsia[g.course[ids[0]]])
            new = not local and yarn not in gen.carrier_of
            if new:
                design = int(gen.course_yarn[g.course[ids[0]]]) if gen.course_yarn.size else 0
                if design in gen.back:  # in already, for fair isle: the strand takes it
                    gen.carrier_of[yarn] = gen.back.pop(design)
                    new = False
                else:
                    gen.carrier_of[yarn] = _take_carrier(gen, free, design)
                gen.strand_yarn[yarn] = design
            carrier = NO_CARRIER if local else gen.carrier_of[yarn]
            ctx = gen.ctx(carrier, int(ids[0]))
            gen.catch = []
            cids = t.stitch[chunk]
            if all(int(g.wale_prev[s, 0]) < 0 for s in cids):
                gen.catch = _cast_on(gen, ctx, chunk, new)
            elif new:
                with prog.code_pass("yarn_start"):
                    prog.in_((carrier,), stitch=int(cids[0]), span=ctx.span)
            _presser(gen, int(g.course[cids[0]]))
        assert ctx is not None  # the first visit begins a course
        with prog.code_pass("shaping"):
            primary.update(_shaping(gen, sub))
        with prog.code_pass("action"):
            knitted = _action_pass(gen, ctx, sub, primary)
            if gen.g.inlay is not None and knitted.size:  # (an intarsia round: once whole)
                _inlay_pass(gen, knitted)
        # the yarn has caught on the first part's stitches: the catching tucks go before the
        # next slice's shaping can need their needles
        _drop_catch(gen)
        if int(sub[-1]) + 1 == course_bounds[ci]:  # the course is done
            with prog.code_pass("action"):  # the moves and crosses finish the instructions
                _carry(gen, chunk)
            _finish_course(gen, ctx, chunk, carrier, free)
        else:
            # Ending stitches wait for the course's cast-off (one chain around it), unless
            # the schedule lets a later slice of the course knit on one of their needles:
            # then this slice gets its own cast-off pass (ch. 6.8), with its own tail.
            ends = ids[g.wale_next[ids, 0] < 0].tolist()
            if ends and _reused_later(gen, ends, t.stitch[int(sub[-1]) + 1 : course_bounds[ci]]):
                with prog.code_pass("cast_off"):
                    left, last_dir = _cast_off(gen, ctx, sub, ends)
                if left >= 0:
                    with prog.code_pass("yarn_end"):
                        _tail_and_drop(ctx, left, last_dir)
    leftover = [pos for pos, n in gen.bed.loops.items() if n > 0]
    if leftover:
        raise Unsupported(f"{len(leftover)} loops would be left on the needles")


def _drop_catch(gen: _Gen) -> None:
    """Drop the catching tucks of a yarn start (`_Gen.catch`) once a pass holds the yarn."""
    if gen.catch:
        with gen.bed.prog.code_pass("yarn_start"):
            for p in gen.catch:
                if gen.bed.loops.get(p, 0):
                    gen.bed.drop(p, -1)
        gen.catch = []


def _take_carrier(gen: _Gen, free: list[int], yarn: int) -> int:
    """A carrier for a new strand of the design's yarn `yarn`: the one the yarn asked for
    when it is free, else the first free one no other yarn asked for. `main`'s strands
    take the machine's carriers in the order `free` lists them, `main`'s own first, a
    carrier taken out going last, as in a one-yarn design (a sleeve beside the body needs
    a carrier of its own; the same carrier brought straight back in would drag its cut
    yarn across, as the independent machine sees it); another yarn comes back on its own."""
    asked = gen.opts.yarn_carriers
    want = asked[yarn] if 0 < yarn < len(asked) else None
    if want is not None and want in free:
        free.remove(want)
        gen.taken.append((len(gen.bed.prog.ops), want, yarn))
        return want
    reserved = {c for i, c in enumerate(asked) if c is not None and i != yarn and i > 0}
    for i, c in enumerate(free):
        if c not in reserved:
            gen.taken.append((len(gen.bed.prog.ops), c, yarn))
            return free.pop(i)
    n = gen.bed.prog.machine.carriers
    raise Unsupported(
        f"more than {n} yarns would be in use at once",
        hint=f"the machine has {n} carriers: let yarns rest less before they are taken out "
        "(`yarn { carry_up: ... }`), or use fewer yarns in the same courses",
    )


def _lead_out(gen: _Gen, ctx: cast.Ctx, sub: np.ndarray) -> None:
    """End a pass (its main steps) past the needle where its yarn's next pass starts, the
    other way: the carrier is then already on the side that pass starts from. Without it a
    Shima DAT needs a carrier move of its own (a kickback row, two with the converter's
    rules) before the next pass: at a half-gauge tube's fold, a purl knitted on the facing
    needle leaves the carrier beyond the next round's first needle."""
    t = gen.t
    v = int(sub[-1])
    w = v + 1
    if w < t.n_visits and t.yarn[w] == t.yarn[v]:
        _lead_to(
            gen,
            ctx,
            int(gen.dirs[v]),
            gen.pos(int(t.stitch[w]))[1],
            int(gen.dirs[w]),
            int(t.stitch[v]),
        )


def _lead_to(gen: _Gen, ctx: cast.Ctx, d: int, there: int, nd: int, stitch: int) -> None:
    """Miss on in direction `d` to needle `there` when the yarn's next pass starts there
    going `nd` = -d and the carrier has not passed it yet (`_lead_out`)."""
    here = gen.bed.carrier_at.get(ctx.carrier)
    if nd != -d or here is None or (here - (there - 0.5 * nd)) * nd <= 0:
        return
    if 0 <= there < gen.bed.prog.machine.needles:
        cast.emit(ctx, "miss", d, ("f", there), stitch)


def _reused_later(gen: _Gen, ends: list[int], rest: np.ndarray) -> bool:
    """Whether a stitch still to be knitted in this course lands on an ending loop's needle."""
    held = {gen.bed.where.get(x) for x in ends}
    return any(gen.pos(int(x)) in held for x in rest)


def _finish_course(
    gen: _Gen, ctx: cast.Ctx, chunk: np.ndarray, carrier: int, free: list[int]
) -> None:
    """Cast off what ends, end the yarn if it ends."""
    g, t = gen.g, gen.t
    ids = t.stitch[chunk]
    where = gen.bed.where
    ends = [s for s in ids[g.wale_next[ids, 0] < 0].tolist() if s in where]
    prog = gen.bed.prog
    if gen.backing_at:
        _close_backing(gen, ids)
    with prog.code_pass("cast_off"):
        left, last_dir = _cast_off(gen, ctx, chunk, ends) if ends else (-1, 0)
    if gen.back:
        _end_back_yarns(gen, int(g.course[ids[-1]]), int(ids[-1]))
    if gen.region_carrier:
        _end_regions(gen, chunk)
    if gen.course_yarn.size:
        _catch_resting(gen, ids, carrier)
    with prog.code_pass("yarn_end"):
        # (an intarsia course, NO_CARRIER: its regions' yarns end in `_end_regions`)
        if carrier != NO_CARRIER and t.flags[chunk[-1]] & tr.END:
            tail_pos = cast.tail(ctx, left, last_dir) if left >= 0 else None
            cast.yarn_end(ctx, tail_pos, left if left >= 0 else int(ids[-1]))
            del gen.carrier_of[int(t.yarn[chunk[-1]])]
            free.append(carrier)  # reuse carriers last: a carrier brought back keeps its yarn
        elif carrier != NO_CARRIER and left >= 0:
            _tail_and_drop(ctx, left, last_dir)


# ---- shaping and alignment ----------------------------------------------------------------------


def _place(gen: _Gen, aligned: tuple, represented: tuple, first: int) -> None:
    """The alignment and shaping passes before a slice: held loops move out of the way, then
    every loop the slice's cycle stands for goes where the slice's layout puts it (the
    schedule guarantees no two of them meet on a needle)."""
    bed = gen.bed
    moves = []
    where_get, realigned = bed.where.get, gen.realigned
    for loops, beds, needles in (aligned, represented):
        for s, b, n in zip(loops.tolist(), beds.tolist(), needles.tolist(), strict=True):
            here = where_get(s)
            if here is None:
                continue
            name = BEDS[b]
            if here[1] == n and here[0] == name:  # (most loops: already there)
                realigned[s] = here
                continue
            realigned[s] = to = (name, n)
            if not (here[1] == n and _stays(gen, s)):
                moves.append((s, here, to))
    if moves:
        _park(gen, moves, gen.pos(first)[1])
        bed.prog.stitch_number(gen.opts.numbers.transfer)
        move(bed, moves)


def _shaping(gen: _Gen, sub: np.ndarray) -> dict[int, int]:
    """Make sure every parent loop of the stitches about to be knitted is on its child's
    needle (the schedule already put it there, except where an increase's loop stands for
    a child of a later slice); returns parent -> the child that receives its loop."""
    g, bed = gen.g, gen.bed
    ids = gen.t.stitch[sub]
    in_sub = set(ids.tolist())
    primary: dict[int, int] = {}
    moves = []
    parents = arrays.unique(g.wale_prev[ids])
    parents = parents[parents >= 0]
    where, positions = bed.where, gen.positions
    for p, (k0, k1) in zip(parents.tolist(), g.wale_next[parents].tolist(), strict=True):
        here = where.get(p)
        if here is None:
            continue
        if k1 < 0 or k1 not in in_sub:  # (-1 is never in the sub-pass)
            if k0 not in in_sub:
                continue
            child = k0
        elif k0 in in_sub:  # two children here: the one on the loop's needle, else the first
            child = k1 if positions[k0] != here and positions[k1] == here else k0
        else:
            child = k1
        primary[p] = child
        to = positions[child]
        if here != to and not (here[1] == to[1] and _stays(gen, p)):
            moves.append((p, here, to))
    if moves:
        _park(gen, moves, gen.pos(int(ids[0]))[1])
        bed.prog.stitch_number(gen.opts.numbers.transfer)
        lifted = _lift_stacks(gen, ids, moves)
        move(bed, moves)
        for s, pos, away in lifted:  # S: back on top of the loops that arrived
            bed.set_rack(0)
            bed.xfer(away, pos, s)
    return primary


def _lift_stacks(gen: _Gen, ids: np.ndarray, moves: list) -> list[tuple[int, Pos, Pos]]:
    """S (stack, ch. 4.2.2 step 5): a stitch whose loop a move joins is lifted to the
    facing needle (or its slider) before the moved loop arrives, and put back after, so it
    ends on top of the stack. Returns (stitch, needle, where it waits)."""
    g, bed = gen.g, gen.bed
    arriving = {m[2] for m in moves}
    out = []
    for k in ids.tolist():
        if int(g.wale_prev[k, 1]) < 0 or gen.pos(k) not in arriving:
            continue
        for p in g.wale_prev[k].tolist():
            pos = bed.where.get(p)
            if int(g.instr[p]) != STACK or pos != gen.pos(k):
                continue
            away = _free_facing(gen, pos)
            bed.set_rack(0)
            bed.xfer(pos, away, p)
            out.append((p, pos, away))
    return out


def _free_facing(gen: _Gen, pos: Pos) -> Pos:
    """The needle facing `pos` on the other bed if it is free, else its slider."""
    other = "b" if pos[0] == "f" else "f"
    for cand in ((other, pos[1]), (other + "s", pos[1])):
        if not gen.bed.loops.get(cand, 0) and cand not in gen.course_needles:
            return cand
    raise Unsupported(f"no free needle or slider faces {pos[0]}{pos[1]} to carry its loop")


def _carry(gen: _Gen, chunk: np.ndarray) -> None:
    """The moves and crosses of a course, after it is knitted (ch. 4.2.2 steps 3-5): every
    loop that goes elsewhere leaves for the facing needle (its slider on a full-gauge tube)
    at racking 0, then comes back on its new needle, one racking per displacement: a
    cable's upper run first (its loops end in front where the runs cross), its relief
    stitches, its lower run, then the moves. An S stitch a move lands on is lifted before
    and put back after, so its loop ends on top. Then each needle's loops stand for the
    stitch knitted there (`instructions`): an emptied needle's next stitch is a yarn-over,
    a needle two loops share knits them together."""
    g, bed = gen.g, gen.bed
    ids = gen.t.stitch[chunk]
    codes = g.instr[ids]
    if not gen.carrying[int(g.course[ids[0]])]:
        return
    if gen.sides is None:
        gen.sides = right_left(g)
    right, left = gen.sides
    # where each stitch's loop belongs now: a later slice of the course may have laid the
    # earlier slices' loops out anew (a ring rotated between a tube's two passes)
    home = {int(x): gen.realigned.get(int(x), gen.pos(int(x))) for x in ids}
    rounds: list[list[tuple[int, Pos, Pos]]] = [[], [], [], []]  # upper, relief, lower, moves
    involved: set[int] = set()
    for cab in cables(g, ids, right, left):
        runs = (0, 2) if cab.upper_first else (2, 0)
        for i, (x, j) in enumerate(zip(cab.group, cab.targets(), strict=True)):
            involved.add(x)
            part = runs[0] if i < cab.first else 1 if i < cab.first + cab.relief else runs[1]
            if j != i:
                rounds[part].append((x, home[x], home[cab.group[j]]))
    for x in ids[np.isin(codes, list(MOVES))].tolist():
        t = neighbour(right, left, x, MOVES[int(g.instr[x])])
        involved |= {x, t}
        rounds[3].append((x, home[x], home[t]))
    # a loop is carried from its needle, or (a B move's) from the needle facing it
    moves = [
        m
        for part in rounds
        for m in part
        if bed.where.get(m[0]) in (m[1], ("b" if m[1][0] == "f" else "f", m[1][1]))
    ]
    if not moves:
        return
    _park(gen, moves, gen.pos(int(ids[-1]))[1])
    bed.prog.stitch_number(gen.opts.numbers.transfer)
    bed.set_rack(0)
    waiting = {}
    for x, here, dst in moves:
        if bed.where[x] != here:  # a B move's loop, knitted on the facing needle
            waiting[x] = _across_from(gen, x, here, dst)
            continue
        if here[0] != dst[0]:
            # the layout put the two stitches on opposite beds (a ring rolled between
            # them): the loop goes straight across, no stop on the facing needle, which is
            # on the target's own bed and could not transfer to it
            waiting[x] = here
            continue
        waiting[x] = _free_facing(gen, here)
        bed.xfer(here, waiting[x], x)
    landing = {dst for x, _, dst in moves if int(g.instr[x]) in MOVES}
    lifted = []
    for t in sorted(involved):
        if int(g.instr[t]) == STACK and home[t] in landing and bed.where.get(t) == home[t]:
            lifted.append((t, _free_facing(gen, home[t])))
            bed.xfer(home[t], lifted[-1][1], t)
    ordered = [
        m
        for round_moves in rounds
        for m in sorted(round_moves, key=lambda m: m[2][1] - m[1][1])
        if m[0] in waiting
    ]
    for x, _here, dst in _landing_order(ordered, waiting):
        bed.set_rack(racking_for(needle_of(waiting[x]), needle_of(dst)))
        bed.xfer(waiting[x], dst, x)
    bed.set_rack(0)
    for t, away in lifted:
        bed.xfer(away, home[t], t)
    for x in involved:  # each needle's loops now stand for the stitch knitted there
        at = bed.where.pop(x, None)
        if at is not None:
            bed.at[at].discard(x)
    for x in involved:
        if bed.loops.get(home[x], 0):
            bed.place(x, home[x])


def _landing_order(moves: list, waiting: dict[int, Pos]) -> list:
    """`moves` in their order, except that a loop never lands on a needle whose own loop
    has not left yet: a loop that goes straight across the beds (`_carry`) waits on its
    home needle until its turn, and a loop carried onto that needle (its course neighbour's
    move) would be taken along with it. Such a landing waits until the needle is left.
    Linear: each move is taken once, when the needle it lands on is free."""
    holding: dict[Pos, int] = Counter(waiting[m[0]] for m in moves)
    blocked: dict[Pos, list] = {}
    out: list = []
    for m in moves:
        if holding.get(m[2], 0):
            blocked.setdefault(m[2], []).append(m)
            continue
        ready = [m]
        while ready:
            x = ready.pop()
            out.append(x)
            left = waiting[x[0]]
            holding[left] -= 1
            if not holding[left]:
                ready.extend(reversed(blocked.pop(left, [])))
    if blocked:
        raise Unsupported(
            "loops carried straight across the beds would have to swap needles "
            f"(onto {' '.join(f'{b}{n}' for b, n in sorted(blocked))})"
        )
    return out


def _across_from(gen: _Gen, x: int, home: Pos, dst: Pos) -> Pos:
    """Where the loop of B move `x` (knitted reversed, so waiting on the needle facing its
    `home`) leaves from for `dst`. When the layout put `dst` on the bed facing `home` (a ring
    rolled between the two stitches), the loop waits on the target's own bed, from which no
    transfer reaches it: it first goes back to its home needle (emptied by the reversed
    knit), and then straight across like an F move's."""
    bed = gen.bed
    at = bed.where[x]
    if at[0] != dst[0]:
        return at
    if bed.loops.get(home, 0):
        raise Unsupported(f"no free needle faces {at[0]}{at[1]} to carry its loop")
    bed.xfer(at, home, x)
    return home


def _park(gen: _Gen, moves: list, toward: int) -> None:
    """Kick every carrier left strictly inside the span of `moves` out of it, to the side
    nearer `toward` (where the next knitting starts): a `miss` one needle outside, on a
    needle the transfers do not touch, so the carrier does not follow a moved loop."""
    idx = [m[1][1] for m in moves] + [m[2][1] for m in moves]
    lo, hi = min(idx), max(idx)
    needles = gen.bed.prog.machine.needles
    for carrier in sorted({*gen.carrier_of.values(), *gen.back.values()}):
        at = gen.bed.carrier_at.get(carrier)
        if at is None or not lo < at < hi:
            continue
        sides = sorted([(lo - 1, -1), (hi + 1, 1)], key=lambda s: abs(s[0] - toward))
        for needle, d in sides:
            if 0 <= needle < needles:
                cast.emit(gen.ctx(carrier, -1), "miss", d, ("f", needle))
                break


# ---- cast-on ----------------------------------------------------------------------------------


def _entries(gen: _Gen, chunk: np.ndarray) -> list[cast.Entry]:
    return [
        cast.Entry(gen.pos(int(s)), int(d) or 1, int(s))
        for s, d in zip(gen.t.stitch[chunk], gen.dirs[chunk], strict=True)
    ]


def _cast_on(gen: _Gen, ctx: cast.Ctx, chunk: np.ndarray, new: bool) -> list[Pos]:
    """Yarn start (for a new yarn) and cast-on of a course of empty needles; returns the
    catching needles to drop after the course."""
    g = gen.g
    c = int(g.course[gen.t.stitch[chunk[0]]])
    entries = _entries(gen, chunk)
    kind = gen.opts.cast_on_for(g.course_names.get(c, ()))
    circular = bool(g.course_circular[c])
    if kind == "precast":
        node = int(g.course_node[c])
        cover = _precast_cover(gen, node)
        cover = {p for p in cover if not gen.bed.loops.get(p, 0)} | {e.pos for e in entries}
        plan = cast.plan_precast(entries, cover)
    else:
        plan = cast.plan_cast_on(kind, entries, circular)
    catch: list[Pos] = []
    if new:
        busy = {st.pos for st in plan} | {e.pos for e in entries}
        # a purl or a B move (or an action that transfers) of the first course needs the
        # needle facing it free
        progs = gen.opts.actions
        busy |= {
            ("b" if e.pos[0] == "f" else "f", e.pos[1])
            for e in entries
            if int(g.instr[e.stitch]) in REVERSED
            or (
                0 <= int(g.action[e.stitch]) < len(progs)
                and getattr(progs[int(g.action[e.stitch])], "transfers", False)
            )
        }
        with gen.bed.prog.code_pass("yarn_start"):
            catch = cast.yarn_start(ctx, plan[0] if plan else entries[0], busy, entries[0].stitch)
    with gen.bed.prog.code_pass("cast_on"):
        cast.emit_plan(ctx, plan)
        if plan:  # end past where the first course starts, as an action pass does
            e0 = entries[0]
            _lead_to(gen, ctx, plan[-1].dir, e0.pos[1], e0.dir, plan[-1].stitch)
    return catch


def _precast_cover(gen: _Gen, node: int) -> set[Pos]:
    """The needles a precast may fill: where the node's stitches will be knitted, except
    needles that the schedule's shaping moves reach or pass (in a slice of the node) before
    their stitch is knitted (a loop of no stitch cannot be carried along with the layout,
    it would block the transfers), and needles a closing split brings its old loop to (a
    cast-on loop there would stand in for the loop that closes the end)."""
    g, sched = gen.g, gen.sched
    ids = np.nonzero(g.node == node)[0]
    spans = [
        (k, min(nf.min(), nt.min()), max(nf.max(), nt.max()))
        for k, _lo, _bf, nf, _bt, nt in sc.moves(g, sched)
        if int(sched.slices.node[k]) == node
    ]
    needle = gen.knit_needle[ids].astype(np.int64)
    # the other side's stitch of a closed end opening into a tube knits through the old
    # loop of a split (`_increases`)
    kids = g.wale_next[ids]
    two = (kids >= 0).all(1)
    across = two & (g.side[np.maximum(kids[:, 0], 0)] != g.side[np.maximum(kids[:, 1], 0)])
    fetched = {
        gen.pos(int(k))
        for p, row in zip(ids[across].tolist(), kids[across].tolist())
        for k in row
        if int(g.side[k]) != int(g.side[p])
    }
    blocked = np.zeros(ids.size, bool)
    if spans:
        k, lo, hi = (np.array(c, np.int64) for c in zip(*spans, strict=True))
        when = sc.knit_slices(sched, g.n_stitches)[ids]
        blocked = ((k <= when[:, None]) & (lo <= needle[:, None]) & (needle[:, None] <= hi)).any(
            axis=1
        )  # type: ignore[assignment]
    return {gen.pos(int(x)) for x in ids[~blocked]} - fetched


# ---- action pass ------------------------------------------------------------------------------


FAST_PASSES = True
"""Whether `_action_pass` takes its short cuts: a plain pass knitted in one `Bed.knit_run`,
and the plain knits of a mixed pass knitted in place without an Action each. Off, every
stitch of every pass is an Action run by `run_actions`: the general route, which
tests/test_fast_routes.py holds the short cuts to (the same ops, op for op)."""


def _action_pass(
    gen: _Gen, ctx: cast.Ctx, chunk: np.ndarray, primary: dict[int, int]
) -> np.ndarray:
    """The main steps of a course part; the visits knitted (the part, but for an intarsia
    round: none until its last part, then the whole round)."""
    g = gen.g
    stitches = gen.t.stitch[chunk]
    if gen.intarsia.size and gen.intarsia[g.course[stitches[0]]]:
        return _intarsia_pass(gen, chunk)
    if (  # (a part of a fair isle course may hold only another yarn's stitches)
        gen.course_yarn.size
        and g.yarn is not None
        and stitches.size
        and (
            bool((g.yarn[stitches] != gen.course_yarn[g.course[stitches[0]]]).any())
            or (gen.jacquard.size > 0 and bool(gen.jacquard[g.course[stitches[0]]]))
        )
    ):
        _fair_isle_pass(gen, ctx, chunk)
        return chunk
    incs = _increases(gen, chunk, primary)
    ids = stitches.tolist()
    for s in ids:
        if s in gen.fetch:
            gen.fetch.discard(s)
            incs[s] = ("fetch",)
    # what `_action` asks of every stitch, read from the arrays once per pass
    halves = g.course_gauge[g.course[stitches]] == 2
    numbers = gen.opts.numbers
    # each plain knit's stitch number, and the number of the loop it lays on an empty
    # needle (`empty_needle_number`), for both routes below
    plain = np.where(halves, numbers.knit_half_gauge, numbers.knit)
    empty = np.where(g.wale_prev[stitches, 0] < 0, numbers.cast_on, plain)
    if (
        FAST_PASSES
        and not incs
        and bool((g.action[stitches] < 0).all())
        and bool(np.isin(g.instr[stitches], _KNITTED).all())
    ):
        # A plain pass (no increase, no action, every stitch knitted here): what the
        # general route below does for it, each stitch's one main step in order and the
        # lead-out after the last, without an Action per stitch (most passes are plain);
        # the run as columns, each made at once (a tuple per stitch cost as much as a knit)
        dirs = gen.dirs[chunk]
        gen.bed.knit_run(
            ids,
            np.where(dirs == 0, 1, dirs).tolist(),
            list(map(gen.positions.__getitem__, ids)),
            plain.tolist(),
            empty.tolist(),
            ctx.carrier,
        )
        if ids:
            _lead_out(gen, ctx, chunk)
        if gen.bed.rack:
            gen.bed.set_rack(0)
        return chunk
    # A pass with some actions is still mostly plain knits: those stitches are kept as
    # (stitch, direction, needle, number, empty-needle number), not as an Action each, and
    # knitted in their place among the main steps, each run of them in one `Bed.knit_run`
    # (they have no pre or post steps, so the other stitches' steps run in the same order
    # as if they had an empty Action each).
    items: list[Action | _Plain] = []
    for s, d, h, a, i, k, e in zip(
        ids,
        gen.dirs[chunk].tolist(),
        halves.tolist(),
        g.action[stitches].tolist(),
        g.instr[stitches].tolist(),
        plain.tolist(),
        empty.tolist(),
        strict=True,
    ):
        if a < 0 and i in _KNITTED_SET and s not in incs:
            items.append((s, d or 1, gen.positions[s], k, e))
        else:
            items.append(_action(gen, ctx, s, d or 1, incs.get(s), h, a, i))
    acts = [a for a in items if isinstance(a, Action)]
    if FAST_PASSES and not actions.splits_by_side(acts):
        actions.prepare_pass(gen, acts)  # (one sub-pass; its warnings)
        _run_mixed(gen, ctx, items, acts, chunk)
        if gen.bed.rack:  # a user action's transfers may leave the machine racked
            gen.bed.set_rack(0)
        return chunk
    acts = [  # per bed: every stitch an Action, so the parts split where the beds change
        a if isinstance(a, Action) else Action(a[0], main=[partial(_knit, gen, ctx, *a[:4])])
        for a in items
    ]
    parts = actions.prepare_pass(gen, acts)  # one per run of stitches on the same bed
    if parts and parts[-1]:
        parts[-1][-1].main.append(lambda: _lead_out(gen, ctx, chunk))
    for part in parts:
        run_actions(part)
    if gen.bed.rack:  # a user action's transfers may leave the machine racked
        gen.bed.set_rack(0)
    return chunk


def _fair_isle_pass(gen: _Gen, ctx: cast.Ctx, chunk: np.ndarray) -> None:
    """A part of a course of several yarns (fair isle; plain knits only, E711): each yarn
    of the part's yarn stacks (`codegen.yarn_stack`) in turn, the course's own first, knits
    the stitches it shows on in the course's direction, tucks where its stack says (a long
    float's catch) and floats behind the rest (thesis ch. 6.9.5: one main step per yarn).
    In a jacquard course every yarn of the region makes its pass, and knits the back
    needles behind the stitches its stack says, where it would float."""
    g = gen.g
    assert g.yarn is not None
    stitches = gen.t.stitch[chunk]
    ys = g.yarn[stitches]
    numbers = gen.opts.numbers
    halves = g.course_gauge[g.course[stitches]] == 2
    plain = np.where(halves, numbers.knit_half_gauge, numbers.knit)
    empty = np.where(g.wale_prev[stitches, 0] < 0, numbers.cast_on, plain)
    dirs = gen.dirs[chunk]
    dirs = np.where(dirs == 0, 1, dirs)
    course = int(g.course[stitches[0]])
    base = int(gen.course_yarn[course])
    yarns = set(ys.tolist())
    region: list[int] = []
    entry, place = gen.stacks.in_part(stitches)  # (`place`: each entry's index in the part)
    mode, owner = gen.stacks.mode[entry], gen.stacks.yarn[entry]
    knits = mode == stk.KNIT
    tucks = (mode == stk.TUCK) & ~gen.stacks.inlay[entry]
    if gen.jacquard.size and gen.jacquard[course]:
        region = gen.region_yarns[int(g.course_node[course])]
        yarns |= set(region)
        # quarter pitch: a yarn knits a front needle and the back one behind it in one
        # pass (all-needle knitting; a Shima row holds both in one column only so)
        gen.bed.set_rack(QUARTER)
    for y in stk.pass_order(base, yarns):
        sel = ys == y
        back = None
        if y in region:  # (a jacquard yarn: the back needles it knits in its pass)
            back = np.zeros(len(stitches), bool)
            back[place[knits & (owner == y)]] = True
        if not sel.any() and (back is None or not back.any()):
            continue
        ids = stitches[sel].tolist()
        first = ids[0] if ids or back is None else int(stitches[np.argmax(back)])
        start = None
        if back is not None and y != base:  # (where a new yarn comes in: the pass's edge)
            start = cast.Entry(gen.positions[int(stitches[0])], int(dirs[0]), int(stitches[0]))
        carrier = ctx.carrier if y == base else _back_carrier(gen, y, first, start)

        spans = None if y == base else _yarn_spans(gen, ids)
        if back is not None:
            _jacquard_run(gen, carrier, stitches, sel, back, dirs, plain, empty, spans)
        else:
            at = np.nonzero(sel)[0]
            cuts: dict[int, list[int]] = {}  # index of the yarn's next knit -> its catches
            for c in np.sort(place[tucks & (owner == y)]).tolist():
                j = int(np.searchsorted(at, c))
                if j == len(at):  # (the stacks put a catch past the yarn's last knit)
                    raise Unsupported(f"a float catch of yarn {y} on stitch {int(stitches[c])}")
                cuts.setdefault(int(at[j]), []).append(c)
            start_j = 0
            for j in range(len(at) + 1):  # runs of the yarn's knits, a catch between two
                if j < len(at) and int(at[j]) not in cuts:
                    continue
                part = at[start_j:j]
                if part.size:
                    gen.bed.knit_run(
                        stitches[part].tolist(),
                        dirs[part].tolist(),
                        [gen.positions[int(s)] for s in stitches[part]],
                        plain[part].tolist(),
                        empty[part].tolist(),
                        carrier,
                        spans,
                    )
                if j < len(at):
                    for c in cuts[int(at[j])]:
                        _catch(gen, carrier, int(stitches[c]), int(dirs[c]), int(ids[0]))
                start_j = j
        _drop_catch(gen)  # its pass holds the new yarn now (or the course's, on a cast-on)
        if y == base:  # (its lead-out in its own pass, before the other yarns')
            _lead_out(gen, ctx, chunk)
    if gen.bed.rack:
        gen.bed.set_rack(0)


def _intarsia_pass(gen: _Gen, chunk: np.ndarray) -> np.ndarray:
    """A part of an intarsia course (thesis ch. 6.9.6): each run of one region's stitches
    knitted by the region's local yarn, a strand of the trace (tracing's R7 starts it on
    the region's first course; its carrier comes in then, over the loops below), in the
    order and directions the trace visits them: each region's yarn goes back and forth
    over its own stitches. Where the trace flags a run's last visit JOIN, its yarn tucks
    on the next run's first needle before turning (the intarsia tuck join): the next run's
    stitch knits that loop in, and the two yarns are linked at every course, so the wall
    between the regions is not a slit. The join comes from the side the course arrives
    from, so a wall's tucks alternate sides."""
    g, t = gen.g, gen.t
    assert g.yarn is not None
    if t.method != "courses":
        raise Unsupported("intarsia needs the course tracer's local yarns (tracing rule R7)")
    course = int(g.course[t.stitch[chunk[0]]])
    circular = bool(g.course_circular[course])
    if circular:
        # A round's slices (one per bed and run) are knitted together, after the last
        # one's shaping, provided it left the loops below where the round knits them.
        gen.round_parts.append(chunk)
        chunk = np.concatenate(gen.round_parts)
        if len(chunk) < int(g.course_len[course]):
            return chunk[:0]
        gen.round_parts = []
        for s in t.stitch[chunk].tolist():
            at = [gen.bed.where.get(int(p)) for p in g.wale_prev[s] if p >= 0]
            if any(pos != gen.positions[s] for pos in at):
                raise Unsupported(
                    "the slices of an intarsia round moved its loops",
                    hint="keep the intarsia band's courses unshaped on a tube",
                )
    stitches = t.stitch[chunk]
    strands = t.yarn[chunk]
    dirs = gen.dirs[chunk]
    dirs = np.where(dirs == 0, 1, dirs)
    numbers = gen.opts.numbers
    halves = g.course_gauge[g.course[stitches]] == 2
    plain = np.where(halves, numbers.knit_half_gauge, numbers.knit)
    if gen.bed.rack:
        gen.bed.set_rack(0)
    runs = np.split(np.arange(len(stitches)), np.nonzero(np.diff(strands) != 0)[0] + 1)
    if gen.join is not None:  # the previous slice's last run's join, onto this first run
        arriving, d, by = gen.join
        gen.join = None
        _join(gen, arriving, t.stitch[chunk[runs[0][:2]]].tolist(), d, by)
    for i, run in enumerate(runs):
        strand = int(strands[run[0]])
        first = int(stitches[run[0]])
        carrier = gen.region_carrier.get(strand)
        if carrier is None:  # the region's local yarn (R7), in over the loops below
            carrier = _take_carrier(gen, gen.free, int(g.yarn[first]))
            gen.region_carrier[strand] = carrier
            with gen.bed.prog.code_pass("yarn_start"):
                gen.bed.prog.in_((carrier,), stitch=first, span=_yarn_spans(gen, [first])[first])
        ids = stitches[run].tolist()
        gen.bed.knit_run(
            ids,
            dirs[run].tolist(),
            [gen.positions[s] for s in ids],
            plain[run].tolist(),
            plain[run].tolist(),
            carrier,
            _yarn_spans(gen, ids),
        )
        if t.flags[int(chunk[run[-1]])] & tr.JOIN:
            d = int(dirs[run[-1]])
            if i + 1 < len(runs) or circular:
                ahead = runs[(i + 1) % len(runs)][:2]
                _join(gen, carrier, stitches[ahead].tolist(), d, first)
            else:  # (the next run is the next slice's: tucked on once it is placed)
                gen.join = (carrier, d, first)
    return chunk


def _join(gen: _Gen, carrier: int, ahead: list[int], d: int, by: int) -> None:
    """The intarsia tuck join: the arriving yarn tucks on the next run's first needle (or
    its second, when a decrease or a closed backing left two loops on the first: a third
    would strain it), which that run's stitch then knits in."""
    for nxt in ahead:
        if gen.bed.loops.get(gen.positions[nxt], 0) <= 1:
            _catch(gen, carrier, nxt, d, by)
            break


def _inlay_pass(gen: _Gen, chunk: np.ndarray) -> None:
    """After a part of a course is knitted: each inlay yarn laid over some of its stitches
    (`yarn { inlay: N }`, thesis ch. 3.1.6) makes a pass of its own in the course's
    direction, not knitting, caught by a tuck on every N-th of those stitches' new loops
    (the course above knits each tuck in with the stitch's loop): the yarn lies in the
    fabric, held at every N needles. It comes in (`in`) with its first tuck, on a loop,
    and rests at the side between its courses as a fair isle yarn does."""
    g = gen.g
    stitches = gen.t.stitch[chunk]
    entry, place = gen.stacks.in_part(stitches)
    laid = gen.stacks.inlay[entry] & (gen.stacks.mode[entry] == stk.TUCK)
    if not laid.any():
        return
    entry, place = entry[laid], place[laid]
    dirs = gen.dirs[chunk]
    dirs = np.where(dirs == 0, 1, dirs)
    origin = g.inlay_origin
    for y in sorted(set(gen.stacks.yarn[entry].tolist())):
        # the stack's tucks (every n-th stitch along the course), on needles holding one
        # new loop: a needle with two (a decrease's, a closed backing's) takes no third
        at = [
            t
            for t in np.sort(place[gen.stacks.yarn[entry] == y]).tolist()
            if gen.bed.loops.get(gen.positions[int(stitches[t])], 0) == 1
        ]
        if not at:
            continue
        first = int(stitches[at[0]])
        carrier = _back_carrier(gen, y, first)
        k = -1 if origin is None else int(origin[first])
        span = g.spans[k] if k >= 0 else gen.bed.span(first)
        half = g.course_gauge[g.course[first]] == 2
        bed, prog = gen.bed, gen.bed.prog
        prog.stitch_number(gen.opts.numbers.knit_half_gauge if half else gen.opts.numbers.knit)
        with prog.code_pass("float_catch"):  # (each tuck names the stitch it rides on)
            for t in at:
                s, d = int(stitches[t]), int(dirs[t])
                pos = gen.positions[s]
                prog.needle_op("tuck", d, needle_of(pos), (carrier,), s, span)
                bed.loops[pos] += 1
                bed.carrier_at[carrier] = pos[1] + 0.5 * d


def _end_regions(gen: _Gen, chunk: np.ndarray) -> None:
    """After a course: take out the local yarns of the intarsia regions it ends (their
    strands' last visits, END), each at its region's first stitch of the course."""
    t = gen.t
    ending = {int(t.yarn[v]) for v in chunk[(t.flags[chunk] & tr.END) != 0].tolist()}
    for strand, carrier in list(gen.region_carrier.items()):
        if strand not in ending:
            continue
        stitch = int(t.stitch[chunk][t.yarn[chunk] == strand].min())
        with gen.bed.prog.code_pass("yarn_end"):
            cast.yarn_end(gen.ctx(carrier, stitch), None, stitch)
        del gen.region_carrier[strand]
        gen.free.append(carrier)


def _jacquard_run(
    gen: _Gen,
    carrier: int,
    stitches: np.ndarray,
    sel: np.ndarray,
    back: np.ndarray,
    dirs: np.ndarray,
    plain: np.ndarray,
    empty: np.ndarray,
    spans: Mapping[int, Span | None] | None,
) -> None:
    """A jacquard yarn's pass: its front stitches (`sel`) and the back needles behind the
    stitches its backing gives it (`back`), in pass order, in one `Bed.knit_run`. At quarter
    pitch a back needle sits a quarter needle right of its front one: the carriage meets
    the front one first going right, the back one going left. A back op names the stitch
    it is behind and points at the `backing` statement; the first on an empty needle is a
    tuck. The loops it leaves are the back layer's (`_Gen.backing_at`)."""
    g = gen.g
    fronts = np.nonzero(sel)[0]
    behind = np.nonzero(back)[0]
    # the needle on the back bed sits right of its front one: going right the carriage
    # meets the front bed's first, whichever of the two is the stitch's own
    on_back = gen.knit_bed[stitches] == 1
    behind_first = (dirs < 0) ^ on_back
    key = np.r_[2 * fronts + behind_first[fronts], 2 * behind + ~behind_first[behind]]
    order = np.argsort(key, kind="stable")
    t = np.r_[fronts, behind][order]
    is_back = (np.arange(len(key)) >= len(fronts))[order]
    ids = stitches[t].tolist()
    positions = gen.positions
    needles = [positions[s] for s in ids]
    flip = {"f": "b", "b": "f"}
    for i in np.nonzero(is_back)[0].tolist():
        pos = needles[i]
        needles[i] = (flip[pos[0]], pos[1])
    origin = g.backing_origin
    back_span = (
        {
            s: (g.spans[k] if (k := int(origin[s])) >= 0 else gen.bed.span(s))
            for s in stitches[behind].tolist()
        }
        if origin is not None
        else None
    )
    gen.bed.knit_run(
        ids,
        dirs[t].tolist(),
        needles,
        plain[t].tolist(),
        empty[t].tolist(),
        carrier,
        spans,
        behind=is_back.tolist(),
        behind_span=back_span,
    )
    for i in np.nonzero(is_back)[0].tolist():
        gen.backing_at[needles[i]] = ids[i]


def _close_backing(gen: _Gen, ids: np.ndarray) -> None:
    """After a jacquard course: the backing's loops behind its stitches whose stitch above
    gets none (`YarnStacks.backed`: the region ends, or the wale is shaped next) go onto their
    stitch's needle, where the stitch above knits them in with its own loop: the back
    layer is closed onto the front, not dropped."""
    g, bed = gen.g, gen.bed
    assert g.backing is not None
    mine = set(ids.tolist())
    backed, kid = gen.backed_list, gen.kid_list
    for behind, s in list(gen.backing_at.items()):
        if s not in mine:
            continue
        if backed[s] and backed[kid[s]]:
            continue  # (the stitch above knits a backing loop through this one)
        front = bed.where.get(s)
        if front is None or front[1] != behind[1]:
            raise Unsupported(f"the jacquard backing behind stitch {s} has no stitch to close onto")
        if bed.rack:
            bed.set_rack(0)
        with bed.prog.code_pass("backing"):
            bed.xfer(behind, front, s)
        del gen.backing_at[behind]


QUARTER = 0.25
"""The racking of a jacquard course's passes (`rack 0.25`, quarter pitch)."""

NO_CARRIER = -1
"""The course carrier of an intarsia course: none, each run is knitted by its region's local
yarn (`_intarsia_pass`)."""

CATCH_RESTING_EVERY = 4
"""A yarn resting at the side while others knit stripes is caught into the edge after
this many courses of rest, and again every this many: what is carried up the side is then
a chain of short strands, not one as long as the rest (a shorter rest needs no catch, and
each catch costs the machine a pass of its own)."""


def _catch_resting(gen: _Gen, ids: np.ndarray, working: int) -> None:
    """After a course of a colour design: every carrier resting at the side of it (a yarn
    carried up between its stripes or bands) that has rested `CATCH_RESTING_EVERY` courses
    since it knitted or was last caught tucks on the course's edge stitch beside it: the
    knitter's twist of the resting yarn into the selvedge. The tuck rides on the stitch's
    new loop and the course above knits it in."""
    g, bed = gen.g, gen.bed
    assert g.yarn is not None
    course = int(g.course[ids[0]])
    knitting = {working} | {gen.back[y] for y in set(g.yarn[ids].tolist()) if y in gen.back}
    for c in [c for c in gen.caught if c in knitting]:
        del gen.caught[c]
    resting = ({*gen.carrier_of.values(), *gen.back.values()}) - knitting
    used: set[Pos] = set()  # one catch per needle and course (a needle holds two loops)
    for carrier in sorted(resting, key=lambda c: (gen.caught.get(c, course), c)):
        since = gen.caught.setdefault(carrier, course)
        at = bed.carrier_at.get(carrier)
        if at is None or course - since < CATCH_RESTING_EVERY:
            continue
        edge = None
        # (the course's two ends: an intarsia round's visits start at a wall)
        start = int(g.course_start[course])
        for s in (start, start + int(g.course_len[course]) - 1):
            pos = bed.where.get(s)
            if (
                pos is not None
                and pos not in used
                and bed.loops.get(pos, 0) == 1
                and abs(pos[1] - at) <= 1
                and g.wale_next[s, 0] >= 0
            ):
                edge = (s, pos)
                break
        if edge is None:
            continue
        s, pos = edge
        d = 1 if pos[1] > at else -1
        gen.caught[carrier] = course
        used.add(pos)
        _catch(gen, carrier, s, d, s, back_out=True)


def _catch(gen: _Gen, carrier: int, s: int, d: int, first: int, back_out: bool = False) -> None:
    """A fair isle yarn's float caught on stitch s's needle: a tuck on its new loop, in the
    pass's direction, at the stitch's own number, pointing at the `knit YARN` statement.
    `back_out`: a resting yarn's catch, whose carrier then goes back past the needle to
    the side it rests on (left inside the fabric, it would be kicked out of the way of
    every pass after)."""
    g = gen.g
    origin = -1 if g.yarn_origin is None else int(g.yarn_origin[first])
    span = g.spans[origin] if origin >= 0 else gen.bed.span(s)
    ctx = cast.Ctx(gen.bed, carrier, gen.opts.numbers, span)
    half = bool(g.course_gauge[g.course[s]] == 2)
    number = gen.opts.numbers.knit_half_gauge if half else gen.opts.numbers.knit
    with gen.bed.prog.code_pass("float_catch"):
        cast.emit(ctx, "tuck", d or 1, gen.positions[s], -1, number)
        if back_out:
            cast.emit(ctx, "miss", -(d or 1), gen.positions[s], -1)


def _yarn_spans(gen: _Gen, ids: list[int]) -> dict[int, Span | None]:
    """Each stitch's `knit YARN` statement (else its own span): where a hazard of a fair
    isle yarn's pass, such as a long float, is reported."""
    g = gen.g
    origin = g.yarn_origin
    out: dict[int, Span | None] = {}
    for s in ids:
        k = -1 if origin is None else int(origin[s])
        out[s] = g.spans[k] if k >= 0 else gen.bed.span(s)
    return out


def _back_carrier(gen: _Gen, yarn: int, stitch: int, start: cast.Entry | None = None) -> int:
    """The carrier of the design's `yarn` for its stitches of a fair isle course: a strand
    of it that is in (a stripe of it resting at the side), or its own, brought in now.

    With `start` (the first needle of a jacquard yarn's pass) it comes in on the inserting
    hook, caught on free needles beyond that edge (`cast.yarn_start`), which the caller
    drops once its pass holds it (`_Gen.catch`): its first op may be a backing tuck on an
    empty needle, which would not hold a yarn brought in with `in`."""
    for strand, design in gen.strand_yarn.items():
        if design == yarn and strand in gen.carrier_of:
            return gen.carrier_of[strand]
    carrier = gen.back.get(yarn)
    if carrier is None:
        carrier = gen.back[yarn] = _take_carrier(gen, gen.free, yarn)
        prog = gen.bed.prog
        with prog.code_pass("yarn_start"):
            if start is None:
                prog.in_((carrier,), stitch=stitch, span=gen.bed.span(stitch))
            else:
                busy = set(gen.course_needles)
                busy |= {("b" if b == "f" else "f", x) for b, x in gen.course_needles}
                gen.catch += cast.yarn_start(gen.ctx(carrier, stitch), start, busy, stitch)
    return carrier


def _end_back_yarns(gen: _Gen, course: int, stitch: int) -> None:
    """After a course: take out each fair isle yarn that does not float in a course of the
    same node within its `carry_up` courses (it would rest too long, or elsewhere)."""
    g, opts = gen.g, gen.opts
    for yarn, carrier in list(gen.back.items()):
        courses = gen.back_courses.get(yarn, [])
        k = bisect_right(courses, course)  # (sorted: the next one in log time, per course)
        nxt = courses[k] if k < len(courses) else None
        carry = (
            opts.yarn_carry_up[yarn]
            if yarn < len(opts.yarn_carry_up)
            else sk.YARN_PROPS["carry_up"].default
        )
        if (
            nxt is not None
            and g.course_node[nxt] == g.course_node[course]
            and nxt - course - 1 <= carry
        ):
            continue
        with gen.bed.prog.code_pass("yarn_end"):
            cast.yarn_end(gen.ctx(carrier, stitch), None, stitch)
        del gen.back[yarn]
        gen.free.append(carrier)


_Plain = tuple[int, int, Pos, int, int]
"""A plain knit of a mixed pass: stitch, direction, needle, stitch number, and the number
of the loop it lays if its needle is empty (`empty_needle_number`)."""

_KNITTED = np.array(
    [i for i, name in enumerate(INSTRUCTIONS) if name == "K" or name[0] in "FXS"], np.int64
)
"""Instructions knitted as a plain knit in the action pass (`_action`'s first branch)."""
_KNITTED_SET = frozenset(_KNITTED.tolist())


def _run_mixed(
    gen: _Gen,
    ctx: cast.Ctx,
    items: list[Action | _Plain],
    acts: list[Action],
    chunk: np.ndarray,
) -> None:
    """`run_actions` of one sub-pass whose plain knits are `items` tuples (`_action_pass`),
    then the lead-out after the last main step. A run of plain knits is knitted in one
    `Bed.knit_run`, which makes the ops and loop changes `_knit` makes for each."""
    run_by_depth([a.pre for a in acts])
    run: list[_Plain] = []
    for it in items:
        if isinstance(it, Action):
            if run:
                _knit_run(gen, ctx, run)
                run = []
            for f in it.main:
                f()
        else:
            run.append(it)
    if run:
        _knit_run(gen, ctx, run)
    if items:
        _lead_out(gen, ctx, chunk)
    run_by_depth([a.post for a in acts])


def _knit_run(gen: _Gen, ctx: cast.Ctx, run: list[_Plain]) -> None:
    """`_knit` of every plain knit of `run`, in order, in one `Bed.knit_run`."""
    gen.bed.knit_run(
        [r[0] for r in run],
        [r[1] for r in run],
        [r[2] for r in run],
        [r[3] for r in run],
        [r[4] for r in run],
        ctx.carrier,
    )


def _knit(gen: _Gen, ctx: cast.Ctx, s: int, d: int, pos: Pos, plain: int) -> None:
    """K: knit through the needle's loops, or, with nothing to knit through, lay a loop
    onto the empty needle."""
    if gen.bed.loops.get(pos, 0):
        cast.emit(ctx, "knit", d, pos, s, plain)
    else:
        cast.emit(ctx, "tuck", d, pos, s, empty_needle_number(gen, s, plain))


def _kickback(gen: _Gen, ctx: cast.Ctx, s: int, d: int, pos: Pos, plain: int) -> None:
    """A kickback increase: on an empty needle the carrier passes it in the pass, then
    comes back to tuck it; on a held one, a plain knit."""
    if gen.bed.loops.get(pos, 0):
        _knit(gen, ctx, s, d, pos, plain)
    else:
        cast.emit(ctx, "miss", d, pos, s)
        cast.emit(ctx, "tuck", -d, pos, s, gen.opts.numbers.increase)


def _action(
    gen: _Gen,
    ctx: cast.Ctx,
    s: int,
    d: int,
    inc: tuple | None,
    half: bool,
    user_action: int,
    instr_code: int,
) -> Action:
    """The built-in action of stitch `s` visited in direction `d` (`half`: its course is in
    half gauge; `user_action`, `instr_code`: its `g.action` and `g.instr`). Each step is a
    partial of a module function, made only for the branch taken: this runs per stitch."""
    numbers = gen.opts.numbers
    pos = gen.positions[s]
    plain = numbers.knit_half_gauge if half else numbers.knit
    if inc is None and user_action >= 0:
        user = actions.lower(gen, ctx, s, d, pos)
        if user is not None:
            return user
    if inc is None:
        instr = INSTRUCTIONS[instr_code]
        if instr == "K" or instr[0] in "FXS":  # the F moves, the crosses and S are knitted
            # here and carried after the course
            return Action(s, main=[partial(_knit, gen, ctx, s, d, pos, plain)])
        if instr == "P" or instr[0] == "B":  # reverse stitches; a B move is knitted reversed
            # and its loop waits on the facing needle for `_carry`, which takes it from there
            return _purl(gen, ctx, s, d, pos, plain, keep=instr[0] == "B") or Action(
                s, main=[partial(_knit, gen, ctx, s, d, pos, plain)]
            )
        if instr == "T":
            return Action(s, main=[partial(cast.emit, ctx, "tuck", d, pos, s, plain)])
        if instr == "M":
            return Action(s, main=[partial(_miss, gen, ctx, s, d, pos)])
        return Action(s, main=[partial(_knit, gen, ctx, s, d, pos, plain)])
    if inc[0] == "kickback":
        return Action(s, main=[partial(_kickback, gen, ctx, s, d, pos, plain)])
    if inc[0] == "laid":
        return Action(s, main=[partial(_knit, gen, ctx, s, d, pos, plain)])
    if inc[0] == "fetch":
        return Action(s, main=[partial(_fetch, gen, s), partial(_knit, gen, ctx, s, d, pos, plain)])
    if inc[0] == "miss":
        return Action(s, main=[partial(cast.emit, ctx, "miss", d, pos, s)])
    _, target, sibling = inc
    return Action(
        s,
        main=[partial(_split, gen, ctx, s, d, target, sibling)],
        post=[partial(_unsplit, gen, target, sibling)],
    )


def _purl(
    gen: _Gen, ctx: cast.Ctx, s: int, d: int, pos: Pos, number: int, keep: bool = False
) -> Action | None:
    """P: a knit made from the other bed (ch. 4.2's lowering): the loop is transferred to the
    facing needle (pre), knitted there (main) and the new loop transferred back (post). The
    facing needle must be empty: always on a flat piece, on a tube only in half gauge; else
    None (the stitch is knitted plain, and W603 says so)."""
    bed, numbers = gen.bed, gen.opts.numbers
    other: Pos = ("b" if pos[0] == "f" else "f", pos[1])
    own = set(int(p) for p in gen.g.wale_prev[s] if p >= 0)
    if (
        bed.loops.get(other, 0) and not bed.at.get(other, set()) <= own
    ) or other in gen.course_needles:
        assert gen.g.origin is not None  # filled in by StitchGraph.__post_init__
        gen.reverse_conflicts[int(gen.g.origin[s])] += 1
        return None
    stays = keep or _purl_continues(gen, s)

    def pre() -> None:
        if bed.loops.get(pos, 0):
            bed.prog.stitch_number(numbers.transfer)
            bed.set_rack(0)
            bed.xfer(pos, other, s)

    def main() -> None:
        if bed.loops.get(other, 0):
            cast.emit(ctx, "knit", d, other, s, number)
        else:
            cast.emit(ctx, "tuck", d, other, s, empty_needle_number(gen, s, number))

    def post() -> None:
        bed.prog.stitch_number(numbers.transfer)
        bed.set_rack(0)
        bed.xfer(other, pos, s)

    return Action(s, pre=[pre], main=[main], post=[] if stays else [post])


def _stays(gen: _Gen, s: int) -> bool:
    """Whether the loop of `s` waits on the facing needle for the next stitch of its wale
    (a flat purl, or an action with `transfer_back: false`), rather than going home."""
    return _purl_continues(gen, s) or actions.keeps_loop(gen, s)


def _purl_continues(gen: _Gen, s: int) -> bool:
    """Whether purl `s`'s new loop stays on the facing needle for the next purl of its
    wale (`steps.continues_in_place`)."""
    kid = continues_in_place(gen, s)
    return kid >= 0 and int(gen.g.instr[kid]) == PURL and int(gen.g.action[kid]) < 0


def _miss(gen: _Gen, ctx: cast.Ctx, s: int, d: int, pos: Pos) -> None:
    """M: the needle does not knit, its loop stays and stands for `s` (a slip stitch: the
    next course knits through the old loop, and the yarn floats past)."""
    bed = gen.bed
    cast.emit(ctx, "miss", d, pos, s)
    for x in bed.at.pop(pos, set()):
        del bed.where[x]
    if bed.loops.get(pos, 0):
        bed.place(s, pos)


def _increases(gen: _Gen, chunk: np.ndarray, primary: dict[int, int]) -> dict[int, tuple]:
    """How each increase of the course is made: the child without its parent's loop gets a
    ("kickback",) (("laid",), a tuck in the pass, across a gauge change), or, for split increases with a free facing needle, the child with the
    loop gets ("split", facing needle, sibling) and its sibling ("miss",). A child whose
    needle already holds a loop (a precast one) is a plain knit.

    A missed sibling holds no yarn of this course, so two neighbours are never both missed:
    the yarn would float across them (a tube growing out of a collapsed end would float
    across its whole back bed); the second one uses a kickback.

    An increase whose children lie on the two sides of the fabric (a closed tube end
    opening into a tube) is always a split, straight onto the sibling's needle when it
    faces, else onto a free needle near it, and the sibling, knitted later in the course,
    fetches the old loop and knits through it (("fetch",)): a kickback there would leave
    the other side's stitch held by nothing but the yarn, and a row of them is an open end,
    not a closed one. A sibling in a later slice of the course is remembered in
    `gen.fetch`."""
    g, bed = gen.g, gen.bed
    forks = [(p, c1) for p, c1 in primary.items() if p in gen.forks]
    if not forks:  # no parent with two children: no increase in this course
        return {}
    stitches = gen.t.stitch[chunk]
    ids = stitches.tolist()
    in_course = set(ids)
    busy = {gen.pos(s) for s in ids}
    busy |= {gen.pos(k) for row in g.wale_next[stitches].tolist() for k in row if k >= 0}
    visit = {s: i for i, s in enumerate(ids)}
    missed: set[int] = set()
    out: dict[int, tuple] = {}
    course = int(g.course[ids[0]])
    for p, c1 in sorted(forks, key=lambda pc: visit.get(pc[1], 0)):
        kids = [k for k in g.wale_next[p].tolist() if k >= 0]
        if len(kids) != 2:
            continue
        c2 = kids[0] if kids[1] == c1 else kids[1]
        src, sib = gen.pos(c1), gen.pos(c2)
        if (
            c1 in in_course
            and int(g.side[c1]) != int(g.side[c2])
            and int(g.course[c2]) == course
            and not bed.loops.get(sib, 0)
            and bed.where.get(p) == src
            and visit[c1] < visit.get(c2, len(ids))
        ):
            target = _split_target(gen, src, sib, busy)
            if target is not None:  # c2, later in this course, knits through the old loop
                out[c1] = ("split", target, c2)
                busy.add(target)
                if c2 in in_course:
                    out[c2] = ("fetch",)
                else:
                    gen.fetch.add(c2)
                continue
        if c2 not in in_course or bed.loops.get(gen.pos(c2), 0):
            continue
        node = int(g.node[c2])
        if gen.opts.increase_for(g.node_names[node]) == "split" and bed.where.get(p) == gen.pos(c1):
            lonely = not ({int(g.cprev[c2]), int(g.cnext[c2])} & missed)
            target = _split_target(gen, gen.pos(c1), gen.pos(c2), busy) if lonely else None
            if target is not None:
                out[c1] = ("split", target, c2)
                out[c2] = ("miss",)
                missed.add(c2)
                busy.add(target)
                continue
            gen.split_fallbacks[node] += 1
        # across a gauge change the finer gauge's new loops are laid in the pass, every
        # other needle, like a cast-on: a kickback each would reverse the carriage twice
        out[c2] = (
            ("laid",)
            if g.course_gauge[g.course[c2]] != g.course_gauge[g.course[p]]
            else ("kickback",)
        )
    return out


def _split_target(gen: _Gen, src: Pos, sib: Pos, busy: set[Pos]) -> Pos | None:
    """A free hook on the other bed, within racking reach of `src`, as near the sibling's
    needle as possible (the old loop waits there for the sibling's next course). Sliders are
    not used: the independent machine does not model a split onto a slider."""
    other = "b" if src[0] == "f" else "f"
    n, m = src[1], sib[1]
    if sib[0] == other:  # an increase across the fold: split straight onto the sibling
        return sib if abs(m - n) <= gen.bed.max_rack else None
    needles = gen.bed.prog.machine.needles
    for k in sorted(range(min(n, m) - 1, max(n, m) + 2), key=lambda k: (abs(k - m), abs(k - n))):
        q = (other, k)
        if max(abs(k - n), abs(k - m)) > gen.bed.max_rack or not 0 <= k < needles:
            continue
        if q not in busy and not gen.bed.loops.get(q, 0):
            return q
    return None


def _split(gen: _Gen, ctx: cast.Ctx, s: int, d: int, target: Pos, sibling: int) -> None:
    """`split`: a new loop for `s` through its parent's loop, which moves to `target` and
    becomes the loop of `sibling`."""
    bed = gen.bed
    src = gen.pos(s)
    # at racking r, back needle k faces front needle k + r
    r = src[1] - target[1] if src[0] == "f" else target[1] - src[1]
    bed.prog.stitch_number(gen.opts.numbers.increase)
    bed.set_rack(r)
    bed.prog.split(
        d,
        needle_of(src),
        needle_of(target),
        (ctx.carrier,),
        stitch=s,
        span=bed.span(s),
    )
    bed.loops[target] += bed.loops.pop(src, 0)
    for x in bed.at.pop(src, ()):
        del bed.where[x]
    bed.loops[src] = 1
    bed.place(s, src)
    bed.place(sibling, target)
    bed.carrier_at[ctx.carrier] = src[1] + 0.5 * d
    bed.set_rack(0)


def _fetch(gen: _Gen, s: int) -> None:
    """Bring the loop standing for `s` (a closing split's old loop) to its needle, if it is
    not there yet."""
    bed, home = gen.bed, gen.pos(s)
    here = bed.where.get(s)
    if here is None or here == home:
        return
    _park(gen, [(s, here, home)], home[1])
    bed.prog.stitch_number(gen.opts.numbers.transfer)
    move(bed, [(s, here, home)])
    bed.set_rack(0)


def _unsplit(gen: _Gen, target: Pos, sibling: int) -> None:
    """The split's post step: the old loop goes from the facing needle to its own (the
    sibling's) needle, so the next course finds every loop where the layout put it."""
    bed, home = gen.bed, gen.pos(sibling)
    if home == target or bed.where.get(sibling) != target or bed.loops.get(home, 0):
        return
    _park(gen, [(sibling, target, home)], home[1])
    bed.prog.stitch_number(gen.opts.numbers.transfer)
    bed.set_rack(home[1] - target[1] if home[0] == "f" else target[1] - home[1])
    bed.xfer(target, home, sibling)
    bed.set_rack(0)


def _presser(gen: _Gen, c: int) -> None:
    """Short rows press the fabric down (the loops of the rows not knitted would lift it);
    `auto` presses only on single-bed passes, where the presser cannot catch the other bed."""
    mode = "auto" if int(gen.g.course_kind[c]) == SHORT_ROW else "off"
    if mode != gen.presser:
        gen.bed.prog.presser(mode)
        gen.presser = mode


# ---- cast-off ---------------------------------------------------------------------------------


def _cast_off(gen: _Gen, ctx: cast.Ctx, chunk: np.ndarray, ends: list[int]) -> tuple[int, int]:
    """Bind off the stitches that end, run by run from the last one knitted; returns the
    stitch whose loop is left for the yarn's tail (-1: none) and its last knit direction."""
    g, t = gen.g, gen.t
    ids = [int(s) for s in t.stitch[chunk]]
    c = int(g.course[ids[0]])
    names = g.course_names.get(c, ())
    kind = gen.opts.cast_off_for(names)

    def neighbours(a: int, b: int) -> bool:
        return int(g.cnext[a]) == b or int(g.cprev[a]) == b

    runs = cast.runs(ends, neighbours, bool(g.course_circular[c]))
    if kind == "none":
        for run in runs:
            cast.drop_run(ctx, run)
        _warn_dropped(gen, names, len(ends), ends[0])
        return -1, 0
    order = {s: i for i, s in enumerate(ids)}
    end_set = set(ends)
    last_dir = int(gen.dirs[chunk[-1]]) or 1
    left, left_dir = -1, 0
    todo = list(reversed(runs))
    while todo:
        run = _nearest_run(gen, todo, ctx.carrier)
        st, d = cast.cast_off_run(
            gen.ctx(ctx.carrier, run[-1]), kind, run, _closing(gen, run, end_set, order), last_dir
        )
        last_dir = d or last_dir
        if not todo:
            left, left_dir = st, d
        elif st >= 0:
            _tail_and_drop(ctx, st, d)
    return left, left_dir


def _nearest_run(gen: _Gen, todo: list[list[int]], carrier: int) -> list[int]:
    """Take from `todo` the run to bind off next: the one with an end nearest the carrier
    (so the yarn does not float back across the course), oriented so that its chain (which
    starts from the run's last stitch) starts at that end. Ties keep yarn order reversed:
    the last run knitted, from its last stitch."""
    at = gen.bed.carrier_at.get(carrier)
    if at is None:
        return todo.pop(0)

    def dist(s: int) -> float:
        p = gen.bed.where.get(s)
        return abs(p[1] - at) if p is not None else float("inf")

    best = min(range(len(todo)), key=lambda i: (min(dist(todo[i][-1]), dist(todo[i][0])), i))
    run = todo.pop(best)
    return run if dist(run[-1]) <= dist(run[0]) else run[::-1]


def _closing(gen: _Gen, run: list[int], ends: set[int], order: dict[int, int]) -> int:
    """A live course neighbour of the run's first stitch (the bind-off's last), to close the
    chain onto: the one knitted before it, else any."""
    g = gen.g
    first = run[0]
    cands = [
        int(n)
        for n in (g.cprev[first], g.cnext[first])
        if n >= 0 and int(n) not in ends and int(n) in gen.bed.where
    ]
    cands.sort(key=lambda n: (order.get(n, len(order)) > order.get(first, 0), n))
    return cands[0] if cands else -1


def _tail_and_drop(ctx: cast.Ctx, stitch: int, d: int) -> None:
    pos = cast.tail(ctx, stitch, d)
    if pos is not None and ctx.bed.loops.get(pos, 0):
        ctx.bed.drop(pos, stitch)


def _warn_dropped(gen: _Gen, names: tuple[str, ...], n: int, s: int) -> None:
    key = names[0] if names else f"course {int(gen.g.course[s])}"
    if key in gen.warned:
        return
    gen.warned.add(key)
    where = f"`{names[0]}`" if names else "a course"
    span = gen.opts.interface_span.get(names[0]) if names else None
    gen.diags.warning(
        "W601",
        f"{where} is not cast off (`cast_off: none`): its {n} loop(s) "
        "are dropped and the edge will unravel unless it is secured off the "
        "machine",
        span or gen.bed.span(s),
        hint="use `cast_off: pickup`, `direct` or `reverse` for a bound edge",
    )
