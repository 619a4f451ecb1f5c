"""knitc's own machine simulation: a fast check of a `MachineProgram` that points at DSL lines.

One pass over the ops with the machine state a V-bed needs for safety: loops per needle as
integer counts, carriers out / brought in / in action, the inserting hook and where it is
parked, the racking, and for each carrier the needle of the last loop it made (followed when
that loop is transferred, as Knitout's carrier motion rule says). For the yarn-stretch rule
it also keeps each loop's identity, needle and yarn neighbours (lists indexed by a loop
number, cheap enough to keep on). Findings carry the op index, its stitch and its source
span, so they become diagnostics at the line that made the op (`add_to_diagnostics`): a
DSL line for `knitc check`, a Knitout line for `knitc lint`.

This is not the judge: the independent oracle (tests/oracle.py) is. The rules follow what
the oracle and the Shima DAT converter enforce (shared/research/knitout-and-dat.md §1.7),
and where the two differ, the stricter one; the hazards are what a knitting technician
checks a program for, with the thresholds of the machine profile (`Machine.max_loops`,
`max_float`, `max_misses`, `max_stretch`):

errors
  E801 misaligned_xfer   xfer/split between needles that do not face each other at the racking
  E802 carrier_not_in    a carrier used, or taken out, while not in action
  E803 loops_left        loops still on needles at the end
  E804 carriers_left     carriers still in action at the end
  E805 hook              inhook while the hook holds yarn, first pass after inhook not
                         leftward, a stitch at or right of the parked hook (it sits just
                         right of the hooked carrier's first loop until releasehook),
                         releasehook of other carriers or before a stitch, out of a carrier
                         still on the hook, hook never released, more than one carrier in
                         an inhook/releasehook/outhook
  E806 needle_range      a needle outside 0 .. machine.needles - 1
  E807 racking           |racking| above the machine's limit, or a fraction other than .25
  E808 needle_use        knit/tuck on a slider, split from a slider, slider to slider
  E809 carrier_state     in/inhook of a carrier already in, out of one that never stitched
  E810 malformed         an op that is not well formed (an internal error of code generation)
  E811 carriers_per_op   more carriers in one op than the machine takes in a pass
warnings
  W801 too_many_loops    an op leaves more than `max_loops` loops on a needle: a tuck or a
                         transfer onto a needle that holds a stack, which the next knit
                         pulls through all at once
  W802 knit_on_empty     knit on a needle holding no loop (a tuck there is a cast-on)
  W803 long_float        a carrier's consecutive loops more than `max_float` needles apart
  W804 long_miss         a knit through a loop the yarn passed over (missed) in more than
                         `max_misses` passes in a row: the held loop is drawn long
  W805 stretch           a transfer that leaves a loop more than `max_stretch` stitch widths
                         further from a yarn neighbour on its bed than they were knitted
                         apart (a width is that distance: 1 needle full gauge, 2 half)
  W806 reverse_occupied  a reverse stitch (loop to the facing needle, knit, back) whose
                         facing needle held a loop of its own bed: the knit takes it and the
                         transfer back moves it off its bed
  W807 loose_yarn        a carrier brought in with `in` (no inserting hook) whose first
                         loop lands on an empty needle: nothing holds the yarn end
  W808 cast_on_knit      a knit through a cast-on loop (a tuck onto an empty needle) before
                         its carrier has turned: no course the other way holds it yet

The oracle's own hazard limits are 4 loops (`max_loops=3`) and floats over 20 needles
(`max_float=20`); knitc's defaults are stricter.
"""

from __future__ import annotations

import math
from collections import Counter
from collections.abc import Iterable
from typing import Any

from knitc.codegen.machine import (
    MachineProgram,
    Needle,
    Op,
    format_number,
    op_problems,
    racking_for,
)
from knitc.diagnostics import Diagnostics, Note
from knitc.records import record
from knitc.source import Span

CODES: dict[str, str] = {
    "misaligned_xfer": "E801",
    "carrier_not_in": "E802",
    "loops_left": "E803",
    "carriers_left": "E804",
    "hook": "E805",
    "needle_range": "E806",
    "racking": "E807",
    "needle_use": "E808",
    "carrier_state": "E809",
    "malformed": "E810",
    "carriers_per_op": "E811",
    "too_many_loops": "W801",
    "knit_on_empty": "W802",
    "long_float": "W803",
    "long_miss": "W804",
    "stretch": "W805",
    "reverse_occupied": "W806",
    "loose_yarn": "W807",
    "cast_on_knit": "W808",
}
"""Finding kind -> diagnostic code (E = error, W = warning)."""

ERROR, WARNING = "error", "warning"


@record(frozen=True)
class Finding:
    """One problem found by the simulator, located at an op (and so at a stitch and span)."""

    kind: str
    severity: str  # "error" | "warning"
    message: str
    op: int  # index into prog.ops; -1 when no op is to blame
    stitch: int = -1
    span: Span | None = None

    @property
    def code(self) -> str:
        return CODES[self.kind]

    @property
    def is_error(self) -> bool:
        return self.severity == ERROR

    def __str__(self) -> str:
        where = f" at {self.span}" if self.span is not None else ""
        op = f" op {self.op}" if self.op >= 0 else ""
        return f"{self.severity}[{self.code}]{op}{where}: {self.message}"

    def to_json(self) -> dict[str, Any]:
        return {
            "kind": self.kind,
            "code": self.code,
            "severity": self.severity,
            "message": self.message,
            "op": self.op,
            "stitch": self.stitch,
            "span": None if self.span is None else self.span.to_json(),
        }


# carrier states
_OUT, _PENDING, _ACTIVE = 0, 1, 2

_PASSIVE_KINDS = frozenset({"comment", "stitch", "stitch_number", "speed", "presser"})
"""Ops that neither end a knitting pass nor a transfer pass."""
_PASS_KINDS = frozenset({"knit", "tuck", "split", "miss"})
"""Ops that go on a knitting pass (any other op that is not passive ends it)."""
_FRONT_BEDS, _BACK_BEDS = ("f", "fs"), ("b", "bs")  # (`Needle.is_front`, `.is_back`)
_SLIDER_BEDS = ("fs", "bs")  # (`Needle.is_slider`)

SHORT_RUN = 4
"""The fewest plain knits `Simulator._knit_run` simulates together (measured: below it the
set-up of a run costs more than the ops it saves, as between a lace pattern's eyelets)."""

_PassKey = tuple[int, tuple[int, ...], float]
"""What a knitting pass keeps (direction, carriers, racking): a loop op with another key,
or one that goes back against the direction, starts a new pass."""


