"""Hover and inlay hints: what the compiler knows about the word under the cursor.

A hover answers from the analysis of the document (`Analysis`): the resolved skeleton for
values (a parameter after its overrides, a node's properties with the defaults filled in,
its interfaces and what they connect to, a yarn's carrier), the stitch graph for sizes
(stitches and courses per node and per yarn), the property tables of
`knitc.frontend.skeleton` for a property name, and short texts taken from
`docs/language.md` for instructions, query functions and keywords.

What is under the cursor is found in two steps: the index (`Analysis.index`) for the names
it knows (params, nodes, yarns, definitions), then the syntax tree for the rest (a property
name, an instruction after `set` or in a grid, a query call, a keyword). When the text does not
parse, the last module that did is used (`Analysis.stale`): its spans are in an older text,
so every answer is checked against the word actually at the cursor in the current text and
dropped when they differ, rather than describing the wrong thing.

Everything here is a pure function of an `Analysis` and an offset (`hover_at`,
`inlay_hints`), run on the compiler thread by the handlers `register` adds.
"""

from __future__ import annotations

import os
import re
from collections.abc import Iterator, Mapping
from typing import TYPE_CHECKING, Any

import numpy as np
from lsprotocol import types

from knitc import arrays
from knitc.frontend import ast
from knitc.frontend import skeleton as sk
from knitc.frontend.fmt import format_expr
from knitc.frontend.names import QUERY_FUNCTIONS
from knitc.lang.evaluate import Profile, Word, show
from knitc.lsp.analysis import Analysis
from knitc.lsp.definitions import doc_comment, signature
from knitc.lsp.index import Ref, Symbol
from knitc.lsp.locations import STDLIB, source_of
from knitc.records import record
from knitc.shaping.stitch_graph import INSTRUCTIONS, StitchGraph
from knitc.source import SourceFile, Span
from knitc.view.figure import INSTR_NAMES

if TYPE_CHECKING:
    from knitc.lsp.server import KnitServer

# ---- texts (after docs/language.md) -----------------------------------------------------------

INSTRUCTION_OPS: dict[str, str] = {
    "K": "knit on the stitch's needle",
    "P": "transfer to the facing needle, knit there, transfer back; on flat fabric the loop "
    "stays on the back bed while the wale stays purl",
    "T": "tuck: the needle keeps its old loop, both are knitted off by the next knit",
    "M": "miss: the needle keeps its old loop, the yarn floats past (a slip stitch)",
    "F": "knit, then after the course carry the loop {n} needle{s} {dir} onto its neighbour's: "
    "the neighbour's next stitch knits both (a decrease), the emptied needle's next stitch "
    "is a yarn-over (the eyelet)",
    "B": "knitted from the back bed (a purl), then after the course carried {n} needle{s} "
    "{dir} from there onto its neighbour's: the neighbour's next stitch knits both, the "
    "emptied needle's next stitch is a yarn-over",
    "X": "a cable: a run of `XR+` (or `XR-`), optional plain relief stitches, then a run of "
    "`XL-` (or `XL+`); after the course the runs swap needles, the `+` run passing in front",
    "S": "knit; when a move lands on it, its loop is lifted first and put back on top",
}
"""How each instruction is knitted (docs/language.md, "How instructions are knitted");
moves and crosses share a text, filled in per mnemonic by `instruction_ops`."""

QUERY_DOCS: dict[str, str] = {
    "all": "every stitch of the layer",
    "filter": "the stitches where the predicate is true; it reads the stitch fields "
    "`course wale course_end wale_end side gauge node index`, numbers, `#params` and "
    "arguments, with arithmetic, comparisons, `and or not`",
    "courses": "the courses in range R (inclusive; fractions between 0 and 1 are of the "
    "extent, negatives and `end` count from the end)",
    "wales": "the wales in range R; with a side, counted along that bed",
    "select": "`courses(Rc) and wales(Rw[, side])`",
    "side": "one bed's stitches: `side(front)` or `side(back)`",
    "neighbors": "`Q.neighbors(R)`: stitches whose distance from Q (course and wale hops) "
    "is in R: `n` is 1 to n, `0:n` includes Q; default 1",
    "boundaries": "the edge of Q (default all): its stitches on a node's first or last "
    "course or a flat course's ends, or next to a stitch outside Q",
    "named": "the stitches on interface courses",
    "shape": '`shape("node")`: the stitches of a node',
    "itf": '`itf("node.top")`, `itf("top")`: the stitches of an interface\'s course',
    "inverse": "`Q.inverse()`: the layer's stitches not in Q, as `not Q`",
    "stretch": "`stretch(g[, Q])`: the on cells of grid g scaled onto Q's bounding box "
    "(nearest neighbour)",
    "tile": "`tile(g[, Q])`: the on cells of g repeated from Q's lower-left corner; g may "
    "be `img(...)`",
    "img": '`img(file, channel = "k", threshold = 0.5)`: a picture stretched onto the '
    "frame, on where the channel reaches the threshold",
    "noise": "`noise(scale, threshold = 0.5, seed = 1)`: deterministic 2-D simplex noise "
    "over the frame, on where it reaches the threshold",
    "wale_grid": "`[Q.]wale_grid(wales, steps)`: a grid that follows wales from Q's first "
    "course, so a chart placed on it follows increases and decreases",
    "stitch_grid": '`[Q.]stitch_grid(w, h, x_align = "left", y_align = "bottom")`: a w × h '
    "grid from Q's lower-left stitch, traced along courses and wales",
}
"""The pattern queries (docs/language.md, "Queries", "Drawn queries and grids")."""

