"""Pictures of what knitc knits (`knitc view`): the time-needle bed (`bed`), the stitch
charts (`chart`), the garment's shape (`shape`, a force layout of the stitch graph) and an
interactive HTML viewer holding all three (`html`). Every view links a stitch or an
operation to the line of the design that made it, and marks the hazards knitc's
simulation found where they happen.

`render_file` is what the CLI calls. `source.load` gives every view the same input: a
`.knit` design compiled through the machine stage (stitch graph, schedule, program), or a
`.k` file read as Knitout (its program only); and the findings of knitc's simulation of
the program, located at its operations.
"""

from __future__ import annotations

from knitc.diagnostics import Diagnostics

VIEWS = ("bed", "chart", "shape", "html")
FORMATS = {
    "bed": (".svg", ".png"),
    "chart": (".svg", ".png"),
    "shape": (".svg", ".png"),
    "html": (".html",),
}


def render_file(
    path: str,
    view: str,
    ext: str,
    *,
    defines: list[str] | tuple[str, ...] = (),
    compact: bool = False,
    three_d: bool = False,
    include: list[str] | tuple[str, ...] = (),
) -> tuple[Diagnostics, bytes | None]:
    """The bytes of `view` of the design or Knitout at `path`, in the format of `ext`
    (".svg", ".png", ".html"); None with the reasons in the diagnostics."""
    if view not in VIEWS:
        raise ValueError(view)
    if ext not in FORMATS[view]:
        diags = Diagnostics()
        diags.error(
            "E930",
            f"--{view} writes {' or '.join(FORMATS[view])} files, not `{ext}`"
            if ext
            else f"--{view} writes {' or '.join(FORMATS[view])} files; the output has no extension",
            None,
            hint=f"name the output like `out{FORMATS[view][0]}`",
        )
        return diags, None
    from knitc.view.source import load

    got = load(path, defines, include)
    if got.input is None:
        return got.diagnostics, None
    fmt = ext.lstrip(".")
    if view == "bed":
        from knitc.view import bed

        data = bed.render(got.input, fmt, compact=compact)
    elif view == "chart":
        from knitc.view import chart

        data = chart.render(got.input, fmt)
    elif view == "shape":
        from knitc.view import shape

        data = shape.render(got.input, fmt, three_d=three_d)
    else:
        from knitc.view import html

        data = html.render(got.input)
    return got.diagnostics, data