class Simulator:
    """The simulation state; `run()` goes through the program once and returns findings.

    After `run()`, `loops` (needle -> loop count, needles with loops only), `active`
    (carriers in, sorted), `hook` (carriers on the hook) and `racking` describe
    the machine at the end. `max_loops` and `max_float` default to the machine profile's.

    `placed`: the needle numbers are where the program's `;;Position:` puts them, as the
    Shima converter does (research §2.2): with `Keep` they are the bed's own, 0 ..
    needles - 1; otherwise the design is moved onto the bed, so only its width must fit
    (a program whose needles run below 0 or past the end starts at its leftmost needle).
    Without it (code generation, which places every needle itself) they are always the
    bed's own.
    """

    fast_path = True
    """Whether `run` takes its fast path for plain knits and tucks (tests turn it off to
    hold the fast path to the general handlers)."""

    def __init__(
        self,
        prog: MachineProgram,
        *,
        max_loops: int | None = None,
        max_float: int | None = None,
        check_end: bool = True,
        limit_per_kind: int = 100,
        placed: bool = False,
        verified: bool = False,
    ) -> None:
        self.prog = prog
        self.verified = verified
        self.machine = prog.machine
        self.bed_lo = 0  # the needle number at the bed's left end
        if placed and prog.position != "Keep":
            used = [n.index for op in prog.ops for n in (op.needle, op.needle2) if n is not None]
            if used and (min(used) < 0 or max(used) >= self.machine.needles):
                self.bed_lo = min(used)
        self.max_loops = self.machine.max_loops if max_loops is None else max_loops
        self.max_float = self.machine.max_float if max_float is None else max_float
        self.max_misses = self.machine.max_misses
        self.max_stretch = self.machine.max_stretch
        self.check_end = check_end
        self.limit_per_kind = limit_per_kind
        self.loops: dict[Needle, int] = {}
        self.last_touch: dict[Needle, int] = {}  # needle -> last op that put loops on it
        self.state: dict[int, int] = {}  # carrier -> _OUT / _PENDING / _ACTIVE
        self.stitched: set[int] = set()  # carriers that made a loop since they came in
        self.not_in: set[int] = set()  # carriers reported as used while out
        self.anchor: dict[int, Needle] = {}  # carrier -> needle of its last loop
        self.last_use: dict[int, int] = {}  # carrier -> last op that used it
        self.hook: tuple[int, ...] = ()
        self.hook_op = -1
        self.hook_stitched = False
        self.hook_dir_checked = False
        # the hook is parked just right of the hooked carrier's first loop: this slot and
        # every one right of it are blocked until releasehook (None: no loop yet)
        self.hook_slot: int | None = None
        self.hook_first: Needle | None = None
        self.hook_block_reported = False
        self.off_bed: set[Needle] = set()  # needles reported outside the bed
        self.too_many_carriers: set[tuple[int, ...]] = set()  # carrier sets reported (E811)
        self.racking: float = 0
        self.findings: list[Finding] = []
        self._counts: Counter[str] = Counter()
        self._i = -1
        # W807: carriers brought in with `in` that have not made a loop yet
        self.loose: set[int] = set()
        # W804: consecutive passes that went over each needle's loops without knitting it
        self.missed: dict[Needle, int] = {}
        self._pass_key: _PassKey | None = None
        self._pass_pos = 0.0
        self._pass_span: dict[bool, list[int]] = {}  # front? -> [lowest, highest] hook index
        # front? -> the hook indices the pass formed loops on
        self._pass_touched: dict[bool, set[int]] = {True: set(), False: set()}
        # W808: each carrier's passes (a new one when it turns), and the cast-on loops
        self._passes = 0
        self.carrier_dir: dict[int, int] = {}
        self.carrier_pass: dict[int, int] = {}
        self.cast_on: dict[Needle, tuple[int, int]] = {}  # tucked on empty: (carrier, pass)
        self.cast_on_live: set[Needle] = set()  # ... and that loop is still the only one
        self.cast_on_reported: set[tuple[int, int]] = set()
        # W806: facing needles a transfer stacked onto, then knitted
        self.rev_stacked: dict[Needle, Needle] = {}  # facing needle -> where the loop came from
        self.rev_knit: dict[Needle, tuple[Needle, int]] = {}  # ... then knitted: (from, op)
        # W805: loop identities (a number per loop-forming op), where each is (None: knitted
        # off or dropped), its yarn neighbours before and after it with the needles between
        # them when the later one was made (on one bed; -1: none), as flat lists (a program
        # of a million stitches keeps a million loops), and the loops a transfer pass moved
        self.loop_at: list[Needle | None] = []
        self.loop_front: list[bool] = []  # knitted on the front bed (W806)
        self.loop_prev: list[int] = []
        self.loop_prev_d: list[int] = []
        self.loop_next: list[int] = []
        self.loop_next_d: list[int] = []
        self.loop_more: dict[int, list[tuple[int, int]]] = {}  # plated loops' other yarns
        self.on_needle: dict[Needle, list[int]] = {}
        self.last_loop: dict[int, int] = {}  # carrier -> its last loop
        self._moved: dict[int, int] = {}  # loop -> the op of this transfer pass that moved it
        self._xfer_racking: float | None = None

    # -- reporting ----------------------------------------------------------------------------

    def _report(self, kind: str, message: str, op: int | None = None) -> None:
        self._counts[kind] += 1
        if self._counts[kind] > self.limit_per_kind:
            return
        i = self._i if op is None else op
        o = self.prog.ops[i] if 0 <= i < len(self.prog.ops) else None
        sev = ERROR if CODES[kind].startswith("E") else WARNING
        self.findings.append(
            Finding(
                kind,
                sev,
                message,
                i,
                o.stitch if o is not None else -1,
                o.span if o is not None else None,
            )
        )

    @property
    def active(self) -> tuple[int, ...]:
        return tuple(sorted(c for c, s in self.state.items() if s != _OUT))

    # -- the run ------------------------------------------------------------------------------

    def run(self) -> list[Finding]:
        """Every op in order, then the end state; the findings.

        Almost every op of a compile is a plain knit or tuck: one carrier in action, on a
        hook needle on the bed, no inserting hook, no loose yarn end, nothing to report. Those
        take the fast path below, which makes exactly the state changes the general handlers
        (`_in_pass`, `_use`, `_loop`, `_knit_through`, `_set`, `_new_loop`) make, in their
        order, without their calls, property lookups and repeated dict lookups. It first
        checks, changing nothing, that none of their findings can arise; when one might (or
        anything unusual holds) the op goes the general way, which decides and reports."""
        handlers = {
            "in": self._in,
            "inhook": self._in,
            "releasehook": self._releasehook,
            "out": self._out,
            "outhook": self._out,
            "knit": self._loop,
            "tuck": self._loop,
            "split": self._loop,
            "miss": self._miss,
            "xfer": self._xfer,
            "drop": self._drop,
            "amiss": self._needle_only,
            "rack": self._rack,
        }
        passive = _PASSIVE_KINDS
        in_pass_kinds = _PASS_KINDS
        verified, machine = self.verified, self.machine
        # the fast path's state (containers that are never replaced, thresholds)
        fast = self.fast_path and machine.max_carriers_per_op >= 1  # (else all are E811)
        lo = self.bed_lo
        hi = lo + machine.needles - 1
        max_loops, max_float, max_misses = self.max_loops, self.max_float, self.max_misses
        loops, loops_get, last_touch = self.loops, self.loops.get, self.last_touch
        state, state_get = self.state, self.state.get
        last_use, stitched_add = self.last_use, self.stitched.add
        anchor, anchor_get = self.anchor, self.anchor.get
        carrier_dir, carrier_dir_get = self.carrier_dir, self.carrier_dir.get
        carrier_pass, carrier_pass_get = self.carrier_pass, self.carrier_pass.get
        loose, missed, cast_on, cast_on_live = (
            self.loose,
            self.missed,
            self.cast_on,
            self.cast_on_live,
        )
        rev_stacked, rev_knit = self.rev_stacked, self.rev_knit
        on_needle, on_needle_pop = self.on_needle, self.on_needle.pop
        loop_at, loop_next, loop_next_d = self.loop_at, self.loop_next, self.loop_next_d
        loop_more, last_loop, last_loop_get = self.loop_more, self.last_loop, self.last_loop.get
        loop_at_append, loop_front_append = loop_at.append, self.loop_front.append
        loop_prev_append, loop_prev_d_append = self.loop_prev.append, self.loop_prev_d.append
        loop_next_append, loop_next_d_append = loop_next.append, loop_next_d.append
        upto = 0  # ops before this one were simulated in bulk (`_knit_run`)
        short = 0  # ... and those before this one are a run too short to be worth it
        ops = self.prog.ops
        for i, op in enumerate(ops):
            if i < upto:
                continue
            if not verified:
                self._i = i
                problems = op_problems(op, machine, carrier_limit=False)
                if problems:
                    self._report("malformed", f"`{op.kind}` op: " + "; ".join(problems))
                    continue
            k = op.kind
            cs = op.carriers
            if (
                (k == "knit" or k == "tuck")
                and len(cs) == 1
                and fast
                and not self.hook  # (and so no parked hook: hook_slot is None)
                and not self._moved  # (a transfer pass to end first)
            ):
                n = op.needle
                assert n is not None
                bed, idx = n
                # a hook, not a slider (E808), on the bed (E806)
                plain = (bed == "f" or bed == "b") and lo <= idx <= hi
                if plain:
                    front = bed == "f"
                    r = self.racking
                    d = op.dir
                    # where n sits: `Needle.position` (an int on the front bed, not a float:
                    # the same sums and comparisons)
                    pos = idx if front else idx + r
                    # _in_pass, which the general way would come to next: does n start a new
                    # pass? Ending the last one counts the misses of the loops it passed over,
                    # which the knit's W804 then reads, so that is done first, here.
                    key = (d, cs, r)
                    touched = self._pass_touched[front]
                    new_pass = (
                        key != self._pass_key or (pos - self._pass_pos) * d < 0 or idx in touched
                    )
                    if new_pass:
                        self._end_pass()
                    c = cs[0]
                    held = loops_get(n, 0)
                    prev = anchor_get(c)
                if (
                    plain
                    and state_get(c, _OUT) != _OUT  # in (E802)
                    and not (loose and c in loose)  # its first loop (W807)
                    and (
                        # a knit: onto a loop (W802), not one missed too often (W804), not
                        # a cast-on loop (W808); it leaves one loop, never too many (W801)
                        (
                            held
                            and not (missed and missed.get(n, 0) > max_misses)
                            and not (cast_on_live and n in cast_on_live)
                        )
                        if k == "knit"
                        else held + 1 <= max_loops  # a tuck: not one loop too many (W801)
                    )
                    and (  # no long float from the carrier's last loop (W803)
                        prev is None
                        or abs(pos - (prev.index + r if prev.bed in _BACK_BEDS else prev.index))
                        <= max_float
                    )
                ):
                    # the rest of _in_pass
                    if new_pass:
                        self._pass_key = key
                        touched = self._pass_touched[front]
                    self._pass_pos = pos
                    touched.add(idx)
                    lo_hi = self._pass_span.get(front)
                    if lo_hi is None:
                        self._pass_span[front] = [idx, idx]
                    elif idx < lo_hi[0]:
                        lo_hi[0] = idx
                    elif idx > lo_hi[1]:
                        lo_hi[1] = idx
                    # _use
                    state[c] = _ACTIVE
                    last_use[c] = i
                    if carrier_dir_get(c) != d:
                        carrier_dir[c] = d
                        self._passes += 1
                        carrier_pass[c] = self._passes
                    # _loop's carrier loop
                    anchor[c] = n
                    stitched_add(c)
                    if k == "knit":
                        # _knit_through, _set(n, 1), the old loops knitted off
                        if missed:
                            missed.pop(n, None)
                        came_from = rev_stacked.pop(n, None) if rev_stacked else None
                        if came_from is not None:
                            rev_knit[n] = (came_from, i)
                        elif rev_knit:
                            rev_knit.pop(n, None)
                        loops[n] = 1
                        last_touch[n] = i
                        for x in on_needle_pop(n, ()):
                            loop_at[x] = None
                    else:
                        # _set(n, held + 1), the tuck's part of _loop
                        loops[n] = held + 1
                        last_touch[n] = i
                        if rev_stacked:
                            rev_stacked.pop(n, None)
                        if rev_knit:
                            rev_knit.pop(n, None)
                        if held:
                            if cast_on_live:
                                cast_on_live.discard(n)
                        else:
                            cast_on[n] = (c, carrier_pass_get(c, -1))
                            cast_on_live.add(n)
                    # _new_loop(n, (c,)): its yarn neighbour, the carrier's last loop
                    x = len(loop_at)
                    y = last_loop_get(c)
                    last_loop[c] = x
                    y_d = -1
                    if y is not None:
                        ny = loop_at[y]
                        if ny is not None and (ny.bed in _FRONT_BEDS) == front:
                            y_d = abs(idx - ny.index)
                            if loop_next[y] < 0:
                                loop_next[y] = x
                                loop_next_d[y] = y_d
                            else:
                                loop_more.setdefault(y, []).append((x, y_d))
                        else:
                            y = None
                    loop_at_append(n)
                    loop_front_append(front)
                    loop_prev_append(-1 if y is None else y)
                    loop_prev_d_append(y_d)
                    loop_next_append(-1)
                    loop_next_d_append(-1)
                    if k == "knit":
                        on_needle[n] = [x]
                        # a run is looked for where one can start: at the start of a pass
                        # or after another kind of op (in a rib's or a cable's pass, where
                        # the bed changes every few knits, there is none to find)
                        if i >= short and (new_pass or ops[i - 1].kind != "knit"):
                            upto, short = self._knit_run(i)
                    else:
                        on_needle.setdefault(n, []).append(x)
                    continue
            # the general way
            self._i = i
            if k not in passive:
                if k != "xfer" and self._moved:
                    self._end_xfer_pass()
                if k not in in_pass_kinds and self._pass_key is not None:
                    self._end_pass()
            h = handlers.get(k)
            if h is not None:
                h(op)
        self._i = -1
        self._end_xfer_pass()
        if self.check_end:
            self._end()
        for kind, count in self._counts.items():
            if count > self.limit_per_kind:
                sev = ERROR if CODES[kind].startswith("E") else WARNING
                self.findings.append(
                    Finding(
                        kind,
                        sev,
                        f"... and {count - self.limit_per_kind} more `{kind}` finding(s)",
                        -1,
                    )
                )
        return self.findings

    def _knit_run(self, i: int) -> tuple[int, int]:
        """After the fast path's plain knit `i`: the plain knits right after it that go on
        with its pass, simulated together. Returns the index of the first op not simulated
        here, and of the first op after the run: a run of fewer than `SHORT_RUN` knits is
        left to the fast path, op by op (its set-up would cost more than it saves), and is
        not looked at again.

        In a plain pass (most of every program) the fast path's knits differ only in their
        needle, so what each checks is a comparison against the knit before it (the same
        direction and yarn, on a hook bed, not back against the pass, within the float
        limit, a needle not yet knitted in the pass) and a look at its needle (loops to
        knit through, not missed too often, not a cast-on loop); the state changes are the
        fast path's, made for the whole run at once: each loop replaces the loops of its
        needle and is the yarn neighbour of the one before it when both are on one bed (a
        rib's or a jacquard's run goes from bed to bed). A run stops before the first op
        that differs in any of these (that op takes the usual way); the W806 bookkeeping of
        reverse stitches in progress, an inserting hook and an open transfer pass keep
        every op on it."""
        ops = self.prog.ops
        first = ops[i]
        d, cs, (bed, idx) = first.dir, first.carriers, first.needle  # type: ignore[misc]
        # a glance first: the next knits of a run go the same way with the same yarn (a
        # lace's or a cable's short runs between transfers stop here, at little cost)
        for j, o in enumerate(ops[i + 1 : i + 1 + SHORT_RUN], i + 1):
            if o.kind != "knit" or o.dir != d or o.carriers != cs:
                return i + 1, j
        if self.rev_stacked or self.rev_knit or self.hook or self._moved:
            return i + 1, i + 1
        machine, verified, r = self.machine, self.verified, self.racking
        lo = self.bed_lo
        hi = lo + machine.needles - 1
        max_float, max_misses = self.max_float, self.max_misses
        loops_get = self.loops.get
        missed, cast_on_live = self.missed, self.cast_on_live
        needles: list[Needle] = []
        prev_pos: float = idx if bed == "f" else idx + r
        # the last needle of each bed in the run (a pass only goes on along a bed); at the
        # start, a needle every one is beyond
        far = -d * (1 << 40)
        last_f, last_b = (idx, far) if bed == "f" else (far, idx)
        touched_f, touched_b = self._pass_touched[True], self._pass_touched[False]
        j, end = i + 1, len(ops)
        while j < end:
            o = ops[j]
            if o.kind != "knit" or o.dir != d or o.carriers != cs:
                break
            n = o.needle
            if n is None:
                break
            b, k = n
            pos: float
            if b == "f":
                if (k - last_f) * d <= 0 or k in touched_f:
                    break
                pos = last_f = k  # (used only if the run goes on)
            elif b == "b":
                if (k - last_b) * d <= 0 or k in touched_b:
                    break
                last_b = k
                pos = k + r
            else:
                break
            if (
                not 0 <= (pos - prev_pos) * d <= max_float  # (on with the pass; W803)
                or not lo <= k <= hi
                or not loops_get(n, 0)
                or (missed and missed.get(n, 0) > max_misses)
                or (cast_on_live and n in cast_on_live)
                or (not verified and op_problems(o, machine, carrier_limit=False))
            ):
                break
            needles.append(n)
            prev_pos = pos
            j += 1
        if len(needles) < SHORT_RUN:
            return i + 1, j
        c = cs[0]
        count = len(needles)
        ks = [n[1] for n in needles]
        one_bed = all(n[0] == bed for n in needles)  # (most runs: a plain pass's)
        fronts = [bed == "f"] * count if one_bed else [n[0] == "f" for n in needles]
        by_bed = (
            [(bed == "f", ks)]
            if one_bed
            else [
                (f, [k for k, x in zip(ks, fronts, strict=True) if x == f]) for f in (True, False)
            ]
        )
        # _in_pass: the needles knitted and the pass's span on each bed, where it is
        for front, on_bed in by_bed:
            if not on_bed:
                continue
            self._pass_touched[front].update(on_bed)
            a, z = min(on_bed[0], on_bed[-1]), max(on_bed[0], on_bed[-1])
            span = self._pass_span.get(front)
            if span is None:
                self._pass_span[front] = [a, z]
            else:
                span[0], span[1] = min(span[0], a), max(span[1], z)
        self._pass_pos = prev_pos
        # _use and _loop's carrier loop
        self.last_use[c] = j - 1
        self.anchor[c] = needles[-1]
        # _knit_through and _set(n, 1): the old loops knitted off
        if missed:
            for n in needles:
                missed.pop(n, None)
        self.loops.update(dict.fromkeys(needles, 1))
        self.last_touch.update(zip(needles, range(i + 1, j)))
        loop_at, on_needle = self.loop_at, self.on_needle
        pop = on_needle.pop
        for n in needles:
            for x in pop(n, ()):
                loop_at[x] = None
        # _new_loop of each: the loop before it is its yarn neighbour if on the same bed
        x0 = len(loop_at)
        if one_bed:
            gaps = [abs(b - a) for a, b in zip([idx, *ks], ks)]
            prevs: Iterable[int] = range(x0 - 1, x0 + count - 1)
            nexts: Iterable[int] = range(x0 + 1, x0 + count)
        else:
            gaps = [
                abs(b[1] - a[1]) if a[0] == b[0] else -1
                for a, b in zip([Needle(bed, idx), *needles], needles)
            ]
            prevs = [x - 1 if g >= 0 else -1 for x, g in enumerate(gaps, x0)]
            nexts = [x + 1 if g >= 0 else -1 for x, g in enumerate(gaps[1:], x0)]
        if gaps[0] >= 0:  # (op i's loop: the last made, with no next yet)
            self.loop_next[x0 - 1] = x0
            self.loop_next_d[x0 - 1] = gaps[0]
        loop_at.extend(needles)
        self.loop_front.extend(fronts)
        self.loop_prev.extend(prevs)
        self.loop_prev_d.extend(gaps)
        self.loop_next.extend(nexts)
        self.loop_next.append(-1)
        self.loop_next_d.extend(gaps[1:])
        self.loop_next_d.append(-1)
        on_needle.update(zip(needles, ([x] for x in range(x0, x0 + count))))
        self.last_loop[c] = x0 + count - 1
        return j, j

    # -- needles ------------------------------------------------------------------------------

    def _in_range(self, op: Op) -> bool:
        """Whether the op's needles are on the bed; each needle off it is reported at its
        first use only (a program placed off the bed would repeat it on every line)."""
        lo = self.bed_lo
        hi = lo + self.machine.needles - 1
        n, n2 = op.needle, op.needle2
        if (n is None or lo <= n.index <= hi) and (n2 is None or lo <= n2.index <= hi):
            return True  # (the common case, without the loop)
        ok = True
        for n in (op.needle, op.needle2):
            if n is not None and not lo <= n.index <= hi:
                if n not in self.off_bed:
                    self.off_bed.add(n)
                    where = (
                        ""
                        if lo == 0
                        else f", where `;;Position: {self.prog.position}` puts the "
                        f"program's {self.machine.needles} needles from its leftmost"
                    )
                    self._report(
                        "needle_range",
                        f"needle {n} is outside the bed ({lo}..{hi}{where}) in `{op}`",
                    )
                ok = False
        return ok

    def _set(self, n: Needle, count: int) -> None:
        before = self.loops.get(n, 0)
        if count:
            self.loops[n] = count
            self.last_touch[n] = self._i
        else:
            self.loops.pop(n, None)
        if count > self.max_loops and count > before:
            self._report(
                "too_many_loops",
                f"{n} holds {count} loops "
                f"(more than {self.max_loops}) after `{self.prog.ops[self._i]}`",
            )

    def _needle_only(self, op: Op) -> None:
        self._in_range(op)

    def _drop(self, op: Op) -> None:
        if self._in_range(op):
            assert op.needle is not None
            n = op.needle
            self._set(n, 0)
            self._forget(n)
            for x in self.on_needle.pop(n, ()):
                self.loop_at[x] = None

    def _forget(self, n: Needle) -> None:
        """What the hazard rules remember about the loops of `n`, once they leave it (each
        looked up only when it holds anything: hashing a Needle is what the run costs)."""
        if self.missed:
            self.missed.pop(n, None)
        if self.cast_on_live:
            self.cast_on_live.discard(n)
        if self.rev_stacked:
            self.rev_stacked.pop(n, None)
        if self.rev_knit:
            self.rev_knit.pop(n, None)

    def _check_transfer(self, op: Op) -> bool:
        a, b = op.needle, op.needle2
        assert a is not None and b is not None
        a_bed, b_bed = a.bed, b.bed
        if a_bed in _SLIDER_BEDS and (b_bed in _SLIDER_BEDS or op.kind == "split"):
            if b_bed in _SLIDER_BEDS:
                self._report("needle_use", f"`{op}` moves loops from a slider to a slider")
            else:
                self._report("needle_use", f"`{op}` splits from a slider")
            return False
        # `aligned(a, b, racking)`, without its conversions and properties
        a_front = a_bed in _FRONT_BEDS
        if a_front == (b_bed in _FRONT_BEDS):
            facing = False
        elif a_front:
            facing = b.index + self.racking == a.index
        else:
            facing = a.index + self.racking == b.index
        if not facing:
            self._report(
                "misaligned_xfer",
                f"{a} and {b} are not aligned at racking "
                f"{format_number(self.racking)} in `{op}` (they face each other "
                f"at racking {racking_for(a, b)})",
            )
        return True

    def _move(self, a: Needle, b: Needle) -> None:
        """The loops of `a` join those of `b`; carriers whose last loop was on `a` follow."""
        loops = self.loops
        moved = loops.get(a, 0)
        if moved:
            self._set(b, loops.get(b, 0) + moved)
            loops.pop(a, None)  # `_set(a, 0)`: no count is negative, so it never reports
            anchor = self.anchor
            for c, n in anchor.items():
                if n == a:
                    anchor[c] = b
            if self.missed:
                m = self.missed.pop(a, 0)
                if m or b in self.missed:
                    self.missed[b] = max(m, self.missed.get(b, 0))
            if self.cast_on_live:
                self.cast_on_live.discard(a)
                self.cast_on_live.discard(b)
        ids = self.on_needle.pop(a, None)
        if ids:
            at, pass_moved, i = self.loop_at, self._moved, self._i
            for x in ids:
                at[x] = b
                pass_moved[x] = i
            self.on_needle.setdefault(b, []).extend(ids)

    def _xfer(self, op: Op) -> None:
        if self._in_range(op) and self._check_transfer(op):
            a, b = op.needle, op.needle2
            assert a is not None and b is not None
            if self._moved and self._xfer_racking != self.racking:
                self._end_xfer_pass()
            self._xfer_racking = self.racking
            self._reverse_stitch(a, b, op)
            self._move(a, b)

    # -- W806: reverse stitches -----------------------------------------------------------------

    def _reverse_stitch(self, a: Needle, b: Needle, op: Op) -> None:
        """A purl by transfer moves a loop to the facing needle, knits it there and moves the
        new loop back. When the facing needle held a loop of its own (knitted on its bed),
        the knit pulls through both and the transfer back carries the facing bed's loop away
        with it."""
        back = self.rev_knit.pop(a, None) if self.rev_knit else None
        if back is not None and back[0] == b:
            k = self.prog.ops[back[1]]
            self._report(
                "reverse_occupied",
                f"reverse stitch on {a}: `{k}` knitted {a}'s own loop together with the one "
                f"moved from {b}, and `{op}` takes both to {b} (the facing needle was occupied)",
            )
        if self.rev_stacked:
            self.rev_stacked.pop(a, None)
            self.rev_stacked.pop(b, None)
        if self.rev_knit:
            self.rev_knit.pop(b, None)
        front = self.loop_front
        on_a, on_b = self.on_needle.get(a), self.on_needle.get(b)
        if (  # (most transfers go onto an empty needle: nothing to look through)
            on_a
            and on_b
            and any(front[x] == (b.bed in _FRONT_BEDS) for x in on_b)
            and any(front[x] == (a.bed in _FRONT_BEDS) for x in on_a)
        ):  # each needle holds a loop knitted on its own bed (else a lace move or decrease)
            self.rev_stacked[b] = a

    # -- W805: yarn stretched by transfers ------------------------------------------------------

    def _end_xfer_pass(self) -> None:
        """After a transfer pass: the loops it moved, against their yarn neighbours on the
        same bed (a neighbour on the other bed moves with the racking, and the racking comes
        back; a knitted-off one lies in the fabric). One finding per pass, the worst loop."""
        moved, self._moved = self._moved, {}
        if not moved:
            return
        at, max_stretch = self.loop_at, self.max_stretch
        prev, prev_d, nxt, nxt_d = (
            self.loop_prev,
            self.loop_prev_d,
            self.loop_next,
            self.loop_next_d,
        )
        more = self.loop_more
        worst: tuple[int, int, int, int] | None = None  # stretch, loop, neighbour, op
        # in stitch widths: the needles they were knitted apart (one in full gauge, two in
        # half gauge, where the loops are as long as two needles' worth of yarn)
        for x, i in moved.items():
            nx = at[x]
            if nx is None:
                continue
            x_front = nx.bed in _FRONT_BEDS
            # `self.neighbours(x)`, in its order (one list made, not three)
            nbs = [(prev[x], prev_d[x]), (nxt[x], nxt_d[x])]
            if more:
                nbs += more.get(x, ())
            for y, knitted in nbs:
                if y < 0:
                    continue
                ny = at[y]
                if ny is None or (ny.bed in _FRONT_BEDS) != x_front:
                    continue
                s = abs(nx.index - ny.index) - knitted
                if s > max_stretch * max(knitted, 1) and (worst is None or s > worst[0]):
                    worst = (s, x, y, i)
        if worst is not None:
            s, x, y, i = worst
            nx, ny = at[x], at[y]
            assert nx is not None and ny is not None
            d = abs(nx.index - ny.index)
            width = max(d - s, 1)
            self._report(
                "stretch",
                f"`{self.prog.ops[i]}` leaves the loop on {nx} {d} needles from its yarn "
                f"neighbour on {ny}, {s} more than they were knitted apart (more than "
                f"{self.max_stretch} stitch width{'s' * (self.max_stretch != 1)}"
                + (f" of {width} needles" if width != 1 else "")
                + "): the yarn between them is stretched",
                op=i,
            )

    def neighbours(self, x: int) -> list[tuple[int, int]]:
        """Loop `x`'s yarn neighbours on its bed when they were made: (loop, needles apart)."""
        out = [(self.loop_prev[x], self.loop_prev_d[x]), (self.loop_next[x], self.loop_next_d[x])]
        return [nb for nb in out if nb[0] >= 0] + self.loop_more.get(x, [])

    def _new_loop(self, n: Needle, carriers: tuple[int, ...]) -> int:
        x = len(self.loop_at)
        self.loop_at.append(n)
        self.loop_front.append(n.is_front)
        self.loop_prev.append(-1)
        self.loop_prev_d.append(-1)
        self.loop_next.append(-1)
        self.loop_next_d.append(-1)
        for c in carriers:
            y = self.last_loop.get(c)
            self.last_loop[c] = x
            if y is None or y == self.loop_prev[x]:  # (plated yarns from one loop: once)
                continue
            ny = self.loop_at[y]
            if ny is None or ny.is_front != n.is_front:
                continue
            d = abs(n.index - ny.index)
            if self.loop_prev[x] < 0:
                self.loop_prev[x], self.loop_prev_d[x] = y, d
            else:
                self.loop_more.setdefault(x, []).append((y, d))
            if self.loop_next[y] < 0:
                self.loop_next[y], self.loop_next_d[y] = x, d
            else:
                self.loop_more.setdefault(y, []).append((x, d))
        return x

    # -- W804: held loops the yarn passes over ---------------------------------------------------

    def _end_pass(self) -> None:
        """Every needle strictly inside a finished knitting pass that holds loops and was not
        knitted in it was missed once more (the yarn went past it in front of the bed)."""
        if self._pass_key is None:
            return
        self._pass_key = None
        loops, missed, new = self.loops, self.missed, tuple.__new__
        for front, (lo, hi) in self._pass_span.items():
            if hi - lo < 2:
                continue
            bed = "f" if front else "b"
            touched = self._pass_touched[front]
            for k in range(lo + 1, hi):
                if k not in touched:
                    # (a Needle made as the tuple it is: a fair isle yarn's pass passes
                    # over every needle of the other yarns, 200k on a jacquard sheet)
                    n = new(Needle, (bed, k))
                    if n in loops:
                        missed[n] = missed.get(n, 0) + 1
        self._pass_span = {}
        self._pass_touched = {True: set(), False: set()}

    def _in_pass(self, op: Op, n: Needle) -> None:
        pos = n.position(self.racking)
        key = (op.dir, op.carriers, self.racking)
        touched = self._pass_touched[n.is_front]
        if key != self._pass_key or (pos - self._pass_pos) * op.dir < 0 or n.index in touched:
            self._end_pass()
            self._pass_key = key
            touched = self._pass_touched[n.is_front]
        self._pass_pos = pos
        if op.kind == "miss" or n.is_slider:
            return
        touched.add(n.index)
        lo_hi = self._pass_span.get(n.is_front)
        if lo_hi is None:
            self._pass_span[n.is_front] = [n.index, n.index]
        elif n.index < lo_hi[0]:
            lo_hi[0] = n.index
        elif n.index > lo_hi[1]:
            lo_hi[1] = n.index

    # -- carriers -----------------------------------------------------------------------------

    def _use(self, op: Op) -> None:
        """Carriers of a knit/tuck/split/miss: in action, first pass after inhook leftward,
        clear of the parked hook, no more than the machine takes in one pass."""
        if (
            len(op.carriers) > self.machine.max_carriers_per_op
            and op.carriers not in self.too_many_carriers
        ):
            self.too_many_carriers.add(op.carriers)
            self._report(
                "carriers_per_op",
                f"`{op}` uses {len(op.carriers)} carriers in one op; the machine takes at "
                f"most {self.machine.max_carriers_per_op} in a pass",
            )
        for c in op.carriers:
            s = self.state.get(c, _OUT)
            if s == _OUT:
                # reported once until the carrier comes in; it stays out, so that the end
                # state does not echo the mistake as a carrier left in
                if c not in self.not_in:
                    self.not_in.add(c)
                    self._report(
                        "carrier_not_in",
                        f"carrier {c} is used by `{op}` but is not "
                        "in (bring it in with `in` or `inhook` first)",
                    )
                continue
            self.state[c] = _ACTIVE
            self.last_use[c] = self._i
            if self.carrier_dir.get(c) != op.dir:
                self.carrier_dir[c] = op.dir
                self._passes += 1
                self.carrier_pass[c] = self._passes
        if self.hook and not self.hook_dir_checked and set(op.carriers) & set(self.hook):
            self.hook_dir_checked = True
            if op.dir > 0:
                self.hook_block_reported = True  # where it parks follows from this mistake
                self._report(
                    "hook",
                    f"the first pass after `inhook` must go leftward (-), "
                    f"but `{op}` goes rightward",
                )
        if self.hook_slot is not None and not self.hook_block_reported:
            assert op.needle is not None
            if math.floor(op.needle.position(self.racking)) >= self.hook_slot:
                self.hook_block_reported = True
                self._report(
                    "hook",
                    f"`{op}` uses {op.needle}, at or right of the inserting hook, which "
                    f"holds carrier(s) {' '.join(map(str, self.hook))} just right of "
                    f"{self.hook_first} until `releasehook`",
                )

    def _one_hooked(self, op: Op) -> None:
        if op.kind in ("inhook", "releasehook", "outhook") and len(op.carriers) > 1:
            self._report(
                "hook",
                f"`{op}`: the inserting hook takes one carrier at a time "
                "(the Knitout writer puts one carrier per line, and the second "
                f"`{op.kind}` would find the hook in use); bring the others in "
                "with `in`",
            )

    def _in(self, op: Op) -> None:
        self._one_hooked(op)
        for c in op.carriers:
            self.not_in.discard(c)
            if self.state.get(c, _OUT) != _OUT:
                self._report("carrier_state", f"`{op}` brings in carrier {c}, which is already in")
                continue  # it stays as it was
            self.state[c] = _PENDING
            self.stitched.discard(c)
            self.anchor.pop(c, None)
            self.last_loop.pop(c, None)
            self.carrier_dir.pop(c, None)
            self.last_use[c] = self._i
            if op.kind == "in":
                self.loose.add(c)
        if op.kind == "inhook":
            if self.hook:
                self._report(
                    "hook",
                    f"`{op}` while the inserting hook still holds carrier(s) "
                    f"{' '.join(map(str, self.hook))} (release it first)",
                )
            self.hook, self.hook_op = op.carriers, self._i
            self.hook_stitched = self.hook_dir_checked = False
            self.hook_slot = self.hook_first = None
            self.hook_block_reported = False

    def _release(self) -> None:
        self.hook = ()
        self.hook_slot = self.hook_first = None

    def _releasehook(self, op: Op) -> None:
        self._one_hooked(op)
        if not self.hook:
            self._report("hook", f"`{op}` but the inserting hook holds nothing")
            return
        if op.carriers != self.hook:
            self._report(
                "hook",
                f"`{op}` but the inserting hook holds carrier(s) {' '.join(map(str, self.hook))}",
            )
        elif not self.hook_stitched:
            self._report("hook", f"`{op}` before any stitch with the hooked carrier(s)")
        self._release()

    def _out(self, op: Op) -> None:
        self._one_hooked(op)
        held = [c for c in op.carriers if c in self.hook]
        if held or (op.kind == "outhook" and self.hook):
            which = " ".join(map(str, held or self.hook))
            self._report(
                "hook",
                f"`{op}` while carrier(s) {which} are still on the inserting "
                "hook (releasehook first)",
            )
            self._release()
        for c in op.carriers:
            s = self.state.get(c, _OUT)
            if s == _OUT:
                if c not in self.not_in:
                    self.not_in.add(c)
                    self._report("carrier_not_in", f"`{op}` takes out carrier {c}, which is not in")
            elif s == _PENDING or c not in self.stitched:
                self._report(
                    "carrier_state",
                    f"`{op}` takes out carrier {c}, which never "
                    "made a stitch since it was brought in",
                )
            self.state[c] = _OUT
            self.anchor.pop(c, None)
            self.last_loop.pop(c, None)
            self.loose.discard(c)
            self.last_use[c] = self._i

    def _miss(self, op: Op) -> None:
        if self._in_range(op):
            assert op.needle is not None
            self._in_pass(op, op.needle)
            self._use(op)

    def _loop(self, op: Op) -> None:
        """knit, tuck, split: a new loop on `needle` made by the carriers."""
        n = op.needle
        assert n is not None
        if not self._in_range(op):
            self._use(op)
            self._park_hook(op, n)
            return
        if n.is_slider:
            self._report("needle_use", f"`{op}` forms a loop on slider {n}")
            self._use(op)
            return
        if op.kind == "split" and not self._check_transfer(op):
            self._use(op)
            return
        if self._moved:
            self._end_xfer_pass()
        self._in_pass(op, n)
        self._use(op)
        self._park_hook(op, n)
        held = self.loops.get(n, 0)
        for c in op.carriers:
            prev = self.anchor.get(c)
            if prev is not None:
                dist = abs(n.position(self.racking) - prev.position(self.racking))
                if dist > self.max_float:
                    self._report(
                        "long_float",
                        f"carrier {c} floats {format_number(dist)} "
                        f"needles from {prev} to {n} (more than {self.max_float})",
                    )
            self.anchor[c] = n
            self.stitched.add(c)
            if c in self.loose:
                self.loose.discard(c)
                if not held and self.state.get(c) == _ACTIVE:
                    self._report(
                        "loose_yarn",
                        f"carrier {c} came in with `in`, not `inhook`, and its first loop "
                        f"`{op}` is on empty needle {n}: nothing holds the yarn end "
                        "(bring it in with `inhook`, or start it on loops)",
                    )
        if op.kind == "knit":
            if not held:
                self._report(
                    "knit_on_empty",
                    f"`{op}` knits on empty needle {n} "
                    "(nothing holds the new loop; tuck to cast on)",
                )
            self._knit_through(op, n, held)
            self._set(n, 1)
            for x in self.on_needle.pop(n, ()):
                self.loop_at[x] = None
            self.on_needle[n] = [self._new_loop(n, op.carriers)]
        elif op.kind == "tuck":
            self._set(n, held + 1)
            if self.rev_stacked:
                self.rev_stacked.pop(n, None)
            if self.rev_knit:
                self.rev_knit.pop(n, None)
            if held:
                if self.cast_on_live:
                    self.cast_on_live.discard(n)
            else:
                c = op.carriers[0]
                self.cast_on[n] = (c, self.carrier_pass.get(c, -1))
                self.cast_on_live.add(n)
            self.on_needle.setdefault(n, []).append(self._new_loop(n, op.carriers))
        else:  # split: the old loops go across, the new one stays
            assert op.needle2 is not None
            self._knit_through(op, n, held)
            self._forget(n)
            self._move(n, op.needle2)
            self._set(n, 1)
            self.on_needle[n] = [self._new_loop(n, op.carriers)]

    def _park_hook(self, op: Op, n: Needle) -> None:
        """The hooked carrier's first loop parks the hook in the slot right of it."""
        if self.hook and set(op.carriers) & set(self.hook):
            self.hook_stitched = True
            if self.hook_slot is None:
                self.hook_slot = math.floor(n.position(self.racking)) + 1
                self.hook_first = n

    def _knit_through(self, op: Op, n: Needle, held: int) -> None:
        """The hazards of pulling a new loop through the loops of `n` (knit or split)."""
        m = self.missed.pop(n, 0) if self.missed else 0
        if m > self.max_misses:
            self._report(
                "long_miss",
                f"`{op}` knits through the loop on {n}, which the yarn passed over "
                f"without knitting it in {m} passes in a row (more than {self.max_misses}): "
                "the held loop is drawn long and strains",
            )
        if self.cast_on_live and n in self.cast_on_live:
            if held == 1:
                self._cast_on_knit(op, n)
            self.cast_on_live.discard(n)
        if op.kind == "knit":
            came_from = self.rev_stacked.pop(n, None) if self.rev_stacked else None
            if came_from is not None:
                self.rev_knit[n] = (came_from, self._i)
            elif self.rev_knit:
                self.rev_knit.pop(n, None)

    def _cast_on_knit(self, op: Op, n: Needle) -> None:
        """A knit through a cast-on loop (a tuck onto the empty needle) before its carrier
        has turned since it tucked it: no course the other way holds the tucks yet, so
        the knit, drawing its yarn from the same side, pulls them off. A cast-on knitted
        back the other way (every cast-on of knitc's, an interlock, a tube's) is fine."""
        c, tucked = self.cast_on[n]
        if c not in op.carriers or tucked != self.carrier_pass.get(c):
            return
        if (c, tucked) in self.cast_on_reported:
            return
        self.cast_on_reported.add((c, tucked))
        self._report(
            "cast_on_knit",
            f"`{op}` knits the cast-on loop on {n} before carrier {c} has turned since it "
            "tucked it onto the empty needle: no course the other way holds the cast-on yet, "
            "and the knit pulls it off (knit the first course back the other way)",
        )

    # -- racking ------------------------------------------------------------------------------

    def _rack(self, op: Op) -> None:
        r = float(op.value)  # type: ignore[arg-type]
        limit = self.machine.racking_limit
        if abs(r) > limit:
            self._report(
                "racking", f"racking {format_number(r)} is beyond the machine's limit of {limit}"
            )
        if r - math.floor(r) not in (0.0, 0.25):
            self._report(
                "racking",
                f"racking {format_number(r)}: only whole racks and "
                "quarter pitch (x.25) are possible",
            )
        self.racking = op.value  # type: ignore[assignment]

    # -- the end ------------------------------------------------------------------------------

    def _end(self) -> None:
        if self.hook:
            self._report(
                "hook",
                "the inserting hook still holds carrier(s) "
                f"{' '.join(map(str, self.hook))} at the end (releasehook)",
                op=self.hook_op,
            )
        if self.loops:
            needles = sorted(self.loops, key=lambda n: (n.bed, n.index))
            total = sum(self.loops.values())
            shown = " ".join(map(str, needles[:16])) + (" ..." if len(needles) > 16 else "")
            last = max(self.last_touch[n] for n in needles)
            self._report(
                "loops_left",
                f"{total} loop(s) left on {len(needles)} needle(s) at "
                f"the end: {shown} (drop or bind off)",
                op=last,
            )
        for c in self.active:
            self._report(
                "carriers_left",
                f"carrier {c} is still in at the end (take it out with `out` or `outhook`)",
                op=self.last_use.get(c, -1),
            )


