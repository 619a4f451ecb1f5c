"""Is the knitted fabric the designed garment? The design's stitch graph against the knit
graph an independent machine made of knitc's program.

`make test` runs knitc's Knitout on knitout-interpreter + virtual-knitting-machine (the
oracle, `tests/oracle.py`), which builds a knit graph of the fabric as it runs: every loop,
the loops it was pulled through (its parents) with the pull direction, and the yarns. That
program accepting the Knitout only says the machine could knit it; this module says whether
what it knitted is what the design says. Every op of knitc's program knows the stitch it
came from and its code pass (`Op.stitch`, `Op.phase`), so each designed stitch finds its
loop: the one its action pass formed (`Expected.loop`).

The design is read as the fabric it should make, course by course (`expect`): every loop
on a needle *stands for* a stitch, and a stitch's new loop must be pulled through exactly
the loops that stand for its designed wale predecessors. The exceptions, each named:

- **kickback increase**: of the two children of an increase, one gets its parent's loops;
  the other is a tuck on an empty needle, held by the course's yarn on both sides (never
  next to another one: a row of them is a hole, not an increase);
- **split increase**: the parent's loops go to the other child's needle; that child either
  knits through them or misses and lets them stand for it;
- **closed bind-off**: a bind-off chain that ends next to a live stitch is closed onto it,
  so that stitch's child also pulls the chain's last loop;
- **float catch**: a fair isle yarn's tuck on a needle whose stitch it floats behind
  (`yarn { tuck_every }`) is knitted in by the stitch above, with that stitch's loop;
- **closed backing**: a jacquard backing's last loops are moved onto the front needles and
  knitted in by the stitches above (or the bind-off) in the same way, and so is an
  intarsia yarn's tuck join on its neighbour region's needle;
- **miss** (M, or an action that misses) forms no loop: the loops below stand for it;
  **tuck** (T, or an action's tuck) adds a loop that the next knit pulls through together
  with the loops below (the next stitch's own check holds it to that); a **split action**
  keeps the loops it splits on the needle too, with its new loop;
- **carried loops**: after a course with lace moves or cables the loops go where the
  instruction sends them (`instructions.neighbour`, `instructions.cables`), so a needle a
  loop left makes a yarn-over (a tuck on an empty needle) and a needle it joined knits both;
- the first course of a yarn knits through its cast-on loops.

Checks, each a `Mismatch` kind that names the stitch, its node and its course:

- ``loop``: a designed stitch with no loop where it must have one;
- ``parents``: its loop was pulled through other loops than designed (a hole, a wale that
  jumps to another stitch, a piece cast on anew where it should continue);
- ``pull``: knitted where a purl was designed, or the other way round;
- ``hole``: two kickback increases next to each other (nothing holds the course there);
- ``unattached``: a loop of the fabric left with nothing pulled through it and not bound
  off (it will unravel);
- ``ring``: a tubular course whose loops are not one closed ring of its designed size,
  on one yarn in course order;
- ``connection``: a connection with no wale in the design, with wales on one side only of
  a two-sided interface (a one-sided seam), or with a wale the fabric has no edge for;
- ``pieces``: the fabric falls into another number of pieces than the design has garments;
- ``yarn``: a stitch's loop is on another carrier than its design yarn's (stripes), or
  two of the design's yarns share a carrier;
- ``backing``: a jacquard stitch with no backing loop behind it, or a backing loop pulled
  through the front's loops or left with nothing through it (`_backing`);
- ``slit``: two neighbouring stitches of an intarsia course knitted by different yarns
  with nothing linking the two (`_walls`).
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field

import numpy as np

from knitc.backends.knitout import knitout_lines
from knitc.codegen.machine import MachineProgram
from knitc.driver import Result
from knitc.patterning.instructions import CROSSES, MOVES, cables, neighbour, right_left
from knitc.scheduling import schedule as sc
from knitc.shaping.stitch_graph import INSTRUCTIONS, StitchGraph, two_bed

P, T, M = (INSTRUCTIONS.index(x) for x in "PTM")
REVERSED = {P} | {k for k, name in enumerate(INSTRUCTIONS) if name[0] == "B"}
"""Instructions knitted from the other bed: their stitch is pulled the other way."""
CARRIED = set(MOVES) | set(CROSSES)
BACK_TO_FRONT = 1


# ---- the fabric, as the oracle reports it -----------------------------------------------------


@dataclass(frozen=True)
class Fabric:
    """The oracle's knit graph (`oracle_runner.py --fabric`), by loop id."""

    line: list[int | None]
    needle: list[str | None]
    yarn: list[int | None]
    parents: list[tuple[int, ...]]
    pulls: list[tuple[int, ...]]
    yarns: list[tuple[int | None, tuple[int, ...]]]
    children: list[list[int]] = field(default_factory=list)
    yarn_pos: dict[int, int] = field(default_factory=dict)

    @classmethod
    def from_json(cls, d: dict) -> Fabric:
        rows = sorted(d["loops"], key=lambda r: r[0])
        if [r[0] for r in rows] != list(range(len(rows))):
            raise ValueError("the oracle's loop ids are not 0..n-1")
        fab = cls(
            line=[r[1] for r in rows],
            needle=[r[2] for r in rows],
            yarn=[r[3] for r in rows],
            parents=[tuple(r[4]) for r in rows],
            pulls=[tuple(r[5]) for r in rows],
            yarns=[(c, tuple(ids)) for c, ids in d["yarns"]],
        )
        fab.children.extend([] for _ in rows)
        for child, ps in enumerate(fab.parents):
            for p in ps:
                fab.children[p].append(child)
        for _, ids in fab.yarns:
            fab.yarn_pos.update((loop, i) for i, loop in enumerate(ids))
        return fab

    def __len__(self) -> int:
        return len(self.line)


