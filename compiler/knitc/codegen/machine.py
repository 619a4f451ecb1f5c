"""The machine-program IR: Knitout-level operations for one V-bed machine (thesis ch. 6.8).

A `MachineProgram` is a machine profile plus a flat list of `Op`s in carriage order, exactly
as they will be written out, so the Knitout backend is a printer and the simulator a single
loop. Every op keeps the stitch (id in the stitch graph, -1 = none) and the source span it
came from, so a finding of the simulator or an error of an external tool can be traced back
to the DSL line that caused it.

Conventions (Knitout v0.6, shared/research/knitout-and-dat.md §1):
- beds are 'f', 'b' (hooks) and 'fs', 'bs' (sliders); `Needle('f', 3)` prints as ``f3``;
- directions are +1 (towards higher needle numbers, Knitout ``+``) and -1 (``-``); ops that
  have no direction store 0;
- at racking R, back needle b(k) faces front needle f(k + R): R = front index - back index;
- carriers are 1-based integers (1..machine.carriers); a carrier set is a tuple, in order;
- `value` is the racking of ``rack``, the number of ``x-stitch-number`` / ``x-speed-number``,
  the ``(L, T)`` pair of ``stitch L T`` (Knitout's leading/stitch values; the Shima back end
  maps them to a stitch number through the converter's table), the mode of
  ``x-presser-mode``, the text of ``comment`` and the (optional) message of
  ``pause``.

Building a program reads like the Knitout it makes::

    prog = MachineProgram(Machine())
    with prog.at(stitch=12, span=span):       # provenance for every op in the block
        prog.knit(+1, Needle("f", 3), 3)      # or prog.knit(+1, "f3", (3,))
        prog.xfer("f3", "b3")
        prog.rack(-1)                         # elided when the racking is already -1
        prog.xfer("b3", "f2")
"""

from __future__ import annotations

import math
from collections import Counter
from collections.abc import Iterable, Iterator
from contextlib import contextmanager
from dataclasses import field
from typing import Any, NamedTuple, cast

from knitc.records import record
from knitc.source import Span

# ---- needles ----------------------------------------------------------------------------------

BEDS = ("f", "b", "fs", "bs")
"""Front hooks, back hooks, front sliders, back sliders."""


class Needle(NamedTuple):
    """One needle: a bed ('f', 'b', 'fs', 'bs') and an index. `str()` gives ``f12``.

    A named tuple, not a dataclass: a compile hashes and compares needles millions of times
    (the loop model and the simulator key their dicts by them), and a tuple does both in C.
    Needles order by bed, then index."""

    bed: str
    index: int  # type: ignore[assignment]  # (shadows tuple.index, which no caller uses)

    def __str__(self) -> str:
        return f"{self.bed}{self.index}"

    @classmethod
    def parse(cls, text: str) -> Needle:
        """``'f12'`` -> Needle('f', 12); also 'b', 'fs', 'bs' and negative indices."""
        t = text.strip()
        bed = t[:2] if t[:2] in ("fs", "bs") else t[:1]
        if bed not in BEDS:
            raise ValueError(f"not a needle: {text!r}")
        try:
            return cls(bed, int(t[len(bed) :]))
        except ValueError:
            raise ValueError(f"not a needle: {text!r}") from None

    @property
    def is_front(self) -> bool:
        return self.bed in ("f", "fs")

    @property
    def is_back(self) -> bool:
        return self.bed in ("b", "bs")

    @property
    def is_slider(self) -> bool:
        return self.bed in ("fs", "bs")

    def shifted(self, delta: int) -> Needle:
        """The needle `delta` places along the same bed."""
        return Needle(self.bed, self.index + delta)

    def opposite(self, index: int | None = None, *, slider: bool = False) -> Needle:
        """A needle of the other bed (hook, or slider if `slider`), by default the same index."""
        bed = ("b" if self.is_front else "f") + ("s" if slider else "")
        return Needle(bed, self.index if index is None else index)

    def position(self, racking: float) -> float:
        """Where the needle sits in front-bed coordinates at `racking` (b(k) faces f(k + R))."""
        return self.index + racking if self.is_back else float(self.index)


NeedleLike = Needle | str


def as_needle(n: NeedleLike) -> Needle:
    return n if type(n) is Needle or isinstance(n, Needle) else Needle.parse(n)


