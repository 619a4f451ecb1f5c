"""Knitout reader: any valid Knitout v0.6 text -> `MachineProgram` (for `knitc k2dat`).

`knitc.backends.knitout.read_knitout` reads back only what knitc writes; this module reads
what anyone writes (shared/research/knitout-and-dat.md §1), keeps every op's source line,
and rejects invalid input with located errors, so `knitc k2dat` can point at the Knitout
line a DAT cannot express.

Format (§1.1-§1.4): line 1 is ``;!knitout-N``; then the header, consecutive ``;;Name: value``
lines; then one operation per line, ``opcode args... [; comment]``, tokens separated by
spaces or tabs (CRLF line ends are accepted with a warning). Headers read: ``Carriers``
(required by the spec; missing -> the machine's 1..10, with a warning), ``Machine``,
``Gauge``, ``Position``, ``Width`` (SWG converter: the bed width used to place a Center or
Keep design; stored in `MachineProgram.width`), ``Yarn-*`` and ``X-*`` (accepted, ignored).

How Knitout maps onto the IR:

* carriers are numbered by their place in the ``Carriers`` header (front to back, the order
  the DAT's carrier codes use): the usual ``1 2 ... 10`` keep their numbers; other names
  (``A B C``, a multi-rail ``1,2;3,4``) are renumbered 1..n with a warning;
* the synonyms are folded as the spec defines them: ``knit D N`` with no carriers is
  ``drop N``, ``tuck D N`` is ``amiss N``, ``split D N N2`` is ``xfer N N2`` (the direction
  of a carrier-less op is meaningless and dropped);
* ``stitch L T`` becomes an op of kind ``stitch`` whose value is the pair ``(L, T)``
  (numbers, ints when integral). The Shima writer maps it through the converter's table
  (research §2.6.7: key (T, L), e.g. ``stitch 10 15`` -> stitch number 85) and must reject a
  pair the table lacks, locating the error at the op's span; ``x-stitch-number K``,
  ``x-speed-number K`` and ``x-presser-mode M`` become ``stitch_number``, ``speed`` and
  ``presser`` ops; ``pause`` a ``pause`` op; other ``x-`` extensions are ignored with a
  warning (spec: readers warn and ignore);
* whole-line comments become ``comment`` ops (unless ``comments=False``); trailing comments,
  ``;!source:`` included, are dropped;
* every op's `span` is ``Span(path, line, col, line, end_col, start, end)`` of its
  instruction (offsets count code points of `text`), so a later stage (the DAT writer) can
  point at the Knitout line.

Rules checked here, as the spec states them (§1.7 "spec-level"); machine limits (racking
range and quarter pitch, needle range, loops, carriers left in, 3+ carriers per pass, the
hook's direction) belong to `knitc.codegen.simulate` and the DAT writer:

  E910  magic line, header syntax and values (Gauge in (0, 100], Width 1..541, the
        machine's needles, Position one of Left/Center/Right/Keep, Carriers: at most 64
        names of at most 32 characters)
  E911  unknown operation (anything but the spec's opcodes and ``x-`` extensions)
  E912  arguments: wrong count, direction not ``+``/``-``, numbers (racking, stitch
        values, extension values) malformed or beyond their limits (below), presser mode
        not on/off/auto
  E913  needle not ``f``/``b``/``fs``/``bs`` + integer (negative allowed), or its number
        beyond +-10,000
  E914  carriers: not declared in the header, listed twice, none where some are needed
        (``in``, ``miss``, ...)
  E915  carrier state: using or taking out a carrier that is not in, bringing in one that
        is, ``releasehook`` of a carrier not on the hook or that has not stitched yet
  E916  ``xfer``/``split`` between needles that are not on opposite beds and aligned at
        the current racking, or from a slider to a slider
  W910  reader warnings: newer Knitout version, unknown header, missing Carriers header,
        renamed carriers, CRLF line ends, ignored extension

Every number is bounded where it is read, on its token, before it is converted, so that
no input makes the reader (or anything after it) raise, allocate or compute without bound:
needles +-`MAX_NEEDLE`, racking +-`MAX_RACKING`, ``stitch`` values +-`MAX_STITCH_VALUE`,
``x-stitch-number`` 0..255 and ``x-speed-number`` 0..245 (what the DAT's option bars hold),
the headers as above. The limits are beyond any machine; each error says its limit.

Errors are collected (up to `MAX_ERRORS`) and raised together as `KnitoutErrors`; the
line parser keeps going after a bad line, skipping its op. `knitout_diagnostics` turns
them into `Diagnostics` for the compiler-style rendering of the CLI.

Speed: one ``str.split`` per line, a dict dispatch on the opcode and caches for needles and
carrier sets, no regular expression on the common path; a line of a plain one-carrier
knit/tuck/miss read before is one dict look-up (fabric repeats its lines). `knitout_to_dat`
skips the ops and their spans altogether: the DAT writer takes the bare records, and a file
with an error is read again with spans for the diagnostics. A 100k-line stockinette reads
into a program in about 0.25 s, and converts to a DAT in under 0.1 s.
"""