KEYWORDS: dict[str, str] = {
    "import": '`import std.NAME [(a, b)]` or `import "path.knit" [(a, b)]`: the definitions '
    "(`pattern`, `action`, `shaper`) of a standard-library module or a `.knit` file, all "
    "or the listed ones.",
    "param": "`param NAME = EXPR`: a design parameter, read as `#NAME`; `-D NAME=VALUE` "
    "(the `knitc.defines` setting) overrides it.",
    "machine": "`machine { ... }`: the machine settings (model, needles, gauge, racking, "
    "carriers, default increase and casting); at most one block.",
    "yarn": "`yarn NAME { ... }`: a yarn the pattern layers knit with (`knit NAME where Q`), "
    "on its own `carrier`; `main`, the design's own yarn, always exists and may be declared "
    "too.",
    "sheet": "`sheet NAME { ... }`: a flat sheet (`type: flat`, the default), or "
    "`type: cylinder` / `auto`; its interfaces are `bottom` and `top`.",
    "tube": "`tube NAME { ... }`: a tube, a sheet of type cylinder (2 × width stitches "
    "around); its interfaces are `bottom` and `top`.",
    "joint": "`joint NAME { ... }`: short rows between two interfaces of equal size "
    "(heels, elbows); its interfaces are `bottom` and `top`.",
    "split": "`split NAME { ... }`: one `base` and `degree` `branches[i]`: a split, or a "
    "merge read the other way.",
    "pattern": "`pattern NODE { ... }`: pattern layers of a node (`before` / `after`: the "
    "global ones, applied first / last); `pattern NAME(a, b = 2) { ... }`: a reusable "
    "pattern definition, run with `apply`.",
    "action": "`action NAME { ... }`: a stitch action, properties and `pre` / `main` / "
    "`post` steps of machine operations; attached to stitches with `use`.",
    "shaper": "`shaper NAME(M, N, ...) { ... }`: a shaper program mapping a course of M "
    "stitches onto one of N (`i -> j`, `i -> (j1, j2)`, `(i1, i2) -> j`).",
    "start": "`start a.bottom`: where the yarn starts; one per connected garment, not at "
    "a connected interface; without one, the first free interface.",
    "open": "`a.bottom open`: leave the interface open (the default): cast on or cast off there.",
    "closed": "`a.bottom closed` / `closed(zigzag)`: close a tubular end: `collapse` (the "
    "default), `zigzag`, `zigzagreturn`; no effect on a flat one (W503).",
    "set": "`set I where Q`: write one of the 17 instructions on the selected stitches.",
    "use": "`use ACTION where Q`: attach a stitch action to the selected stitches.",
    "knit": "`knit YARN where Q`: knit the selected stitches with a declared yarn (`knit "
    "main`: with the design's own again). A course is knitted with one yarn: stripes are "
    "whole courses.",
    "backing": "`backing KIND where Q`: the selected stitches' courses are jacquard: each "
    "yarn of the region knits, besides its own stitches, the back needles behind the others' "
    "(`tubular`, `birdseye`, `pique`, `horizontal`, `vertical`; `float` floats them as fair "
    "isle). On sheets and half-gauge tubes: a full-gauge tube knits its other side there "
    "(E719).",
    "intarsia": "`intarsia where Q`: the selected stitches' courses are intarsia: each "
    "region of one yarn is knitted by a carrier of its own, back and forth over its own "
    "stitches, and tucked to its neighbours at every course (no yarn floats behind "
    "another's stitches). Between courses of one yarn (E730).",
    "apply": "`apply PATTERN(args) where Q`: run a pattern definition on the selection "
    "(arguments by position, then by name, then the defaults).",
    "where": "`where Q`: the stitches the statement applies to, a query; without it, all "
    "the layer's stitches.",
    "let": "`let NAME = EXPR`: in a pattern block, names a selection or a grid for its "
    "later statements; in a program, a variable.",
    "draw": "`draw G where Q`: a singular drawn layer: the grid once, centred in the "
    "selection; rows or columns that do not fit are left out (W710).",
    "stretch": "`stretch G where Q`: a scalable drawn layer: the grid scaled onto the "
    "selection's bounding box (no crosses, E315).",
    "tile": "`tile G where Q`: a tileable drawn layer: the grid repeated from the "
    "selection's lower-left corner.",
    "pre": "the action step before the course is knitted (transfers that bring the loop "
    "where it is knitted).",
    "main": "the action step of the knitting pass itself.",
    "post": "the action step after the course (transfers that put the loop back).",
    "if": "`if COND { ... } else { ... }`: a conditional statement of a program.",
    "else": "the branch of an `if` taken when its condition is false.",
    "for": "`for NAME in EXPR { ... }`: a loop of a program over a list or `range(...)`.",
    "in": "`for NAME in EXPR`: the list or range the loop runs over.",
    "and": "boolean and (short-circuit); of two selections, their intersection.",
    "or": "boolean or (short-circuit); of two selections, their union.",
    "not": "boolean not; of a selection, its complement in the layer.",
}
"""Keywords, from docs/language.md's tables of declarations and statements."""