def racking_for(a: NeedleLike, b: NeedleLike) -> int:
    """The racking at which needles `a` and `b` (on opposite beds) face each other."""
    a, b = as_needle(a), as_needle(b)
    if a.is_front == b.is_front:
        raise ValueError(f"{a} and {b} are on the same bed")
    front, back = (a, b) if a.is_front else (b, a)
    return front.index - back.index


def aligned(a: NeedleLike, b: NeedleLike, racking: float) -> bool:
    """Whether `a` and `b` are on opposite beds and face each other at `racking`."""
    a, b = as_needle(a), as_needle(b)
    if a.is_front == b.is_front:
        return False
    front, back = (a, b) if a.is_front else (b, a)
    return back.index + racking == front.index


# ---- the machine profile ----------------------------------------------------------------------


@record(frozen=True)
class Machine:
    """The target machine: the values written into the Knitout header and checked against."""

    name: str = "SWG091N2"
    needles: int = 541
    """Needles per bed; valid indices are 0 .. needles - 1."""
    gauge: int = 15
    racking_limit: int = 4
    """Largest |racking| allowed."""
    carriers: int = 10
    """Carriers are named 1 .. carriers."""
    max_carriers_per_op: int = 2
    """The Shima backend encodes one or two carriers per pass (research §1.7, 12)."""

    # The hazard thresholds of knitc's simulation (`knitc.codegen.simulate`): what the
    # machine knits reliably, so that `knitc check` and `knitc lint` warn past it. They are
    # not written into the Knitout header (nothing downstream reads them) and so not into
    # `to_json` either.
    max_loops: int = 2
    """Loops a needle may hold (a decrease stacks two); a third, whether tucked or
    transferred onto it, is pulled through with them by the next knit (W801)."""
    max_float: int = 12
    """Needles a carrier's yarn may float between consecutive loops (W803)."""
    max_misses: int = 6
    """Passes in a row the yarn may pass a held loop without knitting it (a slip stitch
    over a few courses) before knitting through it again strains it (W804)."""
    max_stretch: int = 3
    """Stitch widths a transfer may move a loop further from a yarn neighbour on its bed
    than they were knitted apart (a width is that distance: a needle in full gauge, two in
    half gauge); a 3-over-3 cable's outer loops move 3 (W805)."""

    @property
    def carrier_names(self) -> tuple[int, ...]:
        return tuple(range(1, self.carriers + 1))

    def to_json(self) -> dict[str, Any]:
        return {
            "name": self.name,
            "needles": self.needles,
            "gauge": self.gauge,
            "racking_limit": self.racking_limit,
            "carriers": self.carriers,
            "max_carriers_per_op": self.max_carriers_per_op,
        }


# ---- operations -------------------------------------------------------------------------------

KINDS = (
    "in",
    "inhook",
    "releasehook",
    "out",
    "outhook",
    "knit",
    "tuck",
    "split",
    "xfer",
    "drop",
    "miss",
    "amiss",
    "rack",
    "stitch",
    "stitch_number",
    "speed",
    "presser",
    "pause",
    "comment",
)
"""Every op kind, in a fixed order (also the order of `stats()["kinds"]`)."""

CARRIER_KINDS = frozenset({"in", "inhook", "releasehook", "out", "outhook"})
"""Ops that change which carriers are in action (carriers required, no needle)."""
DIRECTED_KINDS = frozenset({"knit", "tuck", "split", "miss"})
"""Ops with a direction and a needle; carriers required (a `split` without carriers is an
`xfer`, a `knit` without carriers a `drop`, a `tuck` without carriers an `amiss`)."""
LOOP_KINDS = frozenset({"knit", "tuck", "split"})
"""Ops that form a new loop."""
SETTING_KINDS = frozenset({"stitch", "stitch_number", "speed", "presser"})
PRESSER_MODES = ("on", "off", "auto")

CODE_PASSES = (
    "",
    "yarn_start",
    "cast_on",
    "action",
    "shaping",
    "alignment",
    "cast_off",
    "yarn_end",
    "float_catch",
    "backing",
)
"""The code pass (thesis ch. 6.8.1) an op belongs to ("float_catch": a fair isle yarn's
tuck that binds its float, `yarn { tuck_every }`; "backing": a jacquard yarn's knit on the
other bed, and the transfer that closes the backing onto the front); '' when it was not made by code
generation (read from a file, built by hand). Tools read it: the fabric check finds the loop
that stands for a stitch (the one its action pass formed), the bench counts transfer passes
by kind, and pictures colour the passes."""

