"""The interactive viewer (`knitc view FILE --html`): one self-contained HTML page.

The page holds the bed, chart and shape views of a design (the bed view alone for a Knitout
file) and draws them with a small script onto a <canvas>: canvas, not SVG, because a
sweater is tens of thousands of stitches and operations and the browser must pan, zoom and
hit-test them at every mouse move. Everything the page needs is inside it (the data as
JSON, `viewer.js` and `viewer.css` inlined from the package, a Content-Security-Policy that
forbids fetching anything), so the file can be mailed, archived or opened from a USB stick
next to the machine, with no server and no network.

The data is columnar (one array per field, not one object per stitch or op): it is what
keeps a 100k-stitch page at a few megabytes and lets the script index it without building
objects. Geometry is computed here, not in the script, so the page draws exactly what knitc
computed and the tests can check it without a browser:

- bed: one row per carriage pass (`pass_rows`, the passes `machine.estimate_passes`
  counts), front bed in the lower half of the row and back bed in the upper half, needles
  across;
- chart: per node, its courses up and its wales across, a tube's front and back faces side
  by side (the back as seen from behind, so a round reads left to right along the yarn);
- shape: the 2-D layout of the stitch graph (`knitc.view.shape.layout`), scaled so that
  neighbouring stitches are about one unit apart.

Every stitch and op keeps its source span, and the page embeds the text of every source
line it refers to, so hovering shows `file:line:col` and the line itself. The warnings panel
lists the compilation's diagnostics and the simulation's findings with the stitches or ops
each is about. The output is deterministic: the same input gives the same bytes.
"""

from __future__ import annotations

import json
from collections.abc import Iterable, Sequence
from importlib.resources import files
from typing import Any

import numpy as np

from knitc.codegen.machine import (
    BEDS,
    CODE_PASSES,
    KINDS,
    MachineProgram,
    Op,
    pass_index,
)
from knitc.codegen.simulate import Finding
from knitc.diagnostics import Diagnostic, Diagnostics
from knitc.scheduling.schedule import Schedule
from knitc.shaping.stitch_graph import INSTRUCTIONS, StitchGraph
from knitc.source import SourceFile, Span
from knitc.view.source import ViewInput

FORMAT_VERSION = 1
"""The version of the embedded data (`data.version`), for tools that read it back."""

CHART_GAP = 4
"""Empty columns between the chart panels of two nodes, and between a tube's two faces
(`TUBE_GAP`), so that pieces and faces read apart."""
TUBE_GAP = 2


# ---- carriage passes --------------------------------------------------------------------------


def pass_rows(ops: Sequence[Op]) -> list[int]:
    """The carriage pass of every op, -1 for ops that do not move the carriage over a
    needle (`machine.pass_index`: the bed view has exactly as many rows as knitc reports
    passes)."""
    return pass_index(ops)


# ---- the data ---------------------------------------------------------------------------------


class _Spans:
    """Deduplicated spans and the source lines they point at.

    A span is stored as [file, line, column, parent] (indices into `files` and into the
    table itself), so a stitch written inside an applied stdlib pattern shows the
    designer's `apply` line and the definition's line; `lines` holds the text of each
    line used, keyed "file:line", read from the compilation's sources (or the file)."""

    def __init__(self, sources: dict[str, SourceFile]) -> None:
        self.sources = sources
        self.files: list[str] = []
        self.rows: list[list[int]] = []
        self.lines: dict[str, str] = {}
        self._file_ids: dict[str, int] = {}
        self._ids: dict[tuple[str, int, int, int], int] = {}

    def add(self, span: Span | None) -> int:
        if span is None:
            return -1
        parent = self.add(span.parent)
        key = (span.file, span.line, span.column, parent)
        got = self._ids.get(key)
        if got is not None:
            return got
        f = self._file_ids.get(span.file)
        if f is None:
            f = self._file_ids[span.file] = len(self.files)
            self.files.append(span.file)
        self._ids[key] = len(self.rows)
        self.rows.append([f, span.line, span.column, parent])
        self.lines.setdefault(f"{f}:{span.line}", self._line(span.file, span.line))
        return self._ids[key]

    def _line(self, path: str, line: int) -> str:
        src = self.sources.get(path)
        if src is None:
            try:
                with open(path, encoding="utf-8") as fh:
                    src = self.sources[path] = SourceFile(path, fh.read())
            except (OSError, UnicodeDecodeError):
                src = self.sources[path] = SourceFile(path, "")
        return src.line_text(line)


