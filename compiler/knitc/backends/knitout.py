"""Knitout writer: `MachineProgram` -> Knitout text (spec v0.6, magic ``;!knitout-2``).

The output is what both Knitout consumers knitc is tested against accept
(shared/research/knitout-and-dat.md §4): the header ``;!knitout-2``, ``;;Machine:``,
``;;Gauge:``, ``;;Carriers: 1 2 ... 10`` and ``;;Position:``; then one op per line, tokens
separated by single spaces, LF line ends, no tabs, no trailing spaces. It is deterministic:
the same program gives the same bytes.

An op with a source span carries it in a trailing Knitout source comment,
``knit + f3 3 ;!source:sweater.knit:12:3`` (spec v0.6: tools echo ``!source:`` comments in
their messages), so an error found by an external tool can be traced back to the DSL line;
`knitout_lines` also gives the op index of every line, to map an external tool's line number
back to the op.

Carrier sets on ``in``/``inhook``/``releasehook``/``out``/``outhook`` are written one carrier
per line by default, because the independent oracle (knitout-interpreter) only parses one
carrier there. Note that the Shima DAT converter wants the first use of carriers brought in
together to name exactly the set of the ``in`` line, so a program that brings two carriers
in at once for one two-carrier op should be written with ``one_carrier_per_line=False`` for
that converter.
"""

from __future__ import annotations

from knitc.codegen.machine import CARRIER_KINDS, MachineProgram, Needle, Op

MAGIC = ";!knitout-2"


def header_lines(prog: MachineProgram) -> list[str]:
    m = prog.machine
    width = [] if prog.width is None else [f";;Width: {prog.width}"]
    return [
        MAGIC,
        f";;Machine: {m.name}",
        f";;Gauge: {m.gauge}",
        ";;Carriers: " + " ".join(str(c) for c in m.carrier_names),
        *width,
        f";;Position: {prog.position}",
    ]


def _one_line(text: str) -> str:
    return " ".join(text.split())


def source_comment(op: Op) -> str:
    """`` ;!source:FILE:LINE:COL`` for an op with a span, else ''."""
    if op.span is None:
        return ""
    return f" ;!source:{_one_line(str(op.span))}"


def op_lines(
    op: Op, *, source_comments: bool = True, one_carrier_per_line: bool = True
) -> list[str]:
    """The Knitout line(s) of one op."""
    tail = source_comment(op) if source_comments else ""
    if op.kind == "comment":
        text = str(op.value)
        return [f"; {line}".rstrip() for line in (text.splitlines() or [""])]
    if op.kind == "pause":
        lines = [f"; {_one_line(str(op.value))}"] if op.value else []
        return lines + ["pause" + tail]
    if op.kind in CARRIER_KINDS and one_carrier_per_line and len(op.carriers) > 1:
        return [f"{op.kind} {c}{tail}" for c in op.carriers]
    return [str(op) + tail]


def knitout_lines(
    prog: MachineProgram, *, source_comments: bool = True, one_carrier_per_line: bool = True
) -> list[tuple[str, int]]:
    """Every line of the Knitout text with the index of the op it came from (-1: header)."""
    out = [(line, -1) for line in header_lines(prog)]
    for i, op in enumerate(prog.ops):
        out += [
            (line, i)
            for line in op_lines(
                op, source_comments=source_comments, one_carrier_per_line=one_carrier_per_line
            )
        ]
    return out


