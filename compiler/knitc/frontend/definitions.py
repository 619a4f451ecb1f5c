"""Imports and definitions: loading `import` modules (the standard library and files
next to the design) and collecting their patterns, actions and shapers, with the
dependencies a selective import brings along."""

from __future__ import annotations

import difflib
import os
from dataclasses import field
from functools import lru_cache
from pathlib import Path
from typing import Any, cast

from knitc.access import (
    MAX_IMPORT_BYTES,
    AccessProblem,
    ReadRoots,
    active_roots,
    check_within,
    read_regular,
)
from knitc.diagnostics import Diagnostics, Note
from knitc.frontend import ast
from knitc.frontend.parser import parse_source
from knitc.lang.evaluate import (
    EvalError,
)
from knitc.records import record
from knitc.resources import stdlib_module
from knitc.source import SourceFile, Span


def _suggest(name: str, options) -> str | None:
    close = difflib.get_close_matches(name, list(options), n=1, cutoff=0.6)
    return f"did you mean `{close[0]}`?" if close else None


@record
class _Defs:
    patterns: dict[str, ast.PatternDef] = field(default_factory=dict)
    actions: dict[str, ast.ActionDef] = field(default_factory=dict)
    shapers: dict[str, ast.ShaperDef] = field(default_factory=dict)
    origin: dict[str, Span] = field(default_factory=dict)

    def kind_of(self, name: str) -> str | None:
        for kind in ("patterns", "actions", "shapers"):
            if name in getattr(self, kind):
                return kind[:-1]
        return None

    def known(self, name: str) -> bool:
        """Defined, or possibly defined by an import that failed (already reported)."""
        return self.kind_of(name) is not None or self.all_lenient or name in self.lenient

    def add(
        self,
        d: ast.PatternDef | ast.ActionDef | ast.ShaperDef,
        diags: Diagnostics,
        *,
        imported: bool,
        at: Span | None = None,
    ) -> None:
        name = d.name.name
        table = cast(
            dict[str, Any],
            {
                ast.PatternDef: self.patterns,
                ast.ActionDef: self.actions,
                ast.ShaperDef: self.shapers,
            }[type(d)],
        )
        if table.get(name) is d:
            return  # the same definition reached through two imports
        if name in self.origin:
            if imported:
                diags.error(
                    "E204",
                    f"two imported definitions are named `{name}`",
                    at or d.name.span,
                    notes=[Note("first defined here", self.origin[name])],
                )
                return
            if self.kind_of(name) is not None and not self._imported(name):
                diags.error(
                    "E205",
                    f"`{name}` is defined twice",
                    d.name.span,
                    notes=[Note("first defined here", self.origin[name])],
                )
                return
            for t in (self.patterns, self.actions, self.shapers):
                t.pop(name, None)
        table[name] = d
        self.origin[name] = d.name.span
        if imported:
            self._imports.add(name)

    def _imported(self, name: str) -> bool:
        return name in self._imports

    def __post_init__(self) -> None:
        self._imports: set[str] = set()
        self.lenient: set[str] = set()
        self.all_lenient = False

    def failed_import(self, imp: ast.Import) -> None:
        if imp.names is None:
            self.all_lenient = True
        else:
            self.lenient.update(n.name for n in imp.names)


class _Silent(EvalError):
    """An evaluation that failed because of an error already reported (no new message)."""

    def __init__(self, span: Span):
        super().__init__("E000", "", span)


_FAILED: Any = object()  # stored in `param_values` for a parameter that failed