_ITEM_KEYWORD: dict[type, str] = {
    ast.Import: "import",
    ast.ParamDecl: "param",
    ast.MachineDecl: "machine",
    ast.YarnDecl: "yarn",
    ast.PatternLayer: "pattern",
    ast.PatternDef: "pattern",
    ast.ActionDef: "action",
    ast.ShaperDef: "shaper",
    ast.Start: "start",
    ast.SetStmt: "set",
    ast.UseStmt: "use",
    ast.KnitStmt: "knit",
    ast.BackingStmt: "backing",
    ast.IntarsiaStmt: "intarsia",
    ast.ApplyStmt: "apply",
    ast.Let: "let",
    ast.If: "if",
    ast.For: "for",
}
"""The keyword a construct's span starts with (node kinds, grid modes and action steps
are read from the node itself)."""

_WORD = re.compile(r"X[RL][+-]|[A-Za-z_][A-Za-z0-9_]*|[0-9][0-9.]*")


@record(frozen=True)
class Info:
    """A hover's Markdown and the code-point offsets of the word it is about."""

    markdown: str
    start: int
    end: int


@record(frozen=True)
class _Word:
    text: str
    start: int
    end: int


# ---- the word under the cursor ---------------------------------------------------------------


def _word_at(source: SourceFile, offset: int) -> _Word | None:
    """The name, mnemonic or number at `offset` (its end counts), outside comments."""
    text = source.text
    if not 0 <= offset <= len(text):
        return None
    line, _ = source.position(offset)
    start = source.line_start(line)
    line_text = source.line_text(line)
    col = offset - start
    if _in_line_comment(line_text, col):
        return None
    found: _Word | None = None
    for m in _WORD.finditer(line_text):
        if m.start() <= col < m.end():
            return _Word(m.group(), start + m.start(), start + m.end())
        if m.end() == col:
            found = _Word(m.group(), start + m.start(), start + m.end())
    return found


def _in_line_comment(line: str, col: int) -> bool:
    """Whether column `col` of `line` is after a `//` that is not inside a string."""
    quoted = False
    i = 0
    while i < min(col, len(line)):
        ch = line[i]
        if ch == "\\" and quoted:
            i += 2
            continue
        if ch == '"':
            quoted = not quoted
        elif not quoted and line.startswith("//", i):
            return True
        i += 1
    return False


def _in_block_comment(module: ast.Module, offset: int) -> bool:
    return any(c.span.start <= offset < c.span.end for c in module.comments)


def _fits(a: Analysis, word: _Word, span: Span, name: str) -> bool:
    """Whether `span` (maybe of a stale module) is the word at the cursor and reads `name`."""
    return span.start == word.start and span.end == word.end and word.text == name


# ---- the hover ----------------------------------------------------------------------------------


def hover_at(a: Analysis, offset: int, defines: Mapping[str, str] | None = None) -> Info | None:
    """What to show for the word at code-point `offset`; None where there is nothing to say
    (whitespace, comments, numbers, past the end, a word the analysis does not know).

    `defines` are the parameter overrides of the editor's settings (by name); by default
    the ones this analysis was made with."""
    module = a.module
    word = _word_at(a.source, offset)
    if module is None or word is None or word.text[0].isdigit():
        return None
    if not a.stale and _in_block_comment(module, offset):
        return None
    if defines is None:
        defines = a.settings.define_map()
    item = a.index.at(offset)
    if item is not None and _fits(a, word, item.span, item.name):
        found = _hover_name(a, item, defines)
        if found is not None:
            return Info(found, word.start, word.end)
    path = list(_path(module, offset))
    text = _hover_syntax(a, path, word)
    return Info(text, word.start, word.end) if text is not None else None


def _hover_name(a: Analysis, item: Symbol | Ref, defines: Mapping[str, str]) -> str | None:
    if item.kind == "param":
        return param_markdown(a, item.name, defines)
    if item.kind == "node":
        return node_markdown(a, item.name)
    if item.kind == "yarn":
        return yarn_markdown(a, item.name)
    if item.kind in ("pattern", "action", "shaper", "import"):
        return definition_markdown(a, item.name, item.kind)
    return None