# ---- what the design says ---------------------------------------------------------------------


@dataclass(frozen=True)
class Mismatch:
    kind: str
    stitch: int
    text: str

    def __str__(self) -> str:
        return f"[{self.kind}] {self.text}"


@dataclass
class Expected:
    """The fabric the design asks for, in the oracle's loop ids (see the module docstring)."""

    loop: dict[int, int]
    """Stitch -> the loop its action pass formed."""
    stands: list[frozenset[int]]
    """Per stitch, the loops standing for it once its course (and its carries) is done."""
    kickbacks: set[int]
    """Stitches made as kickback increases (a tuck with no parent)."""
    realized: list[tuple[int, int]]
    """(parent stitch, child stitch) wales the fabric has."""
    mismatches: list[Mismatch]
    home: np.ndarray
    """Per stitch, the bed its layout knits it on (0 front, 1 back)."""
    backing: dict[int, int] = field(default_factory=dict)
    """A jacquard backing's loop -> the stitch it was knitted behind."""
    needle: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    """Per stitch, the needle its layout knits it on."""


def loops_by_op(prog: MachineProgram, fab: Fabric) -> dict[int, list[int]]:
    """Op index -> the loops it formed (knitc's Knitout lines mapped back to its ops)."""
    op_of_line = [op for _, op in knitout_lines(prog)]
    out: dict[int, list[int]] = {}
    for loop, line in enumerate(fab.line):
        if line is not None and 1 <= line <= len(op_of_line) and op_of_line[line - 1] >= 0:
            out.setdefault(op_of_line[line - 1], []).append(loop)
    return out


def describe(g: StitchGraph, s: int) -> str:
    c = int(g.course[s])
    pos = s - int(g.course_start[c])
    side = "back" if int(g.side[s]) else "front"
    return (
        f"stitch {s} (node `{g.node_names[int(g.node[s])]}`, course {c}, position {pos}, "
        f"{side}, {INSTRUCTIONS[int(g.instr[s])]})"
    )