KNITOUT_OPCODE = {
    "stitch_number": "x-stitch-number",
    "speed": "x-speed-number",
    "presser": "x-presser-mode",
}
"""Knitout opcodes that differ from the kind's name."""


def format_number(v: float | int) -> str:
    """Integers without a decimal point (``2``, ``-1``), others shortest (``0.25``)."""
    if isinstance(v, bool):
        raise TypeError("a boolean is not a number")
    if float(v).is_integer():
        return str(int(v))
    return repr(float(v))


class Op(NamedTuple):
    """One machine operation, with the stitch and source span it came from.

    A named tuple (immutable, compared by value) rather than a frozen dataclass: a program
    has a few ops per stitch, and building a tuple costs a fraction of a frozen
    dataclass's field-by-field initialisation."""

    kind: str
    dir: int = 0
    needle: Needle | None = None
    needle2: Needle | None = None
    carriers: tuple[int, ...] = ()
    value: float | int | str | tuple[float | int, float | int] | None = None
    stitch: int = -1
    span: Span | None = None
    phase: str = ""
    """The code pass that made the op (`CODE_PASSES`)."""

    @property
    def forms_loop(self) -> bool:
        return self.kind in LOOP_KINDS

    def __str__(self) -> str:
        """The Knitout instruction (without comment; carrier sets on one line)."""
        k = self.kind
        cs = " ".join(map(str, self.carriers))
        if k == "comment":
            return f"; {self.value}"
        if k in CARRIER_KINDS:
            return f"{k} {cs}".rstrip()
        if k in DIRECTED_KINDS:
            d = "+" if self.dir > 0 else "-"
            parts = [k, d, str(self.needle)]
            if k == "split":
                parts.append(str(self.needle2))
            return " ".join(parts) + (f" {cs}" if cs else "")
        if k == "xfer":
            return f"xfer {self.needle} {self.needle2}"
        if k in ("drop", "amiss"):
            return f"{k} {self.needle}"
        if k == "rack":
            return f"rack {format_number(self.value)}"  # type: ignore[arg-type]
        if k == "stitch":
            lead, tight = cast("tuple[float, float]", self.value)
            return f"stitch {format_number(lead)} {format_number(tight)}"
        if k in ("stitch_number", "speed"):
            return f"{KNITOUT_OPCODE[k]} {format_number(self.value)}"  # type: ignore[arg-type]
        if k == "presser":
            return f"x-presser-mode {self.value}"
        if k == "pause":
            return "pause"
        raise ValueError(f"unknown op kind {k!r}")

    def to_json(self) -> dict[str, Any]:
        """Compact: only the fields the kind uses, plus provenance when there is some."""
        out: dict[str, Any] = {"op": self.kind}
        if self.dir:
            out["dir"] = "+" if self.dir > 0 else "-"
        if self.needle is not None:
            out["needle"] = str(self.needle)
        if self.needle2 is not None:
            out["needle2"] = str(self.needle2)
        if self.carriers:
            out["carriers"] = list(self.carriers)
        if self.value is not None:
            out["value"] = self.value
        if self.stitch >= 0:
            out["stitch"] = self.stitch
        if self.span is not None:
            out["span"] = self.span.to_json()
        if self.phase:
            out["pass"] = self.phase
        return out


CarriersLike = int | Iterable[int]


def as_carriers(cs: CarriersLike) -> tuple[int, ...]:
    if type(cs) is tuple and len(cs) == 1 and type(cs[0]) is int:
        return cs  # the common case: one carrier, already as it should be
    if isinstance(cs, bool):
        raise TypeError("a boolean is not a carrier")
    if isinstance(cs, int):
        return (cs,)
    return tuple(int(c) for c in cs)


# ---- the program ------------------------------------------------------------------------------

_UNSET: Any = object()