def _path(module: ast.Module, offset: int) -> Iterator[ast.Node]:
    """The nodes whose spans hold `offset`, outermost first (the module excluded)."""
    node: ast.Node = module
    while True:
        inner = [
            c
            for c in node.children()
            if c.span.file != "<unknown>" and c.span.start <= offset <= c.span.end
        ]
        if not inner:
            return
        strict = [c for c in inner if c.span.start <= offset < c.span.end]
        node = (strict or inner)[-1 if not strict else 0]
        yield node


def _hover_syntax(a: Analysis, path: list[ast.Node], word: _Word) -> str | None:
    """The hover of a word the index does not name, from the syntax around it."""
    for node in reversed(path):
        for fn in (
            _on_prop,
            _on_instruction,
            _on_query,
            _on_interface,
            _on_import,
            _on_keyword,
        ):
            found = fn(a, node, path, word)
            if found is not None:
                return found
    return None


# -- properties


def _on_prop(a: Analysis, node: ast.Node, path: list[ast.Node], word: _Word) -> str | None:
    if isinstance(node, ast.Prop) and _fits(a, word, node.name.span, node.name.name):
        table, owner = _prop_table(a, path, node)
        spec = table.get(node.name.name) if table is not None else None
        if spec is None:
            return None
        return prop_markdown(node.name.name, spec, owner) + _resolved_here(a, path, node)
    if isinstance(node, ast.PropRef):
        prop_start = node.span.end - len(node.prop)
        if word.start != prop_start or word.text != node.prop:
            return None
        kind = _node_kind(a, node.node) if node.node else _enclosing_kind(path)
        spec = sk.NODE_PROPS.get(kind or "", {}).get(node.prop)
        return prop_markdown(node.prop, spec, f"`{kind}`") if spec is not None else None
    return None


def _prop_table(
    a: Analysis, path: list[ast.Node], prop: ast.Prop
) -> tuple[dict[str, sk.PropSpec] | None, str]:
    """The property table of the block `prop` is written in, and what that block is."""
    for node in reversed(path):
        if isinstance(node, ast.NodeDecl) and prop in node.props:
            return sk.NODE_PROPS.get(node.kind), f"`{node.kind}`"
        if isinstance(node, ast.MachineDecl):
            return sk.MACHINE_PROPS, "`machine`"
        if isinstance(node, ast.YarnDecl):
            return sk.YARN_PROPS, "`yarn`"
        if isinstance(node, ast.ItfStmt):
            return sk.ITF_PROPS, "interface"
        if isinstance(node, ast.ActionDef):
            return sk.ACTION_PROPS, "`action`"
    return None, ""


def _resolved_here(a: Analysis, path: list[ast.Node], prop: ast.Prop) -> str:
    """The value the property resolved to in its node or yarn, when that is known."""
    decl = next((n for n in reversed(path) if isinstance(n, ast.NodeDecl | ast.YarnDecl)), None)
    skel = a.skeleton
    if decl is None or skel is None or a.stale:
        return ""
    value: Any = None
    if isinstance(decl, ast.NodeDecl) and decl.name.name in skel.nodes:
        value = skel.nodes[decl.name.name].props.get(prop.name.name)
    elif isinstance(decl, ast.YarnDecl) and _declares(skel, decl):
        value = getattr(skel.yarns[decl.name.name], prop.name.name, None)
    return f"\n- here: `{_value(value)}`" if value is not None else ""


def _declares(skel: sk.Skeleton, decl: ast.YarnDecl) -> bool:
    """Whether the skeleton's yarn of that name is this declaration's: of a yarn declared
    twice (E227) it holds the first."""
    yarn = skel.yarns.get(decl.name.name)
    return yarn is not None and yarn.span == decl.span


def _node_kind(a: Analysis, name: str) -> str | None:
    skel = a.skeleton
    if skel is not None and name in skel.nodes:
        return skel.nodes[name].kind
    decl = a.index.declared("node", name)
    return decl.decl.kind if decl is not None and isinstance(decl.decl, ast.NodeDecl) else None


def _enclosing_kind(path: list[ast.Node]) -> str | None:
    return next((n.kind for n in reversed(path) if isinstance(n, ast.NodeDecl)), None)


_UNSET = {"`yarn`": "chosen by knitc"}
"""What a property without a default takes, by its owner when not the machine's value."""


def prop_markdown(name: str, spec: sk.PropSpec, owner: str) -> str:
    """A property's entry of the tables: type, default, the values it takes, its doc."""
    lines = [f"**{name}**: {_kind_text(spec.kind)} — property of {owner}"]
    if spec.doc:
        lines += ["", spec.doc[0].upper() + spec.doc[1:] + "."]
    lines.append("")
    unset = _UNSET.get(owner, "the machine's")
    default = unset if spec.default is None else f"`{_value(spec.default)}`"
    lines.append(f"- default: {default}")
    values = _values_text(spec)
    if values:
        lines.append(f"- values: {values}")
    return "\n".join(lines)


