"""Resolution: AST → skeleton IR.

Loads imports, evaluates design parameters (with `-D` overrides) and node properties with
knitc's own evaluator, detects reference cycles, checks every property's type and range
(the original declared min/max but never enforced them), binds interface statements and
connections, and checks the names used inside pattern layers, actions and shaper programs
so their mistakes surface now rather than when the pattern pass runs.

Errors are collected, never raised: a bad property is reported and replaced by its default,
so one mistake does not hide the next.
"""

from __future__ import annotations

import difflib
import math
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, cast

from knitc.diagnostics import Diagnostics, Note
from knitc.frontend import ast
from knitc.frontend import skeleton as sk
from knitc.frontend.parser import parse_source
from knitc.lang.evaluate import (
    BUILTINS,
    EvalError,
    Evaluator,
    Profile,
    Value,
    Word,
    show,
    type_name,
)
from knitc.patterning.raster import cell_problems
from knitc.resources import stdlib_module
from knitc.source import SourceFile, Span

# ---- scopes for pattern, action and shaper bodies ----------------------------------------------

QUERY_FUNCTIONS = {
    "all": (0, 0),
    "filter": (1, 1),
    "wales": (1, 2),
    "courses": (1, 1),
    "select": (2, 3),
    "side": (1, 1),
    "neighbors": (0, 1),
    "boundaries": (0, 0),
    "named": (0, 0),
    "shape": (1, 1),
    "itf": (1, 1),
    "stretch": (1, 2),
    "tile": (1, 2),
    "img": (1, 3),
    "noise": (1, 3),
    "wale_grid": (0, 2),
    "stitch_grid": (2, 4),
}
"""Pattern queries of thesis Table 5.1, with their (min, max) positional arity."""

STITCH_FIELDS = ("course", "wale", "course_end", "wale_end", "side", "gauge", "node", "index")
"""Names a `filter(...)` predicate can read from each stitch."""

QUERY_WORDS = ("front", "back", "end")

ACTION_CONTEXT = ("needle", "opposite", "dir", "carriers", "position", "stitch", "side")
ACTION_FUNCTIONS = {
    "knit": (1, 3),
    "tuck": (1, 3),
    "miss": (1, 3),
    "xfer": (2, 2),
    "split": (2, 4),
    "drop": (1, 1),
    "kickback": (0, 3),
    "rack": (1, 1),
    "range": (1, 3),
    "len": (1, 1),
}
ACTION_WORDS = ("left", "right", "front", "back")
SHAPER_CONTEXT = ("turn",)
"""Names a shaper program can read besides its parameters (`shaping.shapers`)."""
BUILTIN_ACTIONS = ("knit", "purl", "tuck", "miss", "kickback", "split")
SHAPER_FUNCTIONS = {"range": (1, 3), "len": (1, 1)}

INSTRUCTIONS = (
    "K",
    "P",
    "T",
    "M",
    "FR1",
    "FR2",
    "FL1",
    "FL2",
    "BR1",
    "BR2",
    "BL1",
    "BL2",
    "XR+",
    "XR-",
    "XL+",
    "XL-",
    "S",
)


def _suggest(name: str, options) -> str | None:
    close = difflib.get_close_matches(name, list(options), n=1, cutoff=0.6)
    return f"did you mean `{close[0]}`?" if close else None


@dataclass
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

    def load_file(self, key: str, text: str, display: str) -> ast.Module | None:
        if key not in self.cache:
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
            assert imp.path is not None  # an import names a module or a file
            base = Path(importer).parent if not importer.startswith("<") else Path.cwd()
            path = (base / imp.path).resolve()
            if not path.is_file():
                self.diags.error(
                    "E203",
                    f"cannot find `{imp.path}`",
                    imp.span,
                    hint=f"looked for {os.path.normpath(base / imp.path)}; "
                    "imports are relative to the importing file",
                )
                defs.failed_import(imp)
                return
            key, display = (
                str(path),
                str(base / imp.path) if not importer.startswith("<") else imp.path,
            )
            try:
                text = path.read_text(encoding="utf-8")
            except (OSError, UnicodeDecodeError) as exc:
                self.diags.error("E203", f"cannot read `{imp.path}`: {exc}", imp.span)
                defs.failed_import(imp)
                return
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


# ---- the resolver -------------------------------------------------------------------------------