from __future__ import annotations

import gc
import re
from collections.abc import Iterable, Iterator
from contextlib import contextmanager

from knitc.backends.dat_write import MAX_SPEED_NUMBER, MAX_STITCH_NUMBER, OpRecord
from knitc.codegen.machine import Machine, MachineProgram, Needle, Op
from knitc.diagnostics import Diagnostics
from knitc.records import record
from knitc.source import SourceFile, Span

MAX_ERRORS = 100
KNOWN_VERSION = 2
POSITIONS = ("Left", "Center", "Right", "Keep")

# Limits on every number the reader takes, checked on the token before it is converted (a
# 5,000-digit needle is refused by its length, never handed to `int`, which raises past 4,300
# digits and is quadratic below). Each is beyond any machine, so no knittable file hits one.
MAX_NEEDLE = 10_000
"""Largest |needle number|: the widest beds have about 2,000 needles (541 here), and a
program may sit anywhere on one or be shifted by a bed's width."""
MAX_RACKING = 2 * MAX_NEEDLE
"""Largest |racking|: beyond it no two needles in the readable range face each other."""
MAX_STITCH_VALUE = 1_000
"""Largest |value| of ``stitch L T`` (the Shima table's values are -10..65)."""
MAX_GAUGE = 100
"""Largest ``;;Gauge:`` (needles per inch; the finest machines have about 20)."""
MAX_CARRIERS = 64
"""Most carriers in ``;;Carriers:`` (the largest machines have 32)."""
MAX_CARRIER_NAME = 32
"""Longest carrier name (names are echoed in messages, so they stay short)."""
MAX_VERSION = 999
"""Versions above this are not converted to compare with `KNOWN_VERSION`; still newer."""

_MAGIC = re.compile(r";!knitout-(\d+)\Z")
_NEEDLE = re.compile(r"(fs|bs|f|b)(-?[0-9]+)\Z")
_NUMBER = re.compile(r"[+-]?(?:[0-9]+\.?[0-9]*|\.[0-9]+)\Z")
_UINT = re.compile(r"\+?[0-9]+\Z")
_TOKEN = re.compile(r"[^ \t\r\f\v]+")
_SHOWN = 40
"""Longest token quoted whole in a message (the source line under it shows the rest)."""


# ---- errors -----------------------------------------------------------------------------------


class KnitoutError(ValueError):
    """One problem in a Knitout text, at 1-based `line` and `col` (..`end_col`, exclusive)."""

    def __init__(
        self,
        message: str,
        line: int,
        col: int = 1,
        *,
        end_col: int | None = None,
        code: str = "E912",
        warning: bool = False,
        hint: str | None = None,
    ) -> None:
        super().__init__(f"{line}:{col}: {message}")
        self.message = message
        self.line = line
        self.col = col
        self.end_col = end_col if end_col is not None else col + 1
        self.code = code
        self.warning = warning
        self.hint = hint

    def span(self, path: str) -> Span:
        return Span(path, self.line, self.col, self.line, self.end_col)


class KnitoutErrors(ValueError):
    """Every error found in a Knitout text (in line order), and the reader's warnings."""

    def __init__(
        self, errors: Iterable[KnitoutError], warnings: Iterable[KnitoutError] = ()
    ) -> None:
        errors = list(errors)
        first = errors[0] if errors else None
        more = f" (and {len(errors) - 1} more)" if len(errors) > 1 else ""
        super().__init__(f"{first}{more}" if first else "no errors")
        self.errors = errors
        self.warnings = list(warnings)


def knitout_diagnostics(
    path: str, text: str, errors: Iterable[KnitoutError] = (), warnings: Iterable[KnitoutError] = ()
) -> Diagnostics:
    """The errors and warnings as compiler diagnostics on `path` (source attached, so the
    renderer shows the line and a caret)."""
    diags = Diagnostics()
    diags.add_source(SourceFile(path, text))
    for w in warnings:
        diags.warning(w.code, w.message, w.span(path), hint=w.hint)
    for e in errors:
        diags.error(e.code, e.message, e.span(path), hint=e.hint)
    return diags