_KIND_TEXT = {
    "int": "whole number",
    "number": "number",
    "bool": "boolean",
    "string": "string",
    "choice": "word",
    "width": "number or profile",
    "joint_layout": "`auto` or number",
    "split_layout": "`auto` or list",
    "carriers": "number or list",
    "shaper": "word or shaper",
}


def _kind_text(kind: str) -> str:
    return _KIND_TEXT.get(kind, kind)


def _values_text(spec: sk.PropSpec) -> str:
    if spec.choices:
        out = ", ".join(f"`{c}`" for c in spec.choices)
        return out + (", or a `shaper` name" if spec.kind == "shaper" else "")
    if spec.kind == "shaper":
        return ", ".join(f"`{c}`" for c in sk.SHAPERS) + ", or a `shaper` name"
    if spec.kind == "bool":
        return "`true`, `false`"
    if spec.kind == "carriers":
        return "carriers `1` to `10`, none twice"
    if spec.min is not None and spec.max is not None:
        rng = f"`{show(spec.min)}` to `{show(spec.max)}`"
        if spec.kind == "width":
            return rng + ", or a profile of such"
        if spec.kind == "split_layout":
            return "`auto`, or a list of " + rng + ", one per branch"
        if spec.kind == "joint_layout":
            return "`auto`, or " + rng
        return rng
    return ""


# -- instructions


def _on_instruction(a: Analysis, node: ast.Node, path: list[ast.Node], word: _Word) -> str | None:
    if isinstance(node, ast.BackingStmt) and _fits(a, word, node.kind.span, node.kind.name):
        from knitc.lsp.completion import BACKING_DOCS

        doc = BACKING_DOCS.get(node.kind.name)
        return f"**`{node.kind.name}`** — jacquard backing\n\n{doc}" if doc else None
    if isinstance(node, ast.GridCell) and _fits(a, word, node.span, node.text):
        return instruction_markdown(node.text) if node.text in INSTRUCTIONS else None
    if isinstance(node, ast.SetStmt) and word.text == node.instr:
        before = a.text[node.span.start : word.start]
        if re.fullmatch(r"set\s+", before):
            return instruction_markdown(node.instr)
    return None


def instruction_ops(mnemonic: str) -> str:
    """How the machine knits `mnemonic` (the lowering of thesis ch. 4.2.2)."""
    head = mnemonic[0]
    if mnemonic in INSTRUCTION_OPS:
        return INSTRUCTION_OPS[mnemonic]
    if head in "FB" and len(mnemonic) == 3:
        n = mnemonic[2]
        direction = "right" if mnemonic[1] == "R" else "left"
        return INSTRUCTION_OPS[head].format(n=n, s="" if n == "1" else "s", dir=direction)
    return INSTRUCTION_OPS.get(head, "")


def instruction_markdown(mnemonic: str) -> str:
    name = INSTR_NAMES.get(mnemonic, "")
    return (
        f"**`{mnemonic}`**: {name} — pattern instruction\n\n"
        f"On the machine: {instruction_ops(mnemonic)}."
    )


# -- query functions


def _on_query(a: Analysis, node: ast.Node, path: list[ast.Node], word: _Word) -> str | None:
    if not isinstance(node, ast.Call) or not _in_pattern(path):
        return None
    func = node.func
    if isinstance(func, ast.Name):
        ident, span = func.id, func.span
    elif isinstance(func, ast.Attr):
        ident, span = func.name.name, func.name.span
    else:
        return None
    if not _fits(a, word, span, ident) or ident not in QUERY_DOCS:
        return None
    return query_markdown(ident)


def _in_pattern(path: list[ast.Node]) -> bool:
    return any(isinstance(n, ast.PatternLayer | ast.PatternDef) for n in path)


def query_markdown(name: str) -> str:
    arity = QUERY_FUNCTIONS.get(name)
    if arity is None:
        takes = "chained on a selection"
    else:
        lo, hi = arity
        count = str(lo) if lo == hi else f"{lo} to {hi}"
        takes = f"{count} positional argument{'' if (lo, hi) == (1, 1) else 's'}"
    return f"**`{name}(…)`**: pattern query — {takes}\n\nSelects {QUERY_DOCS[name]}."


# -- interfaces (`palm.top`)


def _on_interface(a: Analysis, node: ast.Node, path: list[ast.Node], word: _Word) -> str | None:
    if not isinstance(node, ast.ItfRef) or not _fits(a, word, node.path.span, node.path.name):
        return None
    skel = a.skeleton
    if skel is None:
        return None
    itf_path = node.path.name
    if itf_path == "branches":
        if not isinstance(node.index, ast.Number):
            return None
        itf_path = f"branches/{node.index.value}"
    itf = skel.interfaces.get(sk.ItfId(node.node.name, itf_path))
    return f"**interface** {_interface_line(skel, itf)}" if itf is not None else None