def expect(result: Result, fab: Fabric) -> Expected:
    """Walk the design course by course and hold each stitch's loop against it."""
    g, prog = result.graph, result.program
    assert g is not None and prog is not None
    by_op = loops_by_op(prog, fab)
    loop: dict[int, int] = {}
    tucked: set[int] = set()  # stitches whose own loop is a tuck
    splits: set[int] = set()  # stitches whose own loop is a split
    missed: set[int] = set()  # stitches whose action misses their needle
    cast_on: set[int] = set()
    cast_off: set[int] = set()
    caught: set[int] = set()  # a fair isle yarn's tucks on its float (`float_catch`)
    backing: dict[int, int] = {}  # a jacquard backing's loops -> the stitch they are behind
    plated: dict[int, frozenset[int]] = {}  # a plated stitch -> its loops, one per yarn
    for k, op in enumerate(prog.ops):
        if op.kind == "miss" and op.phase == "action" and op.stitch >= 0:
            missed.add(op.stitch)
        if op.forms_loop and k in by_op:
            if op.phase == "action" and op.stitch >= 0:
                loop[op.stitch] = by_op[k][-1]
                if len(op.carriers) > 1:  # plated: its loop is the face yarn's, the first
                    loop[op.stitch] = by_op[k][0]
                    plated[op.stitch] = frozenset(by_op[k])
                (tucked.add if op.kind == "tuck" else tucked.discard)(op.stitch)
                (splits.add if op.kind == "split" else splits.discard)(op.stitch)
            elif op.phase == "cast_on":
                cast_on.update(by_op[k])
            elif op.phase == "cast_off":
                cast_off.update(by_op[k])
            elif op.phase == "float_catch":
                caught.update(by_op[k])
            elif op.phase == "backing":
                backing.update(dict.fromkeys(by_op[k], op.stitch))
    n = g.n_stitches
    plain_ok = {d.span for d in result.diagnostics if d.code == "W603" and d.span is not None}
    assert result.schedule is not None
    home, needles = sc.knit_positions(result.schedule, n)
    stands: list[frozenset[int]] = [frozenset()] * n
    out = Expected(loop, stands, set(), [], [], home, backing, needles)
    bad = out.mismatches
    sides = None
    for c in range(g.n_courses):
        ids = g.course_ids(c)
        for s in ids.tolist():
            parents = [int(p) for p in g.wale_prev[s] if p >= 0]
            below = frozenset().union(*(stands[p] for p in parents))
            lp = loop.get(s)
            instr = int(g.instr[s])
            user = int(g.action[s]) >= 0
            if lp is None:  # nothing formed: what is on the needle stands for the stitch
                if instr == M or (user and s in missed) or _split_sibling(g, s, loop, fab):
                    stands[s] = below
                    out.realized += [(p, s) for p in parents]
                elif below:
                    stands[s] = below
                    bad.append(
                        Mismatch(
                            "loop",
                            s,
                            f"{describe(g, s)} was never knitted: no loop of the fabric is its own",
                        )
                    )
                else:
                    bad.append(Mismatch("loop", s, f"{describe(g, s)} has no loop at all"))
                continue
            got = frozenset(fab.parents[lp])
            # a tuck (T, or an action's tuck) adds its loop to those below: the next knit on
            # the needle pulls through both, which that stitch's own check sees
            tuck = instr == T or (user and s in tucked)
            if tuck and not got and not _kickback(g, s, parents, loop, stands, fab):
                stands[s] = plated.get(s, frozenset({lp})) | below
                out.realized += [(p, s) for p in parents]
                continue
            stands[s] = plated.get(s, frozenset({lp}))  # (a plated stitch: a loop per yarn)
            if not parents:
                if got - cast_on:
                    bad.append(
                        Mismatch(
                            "parents",
                            s,
                            f"{describe(g, s)} starts the fabric but "
                            f"was pulled through loops {_names(g, fab, got)}",
                        )
                    )
                elif user and s in splits:  # a split action keeps the cast-on loop it splits
                    stands[s] = stands[s] | got
                continue
            if got == below:
                out.realized += [(p, s) for p in parents]
                _check_pull(g, fab, s, lp, bool(home[s] == 0), plain_ok, bad)
                if user and s in splits:  # a split action keeps the old loop, as a tuck does
                    stands[s] = stands[s] | got
                continue
            if not got and _kickback(g, s, parents, loop, stands, fab):
                out.kickbacks.add(s)
                continue
            if below <= got and (
                got - below <= cast_off or got - below <= caught or got - below <= backing.keys()
            ):
                # a bind-off closed onto its live neighbour: the chain's last loop is knitted
                # in with the neighbour's next stitch; a fair isle yarn's catch on the
                # needle below, or a jacquard backing closed onto its stitch, is knitted in
                # the same way
                out.realized += [(p, s) for p in parents]
                _check_pull(g, fab, s, lp, bool(home[s] == 0), plain_ok, bad)
                continue
            hit = [p for p in parents if stands[p] & got]
            out.realized += [(p, s) for p in hit]
            bad.append(
                Mismatch(
                    "parents",
                    s,
                    f"{describe(g, s)} was pulled through "
                    f"{_names(g, fab, got)} but its designed wale predecessors "
                    f"{parents} stand as {_names(g, fab, below)}",
                )
            )
        if np.isin(g.instr[ids], list(CARRIED)).any():
            if sides is None:
                sides = right_left(g)
            _carry(g, ids, stands, *sides)
    _check_holes(g, out)
    return out


def _names(g: StitchGraph, fab: Fabric, loops: Iterable[int]) -> str:
    loops = sorted(loops)
    if not loops:
        return "no loop"
    shown = ", ".join(f"{x}@{fab.needle[x]}" for x in loops[:6])
    return "loops " + shown + (" ..." if len(loops) > 6 else "")