def write_knitout(
    prog: MachineProgram, *, source_comments: bool = True, one_carrier_per_line: bool = True
) -> str:
    """The Knitout text of `prog` (LF line ends, a final newline): the lines of
    `knitout_lines`, written faster. A program names few distinct needle operations many
    times over and has one span per stitch or DSL line, so the text of each distinct
    operation (its fields but provenance: `Op.__str__` reads no others) and the source
    comment of each span are formatted once."""
    out = header_lines(prog)
    append = out.append
    bodies: dict[tuple, str] = {}  # op[:6] -> its text, for ops without a source comment
    lines: dict[int, dict[tuple, str]] = {}  # id(span) -> op[:6] -> the whole line
    tails: dict[int, str] = {}  # id(span) -> its comment; the ops keep the spans alive

    def tail(op: Op) -> str:  # (only on a cache miss)
        text = tails.get(id(op.span))
        if text is None:
            text = tails[id(op.span)] = source_comment(op)
        return text

    for op in prog.ops:
        if op.kind not in _NEEDLE_KINDS:
            out += op_lines(
                op, source_comments=source_comments, one_carrier_per_line=one_carrier_per_line
            )
            continue
        span = op.span
        # whether every number of the op is an int, so that equal ops print alike (true of
        # every op code generation makes and a verified program holds)
        n, m, cs = op.needle, op.needle2, op.carriers
        if not (
            type(op.dir) is int
            and type(n) is Needle
            and type(n.index) is int
            and (m is None or (type(m) is Needle and type(m.index) is int))
            and (not cs or (len(cs) == 1 and type(cs[0]) is int))
        ):  # 1, 1.0 and True are one key but three texts: format such an op each time
            append(str(op) + tail(op) if source_comments and span is not None else str(op))
            continue
        key = op[:6]  # kind, dir, needle, needle2, carriers, value
        if source_comments and span is not None:
            mine = lines.get(id(span))
            if mine is None:
                mine = lines[id(span)] = {}
            line = mine.get(key)
            if line is None:
                text = bodies.get(key)
                if text is None:
                    text = bodies[key] = str(op)
                line = mine[key] = text + tail(op)
            append(line)
        else:
            text = bodies.get(key)
            if text is None:
                text = bodies[key] = str(op)
            append(text)
    return "\n".join(out) + "\n"


_NEEDLE_KINDS = frozenset({"knit", "tuck", "miss", "split", "xfer", "drop", "amiss"})
"""The ops `write_knitout` formats through its cache: one line each, text from needles,
direction and carriers only."""


def op_of_line(prog: MachineProgram, line: int, **options: bool) -> int:
    """The index of the op written on 1-based `line` of `write_knitout(prog, **options)`
    (-1 for the header or a line past the end)."""
    lines = knitout_lines(prog, **options)
    return lines[line - 1][1] if 1 <= line <= len(lines) else -1


# ---- reading back ---------------------------------------------------------------------------

_OPCODE_KIND = {
    "x-stitch-number": "stitch_number",
    "x-speed-number": "speed",
    "x-presser-mode": "presser",
}


def _number(text: str) -> float | int:
    v = float(text)
    return int(v) if v.is_integer() else v


def read_knitout(text: str) -> MachineProgram:
    """Parse Knitout in the subset `write_knitout` writes back into a program (for tests and
    tools: header values other than Position are not read; comments other than `!source:`
    become comment ops; source comments are not turned back into spans). Raises ValueError
    on a line it cannot read."""

    prog = MachineProgram()
    for lineno, raw in enumerate(text.splitlines(), 1):
        code, _, comment = raw.partition(";")
        tokens = code.split()
        if not tokens:
            c = comment.strip()
            if c.startswith(";Position:"):
                prog.position = c.split(":", 1)[1].strip()
            elif raw.strip().startswith(";") and not c.startswith((";", "!")):
                prog.emit(Op("comment", value=comment[1:] if comment[:1] == " " else comment))
            continue
        op, args = tokens[0], tokens[1:]
        try:
            if op in CARRIER_KINDS:
                prog.emit(Op(op, carriers=tuple(map(int, args))))
            elif op in ("knit", "tuck", "miss", "split"):
                d = {"+": 1, "-": -1}[args[0]]
                n2 = Needle.parse(args[2]) if op == "split" else None
                cs = args[3:] if op == "split" else args[2:]
                prog.emit(Op(op, d, Needle.parse(args[1]), n2, tuple(map(int, cs))))
            elif op == "xfer":
                prog.emit(Op("xfer", needle=Needle.parse(args[0]), needle2=Needle.parse(args[1])))
            elif op in ("drop", "amiss"):
                prog.emit(Op(op, needle=Needle.parse(args[0])))
            elif op == "rack":
                prog.emit(Op("rack", value=_number(args[0])))
            elif op in ("x-stitch-number", "x-speed-number"):
                prog.emit(Op(_OPCODE_KIND[op], value=int(args[0])))
            elif op == "x-presser-mode":
                prog.emit(Op("presser", value=args[0]))
            elif op == "pause":
                prog.emit(Op("pause"))
            else:
                raise ValueError(f"unknown opcode {op!r}")
        except (IndexError, KeyError, ValueError) as e:
            raise ValueError(f"line {lineno}: cannot read {raw!r}: {e}") from None
    return prog