# -- imported modules (`import std.stitches`)


def _on_import(a: Analysis, node: ast.Node, path: list[ast.Node], word: _Word) -> str | None:
    if not isinstance(node, ast.Import) or node.module is None or word.text not in node.module:
        return None
    names_start = node.names[0].span.start if node.names else node.span.end
    if not node.span.start + len("import") < word.start < names_start:
        return None
    return module_markdown(a, ".".join(node.module))


_DEFINITION = re.compile(r"^(pattern|action|shaper)\s+([A-Za-z_][A-Za-z0-9_]*)", re.M)


def module_markdown(a: Analysis, module: str) -> str | None:
    """A standard-library module: the first paragraph of its header comment and the
    definitions it holds."""
    path = STDLIB + module.replace(".", "/") + ".knit"
    source = source_of(path, a.diagnostics.sources)
    if source is None:
        return None
    header: list[str] = []
    for line in source.text.splitlines():
        text = line.strip()
        if not text.startswith("//") or (header and text == "//"):
            break
        header.append(text[2:].strip())
    defs = [f"`{kind} {name}`" for kind, name in _DEFINITION.findall(source.text)]
    lines = [f"**module** `{module}`"]
    if header:
        lines += ["", "\n".join(header)]
    if defs:
        lines += ["", "Defines: " + ", ".join(defs)]
    return "\n".join(lines)


# -- keywords


def _on_keyword(a: Analysis, node: ast.Node, path: list[ast.Node], word: _Word) -> str | None:
    keyword = _keyword(node, word)
    if keyword is None or keyword not in KEYWORDS:
        return None
    return f"**`{keyword}`** — keyword\n\n{KEYWORDS[keyword]}"


def _keyword(node: ast.Node, word: _Word) -> str | None:
    """The keyword `word` is in `node` (the innermost node around it), if it is one."""
    at_start = word.start == node.span.start
    expected: str | None = _ITEM_KEYWORD.get(type(node))
    if isinstance(node, ast.NodeDecl):
        expected = node.kind
    elif isinstance(node, ast.GridStmt):
        expected = node.mode
    elif isinstance(node, ast.ActionStep):
        expected = node.step
    if at_start and word.text == expected:
        return expected
    where = getattr(node, "where", None)
    if word.text == "where" and isinstance(where, ast.Node) and word.end <= where.span.start:
        return "where"
    if isinstance(node, ast.ItfStmt) and word.text == node.state:
        return node.state if word.start >= node.itf.span.end else None
    between = _between(node)
    if between is not None and word.text in between[0]:
        lo, hi = between[1], between[2]
        return word.text if lo <= word.start and word.end <= hi else None
    return None


def _between(node: ast.Node) -> tuple[tuple[str, ...], int, int] | None:
    """Keywords written between two children of `node`, and where they may be."""
    if isinstance(node, ast.Binary) and node.op in ("and", "or"):
        return (node.op,), node.left.span.end, node.right.span.start
    if isinstance(node, ast.Unary) and node.op == "not":
        return ("not",), node.span.start, node.operand.span.start
    if isinstance(node, ast.For):
        return ("in",), node.var.span.end, node.iter.span.start
    if isinstance(node, ast.If) and node.orelse is not None:
        return ("else",), node.then.span.end, node.orelse.span.start
    return None


# ---- parameters ---------------------------------------------------------------------------------


def param_markdown(a: Analysis, name: str, defines: Mapping[str, str]) -> str | None:
    """A parameter's value as resolved, its declaration, and the setting overriding it."""
    decl = a.index.declared("param", name)
    skel = a.skeleton
    value = skel.params.get(name) if skel is not None else None
    if decl is None and value is None:
        return None
    head = f"**param** `{name}`"
    if value is not None:
        head += f" = **{_value(value)}**"
    lines = [head]
    if isinstance(decl, Symbol) and isinstance(decl.decl, ast.ParamDecl):
        expr = _expr_text(decl.decl.value)
        lines += ["", f"Declared on line {decl.decl.span.line}: `param {name} = {expr}`"]
    if name in defines:
        lines += ["", f"Overridden by the knitc.defines setting: {name} = {defines[name]}"]
    return "\n".join(lines)


def _expr_text(expr: ast.Node) -> str:
    try:
        return format_expr(expr)
    except Exception:  # a formatter gap must not cost the hover
        return "…"


def _value(v: Any) -> str:
    """A resolved value as the designer writes it: a constant profile as its number, a
    word bare."""
    if isinstance(v, Profile) and v.is_constant:
        return show(v.points[0][1])
    if isinstance(v, str):
        return v
    if isinstance(v, Word):
        return v.name
    return show(v)


# ---- nodes ----------------------------------------------------------------------------------