@record
class MachineProgram:
    """A machine profile and its operations, in execution order; also the builder.

    The builder methods append one op each and return it. Each takes keyword-only `stitch`
    and `span`; when omitted they default to the innermost `with prog.at(...)` block (else
    -1 / None). `rack`, `stitch_number`, `speed` and `presser` skip redundant settings
    (pass `force=True` to emit anyway). Append ops built elsewhere with `emit`, which keeps
    the builder's racking and settings state right; do not append to `ops` directly.
    """

    machine: Machine = field(default_factory=Machine)
    ops: list[Op] = field(default_factory=list)
    position: str = "Center"
    """The ``;;Position:`` header: Left, Center, Right or Keep."""
    width: int | None = None
    """The ``;;Width:`` header (bed width in needles, used by the Shima back end to place a
    Center or Keep design); None when absent."""
    _racking: float = field(default=0, init=False, repr=False, compare=False)
    _settings: dict[str, Any] = field(default_factory=dict, init=False, repr=False, compare=False)
    _context: list[tuple[int, Span | None]] = field(
        default_factory=list, init=False, repr=False, compare=False
    )
    _phase: str = field(default="", init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        ops, self.ops = self.ops, []
        for op in ops:
            self.emit(op)

    def __len__(self) -> int:
        return len(self.ops)

    def __iter__(self) -> Iterator[Op]:
        return iter(self.ops)

    @property
    def racking(self) -> float:
        """The racking after the last op."""
        return self._racking

    # -- provenance ---------------------------------------------------------------------------

    @contextmanager
    def at(self, stitch: int = -1, span: Span | None = None) -> Iterator[None]:
        """Default provenance for the ops built inside the block (nestable)."""
        self._context.append((stitch, span))
        try:
            yield
        finally:
            self._context.pop()

    @property
    def phase(self) -> str:
        """The code pass the ops built now are tagged with (`code_pass`)."""
        return self._phase

    @contextmanager
    def code_pass(self, name: str) -> Iterator[None]:
        """Tag the ops built inside the block with code pass `name` (`CODE_PASSES`)."""
        if name not in CODE_PASSES:
            raise ValueError(f"unknown code pass {name!r}")
        outer, self._phase = self._phase, name
        try:
            yield
        finally:
            self._phase = outer

    def _prov(self, stitch: int, span: Span | None) -> tuple[int, Span | None]:
        ctx_stitch, ctx_span = self._context[-1] if self._context else (-1, None)
        return (ctx_stitch if stitch is _UNSET else stitch, ctx_span if span is _UNSET else span)

    # -- appending ----------------------------------------------------------------------------

    def emit(self, op: Op) -> Op:
        """Append `op` as is (no elision), tracking racking and settings."""
        if op.kind == "rack":
            self._racking = op.value  # type: ignore[assignment]
        elif op.kind in SETTING_KINDS:
            self._settings[op.kind] = op.value
        self.ops.append(op)
        return op

    def needle_op(
        self,
        kind: str,
        dir: int,
        needle: Needle,
        carriers: tuple[int, ...],
        stitch: int,
        span: Span | None,
        needle2: Needle | None = None,
    ) -> Op:
        """A knit, tuck, miss or xfer from values already in their final form (`Needle`s, a
        tuple of int carriers, explicit provenance): what `knit`/`tuck`/`miss`/`xfer` build,
        without their coercions. Code generation makes one per stitch through here."""
        op = Op(kind, dir, needle, needle2, carriers, None, stitch, span, self._phase)
        self.ops.append(op)
        return op

    def extend(self, ops: Iterable[Op]) -> None:
        for op in ops:
            self.emit(op)

    def _add(self, kind: str, stitch: int, span: Span | None, **kw: Any) -> Op:
        s, sp = self._prov(stitch, span)
        return self.emit(Op(kind, stitch=s, span=sp, phase=self._phase, **kw))

    # -- carriers -----------------------------------------------------------------------------

    def in_(
        self, carriers: CarriersLike, *, stitch: int = _UNSET, span: Span | None = _UNSET
    ) -> Op:
        """``in CS``: bring carriers in from the grippers (Knitout ``in``)."""
        return self._add("in", stitch, span, carriers=as_carriers(carriers))

    def inhook(
        self, carriers: CarriersLike, *, stitch: int = _UNSET, span: Span | None = _UNSET
    ) -> Op:
        return self._add("inhook", stitch, span, carriers=as_carriers(carriers))

    def releasehook(
        self, carriers: CarriersLike, *, stitch: int = _UNSET, span: Span | None = _UNSET
    ) -> Op:
        return self._add("releasehook", stitch, span, carriers=as_carriers(carriers))

    def out(
        self, carriers: CarriersLike, *, stitch: int = _UNSET, span: Span | None = _UNSET
    ) -> Op:
        return self._add("out", stitch, span, carriers=as_carriers(carriers))

    def outhook(
        self, carriers: CarriersLike, *, stitch: int = _UNSET, span: Span | None = _UNSET
    ) -> Op:
        return self._add("outhook", stitch, span, carriers=as_carriers(carriers))

    # -- needle operations --------------------------------------------------------------------

    def knit(
        self,
        dir: int,
        needle: NeedleLike,
        carriers: CarriersLike,
        *,
        stitch: int = _UNSET,
        span: Span | None = _UNSET,
    ) -> Op:
        return self._add(
            "knit", stitch, span, dir=dir, needle=as_needle(needle), carriers=as_carriers(carriers)
        )

    def tuck(
        self,
        dir: int,
        needle: NeedleLike,
        carriers: CarriersLike,
        *,
        stitch: int = _UNSET,
        span: Span | None = _UNSET,
    ) -> Op:
        return self._add(
            "tuck", stitch, span, dir=dir, needle=as_needle(needle), carriers=as_carriers(carriers)
        )

    def split(
        self,
        dir: int,
        needle: NeedleLike,
        needle2: NeedleLike,
        carriers: CarriersLike,
        *,
        stitch: int = _UNSET,
        span: Span | None = _UNSET,
    ) -> Op:
        """New loop on `needle` while its old loops go to the facing `needle2`."""
        return self._add(
            "split",
            stitch,
            span,
            dir=dir,
            needle=as_needle(needle),
            needle2=as_needle(needle2),
            carriers=as_carriers(carriers),
        )

    def miss(
        self,
        dir: int,
        needle: NeedleLike,
        carriers: CarriersLike,
        *,
        stitch: int = _UNSET,
        span: Span | None = _UNSET,
    ) -> Op:
        return self._add(
            "miss", stitch, span, dir=dir, needle=as_needle(needle), carriers=as_carriers(carriers)
        )

    def xfer(
        self,
        needle: NeedleLike,
        needle2: NeedleLike,
        *,
        auto_rack: bool = False,
        stitch: int = _UNSET,
        span: Span | None = _UNSET,
    ) -> Op:
        """Move every loop of `needle` to the facing `needle2`. With `auto_rack`, first rack
        to the racking that aligns them (elided if already there)."""
        a, b = as_needle(needle), as_needle(needle2)
        if auto_rack:
            self.rack(racking_for(a, b), stitch=stitch, span=span)
        return self._add("xfer", stitch, span, needle=a, needle2=b)

    def drop(self, needle: NeedleLike, *, stitch: int = _UNSET, span: Span | None = _UNSET) -> Op:
        return self._add("drop", stitch, span, needle=as_needle(needle))

    def amiss(self, needle: NeedleLike, *, stitch: int = _UNSET, span: Span | None = _UNSET) -> Op:
        return self._add("amiss", stitch, span, needle=as_needle(needle))

    # -- machine state ------------------------------------------------------------------------

    def rack(
        self,
        racking: float,
        *,
        force: bool = False,
        stitch: int = _UNSET,
        span: Span | None = _UNSET,
    ) -> Op | None:
        """Set the racking; returns None (no op) when it is already `racking`."""
        r = int(racking) if float(racking).is_integer() else float(racking)
        if r == self._racking and not force:
            return None
        return self._add("rack", stitch, span, value=r)

    def _setting(
        self, kind: str, value: Any, force: bool, stitch: int, span: Span | None
    ) -> Op | None:
        if not force and self._settings.get(kind, _UNSET) == value:
            return None
        return self._add(kind, stitch, span, value=value)

    def stitch_number(
        self, k: int, *, force: bool = False, stitch: int = _UNSET, span: Span | None = _UNSET
    ) -> Op | None:
        """``x-stitch-number k`` (index into the machine's stitch table)."""
        return self._setting("stitch_number", int(k), force, stitch, span)

    def speed(
        self, k: int, *, force: bool = False, stitch: int = _UNSET, span: Span | None = _UNSET
    ) -> Op | None:
        """``x-speed-number k``."""
        return self._setting("speed", int(k), force, stitch, span)

    def presser(
        self, mode: str, *, force: bool = False, stitch: int = _UNSET, span: Span | None = _UNSET
    ) -> Op | None:
        """``x-presser-mode on|off|auto``."""
        return self._setting("presser", mode, force, stitch, span)

    def pause(
        self, message: str | None = None, *, stitch: int = _UNSET, span: Span | None = _UNSET
    ) -> Op:
        return self._add("pause", stitch, span, value=message)

    def comment(self, text: str, *, stitch: int = _UNSET, span: Span | None = _UNSET) -> Op:
        return self._add("comment", stitch, span, value=text)

    # -- summaries ----------------------------------------------------------------------------

    def stats(self) -> dict[str, Any]:
        kinds = Counter(op.kind for op in self.ops)
        beds: dict[str, list[int]] = {}
        carriers: set[int] = set()
        rackings: list[float] = [0]
        for op in self.ops:
            for n in (op.needle, op.needle2):
                if n is not None:
                    lo_hi = beds.setdefault(n.bed, [n.index, n.index])
                    lo_hi[0] = min(lo_hi[0], n.index)
                    lo_hi[1] = max(lo_hi[1], n.index)
            carriers.update(op.carriers)
            if op.kind == "rack":
                rackings.append(op.value)  # type: ignore[arg-type]
        all_idx = [v for lo_hi in beds.values() for v in lo_hi]
        return {
            "ops": len(self.ops),
            "kinds": {k: kinds[k] for k in KINDS if kinds[k]},
            "passes": estimate_passes(self.ops),
            "carriers": sorted(carriers),
            "needles": {b: beds[b] for b in BEDS if b in beds},
            "needle_range": [min(all_idx), max(all_idx)] if all_idx else None,
            "racking": [min(rackings), max(rackings)],
            "stitches": len({op.stitch for op in self.ops if op.stitch >= 0}),
        }


# ---- passes -----------------------------------------------------------------------------------


def estimate_passes(ops: Iterable[Op]) -> int:
    """Carriage passes, estimated the way backends merge ops (research §1.5; `pass_index`)."""
    return max(pass_index(ops), default=-1) + 1


def pass_index(ops: Iterable[Op]) -> list[int]:
    """The carriage pass of every op (0, 1, ...; -1 for ops the carriage does not make:
    racking, carriers, settings, comments).

    Consecutive knit/tuck/split/miss ops share a pass while direction, carriers and racking
    stay and the needles progress in the direction without reuse; consecutive xfers share
    one while the racking stays and no needle is used twice; drops and amiss likewise. Carrier
    ops, settings and comments do not move the carriage; a pause ends the pass. The views
    draw one row per pass from this, so their rows are the passes knitc reports.
    """
    out: list[int] = []
    append = out.append
    passes = -1
    # the pass in progress: its class ("knit", "xfer", "drop"; None: none), direction,
    # carriers and racking, compared field by field (no key tuple per op)
    cls: str | None = None
    cdir: int = 0
    ccarriers: Any = ()
    crack: float = 0
    used: set[Needle] = set()
    last_pos = 0.0
    racking: float = 0
    directed = DIRECTED_KINDS
    for op in ops:
        k = op.kind
        if k in directed:
            kc, kd, kcar = "knit", op.dir, op.carriers
        elif k == "xfer":
            kc, kd, kcar = "xfer", 0, ()
        elif k == "drop" or k == "amiss":
            kc, kd, kcar = "drop", 0, ()
        else:
            if k == "rack":
                racking = op.value  # type: ignore[assignment]
            elif k == "pause":
                cls = None
            append(-1)
            continue
        n, n2 = op.needle, op.needle2
        assert n is not None
        pos = n.index + racking if n.bed in _BACK else float(n.index)
        same = (
            cls == kc
            and cdir == kd
            and ccarriers == kcar
            and crack == racking
            and n not in used
            and (n2 is None or n2 not in used)
        )
        if same and kc == "knit":
            same = (pos - last_pos) * kd >= 0
        if not same:
            passes += 1
            cls, cdir, ccarriers, crack, used = kc, kd, kcar, racking, set()
        used.add(n)
        if n2 is not None:
            used.add(n2)
        last_pos = pos
        append(passes)
    return out


_BACK = frozenset(("b", "bs"))


# ---- verifier ---------------------------------------------------------------------------------


def _is_number(v: Any) -> bool:
    return isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v)


