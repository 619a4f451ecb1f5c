"""knitc's own machine simulation: a fast check of a `MachineProgram` that points at DSL lines.

One pass over the ops with the machine state a V-bed needs for safety: loops per needle as
integer counts (not loop identities), carriers out / brought in / in action, the inserting
hook, the racking, and for each carrier the needle of the last loop it made (followed when
that loop is transferred, as Knitout's carrier motion rule says). Findings carry the op
index, its stitch and its source span, so they become diagnostics at the DSL line that made
the op (`add_to_diagnostics`).

This is not the judge: the independent oracle (tests/oracle.py) is. The rules follow what
the oracle and the Shima DAT converter enforce (shared/research/knitout-and-dat.md §1.7),
and where the two differ, the stricter one:

errors
  E801 misaligned_xfer   xfer/split between needles that do not face each other at the racking
  E802 carrier_not_in    a carrier used, or taken out, while not in action
  E803 loops_left        loops still on needles at the end
  E804 carriers_left     carriers still in action at the end
  E805 hook              inhook while the hook holds yarn, first pass after inhook not
                         leftward, releasehook of other carriers or before a stitch, out of a
                         carrier still on the hook, hook never released, more than one
                         carrier in an inhook/releasehook/outhook
  E806 needle_range      a needle outside 0 .. machine.needles - 1
  E807 racking           |racking| above the machine's limit, or a fraction other than .25
  E808 needle_use        knit/tuck on a slider, split from a slider, slider to slider
  E809 carrier_state     in/inhook of a carrier already in, out of one that never stitched
  E810 malformed         an op that is not well formed (an internal error of code generation)
warnings
  W801 too_many_loops    an op leaves more than `max_loops` loops on a needle
  W802 knit_on_empty     knit on a needle holding no loop (a tuck there is a cast-on)
  W803 long_float        a carrier's consecutive loops more than `max_float` needles apart

The oracle's own hazard limits are 4 loops (`max_loops=3`) and floats over 20 needles
(`max_float=20`); knitc's defaults are stricter.
"""

from __future__ import annotations

import math
from collections import Counter
from dataclasses import dataclass
from typing import Any

from knitc.codegen.machine import (
    MachineProgram,
    Needle,
    Op,
    aligned,
    format_number,
    op_problems,
    racking_for,
)
from knitc.diagnostics import Diagnostics, Note
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
    "too_many_loops": "W801",
    "knit_on_empty": "W802",
    "long_float": "W803",
}
"""Finding kind -> diagnostic code (E = error, W = warning)."""

ERROR, WARNING = "error", "warning"


@dataclass(frozen=True)
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