def _split_sibling(g: StitchGraph, s: int, loop: dict[int, int], fab: Fabric) -> bool:
    """Whether `s` is the missed child of a split increase (its parent's loop stands for it)."""
    parents = [int(p) for p in g.wale_prev[s] if p >= 0]
    if len(parents) != 1:
        return False
    kids = [int(k) for k in g.wale_next[parents[0]] if k >= 0 and int(k) != s]
    return len(kids) == 1 and kids[0] in loop and bool(fab.parents[loop[kids[0]]])


def _kickback(
    g: StitchGraph,
    s: int,
    parents: list[int],
    loop: dict[int, int],
    stands: list[frozenset[int]],
    fab: Fabric,
) -> bool:
    """Whether parentless `s` is the kickback child of an increase whose other child took
    the parent's loops."""
    if len(parents) != 1 or not stands[parents[0]]:
        return False
    kids = [int(k) for k in g.wale_next[parents[0]] if k >= 0 and int(k) != s]
    return (
        len(kids) == 1
        and kids[0] in loop
        and stands[parents[0]] <= frozenset(fab.parents[loop[kids[0]]])
    )


def _check_pull(
    g: StitchGraph, fab: Fabric, s: int, lp: int, front: bool, plain_ok: set, bad: list[Mismatch]
) -> None:
    """Knit or purl as designed. The face of the fabric is the side away from the other bed,
    so a knit on the bed its layout puts it on (`front`) pulls back to front on the front
    bed and front to back on the back bed; a reversed stitch the other way, unless knitc
    warned that it knits it plain (W603 at its pattern statement, `plain_ok`)."""
    if int(g.action[s]) >= 0:  # a user action decides for itself how it pulls
        return
    purl = int(g.instr[s]) in REVERSED
    if (
        purl
        and g.origin is not None
        and int(g.origin[s]) >= 0
        and g.spans[int(g.origin[s])].chain()[0] in plain_ok
    ):  # the designer's line
        purl = None  # either way
    if purl is None:
        return
    want = BACK_TO_FRONT if front != purl else 1 - BACK_TO_FRONT
    if any(p != want for p in fab.pulls[lp]):
        what = "a purl" if purl else "a knit"
        bad.append(
            Mismatch(
                "pull",
                s,
                f"{describe(g, s)} should be {what} on its face, but "
                f"its loop {lp}@{fab.needle[lp]} is pulled the other way",
            )
        )


def _carry(
    g: StitchGraph,
    ids: np.ndarray,
    stands: list[frozenset[int]],
    right: np.ndarray,
    left: np.ndarray,
) -> None:
    """After a course with moves or crosses, each stitch's needle holds the loops sent to it."""
    dest = {int(s): int(s) for s in ids}
    for cab in cables(g, ids, right, left):
        for x, j in zip(cab.group, cab.targets(), strict=True):
            dest[x] = cab.group[j]
    for s in ids.tolist():
        k = int(g.instr[s])
        if k in MOVES:
            dest[s] = neighbour(right, left, s, MOVES[k])
    landed: dict[int, frozenset[int]] = {s: frozenset() for s in dest}
    for s, t in dest.items():
        landed[t] = landed.get(t, frozenset()) | stands[s]
    for s in dest:
        stands[s] = landed[s]


def _check_holes(g: StitchGraph, out: Expected) -> None:
    """Two kickback increases side by side: the course has nothing holding it there."""
    for s in sorted(out.kickbacks):
        for nb in (int(g.cnext[s]),):
            if nb >= 0 and nb in out.kickbacks:
                out.mismatches.append(
                    Mismatch(
                        "hole",
                        s,
                        f"{describe(g, s)} and its course neighbour {nb} are both "
                        "kickback increases: nothing below holds the course there (a hole)",
                    )
                )


# ---- whole-fabric checks ----------------------------------------------------------------------


def check_fabric(result: Result, fab: Fabric, *, dropped_ok: Iterable[int] = ()) -> list[Mismatch]:
    """Every mismatch between the design of `result` and the knitted `fab`. Loops the design
    lets go (`cast_off: none`, which knitc warns about with W601) and `dropped_ok` are not
    reported as unattached."""
    g = result.graph
    assert g is not None
    ex = expect(result, fab)
    bad = list(ex.mismatches)
    bad += _unattached(g, fab, ex, set(dropped_ok) | _not_cast_off(result))
    bad += _rings(g, fab, ex)
    bad += _connections(result, ex)
    bad += _pieces(g, result.skeleton, ex)
    bad += _yarns(result, fab, ex)
    bad += _backing(g, fab, ex)
    bad += _walls(g, fab, ex)
    return bad


