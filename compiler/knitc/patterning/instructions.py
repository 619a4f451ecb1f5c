"""Pattern instructions checked against the shape, before they are lowered (ch. 4.2.2).

The pattern pass writes an instruction on every stitch; not every instruction can be
knitted where it was written. This pass finds those that cannot, resets them to K and says
so (with the pattern statement that wrote them), so that code generation only ever sees
instructions it can lower:

- instructions on increase and decrease stitches are ignored (W708), as in the original:
  the stitches an increase makes are made by the increase, and a loop the shaping moves
  cannot also be carried by the pattern, nor carry a tuck's extra loop onto a neighbour
  that may hold one too; a tuck on a decrease would add a third loop to the two it merges. Only P stays on the loops of increases and decreases (its
  transfers take the loop there and back before the shaping moves it);
- tucks and misses on the last course of a piece (W708): the cast-off would bind three
  loops at once;
- crosses (W709) must come as a cable: a run of XR+ (XR-), optional plain relief stitches,
  then a run of the complement XL- (XL+), on one bed, over a course that has a next course,
  with no loop carried further than the machine can rack (half gauge doubles distances);
  relief stitches between runs of different widths are refused (they would have to move);
- moves (W709) are bounded on flat courses (the original wrapped around the edge, carrying
  an edge loop across the whole piece), need a next course, and may not make a needle hold
  more than two loops or land on a stitch the shaping or a cable moves.

Moves and crosses do not change the stitch graph: its wales stay those of the shape, which
is what slicing and scheduling lay out. Code generation carries the loops after the course
is knitted (`codegen._carry`), and from then on each needle's loops stand for the stitch
knitted there: a needle a loop left is empty (the next course makes a yarn-over on it, the
eyelet), a needle a loop joined knits two loops together (a decrease). No stitch is created
or deleted here, and only `instr` changes.

Directions are read from each bed's face (`right_left`).
"""

from __future__ import annotations

import dataclasses
from collections import Counter

import numpy as np

from knitc import arrays
from knitc.diagnostics import Diagnostics, Note, at_designer
from knitc.records import record
from knitc.shaping.stitch_graph import INSTRUCTIONS, StitchGraph
from knitc.source import Span

K, P, T, M = (INSTRUCTIONS.index(x) for x in "KPTM")
MOVES = {
    INSTRUCTIONS.index(m): (1 if m[1] == "R" else -1) * int(m[2])
    for m in ("FR1", "FR2", "FL1", "FL2", "BR1", "BR2", "BL1", "BL2")
}
"""Move instruction -> signed needles along the course (right = +)."""
CROSSES = tuple(INSTRUCTIONS.index(x) for x in ("XR+", "XR-", "XL+", "XL-"))
COMPLEMENT = {
    INSTRUCTIONS.index(a): INSTRUCTIONS.index(b) for a, b in (("XR+", "XL-"), ("XR-", "XL+"))
}
"""A cross run that goes right -> the run that must follow it to make the cable."""
UPPER = INSTRUCTIONS.index("XR+")
"""The right-going run that passes in front (the other, XR-, passes behind)."""
STACK = INSTRUCTIONS.index("S")
MAX_RELIEF = 4
"""Plain stitches allowed between the two runs of a cable."""


@record(frozen=True)
class Cable:
    """One cable of a course: its stitches left to right, the widths of its runs."""

    group: tuple[int, ...]
    first: int
    relief: int
    second: int
    upper_first: bool

    def targets(self) -> list[int]:
        """Per stitch of the group, the index in the group whose needle its loop goes to:
        the first run to the last needles, the second run to the first ones."""
        n, f, r, s = len(self.group), self.first, self.relief, self.second
        return [n - f + i for i in range(f)] + [s + i for i in range(r)] + list(range(s))


def check_instructions(g: StitchGraph, diags: Diagnostics, *, racking: int = 4) -> StitchGraph:
    """The graph with every instruction that cannot be knitted where it is reset to K;
    `racking` is the machine's limit, which bounds how far a loop can be carried."""
    run = _Check(g, diags, g.instr.copy(), racking)
    run.irregular()
    run.last_course()
    if np.isin(run.instr, CROSSES).any():
        run.crosses()
    if np.isin(run.instr, list(MOVES)).any():
        run.moves()
    return dataclasses.replace(g, instr=run.instr)