# ---- the reader -------------------------------------------------------------------------------


def _number(text: str) -> int | float | None:
    """A Knitout number (``2``, ``-0.75``, ``.25``) or None; ints when integral. A huge one
    is a huge float (or inf), never an error: callers compare it with their limit."""
    if _NUMBER.match(text) is None:
        return None
    v = float(text)
    return int(v) if v.is_integer() else v


def _bounded_int(text: str, limit: int) -> int | None:
    """The integer `text` (``[+-]?[0-9]+``) if |value| <= `limit`, else None, judged by its
    digit count first so that no long number reaches `int`."""
    digits = text.lstrip("+-").lstrip("0")
    if len(digits) > len(str(limit)):
        return None
    v = int(text)
    return v if -limit <= v <= limit else None


def _newer(version: str) -> bool:
    """Whether the magic line's version digits name a version above `KNOWN_VERSION`."""
    v = _bounded_int(version, MAX_VERSION)
    return v is None or v > KNOWN_VERSION


def _shown(text: str) -> str:
    """`text` for a message: whole when short, else its start and its length."""
    if len(text) <= _SHOWN:
        return text
    return f"{text[: _SHOWN // 2]}... ({len(text)} characters)"


_DIRS = {"+": 1, "-": -1}
_STITCHES = frozenset(("knit", "tuck", "miss"))
_ARITY_HINT = {
    "knit": "knit D N CS",
    "tuck": "tuck D N CS",
    "miss": "miss D N CS",
    "split": "split D N N2 CS",
    "xfer": "xfer N N2",
    "drop": "drop N",
    "amiss": "amiss N",
    "rack": "rack R",
    "stitch": "stitch L T",
    "x-stitch-number": "x-stitch-number K",
    "x-speed-number": "x-speed-number K",
    "x-presser-mode": "x-presser-mode on|off|auto",
    "pause": "pause",
}
_CARRIER_OPS = ("in", "inhook", "releasehook", "out", "outhook")
_KNOWN_OPS = frozenset(_ARITY_HINT) | frozenset(_CARRIER_OPS)


class _Bad(Exception):
    """Internal: abandon the current line; `token` is the index of the offending token
    (-1: the whole instruction)."""

    def __init__(
        self, message: str, token: int = -1, code: str = "E912", hint: str | None = None
    ) -> None:
        self.message, self.token, self.code, self.hint = message, token, code, hint


@record
class _Header:
    machine: str = "SWG091N2"
    gauge: int | float = 15
    carriers: list[str] | None = None
    position: str = "Center"
    width: int | None = None