def _walls(g: StitchGraph, fab: Fabric, ex: Expected) -> list[Mismatch]:
    """In an intarsia course, two neighbouring stitches of different yarns are knitted by
    different yarns of the fabric: they must be linked, else the wall between their
    regions is a slit. Linked: one of the two stitches' loops, or the loop above it, was
    pulled through a loop of the other's yarn (the tuck join), or so was the next stitch
    of that side's yarn (a join one needle in, past a needle holding two loops)."""
    out: list[Mismatch] = []
    if g.backing is None or g.yarn is None:
        return out
    intarsia = g.intarsia_courses()

    def pulled(s: int) -> set[int | None]:
        """The fabric yarns of the loops stitch s's loop and its child's were pulled through."""
        got: set[int | None] = set()
        for t in (s, int(g.wale_next[s].max())):
            if t >= 0 and t in ex.loop:
                got |= {fab.yarn[p] for p in fab.parents[ex.loop[t]]}
        return got

    for c in np.nonzero(intarsia)[0].tolist():
        for s in g.course_ids(c).tolist():
            s2 = int(g.cnext[s])
            if s2 < 0 or g.yarn[s] == g.yarn[s2] or s not in ex.loop or s2 not in ex.loop:
                continue
            a, b = fab.yarn[ex.loop[s]], fab.yarn[ex.loop[s2]]
            if a == b or a in pulled(s2) or b in pulled(s):
                continue
            s3, s0 = int(g.cnext[s2]), int(g.cprev[s])
            if (s3 >= 0 and g.yarn[s3] == g.yarn[s2] and a in pulled(s3)) or (
                s0 >= 0 and g.yarn[s0] == g.yarn[s] and b in pulled(s0)
            ):
                continue
            out.append(
                Mismatch(
                    "slit",
                    s,
                    f"{describe(g, s)} and its neighbour {s2} are of different yarns with "
                    "nothing linking them: the wall between their regions is a slit",
                )
            )
    return out[:50]


def _backing(g: StitchGraph, fab: Fabric, ex: Expected) -> list[Mismatch]:
    """A jacquard course's back layer: every stitch of a two-bed backing whose wale goes
    straight on (one child on the same needle, its only parent) has a backing loop knitted
    behind it; each backing loop is pulled through backing loops only (the back
    layer is a fabric of its own, joined to the front by the yarns that cross) and has
    something pulled through it (the next course's back knit, or the stitch it is closed
    onto at the end of the region, or the bind-off)."""
    out: list[Mismatch] = []
    if g.backing is None:
        return out
    behind = set(ex.backing.values())

    def straight(s: int) -> bool:
        kids = [int(k) for k in g.wale_next[s] if k >= 0]
        return (
            len(kids) == 1
            and int((g.wale_prev[kids[0]] >= 0).sum()) == 1
            and ex.home[kids[0]] == ex.home[s]
            and ex.needle[kids[0]] == ex.needle[s]
        )

    jacquard = two_bed(g.backing)
    backed = np.zeros(g.n_courses, bool)  # a jacquard course that keeps its back layer
    for c in np.unique(g.course[jacquard]).tolist():
        ids = g.course_ids(c).tolist()
        if not all(straight(s) for s in ids):
            continue  # (the back layer closes a course before the fabric is shaped)
        backed[c] = True
        for s in ids:
            if not jacquard[s] or s in behind:
                continue
            out.append(Mismatch("backing", s, f"{describe(g, s)} has no backing behind it"))
    for x, s in sorted(ex.backing.items()):
        stray = [p for p in fab.parents[x] if p not in ex.backing]
        if stray:
            out.append(
                Mismatch(
                    "backing",
                    s,
                    f"the backing loop {x} behind {describe(g, s)} was pulled through "
                    f"loops {_names(g, fab, stray)} of the front",
                )
            )
        if not fab.children[x]:
            out.append(
                Mismatch(
                    "backing",
                    s,
                    f"the backing loop {x} behind {describe(g, s)} has nothing pulled "
                    "through it and is not closed onto the front",
                )
            )
            continue
        # the back layer goes on where the stitch above has a back loop of its own: the
        # back knit there pulls this one through; else it is closed onto the front, where
        # the stitch above pulls it through with the stitch's own loop
        k = int(g.wale_next[s].max())
        goes_on = k >= 0 and bool(jacquard[k]) and bool(backed[int(g.course[s])])
        goes_on = goes_on and bool(backed[int(g.course[k])])
        kids = set(fab.children[x])
        if goes_on and not kids & ex.backing.keys():
            out.append(
                Mismatch(
                    "backing",
                    s,
                    f"the backing loop {x} behind {describe(g, s)} is closed onto the front "
                    "though the back layer goes on above it",
                )
            )
        elif (  # (or a later back knit of the course pulls it: horizontal stripes)
            not goes_on
            and k >= 0
            and k in ex.loop
            and not kids & ex.stands[k]
            and not kids & ex.backing.keys()
        ):
            out.append(
                Mismatch(
                    "backing",
                    s,
                    f"the backing loop {x} behind {describe(g, s)} ends the back layer but "
                    f"the stitch above, {k}, does not knit it in",
                )
            )
    return out[:50]