_PLAIN_KINDS = frozenset({"knit", "tuck", "miss"})
_PHASES = frozenset(CODE_PASSES)
_BED_NAMES = frozenset(BEDS)


def _plain_xfer_ok(op: Op) -> bool:
    """`_plain_ok` for a transfer: two hooks or sliders of opposite beds, nothing else."""
    n, m = op.needle, op.needle2
    return (
        type(n) is Needle
        and type(m) is Needle
        and type(n.bed) is str
        and type(m.bed) is str
        and n.bed in _BED_NAMES
        and m.bed in _BED_NAMES
        and type(n.index) is int
        and type(m.index) is int
        and n.is_front != m.is_front
        and op.dir == 0
        and not op.carriers
        and op.value is None
        and type(op.stitch) is int
        and op.stitch >= -1
        and op.phase in _PHASES
    )


def _plain_ok(op: Op, machine: Machine, carrier_limit: bool) -> bool:
    """The common case of `op_problems` at a glance: a knit, tuck or miss that is well
    formed in every respect the full check looks at (most of a program's ops; a False
    only sends the op through the full check, which then says what is wrong)."""
    n, cs = op.needle, op.carriers
    return (
        type(n) is Needle
        and type(n.bed) is str
        and n.bed in _BED_NAMES
        and type(n.index) is int
        and op.needle2 is None
        and (op.dir == 1 or op.dir == -1)
        and type(op.dir) is int
        and op.value is None
        and type(op.stitch) is int
        and op.stitch >= -1
        and op.phase in _PHASES
        and len(cs) == 1
        and type(cs[0]) is int
        and 1 <= cs[0] <= machine.carriers
        and (machine.max_carriers_per_op >= 1 or not carrier_limit)
    )