def node_counts(graph: StitchGraph) -> dict[str, tuple[int, int]]:
    """Stitches and courses the stitch graph gives each node. A course belongs to one node
    (`course_node`), so the course where two nodes are joined counts for one of them only:
    a node may have a course fewer than its `length`."""
    n = len(graph.node_names)
    stitches = np.bincount(graph.node, minlength=n) if graph.n_stitches else np.zeros(n, int)
    courses = np.bincount(graph.course_node, minlength=n) if graph.n_courses else np.zeros(n, int)
    return {name: (int(stitches[i]), int(courses[i])) for i, name in enumerate(graph.node_names)}


def counts_text(stitches: int, courses: int) -> str:
    return (
        f"{stitches:,} stitch{'' if stitches == 1 else 'es'}, "
        f"{courses:,} course{'' if courses == 1 else 's'}"
    )


def node_markdown(a: Analysis, name: str) -> str | None:
    """A node's kind and resolved properties, its size in the stitch graph, and its
    interfaces with their state, size and what each is connected to."""
    skel = a.skeleton
    node = skel.nodes.get(name) if skel is not None else None
    decl = a.index.declared("node", name)
    if node is None:
        if decl is None or not isinstance(decl.decl, ast.NodeDecl):
            return None
        body = "\n".join(f"  {p.name.name}: {_expr_text(p.value)}" for p in decl.decl.props)
        where = f"line {decl.decl.span.line}"
        return f"```knit\n{decl.decl.kind} {name} {{\n{body}\n}}\n```\n\n*Declared on {where}*"
    assert skel is not None
    props = "\n".join(f"  {k}: {_value(v)}" for k, v in node.props.items())
    lines = [f"```knit\n{node.kind} {name} {{\n{props}\n}}\n```"]
    if a.graph is not None:
        counts = node_counts(a.graph).get(name)
        if counts is not None:
            lines += ["", f"**{counts_text(*counts)}** in the stitch graph"]
    itfs = [skel.interfaces[sk.ItfId(name, p)] for p in node.interface_paths]
    lines += ["", "Interfaces:", ""]
    lines += [f"- {_interface_line(skel, itf)}" for itf in itfs if itf is not None]
    lines += ["", f"*Declared on line {node.span.line}*"]
    return "\n".join(lines)


def _interface_line(skel: sk.Skeleton, itf: sk.Interface) -> str:
    state = itf.state
    if state == "closed" and itf.closing:
        state += f" ({itf.closing})"
    out = f"`{itf.id}`: {state}"
    if itf.size is not None:
        out += f", {itf.size:,} stitch{'' if itf.size == 1 else 'es'}"
    if itf.sides is not None:
        out += ", tubular" if itf.sides == 2 else ", flat"
    partners = [
        str(c.b if c.a == itf.id else c.a) for c in skel.connections if itf.id in (c.a, c.b)
    ]
    if partners:
        out += " → " + ", ".join(f"`{p}`" for p in partners)
    return out


# ---- yarns ---------------------------------------------------------------------------------------


def yarn_counts(graph: StitchGraph, name: str) -> tuple[int, int] | None:
    """Stitches and courses the stitch graph knits with the yarn `name` (None: it has no
    such yarn). A course is knitted with one yarn (E711), so the courses are whole."""
    if graph.yarn is None or name not in graph.yarn_names:
        return None
    mine = graph.yarn == graph.yarn_names.index(name)
    return int(np.count_nonzero(mine)), int(arrays.unique(graph.course[mine]).size)


def yarn_markdown(a: Analysis, name: str) -> str | None:
    """A yarn's declaration with its resolved carrier and carry-up, and how much of the
    stitch graph it knits; `main` also when it is not declared (it always exists)."""
    skel = a.skeleton
    yarn = skel.yarns.get(name) if skel is not None else None
    decl = a.index.declared("yarn", name)
    if yarn is None:
        if decl is not None and isinstance(decl.decl, ast.YarnDecl):
            body = "\n".join(f"  {p.name.name}: {_expr_text(p.value)}" for p in decl.decl.props)
            where = f"line {decl.decl.span.line}"
            return f"```knit\nyarn {name} {{\n{body}\n}}\n```\n\n*Declared on {where}*"
        if name != sk.MAIN_YARN:
            return None
        return f"**yarn** `{name}`\n\n{_MAIN_TEXT}"
    carrier = "" if yarn.carrier is None else f"  carrier: {yarn.carrier}\n"
    lines = [f"```knit\nyarn {name} {{\n{carrier}  carry_up: {yarn.carry_up}\n}}\n```"]
    if yarn.carrier is None:
        lines += ["", "Carrier: chosen by knitc"]
    counts = yarn_counts(a.graph, name) if a.graph is not None else None
    if counts is not None:
        lines += ["", f"**{counts_text(*counts)}** knitted with it in the stitch graph"]
    if name == sk.MAIN_YARN:
        lines += ["", _MAIN_TEXT]
    if yarn.span is not None:
        lines += ["", f"*Declared on line {yarn.span.line}*"]
    return "\n".join(lines)