class Simulator:
    """The simulation state; `run()` goes through the program once and returns findings.

    After `run()`, `loops` (needle -> loop count, needles with loops only), `active`
    (carriers in, sorted), `hook` (carriers on the hook) and `racking` describe
    the machine at the end.
    """

    def __init__(
        self,
        prog: MachineProgram,
        *,
        max_loops: int = 2,
        max_float: int = 12,
        check_end: bool = True,
        limit_per_kind: int = 100,
    ) -> None:
        self.prog = prog
        self.machine = prog.machine
        self.max_loops = max_loops
        self.max_float = max_float
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
        self.racking: float = 0
        self.findings: list[Finding] = []
        self._counts: Counter[str] = Counter()
        self._i = -1

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
        for i, op in enumerate(self.prog.ops):
            self._i = i
            problems = op_problems(op, self.machine)
            if problems:
                self._report("malformed", f"`{op.kind}` op: " + "; ".join(problems))
                continue
            h = handlers.get(op.kind)
            if h is not None:
                h(op)
        self._i = -1
        if self.check_end:
            self._end()
        for kind, n in self._counts.items():
            if n > self.limit_per_kind:
                sev = ERROR if CODES[kind].startswith("E") else WARNING
                self.findings.append(
                    Finding(
                        kind, sev, f"... and {n - self.limit_per_kind} more `{kind}` finding(s)", -1
                    )
                )
        return self.findings

    # -- needles ------------------------------------------------------------------------------

    def _in_range(self, op: Op) -> bool:
        ok = True
        for n in (op.needle, op.needle2):
            if n is not None and not 0 <= n.index < self.machine.needles:
                self._report(
                    "needle_range",
                    f"needle {n} is outside the bed (0..{self.machine.needles - 1}) in `{op}`",
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
            self._set(op.needle, 0)

    def _check_transfer(self, op: Op) -> bool:
        a, b = op.needle, op.needle2
        assert a is not None and b is not None
        if a.is_slider and b.is_slider:
            self._report("needle_use", f"`{op}` moves loops from a slider to a slider")
            return False
        if op.kind == "split" and a.is_slider:
            self._report("needle_use", f"`{op}` splits from a slider")
            return False
        if not aligned(a, b, self.racking):
            self._report(
                "misaligned_xfer",
                f"{a} and {b} are not aligned at racking "
                f"{format_number(self.racking)} in `{op}` (they face each other "
                f"at racking {racking_for(a, b)})",
            )
        return True

    def _move(self, a: Needle, b: Needle) -> None:
        """The loops of `a` join those of `b`; carriers whose last loop was on `a` follow."""
        moved = self.loops.get(a, 0)
        if moved:
            self._set(b, self.loops.get(b, 0) + moved)
            self._set(a, 0)
            for c, n in self.anchor.items():
                if n == a:
                    self.anchor[c] = b

    def _xfer(self, op: Op) -> None:
        if self._in_range(op) and self._check_transfer(op):
            assert op.needle is not None and op.needle2 is not None
            self._move(op.needle, op.needle2)

    # -- carriers -----------------------------------------------------------------------------

    def _use(self, op: Op) -> None:
        """Carriers of a knit/tuck/split/miss: in action, first pass after inhook leftward."""
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
        if self.hook and not self.hook_dir_checked and set(op.carriers) & set(self.hook):
            self.hook_dir_checked = True
            if op.dir > 0:
                self._report(
                    "hook",
                    f"the first pass after `inhook` must go leftward (-), "
                    f"but `{op}` goes rightward",
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
            self.last_use[c] = self._i
        if op.kind == "inhook":
            if self.hook:
                self._report(
                    "hook",
                    f"`{op}` while the inserting hook still holds carrier(s) "
                    f"{' '.join(map(str, self.hook))} (release it first)",
                )
            self.hook, self.hook_op = op.carriers, self._i
            self.hook_stitched = self.hook_dir_checked = False

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
        self.hook = ()

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
            self.hook = ()
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
            self.last_use[c] = self._i

    def _miss(self, op: Op) -> None:
        if self._in_range(op):
            self._use(op)

    def _loop(self, op: Op) -> None:
        """knit, tuck, split: a new loop on `needle` made by the carriers."""
        n = op.needle
        assert n is not None
        if not self._in_range(op):
            self._use(op)
            return
        if n.is_slider:
            self._report("needle_use", f"`{op}` forms a loop on slider {n}")
            self._use(op)
            return
        if op.kind == "split" and not self._check_transfer(op):
            self._use(op)
            return
        self._use(op)
        if set(op.carriers) & set(self.hook):
            self.hook_stitched = True
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
        held = self.loops.get(n, 0)
        if op.kind == "knit":
            if not held:
                self._report(
                    "knit_on_empty",
                    f"`{op}` knits on empty needle {n} "
                    "(nothing holds the new loop; tuck to cast on)",
                )
            self._set(n, 1)
        elif op.kind == "tuck":
            self._set(n, held + 1)
        else:  # split: the old loops go across, the new one stays
            assert op.needle2 is not None
            self._move(n, op.needle2)
            self._set(n, 1)

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
    max_loops: int = 2,
    max_float: int = 12,
    check_end: bool = True,
    limit_per_kind: int = 100,
) -> list[Finding]:
    """Run `prog` on knitc's machine model; findings in program order (end-state ones last).

    max_loops: warn when an op leaves more loops than this on a needle.
    max_float: warn when a carrier's consecutive loops are more than this many needles apart.
    check_end: False for a fragment that deliberately leaves loops or carriers.
    limit_per_kind: report at most this many findings of one kind (then one summary).
    """
    return Simulator(
        prog,
        max_loops=max_loops,
        max_float=max_float,
        check_end=check_end,
        limit_per_kind=limit_per_kind,
    ).run()


def add_to_diagnostics(findings: list[Finding], prog: MachineProgram, diags: Diagnostics) -> None:
    """Report findings as diagnostics at the DSL span of the op that caused them, with a note
    naming the op (and its stitch)."""
    for f in findings:
        notes = []
        if 0 <= f.op < len(prog.ops):
            stitch = f", stitch {f.stitch}" if f.stitch >= 0 else ""
            notes.append(Note(f"machine op {f.op}: `{prog.ops[f.op]}`{stitch}"))
        add = diags.error if f.is_error else diags.warning
        add(f.code, f.message, f.span, notes=notes)