class _Resolver:
    def __init__(
        self,
        module: ast.Module,
        path: str,
        diags: Diagnostics,
        defines: dict[str, ast.Node],
        loader: _Loader,
    ):
        self.module = module
        self.path = path
        self.diags = diags
        self.defines = defines
        self.loader = loader
        self.defs = _Defs()
        self.param_decls: dict[str, ast.ParamDecl] = {}
        self.param_values: dict[str, Value] = {}
        self.param_stack: list[str] = []
        self.node_decls: dict[str, ast.NodeDecl] = {}
        self.prop_values: dict[tuple[str, str], Value] = {}
        self.prop_stack: list[tuple[str, str]] = []
        self.tainted: set[str] = set()
        """Nodes with an earlier error: their sizes are not checked, to avoid cascades."""

    # -- entry
    def run(self) -> sk.Skeleton | None:
        items = self.module.items
        for item in items:
            if isinstance(item, ast.Import):
                self.loader.import_into(item, self.path, self.defs)
        for item in items:
            if isinstance(item, ast.PatternDef | ast.ActionDef | ast.ShaperDef):
                self.defs.add(item, self.diags, imported=False)
        self._collect_params()
        self._collect_nodes()
        machine = self._machine([i for i in items if isinstance(i, ast.MachineDecl)])
        values = {
            name: self._param_value(name, decl.name.span) for name, decl in self.param_decls.items()
        }
        params = {k: v for k, v in values.items() if v is not None}
        nodes: dict[str, sk.PrimNode] = {}
        for name, decl in self.node_decls.items():
            nodes[name] = self._node(decl, machine)
        interfaces = {
            sk.ItfId(n.name, p): sk.Interface(sk.ItfId(n.name, p), span=n.span)
            for n in nodes.values()
            for p in n.interface_paths
        }
        skel = sk.Skeleton(machine, params, nodes, interfaces, [])
        self._topology(skel)
        skel.tainted = set(self.tainted)
        self._layers(skel)
        d: ast.ActionDef | ast.ShaperDef | ast.PatternDef
        for d in self.defs.actions.values():
            self._check_action(d)
        for d in self.defs.shapers.values():
            self._check_shaper(d)
        for item in self.module.items:
            if isinstance(item, ast.PatternDef) and item.name.name in self.node_decls:
                self.diags.warning(
                    "W201",
                    f"`pattern {item.name.name}(...)` defines a reusable pattern; it "
                    f"does not pattern the node `{item.name.name}`",
                    item.name.span,
                    hint=f"to pattern the node, write `pattern {item.name.name} {{ ... }}` "
                    "without parentheses",
                )
        for d in self.defs.patterns.values():
            self._check_layer_body(d.body, {p.name.name for p in d.params}, d.params)
        skel.patterns = dict(self.defs.patterns)
        skel.actions = dict(self.defs.actions)
        skel.shapers = dict(self.defs.shapers)
        return skel

    # -- parameters
    def _collect_params(self) -> None:
        for item in self.module.items:
            if isinstance(item, ast.ParamDecl):
                name = item.name.name
                if name in self.param_decls:
                    self.diags.error(
                        "E401",
                        f"parameter `{name}` is declared twice",
                        item.name.span,
                        notes=[Note("first declared here", self.param_decls[name].name.span)],
                    )
                    continue
                self.param_decls[name] = item
        for name in self.defines:
            if name not in self.param_decls:
                self.diags.error(
                    "E402",
                    f"`-D {name}` names no parameter",
                    None,
                    hint=_suggest(name, self.param_decls)
                    or ("declared parameters: " + (", ".join(self.param_decls) or "none")),
                )

    def _param(self, name: str, span: Span) -> Value:
        if name in self.param_values:
            if self.param_values[name] is _FAILED:
                raise _Silent(span)
            return self.param_values[name]
        decl = self.param_decls.get(name)
        if decl is None:
            raise EvalError(
                "E403",
                f"unknown parameter `#{name}`",
                span,
                _suggest(name, self.param_decls) or f"declare it with `param {name} = ...`",
            )
        if name in self.param_stack:
            cycle = self.param_stack[self.param_stack.index(name) :] + [name]
            if len(cycle) == 2:
                raise EvalError("E404", f"parameter `#{name}` refers to itself", span)
            raise EvalError(
                "E404",
                "parameters refer to each other in a cycle: " + " -> ".join(f"#{c}" for c in cycle),
                span,
            )
        self.param_stack.append(name)
        try:
            expr = self.defines.get(name, decl.value)
            value = Evaluator(self._param, self._no_props).eval(expr)
        except EvalError as err:
            if name != self.param_stack[0]:
                raise
            self._report(err)
            self.param_values[name] = _FAILED
            raise _Silent(span) from None
        finally:
            self.param_stack.pop()
        self.param_values[name] = value
        return value

    def _param_value(self, name: str, span: Span) -> Value | None:
        try:
            return self._param(name, span)
        except _Silent:
            return None
        except EvalError as err:
            self._report(err)
            return None

    @staticmethod
    def _no_props(node: str | None, prop: str, span: Span) -> Value:
        raise EvalError(
            "E405",
            "a parameter cannot refer to a node property",
            span,
            "parameters are evaluated before the nodes; compute from other `#params` instead",
        )

    def _report(self, err: EvalError) -> None:
        if not isinstance(err, _Silent):
            self.diags.error(err.code, err.message, err.span, hint=err.hint)
        if self.prop_stack:
            self.tainted.add(self.prop_stack[0][0])

    # -- nodes and properties
    def _collect_nodes(self) -> None:
        for item in self.module.items:
            if isinstance(item, ast.NodeDecl):
                name = item.name.name
                if name in self.node_decls:
                    self.diags.error(
                        "E209",
                        f"node `{name}` is declared twice",
                        item.name.span,
                        notes=[Note("first declared here", self.node_decls[name].name.span)],
                    )
                    continue
                if name in ("before", "after"):
                    self.diags.error(
                        "E210",
                        f"`{name}` is reserved for global pattern layers",
                        item.name.span,
                        hint="choose another node name",
                    )
                self.node_decls[name] = item

    def _prop_expr(self, node: str, prop: str) -> ast.Prop | None:
        found = None
        for p in self.node_decls[node].props:
            if p.name.name == prop:
                found = found or p
        return found

    def _prop_ref(self, node: str | None, prop: str, span: Span) -> Value:
        """`@prop` as seen by an expression: a constant width reads as a plain number."""
        v = self._prop(node, prop, span)
        if isinstance(v, Profile) and v.is_constant:
            x = v.points[0][1]
            return int(x) if float(x).is_integer() else x
        return v

    def _prop(self, node: str | None, prop: str, span: Span) -> Value:
        if node is None:
            if not self.prop_stack:
                raise EvalError(
                    "E406", f"`@{prop}` needs a node", span, "write `@node.prop` outside a node"
                )
            node = self.prop_stack[-1][0]
        if node not in self.node_decls:
            raise EvalError(
                "E211",
                f"unknown node `{node}` in `@{node}.{prop}`",
                span,
                _suggest(node, self.node_decls),
            )
        key = (node, prop)
        if key in self.prop_values:
            return self.prop_values[key]
        kind = self.node_decls[node].kind
        spec = sk.NODE_PROPS[kind].get(prop)
        if spec is None:
            raise EvalError(
                "E212",
                f"a {kind} has no property `{prop}`",
                span,
                _suggest(prop, sk.NODE_PROPS[kind]),
            )
        if key in self.prop_stack:
            cycle = self.prop_stack[self.prop_stack.index(key) :] + [key]
            if len(cycle) == 2:
                raise EvalError("E407", f"`@{node}.{prop}` refers to itself", span)
            raise EvalError(
                "E407",
                "properties refer to each other in a cycle: "
                + " -> ".join(f"@{n}.{p}" for n, p in cycle),
                span,
            )
        p = self._prop_expr(node, prop)
        if p is None:
            value = spec.default
            if spec.kind == "width":
                value = Profile.constant(value)
            self.prop_values[key] = value
            return value
        self.prop_stack.append(key)
        try:
            raw = Evaluator(self._param, self._prop_ref).eval(p.value)
            value = self._check(spec, raw, p, f"`{prop}`")
        except EvalError as err:
            if len(self.prop_stack) == 1:
                self._report(err)
                self.tainted.add(node)
                value = Profile.constant(spec.default) if spec.kind == "width" else spec.default
            else:
                raise
        finally:
            self.prop_stack.pop()
        self.prop_values[key] = value
        return value

    def _node(self, decl: ast.NodeDecl, machine: sk.MachineSettings) -> sk.PrimNode:
        name, kind = decl.name.name, decl.kind
        schema = sk.NODE_PROPS[kind]
        hint = None
        if kind == "tube" and any(p.name.name == "type" for p in decl.props):
            hint = "a tube is always a cylinder; use `sheet` with `type:` otherwise"
        seen = self._unique_props(decl.props, schema, f"a {kind}", hint)
        props: dict[str, Value] = {}
        for pname in schema:
            if pname in seen:
                try:
                    props[pname] = self._prop(name, pname, seen[pname].span)
                except EvalError as err:
                    self._report(err)
                    self.tainted.add(name)
                    props[pname] = schema[pname].default
            else:
                default = schema[pname].default
                props[pname] = (
                    Profile.constant(default) if schema[pname].kind == "width" else default
                )
        if props.get("gauge") is None:
            props["gauge"] = machine.gauge
        if kind == "tube":
            props["type"] = "cylinder"
        if props.get("increase") == "auto":
            props["increase"] = machine.increase
        self._check_node_consistency(decl, props)
        return sk.PrimNode(name, kind, props, decl.span, {k: v.span for k, v in seen.items()})

    def _check_node_consistency(self, decl: ast.NodeDecl, props: dict[str, Value]) -> None:
        if decl.kind == "split":
            layout = props["layout"]
            degree = props["degree"]
            if isinstance(layout, tuple) and len(layout) != degree:
                p = self._prop_expr(decl.name.name, "layout")
                self.diags.error(
                    "E309",
                    f"`layout` lists {len(layout)} positions but `degree` is {degree}",
                    p.value.span if p else decl.span,
                    hint="give one position in [0, 1] per branch, or `auto`",
                )
        shaper = props.get("shaper")
        if isinstance(shaper, str) and shaper not in sk.SHAPERS:
            prog = self.defs.shapers.get(shaper)
            if prog is not None and (
                len(prog.params) < 2 or any(q.default is None for q in prog.params[2:])
            ):
                p = self._prop_expr(decl.name.name, "shaper")
                self.diags.error(
                    "E310",
                    f"shaper `{shaper}` must take (M, N) and give defaults "
                    "to any further parameters",
                    p.value.span if p else decl.span,
                    notes=[Note("defined here", prog.name.span)],
                )

    def _check(self, spec: sk.PropSpec, v: Value, p: ast.Prop | ast.Node, what: str) -> Value:
        span = p.value.span if isinstance(p, ast.Prop) else p.span
        kind = spec.kind

        def fail(msg: str, hint: str | None = None) -> EvalError:
            if hint is None and isinstance(v, Word) and v.name in self.param_decls:
                hint = f"did you mean `#{v.name}`?"
            return EvalError("E311", msg, span, hint)

        if kind in ("int", "number"):
            if isinstance(v, bool) or not isinstance(v, int | float):
                raise fail(f"{what} must be a number, got {type_name(v)}")
            if kind == "int":
                if isinstance(v, float) and not v.is_integer():
                    raise fail(
                        f"{what} must be a whole number, got {show(v)}",
                        "use round(...), floor(...) or ceil(...)",
                    )
                v = int(v)
            self._range(spec, v, span, what)
            return v
        if kind == "bool":
            if not isinstance(v, bool):
                raise fail(f"{what} must be true or false, got {type_name(v)}")
            return v
        if kind == "string":
            if not isinstance(v, str | Word):
                raise fail(f"{what} must be a string, got {type_name(v)}")
            return str(v)
        if kind in ("choice", "shaper"):
            word = v.name if isinstance(v, Word) else v if isinstance(v, str) else None
            if word is None:
                raise fail(f"{what} must be one of {_choices(spec.choices)}, got {type_name(v)}")
            if word in spec.choices:
                return word
            if kind == "shaper" and (word in self.defs.shapers or self.defs.known(word)):
                return word
            extra = list(self.defs.shapers) if kind == "shaper" else []
            raise EvalError(
                "E312",
                f"{what} cannot be `{word}`",
                span,
                _suggest(word, list(spec.choices) + extra)
                or f"choose one of {_choices(tuple(spec.choices) + tuple(extra))}",
            )
        if kind == "width":
            if isinstance(v, bool) or not isinstance(v, int | float | Profile):
                raise fail(
                    f"{what} must be a number or a profile [t: value, ...], got {type_name(v)}"
                )
            prof = v if isinstance(v, Profile) else Profile.constant(v)
            for x in prof.values():
                self._range(spec, x, span, what)
            return prof
        if kind == "joint_layout":
            if v == Word("auto") or v == "auto":
                return "auto"
            if isinstance(v, bool) or not isinstance(v, int | float):
                raise fail(f"{what} must be `auto` or a position in [0, 1], got {type_name(v)}")
            self._range(spec, v, span, what)
            return float(v)
        if kind == "split_layout":
            if v == Word("auto") or v == "auto":
                return "auto"
            items = v if isinstance(v, tuple) else (v,)
            out = []
            for x in items:
                if isinstance(x, bool) or not isinstance(x, int | float):
                    raise fail(f"{what} must be `auto` or a list of positions in [0, 1]")
                self._range(spec, x, span, what)
                out.append(float(x))
            return tuple(out)
        if kind == "carriers":
            items = v if isinstance(v, tuple) else (v,)
            out = []
            for x in items:
                if isinstance(x, bool) or not isinstance(x, int):
                    raise fail(f"{what} must list carriers by number, got {show(x)}")
                if not 1 <= x <= 10:
                    raise EvalError(
                        "E313", f"{what} must list carriers between 1 and 10, got {show(x)}", span
                    )
                if x in out:
                    raise fail(f"carrier {x} is listed twice")
                out.append(x)
            if not out:
                raise fail("at least one carrier is needed")
            return tuple(out)
        raise AssertionError(kind)

    @staticmethod
    def _range(spec: sk.PropSpec, v: float, span: Span, what: str) -> None:
        if not math.isfinite(v):
            raise EvalError("E313", f"{what} must be a finite number, got {show(v)}", span)
        if spec.min is not None and v < spec.min:
            raise EvalError(
                "E313", f"{what} must be at least {show(spec.min)}, got {show(v)}", span
            )
        if spec.max is not None and v > spec.max:
            raise EvalError("E313", f"{what} must be at most {show(spec.max)}, got {show(v)}", span)

    def _props_block(
        self, props: tuple[ast.Prop, ...], schema: dict[str, sk.PropSpec], what: str
    ) -> dict[str, Value]:
        out: dict[str, Value] = {}
        ev = Evaluator(self._param, self._prop_outside)
        for name, p in self._unique_props(props, schema, what).items():
            try:
                out[name] = self._check(schema[name], ev.eval(p.value), p, f"`{name}`")
            except EvalError as err:
                self._report(err)
        return out

    def _unique_props(
        self, props, schema: dict[str, sk.PropSpec], what: str, type_hint: str | None = None
    ) -> dict[str, ast.Prop]:
        """The properties of a block by name; unknown (E307) and repeated (E308) ones are
        reported and left out."""
        seen: dict[str, ast.Prop] = {}
        for p in props:
            name = p.name.name
            if name not in schema:
                hint = type_hint if name == "type" and type_hint else _suggest(name, schema)
                self.diags.error(
                    "E307",
                    f"{what} has no property `{name}`",
                    p.name.span,
                    hint=hint or "properties: " + ", ".join(schema),
                )
            elif name in seen:
                self.diags.error(
                    "E308",
                    f"property `{name}` is set twice",
                    p.name.span,
                    notes=[Note("first set here", seen[name].name.span)],
                )
            else:
                seen[name] = p
        return seen

    def _prop_outside(self, node: str | None, prop: str, span: Span) -> Value:
        if node is None:
            raise EvalError("E406", f"`@{prop}` needs a node here", span, "write `@node.prop`")
        return self._prop_ref(node, prop, span)

    def _machine(self, decls: list[ast.MachineDecl]) -> sk.MachineSettings:
        for extra in decls[1:]:
            self.diags.error(
                "E314",
                "a second `machine` block",
                extra.span,
                notes=[Note("first here", decls[0].span)],
                hint="merge the settings into one block",
            )
        values = self._props_block(decls[0].props, sk.MACHINE_PROPS, "`machine`") if decls else {}
        full = {k: values.get(k, s.default) for k, s in sk.MACHINE_PROPS.items()}
        return sk.MachineSettings(span=decls[0].span if decls else None, **full)

    # -- interfaces, connections, starts
    def _itf(self, ref: ast.ItfRef, nodes: dict[str, sk.PrimNode]) -> sk.ItfId | None:
        name = ref.node.name
        got = self._itf_id(ref, nodes)
        if got is None:
            self.tainted.add(name)
        return got

    def _itf_id(self, ref: ast.ItfRef, nodes: dict[str, sk.PrimNode]) -> sk.ItfId | None:
        name = ref.node.name
        node = nodes.get(name)
        if node is None:
            close = difflib.get_close_matches(name, list(nodes), n=1, cutoff=0.6)
            self.tainted.update(close)  # the node the designer probably meant
            self.diags.error(
                "E211",
                f"unknown node `{name}`",
                ref.node.span,
                hint=f"did you mean `{close[0]}`?" if close else None,
            )
            return None
        path = ref.path.name
        if node.kind == "split":
            if path == "branches":
                if ref.index is None:
                    self.diags.error("E213", "which branch? write `branches[i]`", ref.span)
                    return None
                try:
                    i = Evaluator(self._param, self._prop_outside).eval(ref.index)
                except EvalError as err:
                    self._report(err)
                    return None
                degree = int(cast(int, node.props["degree"]))
                if (
                    isinstance(i, bool)
                    or not isinstance(i, int | float)
                    or not float(i).is_integer()
                    or not 0 <= i < degree
                ):
                    self.diags.error(
                        "E214",
                        f"`{name}` has branches 0 to {degree - 1}, not {show(i)}",
                        ref.index.span,
                        hint="raise the split's `degree` to add branches",
                    )
                    return None
                return sk.ItfId(name, f"branches/{int(i)}")
            valid = ["base", "branches[i]"]
        else:
            valid = ["bottom", "top"]
        if ref.index is not None or path not in valid:
            self.diags.error(
                "E215",
                f"a {node.kind} has no interface `{path}`"
                + ("[...]" if ref.index is not None else ""),
                ref.path.span,
                hint=_suggest(path, valid) or "interfaces: " + ", ".join(valid),
            )
            return None
        return sk.ItfId(name, path)

    def _topology(self, skel: sk.Skeleton) -> None:
        stated: dict[sk.ItfId, Span] = {}
        for item in self.module.items:
            if isinstance(item, ast.Connect):
                a, b = self._itf(item.a, skel.nodes), self._itf(item.b, skel.nodes)
                if a is not None and b is not None:
                    skel.connections.append(sk.Connection(a, b, item.span))
                else:  # the other end is left unconnected only because of this error
                    self.tainted.update((item.a.node.name, item.b.node.name))
            elif isinstance(item, ast.ItfStmt):
                itf_id = self._itf(item.itf, skel.nodes)
                if itf_id is None:
                    continue
                itf = skel.interfaces[itf_id]
                if item.state is not None:
                    if itf_id in stated:
                        self.diags.warning(
                            "W504",
                            f"the state of `{itf_id}` is set twice; the later one wins",
                            item.span,
                            notes=[Note("first set here", stated[itf_id])],
                        )
                    stated[itf_id] = item.span
                    itf.state = item.state
                    itf.span = item.span
                if item.state == "open":
                    itf.closing = None
                if item.state == "closed":
                    itf.closing = "collapse"
                    if item.closing is not None:
                        if item.closing.name not in sk.CLOSINGS:
                            self.diags.error(
                                "E312",
                                f"no closing mode `{item.closing.name}`",
                                item.closing.span,
                                hint=_suggest(item.closing.name, sk.CLOSINGS)
                                or "choose one of " + _choices(sk.CLOSINGS),
                            )
                        else:
                            itf.closing = item.closing.name
                if item.props is not None:
                    vals = self._props_block(item.props, sk.ITF_PROPS, "an interface")
                    itf.cast_on = str(vals.get("cast_on", itf.cast_on))
                    itf.cast_off = str(vals.get("cast_off", itf.cast_off))
            elif isinstance(item, ast.Start):
                itf_id = self._itf(item.itf, skel.nodes)
                if itf_id is not None:
                    skel.starts.append(sk.YarnStart(itf_id, False, item.span))

    # -- pattern layers
    def _layers(self, skel: sk.Skeleton) -> None:
        for item in self.module.items:
            if not isinstance(item, ast.PatternLayer):
                continue
            target = item.target.name
            if target not in ("before", "after") and target not in skel.nodes:
                self.diags.error(
                    "E216",
                    f"pattern for unknown node `{target}`",
                    item.target.span,
                    hint=_suggest(target, list(skel.nodes) + ["before", "after"])
                    or "write `pattern NODE { ... }`, `pattern before { ... }` "
                    "or `pattern after { ... }`",
                )
                continue
            self._check_layer_body(item.body, set(), ())
            for stmt in item.body:
                skel.layers.append(sk.Layer(target, stmt, item.span))

    def _check_layer_body(self, body, params: set[str], formals) -> None:
        for f in formals:
            if f.default is not None:
                self._check_expr(f.default, "decl", set())
        scope = set(params)
        for stmt in body:
            if isinstance(stmt, ast.Let):
                self._check_expr(stmt.value, "query", scope)
                scope.add(stmt.name.name)
                continue
            where = getattr(stmt, "where", None)
            if where is not None:
                self._check_expr(where, "query", scope)
            if isinstance(stmt, ast.UseStmt):
                name = stmt.action.name
                if not self.defs.known(name) and name not in BUILTIN_ACTIONS:
                    self.diags.error(
                        "E217",
                        f"unknown action `{name}`",
                        stmt.action.span,
                        hint=_suggest(name, list(self.defs.actions) + list(BUILTIN_ACTIONS))
                        or "define it with `action NAME { ... }` or import it "
                        "(e.g. `import std.actions`)",
                    )
            elif isinstance(stmt, ast.ApplyStmt):
                self._check_apply(stmt, scope)
            elif isinstance(stmt, ast.GridStmt):
                self._check_expr(stmt.grid, "query", scope)
                if isinstance(stmt.grid, ast.Grid):
                    self._check_grid(stmt.grid, stmt.mode)

    def _check_apply(self, stmt: ast.ApplyStmt, scope: set[str]) -> None:
        name = stmt.pattern.name
        d = self.defs.patterns.get(name)
        for a in stmt.args:
            self._check_expr(a.value if isinstance(a, ast.KwArg) else a, "query", scope)
        if d is None and self.defs.known(name):
            return
        if d is None:
            self.diags.error(
                "E218",
                f"unknown pattern `{name}`",
                stmt.pattern.span,
                hint=_suggest(name, self.defs.patterns)
                or "define it with `pattern NAME(...) { ... }` or import it "
                "(e.g. `import std.stitches`)",
            )
            return
        formals = [p.name.name for p in d.params]
        positional = [a for a in stmt.args if not isinstance(a, ast.KwArg)]
        if len(positional) > len(formals):
            self.diags.error(
                "E219",
                f"`{name}` takes at most {len(formals)} argument(s), got {len(positional)}",
                stmt.span,
                notes=[Note("defined here", d.name.span)],
            )
            return
        given = set(formals[: len(positional)])
        for a in stmt.args:
            if isinstance(a, ast.KwArg):
                if a.name.name not in formals:
                    self.diags.error(
                        "E219",
                        f"`{name}` has no parameter `{a.name.name}`",
                        a.name.span,
                        hint=_suggest(a.name.name, formals)
                        or (
                            "its parameters: " + ", ".join(formals)
                            if formals
                            else f"`{name}` takes no parameters"
                        ),
                    )
                given.add(a.name.name)
        missing = [p.name.name for p in d.params if p.default is None and p.name.name not in given]
        if missing:
            self.diags.error(
                "E219",
                f"`{name}` needs a value for " + ", ".join(f"`{m}`" for m in missing),
                stmt.span,
                notes=[Note("defined here", d.name.span)],
            )

    def _check_grid(self, grid: ast.Grid, mode: str) -> None:
        for kind, cell in cell_problems(grid, mode):
            if kind == "unknown":
                self.diags.error(
                    "E220",
                    f"`{cell.text}` is not a pattern instruction",
                    cell.span,
                    hint=_suggest(cell.text, INSTRUCTIONS)
                    or "use K P T M FR1 FR2 FL1 FL2 BR1 BR2 BL1 BL2 XR+ XR- XL+ "
                    "XL- S, or `.` to leave a stitch as it is",
                )
            else:
                self.diags.error(
                    "E315",
                    "a stretched grid cannot hold crosses",
                    cell.span,
                    hint="scaling would tear cable pairs apart; use `tile` or `draw`",
                )

    # -- name checks in bodies
    def _check_expr(self, e: ast.Node, ctx: str, scope: set[str]) -> None:
        """Report unknown names in an expression of a layer (`query`), an action or a shaper."""
        if isinstance(e, ast.Call) and isinstance(e.func, ast.Name):
            fname = e.func.id
            table = {
                "query": QUERY_FUNCTIONS,
                "action": ACTION_FUNCTIONS,
                "shaper": SHAPER_FUNCTIONS,
                "decl": {},
            }[ctx]
            arity = table.get(fname) or BUILTINS.get(fname, (None, None))[1]
            if arity is None:
                self.diags.error(
                    "E201",
                    f"unknown function `{fname}`",
                    e.func.span,
                    hint=_suggest(fname, list(table) + list(BUILTINS)),
                )
            else:
                n = sum(1 for a in e.args if not isinstance(a, ast.KwArg))
                lo, hi = arity
                if not lo <= n <= hi:
                    want = str(lo) if lo == hi else f"{lo} to {hi}"
                    self.diags.error("E304", f"`{fname}` takes {want} argument(s), got {n}", e.span)
            inner = scope
            if fname == "filter":
                inner = scope | set(STITCH_FIELDS)
            for a in e.args:
                if isinstance(a, ast.KwArg):
                    self._check_expr(a.value, ctx, inner)
                elif isinstance(a, ast.Range):
                    for part in (a.start, a.stop, a.step):
                        if part is not None:
                            self._check_expr(part, ctx, inner | {"end"})
                else:
                    self._check_expr(a, ctx, inner)
            return
        if isinstance(e, ast.Name):
            allowed = set(scope)
            if ctx == "query":
                allowed |= set(QUERY_WORDS)
            elif ctx == "action":
                allowed |= set(ACTION_CONTEXT) | set(ACTION_WORDS)
            elif ctx == "shaper":
                allowed |= set(SHAPER_CONTEXT)
            if e.id not in allowed:
                self.diags.error(
                    "E221",
                    f"unknown name `{e.id}`",
                    e.span,
                    hint=_suggest(e.id, allowed) or self._name_hint(ctx),
                )
            return
        if isinstance(e, ast.PropRef):
            if ctx != "decl" and e.node is not None and e.node not in self.node_decls:
                self.diags.error(
                    "E211",
                    f"unknown node `{e.node}`",
                    e.span,
                    hint=_suggest(e.node, self.node_decls),
                )
            return
        if isinstance(e, ast.ParamRef):
            if e.name not in self.param_decls:
                self.diags.error(
                    "E403",
                    f"unknown parameter `#{e.name}`",
                    e.span,
                    hint=_suggest(e.name, self.param_decls),
                )
            return
        if isinstance(e, ast.Attr):
            self._check_expr(e.obj, ctx, scope)
            return
        for child in e.children():
            self._check_expr(child, ctx, scope)

    @staticmethod
    def _name_hint(ctx: str) -> str:
        if ctx == "query":
            return (
                "stitch fields (course, wale, ...) are readable inside `filter(...)`; "
                "bind other names with `let`"
            )
        if ctx == "action":
            return "available: " + ", ".join(ACTION_CONTEXT) + ", and names bound with `let`"
        if ctx == "shaper":
            return (
                "available: M, N (the shaper's parameters), `turn`, and names bound with "
                "`let` or a `for` loop"
            )
        return "bind names with `let` or a `for` loop"

    def _check_block(self, block: ast.Block, ctx: str, scope: set[str]) -> None:
        scope = set(scope)
        for stmt in block.stmts:
            if isinstance(stmt, ast.Let):
                self._check_expr(stmt.value, ctx, scope)
                scope.add(stmt.name.name)
            elif isinstance(stmt, ast.Assign):
                if stmt.name.name not in scope:
                    self.diags.error(
                        "E222",
                        f"`{stmt.name.name}` is assigned before `let`",
                        stmt.name.span,
                        hint=f"declare it first: `let {stmt.name.name} = ...`",
                    )
                    scope.add(stmt.name.name)
                self._check_expr(stmt.value, ctx, scope)
            elif isinstance(stmt, ast.If):
                self._check_expr(stmt.cond, ctx, scope)
                self._check_block(stmt.then, ctx, scope)
                orelse = stmt.orelse
                while isinstance(orelse, ast.If):
                    self._check_expr(orelse.cond, ctx, scope)
                    self._check_block(orelse.then, ctx, scope)
                    orelse = orelse.orelse
                if orelse is not None:
                    self._check_block(orelse, ctx, scope)
            elif isinstance(stmt, ast.For):
                self._check_expr(stmt.iter, ctx, scope)
                self._check_block(stmt.body, ctx, scope | {stmt.var.name})
            elif isinstance(stmt, ast.MapStmt):
                if ctx != "shaper":
                    self.diags.error(
                        "E223", "`->` mappings only appear in shaper programs", stmt.span
                    )
                self._check_expr(stmt.src, ctx, scope)
                self._check_expr(stmt.dst, ctx, scope)
            elif isinstance(stmt, ast.ExprStmt):
                self._check_expr(stmt.expr, ctx, scope)

    def _check_action(self, d: ast.ActionDef) -> None:
        props = [i for i in d.items if isinstance(i, ast.Prop)]
        self._props_block(tuple(props), sk.ACTION_PROPS, "an action")
        steps: dict[str, ast.ActionStep] = {}
        for item in d.items:
            if isinstance(item, ast.ActionStep):
                if item.step in steps:
                    self.diags.error(
                        "E224",
                        f"step `{item.step}` is written twice",
                        item.span,
                        notes=[Note("first here", steps[item.step].span)],
                    )
                    continue
                steps[item.step] = item
                self._check_block(item.body, "action", set())
        if "main" not in steps:
            self.diags.error(
                "E225",
                f"action `{d.name.name}` has no `main` step",
                d.name.span,
                hint="`main { ... }` emits the operation that forms the stitch",
            )

    def _check_shaper(self, d: ast.ShaperDef) -> None:
        self._check_block(d.body, "shaper", {p.name.name for p in d.params})