def op_problems(op: Op, machine: Machine, *, carrier_limit: bool = True) -> list[str]:
    """What is structurally wrong with one op (empty = well formed). Machine limits other
    than the carrier names (needle range, racking limit, alignment, carrier state, loops) are
    the simulator's findings (`knitc.codegen.simulate`), not structure. The carriers per op
    are structure for code generation (it never writes more than the machine takes), but
    a Knitout file from another tool may name three, so the simulator passes
    `carrier_limit=False` and reports them as a finding of their own."""
    k = op.kind
    if type(k) is str and type(op.phase) is str:  # (hashable: the fast checks use sets)
        if k in _PLAIN_KINDS and _plain_ok(op, machine, carrier_limit):
            return []
        if k == "xfer" and _plain_xfer_ok(op):
            return []
    return _full_problems(op, machine, carrier_limit)


def _full_problems(op: Op, machine: Machine, carrier_limit: bool) -> list[str]:
    """`op_problems` without its fast paths (tests hold the two to the same answers)."""
    k = op.kind
    if k not in KINDS:
        return [f"unknown kind {k!r}"]
    problems: list[str] = []
    wants_needle = k in DIRECTED_KINDS or k in ("xfer", "drop", "amiss")
    wants_needle2 = k in ("split", "xfer")
    wants_carriers = k in DIRECTED_KINDS or k in CARRIER_KINDS
    if (op.needle is not None) != wants_needle:
        problems.append("needle " + ("missing" if wants_needle else "not allowed"))
    if (op.needle2 is not None) != wants_needle2:
        problems.append("second needle " + ("missing" if wants_needle2 else "not allowed"))
    for n in (op.needle, op.needle2):
        if n is not None and (
            not isinstance(n, Needle)
            or n.bed not in BEDS
            or not isinstance(n.index, int)
            or isinstance(n.index, bool)
        ):
            problems.append(f"bad needle {n!r}")
    if k in DIRECTED_KINDS:
        if op.dir not in (1, -1) or isinstance(op.dir, bool):
            problems.append(f"direction {op.dir!r} is not +1 or -1")
    elif op.dir != 0:
        problems.append("direction not allowed")
    if wants_carriers and not op.carriers:
        problems.append("carriers missing")
    if not wants_carriers and op.carriers:
        problems.append("carriers not allowed")
    if len(set(op.carriers)) != len(op.carriers):
        problems.append("a carrier is listed twice")
    if any(
        not isinstance(c, int) or isinstance(c, bool) or not 1 <= c <= machine.carriers
        for c in op.carriers
    ):
        problems.append(f"carriers {list(op.carriers)} outside 1..{machine.carriers}")
    if carrier_limit and k in DIRECTED_KINDS and len(op.carriers) > machine.max_carriers_per_op:
        problems.append(
            f"{len(op.carriers)} carriers in one op (at most {machine.max_carriers_per_op})"
        )
    if (
        wants_needle2
        and isinstance(op.needle, Needle)
        and isinstance(op.needle2, Needle)
        and op.needle.is_front == op.needle2.is_front
    ):
        problems.append(f"{op.needle} and {op.needle2} are on the same bed")
    if k == "rack":
        if not _is_number(op.value):
            problems.append(f"racking {op.value!r} is not a number")
    elif k == "stitch":
        if not (
            isinstance(op.value, tuple)
            and len(op.value) == 2
            and all(_is_number(v) for v in op.value)
        ):
            problems.append(f"stitch values {op.value!r} are not a pair of numbers")
    elif k in ("stitch_number", "speed"):
        if not isinstance(op.value, int) or isinstance(op.value, bool) or op.value < 0:
            problems.append(f"value {op.value!r} is not a non-negative integer")
    elif k == "presser":
        if op.value not in PRESSER_MODES:
            problems.append(f"mode {op.value!r} is not on, off or auto")
    elif k == "comment":
        if not isinstance(op.value, str):
            problems.append("comment text missing")
    elif k == "pause":
        if op.value is not None and not isinstance(op.value, str):
            problems.append("pause message is not text")
    elif op.value is not None:
        problems.append("value not allowed")
    if not isinstance(op.stitch, int) or op.stitch < -1:
        problems.append(f"stitch {op.stitch!r} is not an id or -1")
    if op.phase not in CODE_PASSES:
        problems.append(f"code pass {op.phase!r} is unknown")
    return problems