class _Reader:
    def __init__(self, text: str, path: str, comments: bool) -> None:
        self.text = text
        self.path = path
        self.comments = comments
        self.errors: list[KnitoutError] = []
        self.warnings: list[KnitoutError] = []
        self.ops: list[Op] = []
        self.racking: float = 0
        self.names: dict[str, int] = {}
        self.needles: dict[str, Needle] = {}
        self.csets: dict[tuple[str, ...], tuple[int, ...]] = {}
        self.active: dict[int, bool] = {}  # carrier in action -> has made a stitch
        self.hook: list[int] = []
        self.not_in: set[int] = set()  # reported as used while out (once each)
        self.seen: dict[str, tuple[OpRecord, int, int, int]] = {}
        """Plain one-carrier knit/tuck/miss lines read so far: (record, carrier, columns)."""
        # where the current line is
        self.lineno = 0
        self.raw = ""
        self.code = ""

    # -- reporting ----------------------------------------------------------------------------

    def _columns(self, token: int) -> tuple[int, int]:
        """1-based [col, end_col) of token `token` of the current line's instruction (-1:
        the whole instruction)."""
        spans = [(m.start() + 1, m.end() + 1) for m in _TOKEN.finditer(self.code)]
        if not spans:
            return 1, max(len(self.raw), 1) + 1
        if token < 0 or token >= len(spans):
            return spans[0][0], spans[-1][1]
        return spans[token]

    def error(
        self, message: str, token: int = -1, code: str = "E912", hint: str | None = None
    ) -> None:
        col, end = self._columns(token)
        self.errors.append(
            KnitoutError(message, self.lineno, col, end_col=end, code=code, hint=hint)
        )
        if len(self.errors) >= MAX_ERRORS:
            raise _TooMany

    def warn(self, message: str, token: int = -1, *, line: int | None = None) -> None:
        """A warning at `token` of the current line, or at the start of `line`."""
        if line is None:
            c, end = self._columns(token)
            line = self.lineno
        else:
            c, end = 1, 2
        self.warnings.append(KnitoutError(message, line, c, end_col=end, code="W910", warning=True))

    # -- header -------------------------------------------------------------------------------

    def header(self, lines: list[str]) -> tuple[_Header, int]:
        """Read the magic line and the header; returns it and the index of the first body
        line."""
        h = _Header()
        self.lineno, self.raw = 1, lines[0] if lines else ""
        self.code = self.raw
        m = _MAGIC.match(self.raw)
        if m is None:
            self.error(
                f"the first line must be the Knitout magic `;!knitout-2`, not `{_shown(self.raw)}`",
                code="E910",
            )
        elif _newer(m.group(1)):
            self.warn(
                f"Knitout version {_shown(m.group(1))} is newer than the {KNOWN_VERSION} "
                "this reader knows"
            )
        # without the magic, the first line is still read as what it looks like
        i = 1 if m is not None or self.raw.startswith(";") and not self.raw.startswith(";;") else 0
        seen: set[str] = set()
        while i < len(lines):
            raw = lines[i]
            if not raw.startswith(";;") or ": " not in raw:
                break
            self.lineno, self.raw, self.code = i + 1, raw, raw
            name, value = raw[2:].split(": ", 1)
            if name in seen:
                self.warn(f"header `{_shown(name)}` given twice; the last value is used")
            seen.add(name)
            self._header_line(h, name, value.strip())
            i += 1
        if h.carriers is None:
            self.warn(
                "no `;;Carriers:` header (the spec requires one); assuming carriers "
                "1 2 3 4 5 6 7 8 9 10",
                line=min(i + 1, max(len(lines), 1)),
            )
            h.carriers = [str(c) for c in range(1, 11)]
        return h, i

    def _header_line(self, h: _Header, name: str, value: str) -> None:
        def bad(msg: str, hint: str | None = None) -> None:
            self.error(f"`;;{_shown(name)}:` {msg}, not `{_shown(value)}`", code="E910", hint=hint)

        if name == "Carriers":
            names = [
                n for rail in value.split() for side in rail.split(";") for n in side.split(",")
            ]
            if not names or any(not n for n in names):
                return bad("needs carrier names separated by spaces")
            if len(names) > MAX_CARRIERS:
                return bad(
                    f"names {len(names)} carriers",
                    f"at most {MAX_CARRIERS} are read; the largest machines have 32",
                )
            if any(len(n) > MAX_CARRIER_NAME for n in names):
                return bad(
                    "has a carrier name that is too long",
                    f"carrier names are at most {MAX_CARRIER_NAME} characters",
                )
            if len(set(names)) != len(names):
                return bad("names a carrier twice")
            h.carriers = names
            if names != [str(k) for k in range(1, len(names) + 1)]:
                self.warn(
                    "carriers are numbered by their place in the `;;Carriers:` header: "
                    + ", ".join(f"{n} -> {k}" for k, n in enumerate(names, 1))
                )
        elif name == "Machine":
            h.machine = value or h.machine
        elif name == "Gauge":
            g = _number(value)
            if g is None or not 0 < g <= MAX_GAUGE:
                return bad(
                    "must be a number greater than zero",
                    f"the gauge is needles per inch, at most {MAX_GAUGE}",
                )
            h.gauge = g
        elif name == "Position":
            if value not in POSITIONS:
                return bad("must be Left, Center, Right or Keep")
            h.position = value
        elif name == "Width":
            needles = Machine().needles
            w = _bounded_int(value, needles) if value.isascii() and value.isdigit() else None
            if w is None or w <= 0:
                return bad(
                    "must be a positive integer (the bed width in needles)",
                    f"the machine's beds have {needles} needles, so the width is 1..{needles}",
                )
            h.width = w
        elif name.startswith(("Yarn-", "X-")):
            pass
        else:
            self.warn(f"unknown header `;;{_shown(name)}:` ignored")

    # -- body ---------------------------------------------------------------------------------

    def needle(self, tokens: list[str], k: int) -> Needle:
        if k >= len(tokens):
            raise _Bad("a needle is missing")
        t = tokens[k]
        n = self.needles.get(t)
        if n is None:
            m = _NEEDLE.match(t)
            if m is None:
                raise _Bad(
                    f"`{_shown(t)}` is not a needle (f, b, fs or bs followed by an integer, "
                    "e.g. f12, b-3, fs0)",
                    k,
                    "E913",
                )
            index = _bounded_int(m.group(2), MAX_NEEDLE)
            if index is None:
                raise _Bad(
                    f"needle `{_shown(t)}` is beyond any bed",
                    k,
                    "E913",
                    f"needle numbers are read from -{MAX_NEEDLE} to {MAX_NEEDLE}; the "
                    f"machine has {Machine().needles} needles per bed",
                )
            n = self.needles[t] = Needle(m.group(1), index)
        return n

    def carriers(self, tokens: list[str], k: int) -> tuple[int, ...]:
        key = tuple(tokens[k:])
        cs = self.csets.get(key)
        if cs is None:
            names = self.names
            out: list[int] = []
            for j, t in enumerate(key, k):
                c = names.get(t)
                if c is None:
                    raise _Bad(
                        f"carrier `{_shown(t)}` is not declared in the `;;Carriers:` header "
                        f"({' '.join(names)})",
                        j,
                        "E914",
                    )
                if c in out:
                    raise _Bad(f"carrier `{t}` is listed twice", j, "E914")
                out.append(c)
            cs = self.csets[key] = tuple(out)
        return cs

    def direction(self, tokens: list[str]) -> int:
        if len(tokens) < 2:
            raise _Bad(f"`{tokens[0]}` needs a direction: {_ARITY_HINT[tokens[0]]}")
        d = _DIRS.get(tokens[1])
        if d is None:
            raise _Bad(f"direction must be `+` or `-`, not `{_shown(tokens[1])}`", 1)
        return d

    def use(self, cs: tuple[int, ...], tokens: list[str], first: int) -> None:
        """Carriers of a knit/tuck/split/miss must be in; they have now stitched."""
        active = self.active
        for j, c in enumerate(cs):
            if c not in active:
                if c not in self.not_in:
                    self.not_in.add(c)
                    self.error(
                        f"carrier {tokens[first + j]} is used but is not in (bring it "
                        "in with `in` or `inhook` first)",
                        first + j,
                        "E915",
                    )
                continue
            active[c] = True

    def aligned(self, a: Needle, b: Needle, tokens: list[str], k: int) -> None:
        if a.is_front == b.is_front or (a.is_slider and b.is_slider):
            why = "a slider to a slider" if a.is_front != b.is_front else "the same bed"
            raise _Bad(
                f"`{tokens[0]}` moves loops from {a} to {b}, on {why} (the target "
                "must be on the opposite bed)",
                k,
                "E916",
            )
        front, back = (a, b) if a.is_front else (b, a)
        if back.index + self.racking != front.index:
            r = self.racking
            raise _Bad(
                f"{a} and {b} are not aligned at racking {_fmt(r)} (they face each "
                f"other at racking {front.index - back.index}; at racking R, b(k) "
                "faces f(k+R))",
                k,
                "E916",
            )

    def arity(self, tokens: list[str], n: int) -> None:
        if len(tokens) != n:
            op = tokens[0]
            raise _Bad(
                f"`{op}` takes {n - 1} argument{'s' * (n != 2)} "
                f"({_ARITY_HINT[op]}), got {len(tokens) - 1}",
                n if len(tokens) > n else -1,
            )

    def body(self, lines: list[str], start: int, crlf: list[bool] | None) -> None:
        """The instruction lines from `start` (`crlf`: which lines lost a CR, or None), as
        ops with spans (and comment ops if `comments`)."""
        path, ops, comments = self.path, self.ops, self.comments
        seen, active = self.seen, self.active
        offset = sum(len(x) + 1 for x in lines[:start])
        if crlf is not None:
            offset += sum(crlf[:start])
        for i in range(start, len(lines)):
            raw = lines[i]
            line_start = offset
            offset += len(raw) + 1
            if crlf is not None and crlf[i]:
                offset += 1
            hit = seen.get(raw)
            if hit is not None and hit[1] in active:
                rec, c, lead, end = hit
                active[c] = True
            else:
                k = raw.find(";")
                if k >= 0 and not raw[:k].split():
                    if comments:
                        text = raw[k + 1 :]
                        ops.append(
                            Op(
                                "comment",
                                value=text[1:] if text.startswith(" ") else text,
                                span=Span(
                                    path,
                                    i + 1,
                                    k + 1,
                                    i + 1,
                                    len(raw) + 1,
                                    line_start + k,
                                    line_start + len(raw),
                                ),
                            )
                        )
                    continue
                got = self.line(i, raw)
                if got is None:
                    continue
                rec, lead, end = got
            ops.append(
                Op(
                    *rec,
                    -1,
                    Span(
                        path, i + 1, lead + 1, i + 1, end + 1, line_start + lead, line_start + end
                    ),
                )
            )

    def records(self, lines: list[str], start: int) -> list[OpRecord]:
        """The instruction lines from `start` as bare records, without spans or comments: what
        `knitout_to_dat` converts (after any error or warning it starts again with `body`)."""
        out: list[OpRecord] = []
        append = out.append
        seen, active = self.seen, self.active
        for i in range(start, len(lines)):
            raw = lines[i]
            hit = seen.get(raw)
            if hit is not None and hit[1] in active:
                active[hit[1]] = True
                append(hit[0])
                continue
            got = self.line(i, raw)
            if got is not None:
                append(got[0])
        return out

    def line(self, i: int, raw: str) -> tuple[OpRecord, int, int] | None:
        """Line `i` (0-based) `raw`, which `seen` did not answer: its record and the 0-based
        [start, end) columns of its instruction, or None (blank, a comment, or a line with an
        error or a warning, reported). A plain one-carrier knit/tuck/miss goes into `seen`."""
        self.lineno, self.raw = i + 1, raw
        k = raw.find(";")
        code = raw if k < 0 else raw[:k]
        self.code = code
        tokens = code.split()
        if not tokens:
            return None
        try:
            rec = self.instruction(tokens)
        except _Bad as bad:
            self.error(bad.message, bad.token, bad.code, bad.hint)
            return None
        except _Warn as w:
            self.warn(w.message, 0)
            return None
        lead = len(code) - len(code.lstrip())
        end = len(code.rstrip())
        if len(tokens) == 4 and rec[0] in _STITCHES and rec[4][0] in self.active:
            # One carrier, in (so no error): the same text is the same op again, as long as
            # its carrier is still in.
            self.seen[raw] = (rec, rec[4][0], lead, end)
        return rec, lead, end

    def instruction(self, t: list[str]) -> OpRecord:
        """The op of one instruction line, as an `OpRecord`; raises _Bad (and _Warn for an
        ignored extension)."""
        op = t[0]
        if op == "knit" or op == "tuck" or op == "miss":
            if len(t) == 4:  # the common case, one carrier: straight from the caches
                d = _DIRS.get(t[1])
                n = self.needles.get(t[2])
                cs = self.csets.get((t[3],))
                if d is not None and n is not None and cs is not None and cs[0] in self.active:
                    self.active[cs[0]] = True
                    return (op, d, n, None, cs, None)
            d = self.direction(t)
            n = self.needle(t, 2)
            cs = self.carriers(t, 3)
            if not cs:
                if op == "miss":
                    raise _Bad(
                        "`miss` needs carriers (it moves them without touching the needle)",
                        -1,
                        "E914",
                    )
                return ("drop" if op == "knit" else "amiss", 0, n, None, (), None)
            self.use(cs, t, 3)
            return (op, d, n, None, cs, None)
        if op == "xfer":
            self.arity(t, 3)
            a, b = self.needle(t, 1), self.needle(t, 2)
            self.aligned(a, b, t, 2)
            return ("xfer", 0, a, b, (), None)
        if op == "split":
            d = self.direction(t)
            a, b = self.needle(t, 2), self.needle(t, 3)
            cs = self.carriers(t, 4)
            self.aligned(a, b, t, 3)
            if not cs:
                return ("xfer", 0, a, b, (), None)
            self.use(cs, t, 4)
            return ("split", d, a, b, cs, None)
        if op == "drop" or op == "amiss":
            self.arity(t, 2)
            return (op, 0, self.needle(t, 1), None, (), None)
        if op in _CARRIER_OPS:
            return self.carrier_op(t)
        if op == "rack":
            self.arity(t, 2)
            r = _number(t[1])
            if r is None:
                raise _Bad(f"racking must be a number (e.g. 1, -2, 0.25), not `{_shown(t[1])}`", 1)
            if abs(r) > MAX_RACKING:
                raise _Bad(
                    f"racking {_shown(t[1])} is beyond any machine",
                    1,
                    hint=f"racking is read up to {MAX_RACKING} either way (no two needles "
                    f"of -{MAX_NEEDLE}..{MAX_NEEDLE} face each other further); the machine "
                    f"racks at most {Machine().racking_limit}",
                )
            self.racking = r
            return ("rack", 0, None, None, (), r)
        if op == "stitch":
            self.arity(t, 3)
            lead, tight = _number(t[1]), _number(t[2])
            if lead is None or tight is None:
                k = 1 if lead is None else 2
                raise _Bad(f"stitch values must be numbers, not `{_shown(t[k])}`", k)
            for k, v in ((1, lead), (2, tight)):
                if abs(v) > MAX_STITCH_VALUE:
                    raise _Bad(
                        f"stitch value {_shown(t[k])} is beyond any machine's settings",
                        k,
                        hint=f"stitch values are read from -{MAX_STITCH_VALUE} to "
                        f"{MAX_STITCH_VALUE}; the Shima table's pairs are like `stitch 10 15`",
                    )
            return ("stitch", 0, None, None, (), (lead, tight))
        if op == "x-stitch-number" or op == "x-speed-number":
            self.arity(t, 2)
            if _UINT.match(t[1]) is None:
                raise _Bad(f"`{op}` takes a non-negative integer, not `{_shown(t[1])}`", 1)
            stitch = op == "x-stitch-number"
            top = MAX_STITCH_NUMBER if stitch else MAX_SPEED_NUMBER
            value = _bounded_int(t[1], top)
            if value is None:
                raise _Bad(
                    f"`{op}` {_shown(t[1])} is beyond the machine's table",
                    1,
                    hint=f"it takes 0..{top} (the value is one colour of a DAT option bar)",
                )
            return ("stitch_number" if stitch else "speed", 0, None, None, (), value)
        if op == "x-presser-mode":
            self.arity(t, 2)
            if t[1] not in ("on", "off", "auto"):
                raise _Bad(f"presser mode must be on, off or auto, not `{_shown(t[1])}`", 1)
            return ("presser", 0, None, None, (), t[1])
        if op == "pause":
            self.arity(t, 1)
            return ("pause", 0, None, None, (), None)
        if op.startswith("x-"):
            raise _Warn(f"extension `{_shown(op)}` is not supported; ignored")
        raise _Bad(f"unknown operation `{_shown(op)}`", 0, "E911")

    def carrier_op(self, t: list[str]) -> OpRecord:
        op = t[0]
        if len(t) < 2:
            raise _Bad(f"`{op}` needs at least one carrier ({op} CS)", -1, "E914")
        cs = self.carriers(t, 1)
        active, hook = self.active, self.hook
        for j, c in enumerate(cs, 1):
            name = t[j]
            if op in ("in", "inhook"):
                if c in active:
                    raise _Bad(f"carrier {name} is already in", j, "E915")
            elif c not in active:
                raise _Bad(f"`{op}` of carrier {name}, which is not in", j, "E915")
            elif op == "releasehook":
                if c not in hook:
                    held = " ".join(self._name(h) for h in hook) or "nothing"
                    raise _Bad(
                        f"`releasehook` of carrier {name}, which the inserting hook "
                        f"does not hold (it holds {held})",
                        j,
                        "E915",
                    )
                if not active[c]:
                    raise _Bad(
                        f"`releasehook` of carrier {name} before it made a stitch", j, "E915"
                    )
        if op in ("in", "inhook"):
            for c in cs:
                active[c] = False
                self.not_in.discard(c)
            if op == "inhook":
                hook.extend(cs)
        else:
            for c in cs:
                if c in hook:
                    hook.remove(c)
                if op != "releasehook":
                    del active[c]
        return (op, 0, None, None, cs, None)

    def _name(self, c: int) -> str:
        for n, k in self.names.items():
            if k == c:
                return n
        return str(c)