def _ops(prog: MachineProgram, spans: _Spans) -> dict[str, Any]:
    """The ops as columns: kind, direction, needle (bed index, number), second needle,
    carriers (index into `carriers`), racking, stitch, span, pass row, code pass."""
    kind_ids = {k: i for i, k in enumerate(KINDS)}
    bed_ids = {b: i for i, b in enumerate(BEDS)}
    phase_ids = {p: i for i, p in enumerate(CODE_PASSES)}
    carrier_sets: dict[tuple[int, ...], int] = {}
    cols: dict[str, list[Any]] = {
        k: [] for k in ("kind", "dir", "bed", "needle", "bed2", "needle2", "carriers")
    }
    cols.update({k: [] for k in ("racking", "stitch", "span", "pass", "phase")})
    racking: float | int = 0
    rows = pass_rows(prog.ops)
    for op, row in zip(prog.ops, rows):
        if op.kind == "rack":
            racking = op.value  # type: ignore[assignment]
        cols["kind"].append(kind_ids[op.kind])
        cols["dir"].append(op.dir)
        for bed, num, n in (("bed", "needle", op.needle), ("bed2", "needle2", op.needle2)):
            cols[bed].append(-1 if n is None else bed_ids[n.bed])
            cols[num].append(0 if n is None else n.index)
        if op.carriers:
            cols["carriers"].append(carrier_sets.setdefault(op.carriers, len(carrier_sets)))
        else:
            cols["carriers"].append(-1)
        cols["racking"].append(racking)
        cols["stitch"].append(op.stitch)
        cols["span"].append(spans.add(op.span))
        cols["pass"].append(row)
        cols["phase"].append(phase_ids.get(op.phase, 0))
    out: dict[str, Any] = {"count": len(prog.ops), "passes": max(rows, default=-1) + 1}
    out.update(cols)
    out["carrier_sets"] = [" ".join(map(str, cs)) for cs in carrier_sets]
    return out


def _primary_ops(prog: MachineProgram, n: int) -> np.ndarray:
    """For each stitch, the op that stands for it on the bed: the loop its action pass
    formed (what the fabric check reads too), else its first loop, else its first op."""
    best = np.full(n, -1, np.int64)
    rank = np.full(n, 9, np.int8)
    for i, op in enumerate(prog.ops):
        s = op.stitch
        if s < 0 or s >= n:
            continue
        r = 0 if op.forms_loop and op.phase == "action" else 1 if op.forms_loop else 2
        if r < rank[s]:
            rank[s], best[s] = r, i
    return best