def _yarns(result: Result, fab: Fabric, ex: Expected) -> list[Mismatch]:
    """Each stitch's loop is on a yarn of the carrier its design yarn holds: a yarn that
    declares a carrier is on that one, or, for a strand knitted beside another of the
    same yarn (a sleeve beside the body), on a carrier no other yarn declares; and no two
    of the design's yarns share a carrier."""
    g, skel = result.graph, result.skeleton
    assert g is not None and g.yarn is not None and skel is not None
    declared = [y.carrier for y in skel.yarn_list]
    bad: list[Mismatch] = []
    used: dict[int, set[int]] = {}  # design yarn -> carriers its loops are on
    for s, loop in sorted(ex.loop.items()):
        y = fab.yarn[loop]
        carrier = None if y is None else fab.yarns[y][0]
        want = int(g.yarn[s])
        if carrier is None:
            continue
        used.setdefault(want, set()).add(carrier)
        asked = declared[want] if g.colourwork and want < len(declared) else None
        others = {c for i, c in enumerate(declared) if i != want and c is not None}
        if asked is not None and carrier != asked and carrier in others:
            bad.append(
                Mismatch(
                    "yarn",
                    s,
                    f"{describe(g, s)} is on carrier {carrier}, not on {g.yarn_names[want]}'s "
                    f"carrier {asked}",
                )
            )
    for a, ca in used.items():
        for b, cb in used.items():
            if a < b and ca & cb:
                bad.append(
                    Mismatch(
                        "yarn",
                        -1,
                        f"yarns {g.yarn_names[a]} and {g.yarn_names[b]} share carrier(s) "
                        f"{sorted(ca & cb)}",
                    )
                )
    return bad[:50]


def _not_cast_off(result: Result) -> set[int]:
    """The ending stitches of courses whose cast-off is `none`: the design drops them."""
    from knitc.codegen.generate import options_from_skeleton

    g, skel = result.graph, result.skeleton
    assert g is not None and skel is not None
    opts = options_from_skeleton(skel)
    ends = (g.wale_next < 0).all(1)
    out: set[int] = set()
    for c in range(g.n_courses):
        if opts.cast_off_for(g.course_names.get(c, ())) == "none":
            ids = g.course_ids(c)
            out.update(ids[ends[ids]].tolist())
    return out


def _unattached(g: StitchGraph, fab: Fabric, ex: Expected, dropped_ok: set[int]) -> list[Mismatch]:
    """Loops that stand for a stitch but that nothing was pulled through: every ending
    stitch is bound off (its loop knitted into the bind-off chain), every other loop is
    knitted through by the course above."""
    out = []
    for s in range(g.n_stitches):
        if s in dropped_ok:
            continue
        loose = sorted(x for x in ex.stands[s] if not fab.children[x])
        if loose:
            out.append(
                Mismatch(
                    "unattached",
                    s,
                    f"{describe(g, s)}: {_names(g, fab, loose)} "
                    "have nothing pulled through them and are not bound off",
                )
            )
    return out