def right_left(g: StitchGraph) -> tuple[np.ndarray, np.ndarray]:
    """Per stitch, its neighbour to the right and to the left, seen from the face of its
    bed (-1 past the end of a flat course). The graph's course links follow the yarn, whose
    direction alternates on flat courses; as in the original, a course's orientation is read
    from two consecutive stitches on one bed: the needle index increasing on the front bed,
    or decreasing on the back bed, is rightwards."""
    nxt = np.maximum(g.cnext, 0)
    pair = (g.cnext >= 0) & (g.side[nxt] == g.side)
    step = np.sign(g.needle[nxt].astype(np.int64) - g.needle) * (1 - 2 * g.side.astype(np.int64))
    orient = np.ones(g.n_courses, np.int64)
    ids = np.nonzero(pair & (step != 0))[0]
    courses, first = np.unique(g.course[ids], return_index=True)
    orient[courses] = step[ids[first]]
    forward = orient[g.course] > 0
    right = np.where(forward, g.cnext, g.cprev).astype(np.int64)
    left = np.where(forward, g.cprev, g.cnext).astype(np.int64)
    return right, left


def origin_site(g: StitchGraph, origin: int) -> tuple[Span | None, list[Note]]:
    """Where to report about stitches a pattern statement wrote (`g.origin`): the
    designer's line, with notes into the applied definitions it went through."""
    if origin < 0:
        return None, []
    return at_designer(g.spans[origin])


def neighbour(right: np.ndarray, left: np.ndarray, s: int, k: int) -> int:
    """The stitch `k` places right of `s` (negative: left), -1 past a flat course's end."""
    links = right if k > 0 else left
    for _ in range(abs(k)):
        s = int(links[s])
        if s < 0:
            return -1
    return s


def cables(g: StitchGraph, ids: np.ndarray, right: np.ndarray, left: np.ndarray) -> list[Cable]:
    """The cables among stitches `ids` of one course, as `check_instructions` left them
    (every remaining cross stitch belongs to a valid cable)."""
    out = []
    instr = g.instr
    for s0 in ids.tolist():
        code = int(instr[s0])
        if code not in COMPLEMENT or (left[s0] >= 0 and int(instr[left[s0]]) == code):
            continue
        cab = _scan(instr, right, s0)
        if cab is not None:
            out.append(cab)
    return out


def _scan(instr: np.ndarray, right: np.ndarray, s0: int) -> Cable | None:
    """The cable whose first run starts at `s0` (None if the runs do not make one)."""
    code = int(instr[s0])
    comp = COMPLEMENT[code]
    group: list[int] = []
    x, f, r, s = s0, 0, 0, 0
    while x >= 0 and int(instr[x]) == code and (x != s0 or not group):
        group.append(x)
        f += 1
        x = int(right[x])
    while x >= 0 and r <= MAX_RELIEF and int(instr[x]) not in CROSSES and x != s0:
        group.append(x)
        r += 1
        x = int(right[x])
    while x >= 0 and int(instr[x]) == comp and x != s0:
        group.append(x)
        s += 1
        x = int(right[x])
    if s == 0 or r > MAX_RELIEF or (r and f != s):
        return None
    return Cable(tuple(group), f, r, s, code == UPPER)