def _choices(options: tuple[str, ...]) -> str:
    opts = [f"`{o}`" for o in options]
    return ", ".join(opts[:-1]) + " or " + opts[-1] if len(opts) > 1 else opts[0]


def parse_define(text: str, diags: Diagnostics) -> tuple[str, ast.Node] | None:
    """Parse a `-D name=value` option with the language's own grammar."""
    name, sep, value = text.partition("=")
    name = name.strip()
    if not sep or not name.isidentifier():
        diags.error(
            "E408", f"bad `-D {text}`", None, hint="write `-D name=value`, e.g. `-D finger_len=26`"
        )
        return None
    own = Diagnostics()
    source = SourceFile(f"<-D {name}>", f"param {name} = {value}")
    module = parse_source(source, own)
    diags.add_source(source)
    if module is None or len(module.items) != 1:
        diags.error(
            "E408",
            f"cannot read the value of `-D {text}`",
            None,
            hint="values are knitc expressions: numbers, words, strings, lists, profiles",
        )
        return None
    decl = module.items[0]
    assert isinstance(decl, ast.ParamDecl)
    return name, decl.value


def resolve(
    module: ast.Module, path: str, diags: Diagnostics, defines: dict[str, ast.Node] | None = None
) -> sk.Skeleton | None:
    """AST → skeleton IR. Returns None only if the module could not be resolved at all."""
    loader = _Loader(diags)
    skel = _Resolver(module, path, diags, defines or {}, loader).run()
    if skel is not None:
        sk.verify(skel, diags)
    return skel