def chart_layout(g: StitchGraph) -> tuple[np.ndarray, np.ndarray, list[list[Any]]]:
    """Chart coordinates of every stitch, and each node's panel [name, x, y, width, height,
    face width] (the face width is 0 for a node without tube faces).

    A node's panel has its courses up (the node's first course at the bottom) and its wales
    across, each course centred in the panel so that shaping shows as the outline; a
    circular course puts its front face on the left and its back face on the right, the back
    mirrored (seen from behind) so that the yarn runs left to right across both. Panels
    are packed in rows, in node order, about as wide as they are tall altogether."""
    from knitc.patterning.query import coords

    n = g.n_stitches
    x = np.zeros(n, np.float64)
    y = np.zeros(n, np.float64)
    if n == 0:
        return x, y, []
    c = coords(g)
    circ = g.course_circular[g.course]
    back = g.side.astype(bool)
    # Per course: how many stitches on each face (circular) or in all (flat).
    per_course_back = np.bincount(g.course, weights=back, minlength=g.n_courses)
    per_course_front = g.course_len - per_course_back
    n_nodes = len(g.node_names)
    face_w = np.zeros(n_nodes)  # widest face (circular) of the node
    flat_w = np.zeros(n_nodes)  # widest flat course of the node
    for cid in range(g.n_courses):
        k = int(g.course_node[cid])
        if g.course_circular[cid]:
            face_w[k] = max(face_w[k], per_course_front[cid], per_course_back[cid])
        else:
            flat_w[k] = max(flat_w[k], g.course_len[cid])
    panel_w = np.maximum(flat_w, np.where(face_w > 0, 2 * face_w + TUBE_GAP, 0))
    # Where a node has tube faces, the width of one face (0 for a flat node), for labels.
    half_w = [float(face_w[i]) if face_w[i] > 0 and flat_w[i] == 0 else 0.0 for i in range(n_nodes)]
    heights = np.zeros(n_nodes)
    np.maximum.at(heights, g.node, c.course + 1)
    # Shelf packing: rows of panels in node order, a row about as wide as the whole is tall.
    used = [i for i in range(n_nodes) if heights[i] > 0]
    area = float(sum(panel_w[i] * heights[i] for i in used))
    target = max(float(max((panel_w[i] for i in used), default=1)), (area * 2.0) ** 0.5)
    origin_x = np.zeros(n_nodes)
    origin_y = np.zeros(n_nodes)
    panels: list[list[Any]] = []
    row_x, row_y, row_h = 0.0, 0.0, 0.0
    for i in used:
        if row_x > 0 and row_x + panel_w[i] > target:
            row_y += row_h + CHART_GAP + 2
            row_x, row_h = 0.0, 0.0
        origin_x[i], origin_y[i] = row_x, row_y
        panels.append(
            [g.node_names[i], row_x, row_y, float(panel_w[i]), float(heights[i]), half_w[i]]
        )
        row_x += panel_w[i] + CHART_GAP
        row_h = max(row_h, heights[i])
    node = g.node
    pw = panel_w[node]
    # Flat courses: wale across, centred.
    flat_x = (pw - g.course_len[g.course]) / 2 + c.wale
    # Circular courses: each face centred in its half; the back mirrored.
    half = face_w[node]
    fw = per_course_front[g.course]
    bw = per_course_back[g.course]
    front_x = (half - fw) / 2 + c.swale
    back_x = half + TUBE_GAP + (half - bw) / 2 + (bw - 1 - c.swale)
    x = np.where(circ, np.where(back, back_x, front_x), flat_x) + origin_x[node]
    y = c.course.astype(np.float64) + origin_y[node]
    return x, y, panels


def shape_layout(g: StitchGraph, schedule: Schedule | None = None) -> tuple[np.ndarray, str]:
    """2-D points of the garment's shape, in stitch widths, and where they came from
    ("layout", or "courses" for the fallback).

    The layout is `knitc.view.shape.layout` (a force layout of the stitch graph, started
    from the schedule's needles); when it is not available (it is optional to this page,
    and a failure there must not cost the user the bed and chart views), the stitches stand
    at (wale, course) of the whole graph, which still shows each piece's outline."""
    n = g.n_stitches
    pts: np.ndarray | None = None
    how = "layout"
    try:
        from knitc.view.shape import layout

        got = np.asarray(layout(g, schedule=schedule), dtype=np.float64)
        if got.ndim == 2 and got.shape[0] == n and got.shape[1] >= 2:
            pts = got[:, :2]
    except ImportError:
        pts = None
    if pts is None or not np.all(np.isfinite(pts)):
        from knitc.patterning.query import coords

        how = "courses"
        wale = coords(g).wale if n else np.zeros(0)
        pts = np.column_stack([wale, g.course]).astype(np.float64)
    if n:
        pts = pts - pts.min(axis=0)
    return pts, how


def _round(a: np.ndarray, digits: int = 2) -> list[float | int]:
    """Coordinates as short JSON numbers: integers without a decimal point."""
    r = np.round(a.astype(np.float64), digits)
    return [int(v) if v.is_integer() else v for v in r.tolist()]