def _rings(g: StitchGraph, fab: Fabric, ex: Expected) -> list[Mismatch]:
    """Each tubular course is one closed ring: its loops on one yarn, in course order,
    crossing between the beds exactly twice around, as many as designed. A course of
    several yarns (fair isle) is one ring per yarn: each yarn's loops on one yarn of the
    fabric, in course order."""
    out = []
    band = g.intarsia_courses()
    for c in np.nonzero(g.course_circular)[0].tolist():
        ids = g.course_ids(c).tolist()
        own = [ex.loop[s] for s in ids if s in ex.loop]
        if len(own) < len(ids):
            continue  # missed stitches (and their reports) make no ring of their own
        first = ids[0]
        assert g.yarn is not None
        if band[c]:
            continue  # an intarsia round is a ring of regions, each its own yarn (`_walls`)
        design = g.yarn[ids].tolist()
        if len(set(design)) > 1:  # fair isle: each yarn's own stitches, in course order
            for y in sorted(set(design)):
                mine = [ex.loop[s] for s, d in zip(ids, design, strict=True) if d == y]
                pos = [fab.yarn_pos.get(x, -1) for x in mine]
                if len({fab.yarn[x] for x in mine}) != 1 or any(
                    b <= a for a, b in zip(pos, pos[1:])
                ):
                    out.append(
                        Mismatch(
                            "ring",
                            first,
                            f"the {g.yarn_names[y]} stitches of tubular course {c} are not "
                            "knitted by one yarn in course order",
                        )
                    )
            continue
        yarns = {fab.yarn[x] for x in own}
        pos = [fab.yarn_pos.get(x, -1) for x in own]
        beds = [int(ex.home[s]) for s in ids]
        turns = sum(beds[i] != beds[i - 1] for i in range(len(beds)))
        problem = None
        if len(yarns) != 1:
            problem = f"is knitted with {len(yarns)} yarns"
        elif any(b <= a for a, b in zip(pos, pos[1:])):
            problem = "is not knitted in its course order"
        elif len(set(beds)) == 2 and turns != 2:
            problem = f"crosses between the beds {turns} times instead of twice"
        if problem:
            out.append(
                Mismatch(
                    "ring",
                    first,
                    f"the tubular course {c} of node "
                    f"`{g.node_names[int(g.course_node[c])]}` ({len(ids)} stitches) "
                    f"{problem}",
                )
            )
    return out


def _connections(result: Result, ex: Expected) -> list[Mismatch]:
    """Each connection of the design joins its two nodes: the design has wales between them
    (on both sides of a two-sided interface: else a one-sided seam), and the fabric has a
    stitch edge for every one of them (else a hole, or a piece knitted apart)."""
    g, skel = result.graph, result.skeleton
    assert g is not None and skel is not None
    src, slot = np.nonzero(g.wale_next >= 0)
    dst = g.wale_next[src, slot]
    realized = set(ex.realized)
    sizes = np.bincount(g.node, minlength=len(g.node_names))
    out = []
    for conn in skel.connections:
        na, nb = (g.node_names.index(i.node) for i in (conn.a, conn.b))
        if na == nb or not sizes[na] or not sizes[nb]:
            continue  # a node whose only course is the other's: joined by sharing it
        between = ((g.node[src] == na) & (g.node[dst] == nb)) | (
            (g.node[src] == nb) & (g.node[dst] == na)
        )
        wales = list(zip(src[between].tolist(), dst[between].tolist()))
        what = f"the connection {conn.a} -> {conn.b}"
        if not wales:
            out.append(
                Mismatch(
                    "connection",
                    -1,
                    f"{what} has no wale in the design: its two nodes are knitted apart",
                )
            )
            continue
        tubes = [
            g.node_names.index(i.node) for i in (conn.a, conn.b) if skel.interfaces[i].sides == 2
        ]
        ends = [[x for w in wales for x in w if int(g.node[x]) == t] for t in tubes]
        per_node = [{int(g.side[x]) for x in e} for e in ends]
        # The tube's course at the seam: a tube closed 2:1 before it merges (W501) ends in a
        # course on one bed, which joins the other node on that side only, as designed.
        seam_sides = [
            {int(v) for v in g.side[(g.node == t) & np.isin(g.course, g.course[e])]}
            for t, e in zip(tubes, ends, strict=True)
        ]
        sides = set().union(*per_node) if per_node else set()
        two_sided = [len(ss) == 2 for ss in seam_sides]
        if any(two_sided) and not any(len(ss) == 2 for ss in per_node):
            out.append(
                Mismatch(
                    "connection",
                    wales[0][1],
                    f"{what} joins a tube on one side "
                    f"only (its wales are all on the {'back' if sides == {1} else 'front'})"
                    ": a one-sided seam",
                )
            )
        # a kickback increase's new loop is made by the increase, not pulled through
        missing = [(p, s) for p, s in wales if (p, s) not in realized and s not in ex.kickbacks]
        if missing:
            p, s = missing[0]
            out.append(
                Mismatch(
                    "connection",
                    s,
                    f"{what}: {len(missing)} of its "
                    f"{len(wales)} wales have no stitch edge in the fabric, first "
                    f"{describe(g, p)} -> {describe(g, s)}",
                )
            )
    return out


