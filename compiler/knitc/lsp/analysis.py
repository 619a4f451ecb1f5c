"""What the server knows about one open document: the front end's IRs and diagnostics.

While the designer types, the server runs the pipeline's front end, parse → resolve →
stitch graph (shaping, patterns, instruction checks), on every edit: a glove-sized design
takes about 20 ms there once the parser and the standard library are warm. The back end
(tracing to simulation, seconds on a sweater) runs in `backend`, in another process.

An `Analysis` is immutable: features read the one for the text they were asked about and
never see it change under them. When the text does not parse, the last module that did is
kept (`module`, marked `stale`) so that outline, folding and go-to-definition keep working
on the rest of the file while one statement is half written.
"""

from __future__ import annotations

import time
from dataclasses import replace
from functools import cached_property

from knitc import driver
from knitc.diagnostics import Diagnostics
from knitc.frontend import ast
from knitc.frontend import skeleton as sk
from knitc.lsp import index as ix
from knitc.lsp.positions import UTF16, Locator
from knitc.lsp.settings import Settings
from knitc.records import record
from knitc.shaping import stitch_graph as sg
from knitc.source import SourceFile

FAST_STITCHES = 150_000
"""Largest design (by `skeleton.stitch_estimate`) shaped while the designer types: shaping
is linear in stitches, and past this it takes longer than an edit should wait. A larger
design gets its shaping diagnostics from the back end, which a newer edit can stop."""


WARM_UP = (
    "import std.stitches\nimport std.actions\nimport std.motifs\nimport std.shapers\n"
    "tube warm { length: 2 width: 2 }\n"
)
"""A design whose compilation builds the parser and parses the whole standard library, so
that the first edit the designer makes is as quick as the next (the server and the
back end's worker compile it when they start)."""


@record(frozen=True)
class Analysis:
    uri: str
    version: int | None
    path: str
    """The file's path (or `<uri>` for a document that is not a file): what spans name."""
    source: SourceFile
    settings: Settings
    result: driver.Result
    """The front end's result: diagnostics and the IRs as far as it got."""
    module: ast.Module | None
    """This text's syntax tree or, when it does not parse, the last one that did."""
    stale: bool = False
    """`module` is an earlier text's (this one has syntax errors)."""
    shaped: bool = True
    """Shaping ran here (False: the design is too large to shape while typing)."""
    seconds: float = 0.0

    @property
    def text(self) -> str:
        return self.source.text

    @property
    def diagnostics(self) -> Diagnostics:
        return self.result.diagnostics

    @property
    def skeleton(self) -> sk.Skeleton | None:
        return self.result.skeleton

    @property
    def graph(self) -> sg.StitchGraph | None:
        return self.result.graph

    def locator(self, encoding: str = UTF16) -> Locator:
        """Positions in this text (a stale `module`'s spans are in an earlier one)."""
        return Locator(self.source, encoding)

    @cached_property
    def index(self) -> ix.Index:
        """The names `module` declares and uses (empty when nothing ever parsed)."""
        return ix.build(self.module) if self.module is not None else ix.Index()


def analyse(
    uri: str,
    version: int | None,
    path: str,
    text: str,
    settings: Settings,
    previous: Analysis | None = None,
) -> Analysis:
    """Run the front end on `text`, reusing `previous` when nothing it depends on changed."""
    if previous is not None and previous.text == text and previous.settings == settings:
        return replace(previous, version=version)
    start = time.perf_counter()
    result = driver.compile_source(
        text,
        path,
        defines=settings.defines,
        until="skeleton",
        include=settings.include,
        max_stitches=settings.max_stitches,
    )
    shaped = True
    if result.ok and result.skeleton is not None:
        if sum(sk.stitch_estimate(result.skeleton.nodes).values()) <= FAST_STITCHES:
            driver.resume(result, "stitch-graph")
        else:
            shaped = False
    module, stale = result.module, False
    if module is None and previous is not None:
        module, stale = previous.module, True
    return Analysis(
        uri,
        version,
        path,
        SourceFile(path, text),
        settings,
        result,
        module,
        stale,
        shaped,
        time.perf_counter() - start,
    )