class _Loader:
    """Finds, parses and caches modules; imports bring in definitions only."""

    def __init__(self, diags: Diagnostics):
        self.diags = diags
        self.cache: dict[str, ast.Module | None] = {}
        self.loading: list[str] = []
        self.roots: ReadRoots | None = None
        """The folders imports may read: the running compilation's, else (a resolver run
        outside the driver) the folder of the design, whose imports come first."""

    def _read_file(self, imp: ast.Import, importer: str) -> tuple[str, str, str] | None:
        """(cache key, name for messages, text) of the file `imp` names, or None after
        reporting why it may not or cannot be read. Only a `.knit` file below the allowed
        folders is read, so no error ever quotes a file that is not a design (a design
        must not be able to print `/etc/passwd` or an environment into a build log)."""
        assert imp.path is not None  # an import names a module or a file
        if self.roots is None:
            self.roots = active_roots() or ReadRoots.for_design(importer)
        base = Path(importer).parent if not importer.startswith("<") else Path.cwd()
        joined = base / imp.path
        try:
            real = check_within(str(joined), imp.path, self.roots, "imports")
        except AccessProblem as problem:
            self.diags.error("E226", problem.message, imp.span, hint=problem.hint)
            return None
        if not os.path.exists(real):
            self.diags.error(
                "E203",
                f"cannot find `{imp.path}`",
                imp.span,
                hint=f"looked for {os.path.normpath(joined)}; "
                "imports are relative to the importing file",
            )
            return None
        if not real.endswith(".knit"):
            self.diags.error(
                "E226",
                f"`{imp.path}` is not a design: an import reads a `.knit` file",
                imp.span,
                hint="import knitc modules (`.knit` files of definitions) or the standard "
                "library (`import std.NAME`)",
            )
            return None
        try:
            data = read_regular(real, imp.path, MAX_IMPORT_BYTES)
        except AccessProblem as problem:
            self.diags.error("E203", problem.message, imp.span)
            return None
        try:
            text = data.decode("utf-8-sig")  # a BOM some editors write is not text
        except UnicodeDecodeError:
            self.diags.error("E203", f"cannot read `{imp.path}`: it is not UTF-8 text", imp.span)
            return None
        display = str(joined) if not importer.startswith("<") else imp.path
        return real, display, text

    def load_file(self, key: str, text: str, display: str) -> ast.Module | None:
        if key not in self.cache:
            if key.startswith("std:"):
                source, module = _stdlib_parsed(display, text)
                self.diags.add_source(source)
                self.cache[key] = module
            else:
                self.cache[key] = parse_source(SourceFile(display, text), self.diags)
        return self.cache[key]

    def import_into(self, imp: ast.Import, importer: str, defs: _Defs) -> None:
        if imp.module is not None:
            dotted = ".".join(imp.module)
            res = stdlib_module(dotted)
            if not res.is_file():
                self.diags.error(
                    "E202",
                    f"no standard-library module `{dotted}`",
                    imp.span,
                    hint=self._stdlib_hint(dotted),
                )
                defs.failed_import(imp)
                return
            key, display, text = (
                f"std:{dotted}",
                f"<stdlib>/{'/'.join(imp.module)}.knit",
                (res.read_text(encoding="utf-8")),
            )
        else:
            found = self._read_file(imp, importer)
            if found is None:
                defs.failed_import(imp)
                return
            key, display, text = found
        if key in self.loading:
            self.diags.error(
                "E206",
                "import cycle",
                imp.span,
                hint="modules must not import each other in a loop",
            )
            defs.failed_import(imp)
            return
        module = self.load_file(key, text, display)
        if module is None:
            defs.failed_import(imp)
            return
        self.loading.append(key)
        try:
            sub = _Defs()
            for item in module.items:
                if isinstance(item, ast.Import):
                    self.import_into(item, display, sub)
                elif isinstance(item, ast.PatternDef | ast.ActionDef | ast.ShaperDef):
                    sub.add(item, self.diags, imported=False)
                else:
                    self.diags.error(
                        "E207",
                        "an imported module may only hold definitions",
                        item.span,
                        notes=[Note("imported here", imp.span)],
                        hint="move garment parts (nodes, params, connections, layers) into "
                        "the main file; import `pattern`, `action` and `shaper` "
                        "definitions",
                    )
                    break
        finally:
            self.loading.pop()
        wanted = None
        if imp.names is not None:
            wanted = {}
            for n in imp.names:
                if sub.kind_of(n.name) is None:
                    where = ".".join(imp.module) if imp.module else imp.path
                    self.diags.error(
                        "E208",
                        f"`{n.name}` is not defined in `{where}`",
                        n.span,
                        hint=_suggest(n.name, sub.origin)
                        or (
                            "it defines " + ", ".join(f"`{x}`" for x in sub.origin)
                            if sub.origin
                            else "it defines nothing"
                        ),
                    )
                    defs.lenient.add(n.name)
                else:
                    wanted[n.name] = n
        needed = None if wanted is None else _with_dependencies(set(wanted), sub)
        for table in (sub.patterns, sub.actions, sub.shapers):
            for name, d in table.items():
                if needed is None or name in needed:
                    defs.add(d, self.diags, imported=True, at=imp.span)

    @staticmethod
    def _stdlib_hint(dotted: str) -> str:
        from knitc.resources import stdlib_root

        std = stdlib_root().joinpath("std")
        names = sorted(f"std.{p.name[:-5]}" for p in std.iterdir() if p.name.endswith(".knit"))
        return _suggest(dotted, names) or "available: " + ", ".join(names)


def _with_dependencies(names: set[str], sub: _Defs) -> set[str]:
    """`names` and, transitively, the module's definitions they `apply` or `use`: importing
    a pattern brings what it is built from (definitions share one namespace, so a
    selective import would otherwise leave its body pointing at names nobody imported)."""
    todo, out = list(names), set(names)
    while todo:
        d = sub.patterns.get(todo.pop())
        if d is None:
            continue
        for ref in _references(d.body):
            if ref not in out and sub.kind_of(ref) is not None:
                out.add(ref)
                todo.append(ref)
    return out


def _references(stmts) -> list[str]:
    """Definition names applied or used by pattern statements (not in expressions)."""
    return [
        st.pattern.name if isinstance(st, ast.ApplyStmt) else st.action.name
        for st in stmts
        if isinstance(st, ast.ApplyStmt | ast.UseStmt)
    ]


@lru_cache(maxsize=32)
def _stdlib_parsed(display: str, text: str) -> tuple[SourceFile, ast.Module]:
    """A standard-library module's syntax tree, parsed once per process: every compile
    imports the same few modules, and the language server compiles on every edit. (Its
    text is part of the key, so an edited stdlib in an editable install is read anew.) The
    stdlib parses without errors (tests/test_stdlib_patterns.py); if it ever did not, this
    raises rather than hide them."""
    diags = Diagnostics()
    source = SourceFile(display, text)
    module = parse_source(source, diags)
    if module is None:
        raise ValueError(f"the standard library does not parse:\n{diags.render()}")
    return source, module