class _Warn(Exception):
    def __init__(self, message: str) -> None:
        self.message = message


class _TooMany(Exception):
    pass


def _fmt(v: float) -> str:
    return str(int(v)) if float(v).is_integer() else repr(float(v))


@contextmanager
def gc_paused() -> Iterator[None]:
    """Pause the cyclic garbage collector while building a program op by op: the readers make
    a few acyclic objects per op, and the collector's repeated scans of the growing op list
    would otherwise take about half the time."""
    collecting = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if collecting:
            gc.enable()


def _lines(text: str) -> tuple[list[str], list[bool] | None]:
    """The lines of `text` without their LF, and without a CR before it; the second value
    says which lines lost one (None when none did)."""
    lines = text.split("\n")
    if lines and lines[-1] == "":
        lines.pop()
    if "\r" in text:
        crlf = [line.endswith("\r") for line in lines]
        if any(crlf):
            lines = [line[:-1] if cr else line for line, cr in zip(lines, crlf, strict=True)]
            return lines, crlf
    return lines, None


def _crlf_warning(crlf: list[bool]) -> KnitoutError:
    return KnitoutError(
        "CRLF line ends (Knitout lines end with LF)",
        crlf.index(True) + 1,
        1,
        code="W910",
        warning=True,
    )


def _machine(h: _Header) -> Machine:
    return Machine(
        name=h.machine,
        gauge=h.gauge,  # type: ignore[arg-type]
        carriers=len(h.carriers or ()) or Machine().carriers,
    )