def verify(prog: MachineProgram) -> list[str]:
    """Structural invariants (every op well formed for its kind); empty = valid.

    These are compiler invariants: a violation is an internal error of code generation.
    """
    problems: list[str] = []
    if prog.position not in ("Left", "Center", "Right", "Keep"):
        problems.append(f"position {prog.position!r} is not Left, Center, Right or Keep")
    machine = prog.machine
    # `op_problems`' plain-knit check, inlined, with the needle and carrier checks made
    # once per object: code generation shares its Needle objects and carrier tuples, so a
    # program of a million ops has a few hundred of each. The caches key the objects by
    # identity (a value lookup would let Needle("f", True) pass as Needle("f", 1)) and hold
    # them, so that no other object can take a remembered id.
    needles_ok: dict[int, Needle] = {}
    carriers_ok: dict[int, tuple[int, ...]] = {}
    one = 1 <= machine.max_carriers_per_op
    plain, phases = _PLAIN_KINDS, _PHASES
    for i, op in enumerate(prog.ops):
        if type(op) is Op:
            k, d, n, n2, cs, v, s, _, ph = op
            if (
                type(k) is str
                and k in plain
                and n2 is None
                and v is None
                and type(d) is int
                and (d == 1 or d == -1)
                and type(s) is int
                and s >= -1
                and type(ph) is str
                and ph in phases
                and one
                and (id(n) in needles_ok or _needle_ok(n, needles_ok))
                and (id(cs) in carriers_ok or _carriers_ok(cs, machine, carriers_ok))
            ):
                continue
        bad = op_problems(op, machine)
        if bad:
            problems += [f"op {i} ({op.kind}): {p}" for p in bad]
    return problems


def _needle_ok(n: Any, seen: dict[int, Needle]) -> bool:
    """`verify`: is `n` a well-formed needle (remembered in `seen` if so)?"""
    ok = type(n) is Needle and type(n.bed) is str and n.bed in _BED_NAMES and type(n.index) is int
    if ok:
        seen[id(n)] = n
    return ok


def _carriers_ok(cs: Any, machine: Machine, seen: dict[int, tuple[int, ...]]) -> bool:
    """`verify`: is `cs` the one carrier of a plain op (remembered in `seen` if so)?"""
    ok = (
        type(cs) is tuple and len(cs) == 1 and type(cs[0]) is int and 1 <= cs[0] <= machine.carriers
    )
    if ok:
        seen[id(cs)] = cs
    return ok


# ---- stable JSON ------------------------------------------------------------------------------


def to_json(prog: MachineProgram) -> dict[str, Any]:
    """The dump of `knitc --emit machine`: stats first, then the machine and the ops."""
    return {
        "stats": prog.stats(),
        "machine": prog.machine.to_json(),
        "position": prog.position,
        "ops": [op.to_json() for op in prog.ops],
    }