def build_data(inp: ViewInput) -> dict[str, Any]:
    """Everything the page shows, as plain JSON data (see the module docstring)."""
    diags = inp.diagnostics
    spans = _Spans(dict(diags.sources))
    data: dict[str, Any] = {
        "version": FORMAT_VERSION,
        "file": inp.path,
        "design": inp.graph is not None,
        "kinds": list(KINDS),
        "beds": list(BEDS),
        "phases": list(CODE_PASSES),
        "instructions": list(INSTRUCTIONS),
        "machine": inp.program.machine.to_json(),
    }
    data["ops"] = _ops(inp.program, spans)
    g = inp.graph
    primary = np.zeros(0, np.int64)
    if g is not None:
        data["stitches"], primary = _stitch_data(inp, g, spans)
    data["warnings"] = _warnings(inp, diags, spans, primary)
    data["spans"] = spans.rows
    data["files"] = spans.files
    data["lines"] = spans.lines
    return data


def _stitch_data(
    inp: ViewInput, g: StitchGraph, spans: _Spans
) -> tuple[dict[str, Any], np.ndarray]:
    from knitc.patterning.query import coords

    c = coords(g)
    span_ids = np.array([spans.add(s) for s in g.spans] + [-1], np.int64)
    origin = g.origin if g.origin is not None else np.full(g.n_stitches, -1, np.int32)
    cx, cy, panels = chart_layout(g)
    pts, shape_from = shape_layout(g, inp.schedule)
    primary = _primary_ops(inp.program, g.n_stitches)
    action_names: list[str] = []
    if inp.result is not None and inp.result.skeleton is not None:
        from knitc.patterning import actions

        action_names = actions.names(inp.result.skeleton)
    out = {
        "count": g.n_stitches,
        "nodes": list(g.node_names),
        "node": g.node.tolist(),
        "course": c.course.tolist(),
        "wale": c.wale.tolist(),
        "side": g.side.tolist(),
        "circular": g.course_circular[g.course].astype(np.int8).tolist(),
        "instr": g.instr.tolist(),
        "action": g.action.tolist(),
        "action_names": action_names,
        "span": span_ids[g.span].tolist(),
        "origin": span_ids[origin].tolist(),
        "op": primary.tolist(),
        "chart_x": _round(cx),
        "chart_y": _round(cy),
        "panels": panels,
        "shape_x": _round(pts[:, 0]),
        "shape_y": _round(pts[:, 1]),
        "shape_from": shape_from,
    }
    return out, primary


def _designer_line(span: Span) -> tuple[str, int]:
    top = span.chain()[0]
    return top.file, top.line


def _warnings(
    inp: ViewInput, diags: Diagnostics, spans: _Spans, primary: np.ndarray
) -> list[dict[str, Any]]:
    """The warnings panel: the simulation's findings (at their op and stitch) and every
    other diagnostic of the compilation, with the stitches (a design) or ops (Knitout)
    made by the line it points at."""
    out: list[dict[str, Any]] = []
    seen: set[tuple[str, str]] = set()
    ops = inp.program.ops
    for f in inp.findings:
        seen.add((f.code, f.message))
        out.append(_finding(f, ops, spans))
    g = inp.graph
    line_of_span: list[tuple[str, int]] = []
    if g is not None:
        line_of_span = [_designer_line(s) for s in g.spans]
    op_lines: dict[tuple[str, int], list[int]] | None = None
    for d in diags.sorted():
        if (d.code, d.message) in seen:
            continue
        entry = _diagnostic(d, spans)
        if d.span is not None:
            where = (d.span.file, d.span.line)
            if g is not None:
                hit = [i for i, ln in enumerate(line_of_span) if ln == where]
                if hit:
                    sel = np.isin(g.span, hit)
                    if g.origin is not None:
                        sel |= np.isin(g.origin, hit)
                    entry["stitches"] = np.nonzero(sel)[0].tolist()
            else:
                if op_lines is None:
                    op_lines = _ops_by_line(ops)
                entry["ops"] = op_lines.get(where, [])
        out.append(entry)
    return out


def _ops_by_line(ops: Iterable[Op]) -> dict[tuple[str, int], list[int]]:
    by: dict[tuple[str, int], list[int]] = {}
    for i, op in enumerate(ops):
        if op.span is not None:
            by.setdefault(_designer_line(op.span), []).append(i)
    return by