def simulate(
    prog: MachineProgram,
    *,
    max_loops: int | None = None,
    max_float: int | None = None,
    check_end: bool = True,
    limit_per_kind: int = 100,
    placed: bool = False,
    verified: bool = False,
) -> list[Finding]:
    """Run `prog` on knitc's machine model; findings in program order (end-state ones last).

    max_loops: warn when an op leaves more loops than this on a needle (default: the
      machine profile's `max_loops`).
    max_float: warn when a carrier's consecutive loops are more than this many needles apart
      (default: the profile's `max_float`).
    check_end: False for a fragment that deliberately leaves loops or carriers.
    limit_per_kind: report at most this many findings of one kind (then one summary).
    placed: needle numbers as the program's `;;Position:` places them (`Simulator`), for a
      Knitout file read from another tool.
    verified: every op already passed `machine.verify` (the driver checks them just before),
      so the per-op check is not repeated: each op of a compile is validated once.
    """
    return Simulator(
        prog,
        max_loops=max_loops,
        max_float=max_float,
        check_end=check_end,
        limit_per_kind=limit_per_kind,
        placed=placed,
        verified=verified,
    ).run()


def add_to_diagnostics(findings: list[Finding], prog: MachineProgram, diags: Diagnostics) -> None:
    """Report findings as diagnostics at the span of the op that caused them (a DSL line, or
    the Knitout line of a program read from a file), with a note naming the op (and its
    stitch)."""
    for f in findings:
        notes = []
        if 0 <= f.op < len(prog.ops):
            stitch = f", stitch {f.stitch}" if f.stitch >= 0 else ""
            notes.append(Note(f"machine op {f.op}: `{prog.ops[f.op]}`{stitch}"))
        add = diags.error if f.is_error else diags.warning
        add(f.code, f.message, f.span, notes=notes)
