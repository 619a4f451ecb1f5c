"""The needle bed as code generation sees it: which loops are where, and the racking.

Every emitter here writes one machine operation and updates the loop model in the same
step, so the code passes (cast-on, actions, shaping, cast-off) never disagree with the
program about where a stitch's loop is. Positions are (bed, needle) pairs with bed one of
'f', 'b' (hooks) or 'fs', 'bs' (sliders), the keys of the loop model; an operation gets
the `Needle` of its position (`needle`), never a name to parse back.
"""

from __future__ import annotations

from collections import defaultdict
from collections.abc import Mapping
from dataclasses import field

from knitc.codegen.machine import MachineProgram, Needle, Op
from knitc.records import record
from knitc.shaping.stitch_graph import StitchGraph
from knitc.source import Span

Pos = tuple[str, int]
BEDS = ("f", "b")
SLIDERS = ("fs", "bs")


_NEEDLES: dict[Pos, Needle] = {}
"""One `Needle` per bed position, made at its first use: a program names the same few
hundred needles over and over, and a shared instance is found in dicts by identity."""


def needle(pos: Pos) -> Needle:
    """The machine needle of a bed position."""
    n = _NEEDLES.get(pos)
    if n is None:
        n = Needle(pos[0], pos[1])
        if type(pos[1]) is int:  # ('f', 3.0) finds ('f', 3): only exact keys are kept
            _NEEDLES[pos] = n
    elif type(pos[1]) is not int:
        n = Needle(pos[0], pos[1])
    return n


class Unsupported(Exception):
    """Something the code passes cannot plan yet: reported as E602 at the course's line,
    with `hint` (else the transfer planner's: most of these are transfers it found no way
    to make)."""

    def __init__(self, message: str, hint: str | None = None) -> None:
        super().__init__(message)
        self.hint = hint