def parse_knitout(
    text: str,
    path: str = "<knitout>",
    *,
    comments: bool = True,
    warnings: list[KnitoutError] | None = None,
) -> MachineProgram:
    """Read Knitout `text` (from file `path`, for spans) into a `MachineProgram`.

    Raises `KnitoutErrors` (every error, in line order, at most `MAX_ERRORS`) on invalid
    input. Warnings are appended to `warnings` when given. The program's machine has the
    header's name, gauge and carrier count; its position and width the header's."""
    r = _Reader(text, path, comments)
    lines, crlf = _lines(text)
    if crlf is not None:
        r.warnings.append(_crlf_warning(crlf))
    h = _Header()
    with gc_paused():
        try:
            h, start = r.header(lines)
            assert h.carriers is not None
            r.names = {n: k for k, n in enumerate(h.carriers, 1)}
            r.body(lines, start, crlf)
        except _TooMany:
            r.errors.append(
                KnitoutError(
                    f"too many errors (stopped after {MAX_ERRORS})",
                    r.errors[-1].line,
                    1,
                    code="E912",
                )
            )
    if warnings is not None:
        warnings.extend(r.warnings)
    if r.errors:
        r.errors.sort(key=lambda e: (e.line, e.col))
        raise KnitoutErrors(r.errors, r.warnings)
    prog = MachineProgram(_machine(h), position=h.position, width=h.width)
    prog.extend(r.ops)
    return prog