@record
class _Check:
    g: StitchGraph
    diags: Diagnostics
    instr: np.ndarray
    racking: int

    def __post_init__(self) -> None:
        g = self.g
        self.n_next = (g.wale_next >= 0).sum(1)
        self.n_prev = (g.wale_prev >= 0).sum(1)
        self.right, self.left = right_left(g)
        self.dec_parent = (self.n_next == 1) & (self.n_prev[np.maximum(g.wale_next[:, 0], 0)] == 2)

    def drop(self, mask: np.ndarray, code: str, what: str, hint: str) -> None:
        """Reset `mask` to K with one warning per pattern statement that wrote it."""
        ids = np.nonzero(mask)[0]
        if not ids.size:
            return
        g = self.g
        assert g.origin is not None  # filled in by StitchGraph.__post_init__
        for origin, n in sorted(Counter(g.origin[ids].tolist()).items()):
            first = int(ids[g.origin[ids] == origin][0])
            span, notes = origin_site(g, origin)
            self.diags.warning(
                code, f"{n} {what}", span or g.spans[int(g.span[first])], hint=hint, notes=notes
            )
        self.instr[mask] = K

    def irregular(self) -> None:
        g, instr = self.g, self.instr
        inc_parent = self.n_next == 2
        wp = np.maximum(g.wale_prev, 0)
        inc_child = ((g.wale_prev >= 0) & inc_parent[wp]).any(1)
        dec_child = self.n_prev == 2
        bad = (instr != K) & (
            inc_child | ((inc_parent | self.dec_parent) & (instr != P)) | (dec_child & (instr == T))
        )
        self.drop(
            bad,
            "W708",
            "pattern instruction(s) on increase or decrease stitches are "
            "ignored: these stitches are knitted plain",
            "an increase makes its own stitches, and a loop the shaping moves cannot be "
            "carried by the pattern too; keep motifs away from shaping",
        )

    def last_course(self) -> None:
        last = self.n_next == 0
        self.drop(
            np.isin(self.instr, (T, M)) & last,
            "W708",
            "tuck or miss stitch(es) on "
            "the last course of a piece are knitted plain: the cast-off would bind "
            "three loops at once",
            "end the motif a course before the piece's last course",
        )
        carried = np.isin(self.instr, list(MOVES) + list(CROSSES))
        self.drop(
            carried & last,
            "W709",
            "move or cross stitch(es) on the last course of a "
            "piece are not applied: there is no next course to carry the loops into",
            "end the motif a course before the piece's last course",
        )

    def crosses(self) -> None:
        g, instr = self.g, self.instr
        ok = np.zeros(g.n_stitches, bool)
        for c in arrays.unique(g.course[np.isin(instr, CROSSES)]).tolist():
            for cab in cables(g, g.course_ids(c), self.right, self.left):
                grp = np.array(cab.group)
                reach = (len(grp) - min(cab.first, cab.second)) * int(g.course_gauge[c])
                if (
                    len(set(g.side[grp].tolist())) == 1
                    and (self.n_next[grp] == 1).all()
                    and not self.dec_parent[grp].any()
                    and reach <= self.racking
                ):
                    ok[grp[np.isin(instr[grp], CROSSES)]] = True
        self.drop(
            np.isin(instr, CROSSES) & ~ok,
            "W709",
            "cross stitch(es) are not applied "
            "and are knitted plain: a cable needs a run of XR+ (XR-) followed by a run "
            "of XL- (XL+), on one bed, away from shaping, and within the machine's "
            "racking",
            "pair every right-going cross run with its complement, e.g. "
            "`XR+ XR+ XL- XL-`; relief stitches between the runs need runs of equal "
            "width",
        )

    def moves(self) -> None:
        """A needle ends with the loop of its own stitch unless that one moves away, plus
        every loop that moves onto it; more than two is refused, in stitch order."""
        g, instr = self.g, self.instr
        movers = np.nonzero(np.isin(instr, list(MOVES)))[0].tolist()
        bad = np.zeros(g.n_stitches, bool)
        plan = []
        for s in movers:
            t = neighbour(self.right, self.left, s, MOVES[int(instr[s])])
            reach = abs(MOVES[int(instr[s])]) * int(g.course_gauge[g.course[s]])
            if (
                t < 0
                or g.side[t] != g.side[s]
                or self.n_next[t] != 1
                or reach > self.racking
                or self.dec_parent[t]
                or int(instr[t]) in CROSSES
            ):
                bad[s] = True
            else:
                plan.append((s, t))
        while True:  # a refused move keeps its loop home, which may refuse another one
            leaving = {s for s, _ in plan}
            held: Counter = Counter()
            refused = []
            for s, t in plan:
                if (t not in leaving) + held[t] + 1 > 2:
                    refused.append(s)
                else:
                    held[t] += 1
            if not refused:
                break
            bad[refused] = True
            plan = [(s, t) for s, t in plan if s not in set(refused)]
        self.drop(
            bad,
            "W709",
            "move(s) are not applied and are knitted plain: the loop "
            "would leave the fabric or its bed, land on a stitch that shaping or a "
            "cable moves, "
            "or make a third loop on a needle",
            "moves on flat courses stay inside "
            "the piece (edge stitches cannot move outwards); at most two loops may "
            "meet on a needle",
        )