def _pieces(g: StitchGraph, skel, ex: Expected) -> list[Mismatch]:
    """As many pieces of fabric as the design has garments (nodes joined by connections)."""
    nodes = list(g.node_names)
    designed = _components(
        len(nodes), [(nodes.index(c.a.node), nodes.index(c.b.node)) for c in skel.connections]
    )
    made = _components(g.n_stitches, list(ex.realized) + _course_edges(g))
    if made != designed:
        return [
            Mismatch(
                "pieces", -1, f"the fabric is {made} piece(s); the design has {designed} garment(s)"
            )
        ]
    return []


def _course_edges(g: StitchGraph) -> list[tuple[int, int]]:
    has = np.nonzero(g.cnext >= 0)[0]
    return list(zip(has.tolist(), g.cnext[has].tolist()))


def _components(n: int, edges: list[tuple[int, int]]) -> int:
    parent = list(range(n))

    def find(x: int) -> int:
        while parent[x] != x:
            parent[x] = parent[parent[x]]
            x = parent[x]
        return x

    for a, b in edges:
        ra, rb = find(a), find(b)
        if ra != rb:
            parent[ra] = rb
    return sum(1 for x in range(n) if find(x) == x)


def describe_all(mismatches: list[Mismatch], limit: int = 25) -> str:
    lines = [str(m) for m in mismatches[:limit]]
    if len(mismatches) > limit:
        lines.append(f"... and {len(mismatches) - limit} more")
    return "\n".join(lines)


# ---- for tests --------------------------------------------------------------------------------


def _source_of(i: int, r: Result) -> str:
    """A design's name in a failure: its source text and `-D` values, to reproduce it."""
    from knitc.frontend.fmt import format_expr

    text = next((f.text for p, f in r.diagnostics.sources.items() if not p.startswith("<")), "")
    defines = " ".join(f"-D {k}={format_expr(v)}" for k, v in r.defines.items())
    return f"design {i} ({defines or 'no -D'}):\n{text}"


ANNOUNCED_BY = {"Long_Float_Warning": "W803"}
"""The independent machine's hazard warnings and the knitc warning that announces each at
the design's line: a design may be hazardous (the designer's choice, warned about), but
never silently so."""


def assert_knits_as_designed(
    results: Sequence[Result],
    *,
    names: Sequence[str] | None = None,
    allow: Sequence[Iterable[str]] | Iterable[str] = (),
    dropped_ok: Sequence[Iterable[int]] | None = None,
) -> None:
    """Run every compiled design on the independent machine (one oracle process for all) and
    fail, listing every problem of every design, unless each runs clean (`assert_clean`) and
    knits the fabric its design says (`check_fabric`). A hazard the design's own diagnostics
    announce (`ANNOUNCED_BY`) is tolerated.

    allow: hazard warnings tolerated, for all designs or (a sequence of sequences) per design.
    dropped_ok: per design, stitches whose loops the design lets go (`cast_off: none`).
    """
    __tracebackhide__ = True
    from knitc.backends.knitout import write_knitout
    from oracle import run_oracle_on_text

    names = list(names) if names is not None else [_source_of(i, r) for i, r in enumerate(results)]
    allows = (
        list(allow) if allow and not isinstance(next(iter(allow)), str) else [allow] * len(results)
    )
    texts = []
    for name, r in zip(names, results, strict=True):
        assert r.program is not None, f"{name} did not compile:\n{r.diagnostics.render()}"
        texts.append(write_knitout(r.program))
    reports = run_oracle_on_text(texts, fabric=True)
    failures = []
    for i, (name, r, report) in enumerate(zip(names, results, reports, strict=True)):
        codes = {d.code for d in r.diagnostics}
        announced = [h for h, code in ANNOUNCED_BY.items() if code in codes]
        problems = report.problems(allow=[*allows[i], *announced])
        if problems:
            failures.append(f"{name}: " + report.describe(problems))
            continue
        if report.fabric is None:
            failures.append(f"{name}: the oracle returned no knit graph")
            continue
        bad = check_fabric(
            r, Fabric.from_json(report.fabric), dropped_ok=dropped_ok[i] if dropped_ok else ()
        )
        if bad:
            failures.append(
                f"{name}: the fabric is not the design ({len(bad)} mismatch(es)):\n"
                + describe_all(bad)
            )
    if failures:
        raise AssertionError("\n\n".join(failures))