@record
class Bed:
    g: StitchGraph
    prog: MachineProgram
    max_rack: int
    loops: dict[Pos, int] = field(default_factory=lambda: defaultdict(int))
    """How many loops each needle holds (cast-on loops included)."""
    where: dict[int, Pos] = field(default_factory=dict)
    """Current position of each live stitch's loop."""
    at: dict[Pos, set[int]] = field(default_factory=lambda: defaultdict(set))
    """The inverse of `where`: the stitches whose loops are on a needle."""
    rack: float = 0
    carrier_at: dict[int, float] = field(default_factory=dict)
    """Where each carrier in use was left (needle position, between needles)."""
    _span_of: list | None = None
    _per_stitch: dict[str, list[int]] = field(default_factory=dict)

    def span(self, s: int):
        if self._span_of is None:  # every stitch's span, looked up once per op otherwise
            spans = self.g.spans
            self._span_of = [spans[i] for i in self.g.span.tolist()]
        return self._span_of[s] if s >= 0 else None

    def stitch_courses(self) -> list[int] | None:
        """The course of every stitch as a list (`per_stitch`)."""
        return self.per_stitch("course")

    def stitch_nodes(self) -> list[int] | None:
        """The node of every stitch as a list (`per_stitch`)."""
        return self.per_stitch("node")

    def per_stitch(self, name: str) -> list[int] | None:
        """The graph's per-stitch array `name` as a Python list, made once: the transfer
        planner asks it of every loop on the bed, for every plan, and a numpy scalar per
        look-up is slow. None for a graph without that array."""
        got = self._per_stitch.get(name)
        if got is None:
            array = getattr(self.g, name, None)
            if array is None:
                return None
            got = self._per_stitch[name] = array.tolist()
        return got

    def set_rack(self, r: float) -> None:
        if r != self.rack:
            if abs(r) > self.max_rack:
                raise Unsupported(
                    f"a transfer needs racking {r}, beyond the machine's {self.max_rack}"
                )
            self.prog.rack(r)
            self.rack = r

    def xfer(self, src: Pos, dst: Pos, stitch: int) -> None:
        self.prog.needle_op("xfer", 0, needle(src), (), stitch, self.span(stitch), needle(dst))
        moved = self.loops.pop(src, 0)
        self.loops[dst] += moved
        for s in self.at.pop(src, ()):
            self.where[s] = dst
            self.at[dst].add(s)

    def stitch_op(self, kind: str, d: int, pos: Pos, stitch: int, carrier: int) -> None:
        """knit / tuck / miss at `pos`; `stitch` -1 = a loop of no graph stitch (cast-on)."""
        if kind not in ("knit", "tuck", "miss"):
            raise ValueError(kind)
        self.prog.needle_op(kind, d, needle(pos), (carrier,), stitch, self.span(stitch))
        if kind == "knit":
            for s in self.at.pop(pos, ()):
                del self.where[s]
            self.loops[pos] = 1
        elif kind == "tuck":
            self.loops[pos] += 1
        self.carrier_at[carrier] = pos[1] + 0.5 * d
        if stitch >= 0 and kind != "miss":  # `place`, inlined: this runs once per stitch
            where = self.where
            old = where.get(stitch)
            if old is not None:
                self.at[old].discard(stitch)
            where[stitch] = pos
            self.at[pos].add(stitch)

    def knit_run(
        self,
        stitches: list[int],
        dirs: list[int],
        needles: list[Pos],
        numbers: list[int],
        empty_numbers: list[int],
        carrier: int,
        span_of: Mapping[int, Span | None] | None = None,
        behind: list[bool] | None = None,
        behind_span: Mapping[int, Span | None] | None = None,
    ) -> None:
        """A plain pass, stitch by stitch in order: each stitch knitted in its direction on
        its needle through the needle's loops at its stitch number, or on an empty needle
        tucked at its empty-needle number. The ops and the loop model are those of
        `prog.stitch_number` and `stitch_op` per stitch; made here in one loop, from one
        list per column, because most passes of every design are plain (issue 16).
        `span_of` gives the ops of these stitches other source spans (a fair isle yarn's
        knits point at the `knit YARN` statement).

        `behind` marks entries that are a jacquard backing's loop on the needle behind the
        stitch (its needle given): knitted at the stitch number (a tuck on an empty needle),
        code pass "backing", at `behind_span` of the stitch, a loop of no stitch."""
        prog, loops, where, at = self.prog, self.loops, self.where, self.at
        carriers = (carrier,)
        if self._span_of is None:
            self.span(0)
        spans: Mapping[int, Span | None] | list[Span] | None = span_of or self._span_of
        assert spans is not None
        number = None
        pos = None
        d = 0
        # each op is `prog.needle_op`'s, built here without its call and the named tuple's
        # Python-level __new__ (two calls per stitch of every plain pass)
        ops, new, phase, shared = prog.ops, tuple.__new__, prog.phase, _NEEDLES.get
        for i, (stitch, d, pos, plain, empty) in enumerate(
            zip(stitches, dirs, needles, numbers, empty_numbers, strict=True)
        ):
            full = loops.get(pos, 0)
            if behind is not None and behind[i]:  # a backing loop: no stitch's own
                if at.get(pos):
                    raise Unsupported(
                        f"the jacquard backing behind stitch {stitch} needs needle "
                        f"{pos[0]}{pos[1]}, which holds fabric",
                        hint="a jacquard backing knits on the needles behind a sheet: keep "
                        "other fabric off them (knit the sheet on its own, or `backing float`)",
                    )
                if plain != number:
                    prog.stitch_number(plain)
                    number = plain
                n = shared(pos) or needle(pos)
                span = behind_span[stitch] if behind_span is not None else spans[stitch]
                kind = "knit" if full else "tuck"
                ops.append(new(Op, (kind, d, n, None, carriers, None, stitch, span, "backing")))
                loops[pos] = 1  # (a knit leaves its new loop; a tuck on an empty needle, one)
                continue
            k = plain if full else empty
            if k != number:
                prog.stitch_number(k)
                number = k
            n = shared(pos) or needle(pos)  # (`needle`'s cache hit: these indices are ints)
            ops.append(
                new(
                    Op,
                    (
                        "knit" if full else "tuck",
                        d,
                        n,
                        None,
                        carriers,
                        None,
                        stitch,
                        spans[stitch],
                        phase,
                    ),
                )
            )
            if full:
                for s in at.pop(pos, ()):
                    del where[s]
                loops[pos] = 1
            else:
                loops[pos] += 1
            old = where.get(stitch)
            if old is not None:
                at[old].discard(stitch)
            where[stitch] = pos
            at[pos].add(stitch)
        if pos is not None:
            self.carrier_at[carrier] = pos[1] + 0.5 * d

    def place(self, stitch: int, pos: Pos) -> None:
        old = self.where.get(stitch)
        if old is not None:
            self.at[old].discard(stitch)
        self.where[stitch] = pos
        self.at[pos].add(stitch)

    def drop(self, pos: Pos, stitch: int) -> None:
        self.prog.drop(needle(pos), stitch=stitch, span=self.span(stitch))
        self.loops.pop(pos, None)
        for s in self.at.pop(pos, ()):
            del self.where[s]