def knitout_to_dat(
    text: str, path: str = "<knitout>", *, warnings: list[KnitoutError] | None = None
) -> bytes | None:
    """The DAT file of Knitout `text`, byte for byte what `parse_knitout`, `to_dat` and
    `encode` make of it, when all goes well; the reader's warnings are appended to
    `warnings` (without that list, a warning counts as not going well). None when the text
    has an error or the DAT writer refuses the program: then the caller reads it again with
    `read_knitout` and converts that, for the diagnostics, which need each op's span
    (`knitc k2dat`).

    Faster than that route (a fifth of the time on a 100k-line stockinette): the lines become
    bare records, without spans or comments, which the DAT writer takes as they are."""
    from knitc.backends.dat_format import DatError, encode
    from knitc.backends.dat_write import DatWriteError, records_to_dat

    r = _Reader(text, path, comments=False)
    lines, crlf = _lines(text)
    if crlf is not None:
        r.warnings.append(_crlf_warning(crlf))
    with gc_paused():
        try:
            h, start = r.header(lines)
            if r.errors:
                return None
            assert h.carriers is not None
            r.names = {n: k for k, n in enumerate(h.carriers, 1)}
            records = r.records(lines, start)
        except _TooMany:
            return None
        if r.errors or (r.warnings and warnings is None):
            return None
        try:
            data = encode(records_to_dat(records, _machine(h), width=h.width, position=h.position))
        except (DatWriteError, DatError):
            return None
    if warnings is not None:
        warnings.extend(r.warnings)
    return data


def read_knitout_file(path: str) -> tuple[MachineProgram | None, Diagnostics]:
    """The program of the Knitout file at `path` (None after errors) and its diagnostics:
    E001 when it cannot be read or is not UTF-8, the reader's errors and warnings with the
    source attached. What `k2dat`, `lint` and `view` all start from."""
    try:
        with open(path, "rb") as f:
            text = f.read().decode("utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        diags = Diagnostics()
        diags.error("E001", f"cannot read `{path}`: {exc}", None)
        return None, diags
    return read_knitout(text, path)


def read_knitout(text: str, path: str) -> tuple[MachineProgram | None, Diagnostics]:
    """`parse_knitout` as diagnostics: the program (None after errors) and the reader's
    errors and warnings located in `text` (read from `path`)."""
    warnings: list[KnitoutError] = []
    try:
        prog = parse_knitout(text, path, warnings=warnings)
    except KnitoutErrors as exc:
        return None, knitout_diagnostics(path, text, exc.errors, exc.warnings)
    return prog, knitout_diagnostics(path, text, (), warnings)