_MAIN_TEXT = (
    "The design's own yarn: every stitch no `knit` statement gives another one; without a "
    "declaration it takes the machine's first carrier."
)


# ---- definitions ----------------------------------------------------------------------------------


def definition_markdown(a: Analysis, name: str, kind: str) -> str | None:
    """A pattern, action or shaper: its signature, the comment above its definition, and
    the module or file it is defined in."""
    defn = _definition(a, name, kind)
    if defn is None:
        return None
    sig = _signature(defn)
    doc = _doc_comment(a, defn.span)
    lines = [f"```knit\n{sig}\n```"]
    if doc:
        lines += ["", doc]
    lines += ["", f"*Defined in {_where(a, defn.span)}*"]
    return "\n".join(lines)


_Def = ast.PatternDef | ast.ActionDef | ast.ShaperDef


def _definition(a: Analysis, name: str, kind: str) -> _Def | None:
    kinds = ("pattern", "action", "shaper") if kind == "import" else (kind,)
    for k in kinds:
        local = a.index.declared(k, name)
        if local is not None and isinstance(local.decl, _Def):
            return local.decl
    skel = a.skeleton
    if skel is None:
        return None
    tables: dict[str, Mapping[str, _Def]] = {
        "pattern": skel.patterns,
        "action": skel.actions,
        "shaper": skel.shapers,
    }
    return next((tables[k][name] for k in kinds if name in tables[k]), None)


def _signature(defn: _Def) -> str:
    word = (
        "action"
        if isinstance(defn, ast.ActionDef)
        else "pattern"
        if isinstance(defn, ast.PatternDef)
        else "shaper"
    )
    return f"{word} {signature(defn)}"


def _file_text(a: Analysis, path: str) -> SourceFile | None:
    if path == a.path:
        return a.source if not a.stale else None
    return source_of(path, a.diagnostics.sources)


def _doc_comment(a: Analysis, span: Span) -> str:
    """The `//` lines right above the definition at `span` (its documentation)."""
    source = _file_text(a, span.file)
    if source is None or not 1 <= span.line <= source.line_count:
        return ""
    return doc_comment(source, span.line)


def _where(a: Analysis, span: Span) -> str:
    if span.file.startswith(STDLIB):
        module = span.file[len(STDLIB) :].removesuffix(".knit").replace("/", ".")
        return f"`{module}` (line {span.line})"
    if span.file == a.path:
        return f"this file (line {span.line})"
    base = os.path.dirname(a.path) if not a.path.startswith("<") else ""
    shown = os.path.relpath(span.file, base) if base else span.file
    return f"`{shown}` (line {span.line})"


# ---- inlay hints ---------------------------------------------------------------------------------


@record(frozen=True)
class Hint:
    """An inlay hint at a code-point offset."""

    offset: int
    label: str


def inlay_hints(a: Analysis, start: int, end: int) -> list[Hint]:
    """`: 1,240 stitches, 40 courses` after the name of each node declared between the
    code-point offsets `start` and `end`; none when the design was not shaped."""
    if a.stale or not a.shaped or a.graph is None or a.module is None:
        return []
    counts = node_counts(a.graph)
    hints = []
    for item in a.module.items:
        if not isinstance(item, ast.NodeDecl) or not start <= item.name.span.end <= end:
            continue
        got = counts.get(item.name.name)
        if got is not None:
            hints.append(Hint(item.name.span.end, ": " + counts_text(*got)))
    return hints


# ---- the server's handlers ------------------------------------------------------------------------


def register(server: KnitServer) -> None:
    """Add hover and inlay hints to `server`."""

    @server.feature(types.TEXT_DOCUMENT_HOVER)
    async def hover(ls: KnitServer, params: types.HoverParams) -> types.Hover | None:
        a = await ls.analysis_for(params.text_document.uri)
        if a is None:
            return None
        loc = a.locator(ls.encoding)
        info = await ls.run_safely(
            hover_at, a, loc.offset(params.position), ls.settings.define_map()
        )
        if info is None:
            return None
        return types.Hover(
            contents=types.MarkupContent(kind=types.MarkupKind.Markdown, value=info.markdown),
            range=loc.offsets_range(info.start, info.end),
        )

    @server.feature(types.TEXT_DOCUMENT_INLAY_HINT, types.InlayHintOptions(resolve_provider=False))
    async def inlay_hint(ls: KnitServer, params: types.InlayHintParams) -> list[types.InlayHint]:
        a = await ls.analysis_for(params.text_document.uri)
        if a is None:
            return []
        loc = a.locator(ls.encoding)
        start, end = loc.offset(params.range.start), loc.offset(params.range.end)
        hints: list[Hint] = await ls.run_safely(inlay_hints, a, start, end) or []
        return [
            types.InlayHint(
                position=loc.position(h.offset),
                label=h.label,
                kind=types.InlayHintKind.Type,
                padding_right=True,
            )
            for h in hints
        ]