def _finding(f: Finding, ops: Sequence[Op], spans: _Spans) -> dict[str, Any]:
    entry: dict[str, Any] = {
        "code": f.code,
        "severity": f.severity,
        "message": f.message,
        "span": spans.add(f.span),
        "source": "simulation",
        "ops": [f.op] if f.op >= 0 else [],
        "stitches": [f.stitch] if f.stitch >= 0 else [],
    }
    if 0 <= f.op < len(ops):
        entry["op_text"] = str(ops[f.op])
    return entry


def _diagnostic(d: Diagnostic, spans: _Spans) -> dict[str, Any]:
    return {
        "code": d.code,
        "severity": d.severity.value,
        "message": d.message,
        "span": spans.add(d.span),
        "source": "compilation",
        "ops": [],
        "stitches": [],
        "notes": [[n.message, spans.add(n.span)] for n in d.notes],
        "hint": d.hint or "",
    }


# ---- the page ---------------------------------------------------------------------------------


def _asset(name: str) -> str:
    return files("knitc.view").joinpath(name).read_text(encoding="utf-8")


def _json_for_script(data: Any) -> str:
    """JSON that is safe inside a <script> element and holds no URL: `<`, `>` and `&` as
    \\u escapes (no `</script>` or comment can end the element early) and `/` as `\\/`
    (so a source line that quotes an address does not put a URL into the page)."""
    text = json.dumps(data, ensure_ascii=False, separators=(",", ":"), allow_nan=False)
    return (
        text.replace("<", "\\u003c")
        .replace(">", "\\u003e")
        .replace("&", "\\u0026")
        .replace("/", "\\/")
        .replace("\u2028", "\\u2028")
        .replace("\u2029", "\\u2029")
    )


def _escape(text: str) -> str:
    return (
        text.replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;").replace('"', "&quot;")
    )


CSP = "default-src 'none'; script-src 'unsafe-inline'; style-src 'unsafe-inline'; img-src data:"
"""Nothing may be fetched: the page is self-contained by construction, not by care."""


def page(data: dict[str, Any]) -> str:
    """The HTML text of the viewer for `data` (`build_data`)."""
    title = f"knitc view: {data['file']}"
    return (
        "<!DOCTYPE html>\n"
        '<html lang="en">\n<head>\n<meta charset="utf-8">\n'
        f'<meta http-equiv="Content-Security-Policy" content="{CSP}">\n'
        '<meta name="viewport" content="width=device-width, initial-scale=1">\n'
        '<link rel="icon" href="data:,">\n'
        f"<title>{_escape(title)}</title>\n"
        f"<style>\n{_asset('viewer.css')}</style>\n"
        "</head>\n<body>\n"
        '<header id="bar">\n'
        f'  <span id="title">{_escape(data["file"])}</span>\n'
        '  <nav id="tabs">'
        '<button type="button" data-view="bed">Bed</button>'
        '<button type="button" data-view="chart">Chart</button>'
        '<button type="button" data-view="shape">Shape</button>'
        "</nav>\n"
        '  <button type="button" id="fit" title="fit the view to the window">Fit</button>\n'
        '  <span id="legend"></span>\n'
        "</header>\n"
        '<main id="main">\n'
        '  <div id="stage"><canvas id="canvas"></canvas><canvas id="overlay"></canvas>'
        '<div id="notice" hidden></div></div>\n'
        '  <aside id="side"><h2>Warnings <span id="warning-count"></span></h2>'
        '<ol id="warnings"></ol></aside>\n'
        "</main>\n"
        '<div id="tooltip" hidden></div>\n'
        '<script type="application/json" id="knitc-data">'
        f"{_json_for_script(data)}"
        "</script>\n"
        f"<script>\n{_asset('viewer.js')}</script>\n"
        "</body>\n</html>\n"
    )


def render(inp: ViewInput) -> bytes:
    """The viewer page of `inp`, as UTF-8 bytes (what `knitc view --html` writes)."""
    return page(build_data(inp)).encode("utf-8")
