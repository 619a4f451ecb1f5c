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
import re
from typing import cast

from knitc.diagnostics import Diagnostics, Note
from knitc.frontend import ast
from knitc.frontend import skeleton as sk
from knitc.frontend.definitions import _FAILED, _Defs, _Loader, _Silent, _suggest
from knitc.frontend.names import NameChecker
from knitc.frontend.parser import parse_source
from knitc.lang.evaluate import (
    EvalError,
    Evaluator,
    Profile,
    Value,
    Word,
    show,
    type_name,
)
from knitc.source import SourceFile, Span

# ---- the resolver -------------------------------------------------------------------------------


_HEX_COLOUR = re.compile(r"#[0-9a-fA-F]{6}")
"""A yarn's `colour`."""


_PLATING = " (plating)"
"""Marks a carrier taken by a yarn's plating in `_yarns`' carrier owners."""


class _Resolver:
    def __init__(
        self,
        module: ast.Module,
        path: str,
        diags: Diagnostics,
        defines: dict[str, ast.Node],
        loader: _Loader,
        max_stitches: int = sk.MAX_STITCHES,
    ):
        self.module = module
        self.max_stitches = max_stitches
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
        self.names = NameChecker(
            self.module, self.diags, self.defs, self.node_decls, self.param_decls, self._props_block
        )
        machine = self._machine([i for i in items if isinstance(i, ast.MachineDecl)])
        yarns = self._yarns(machine)
        self.names.yarns = set(yarns)
        values = {
            name: self._param_value(name, decl.name.span) for name, decl in self.param_decls.items()
        }
        params = {k: v for k, v in values.items() if v is not None}
        nodes: dict[str, sk.PrimNode] = {}
        for name, decl in self.node_decls.items():
            nodes[name] = self._node(decl, machine)
        self._check_budget(nodes)
        interfaces = {
            sk.ItfId(n.name, p): sk.Interface(sk.ItfId(n.name, p), span=n.span)
            for n in nodes.values()
            for p in n.interface_paths
        }
        skel = sk.Skeleton(machine, params, nodes, interfaces, [])
        self._topology(skel)
        skel.tainted = set(self.tainted)
        skel.yarns = yarns
        self.names.layers(skel)
        d: ast.ActionDef | ast.ShaperDef | ast.PatternDef
        for d in self.defs.actions.values():
            self.names.check_action(d)
        for d in self.defs.shapers.values():
            self.names.check_shaper(d)
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
            self.names.check_layer_body(d.body, {p.name.name for p in d.params}, d.params)
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
    def _check_budget(self, nodes: dict[str, sk.PrimNode]) -> None:
        """Refuse a design larger than knitc compiles (E512) before any stitch is made:
        every property may be in range and the product still need tens of gigabytes."""
        sizes = sk.stitch_estimate(nodes)
        total = sum(sizes.values())
        if total > self.max_stitches:
            big = max(sizes, key=lambda k: sizes[k])
            node = nodes[big]
            self.diags.error(
                "E512",
                f"the design would have about {total:,} stitches (`{big}` alone {sizes[big]:,}); "
                f"the limit is {self.max_stitches:,}",
                node.prop_spans.get("length", node.span),
                hint="a garment is tens of thousands of stitches: check `length` and `width`; "
                "if the design is meant to be this large, raise it with --max-stitches",
            )

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
            other = self.defs.kind_of(word)
            if kind == "shaper" and (
                word in self.defs.shapers or (other is None and self.defs.known(word))
            ):
                return word  # a shaper, or one a failed import may have defined
            extra = list(self.defs.shapers) if kind == "shaper" else []
            if kind == "shaper" and other is not None:
                raise EvalError(
                    "E312",
                    f"{what} cannot be `{word}`: it is {'an' if other == 'action' else 'a'} "
                    f"{other}, not a shaper",
                    span,
                    f"choose one of {_choices(tuple(spec.choices) + tuple(extra))}",
                )
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

    def _yarns(self, machine: sk.MachineSettings) -> dict[str, sk.Yarn]:
        """The declared yarns, `main` first (declared or not), each carrier used once."""
        decls: dict[str, ast.YarnDecl] = {}
        for item in self.module.items:
            if not isinstance(item, ast.YarnDecl):
                continue
            name = item.name.name
            if name in decls:
                self.diags.error(
                    "E227",
                    f"yarn `{name}` is declared twice",
                    item.name.span,
                    notes=[Note("first declared here", decls[name].name.span)],
                )
                continue
            decls[name] = item
        out: dict[str, sk.Yarn] = {}
        owner: dict[int, str] = {}
        for name in [sk.MAIN_YARN] + [n for n in decls if n != sk.MAIN_YARN]:
            decl = decls.get(name)
            values = self._props_block(decl.props, sk.YARN_PROPS, f"yarn `{name}`") if decl else {}
            carrier = values.get("carrier")
            if carrier is None and name == sk.MAIN_YARN:
                carrier = machine.carriers[0]
            carry = values.get("carry_up", sk.YARN_PROPS["carry_up"].default)
            assert carrier is None or isinstance(carrier, int)
            assert isinstance(carry, int)
            first = owner.get(carrier) if carrier is not None else None
            if first is not None and decl is not None:
                plater = first[: -len(_PLATING)] if first.endswith(_PLATING) else None
                held = decls.get(plater or first)
                self.diags.error(
                    "E321",
                    f"yarn `{plater}`'s plating and yarn `{name}` both use carrier {carrier}"
                    if plater
                    else f"yarns `{first}` and `{name}` both use carrier {carrier}",
                    next(p.span for p in decl.props if p.name.name == "carrier"),
                    notes=[Note(f"`{plater or first}` declared here", held.name.span)]
                    if held
                    else [],
                    hint="a carrier holds one yarn: give each yarn its own carrier"
                    + ("" if held else " (`main` takes the machine's first carrier)"),
                )
            if carrier is not None:
                owner.setdefault(carrier, name)
            plating = values.get("plating") or None  # (0: none)
            assert plating is None or isinstance(plating, int)
            if plating is not None and decl is not None:
                first = owner.get(plating)
                if first is not None:
                    plater = first[: -len(_PLATING)] if first.endswith(_PLATING) else None
                    held = decls.get(plater or first)
                    self.diags.error(
                        "E321",
                        f"yarn `{name}`'s plating and "
                        + (f"yarn `{plater}`'s plating" if plater else f"yarn `{first}`")
                        + f" both use carrier {plating}",
                        next(p.span for p in decl.props if p.name.name == "plating"),
                        notes=[Note(f"`{plater or first}` declared here", held.name.span)]
                        if held
                        else [],
                        hint="a plating yarn needs a carrier of its own, which no other yarn uses",
                    )
                    plating = None
                else:
                    owner[plating] = name + _PLATING
            tuck = values.get("tuck_every", 0)
            assert isinstance(tuck, int)
            colour = str(values.get("colour", ""))
            if colour and not _HEX_COLOUR.fullmatch(colour):
                assert decl is not None
                self.diags.error(
                    "E313",
                    f'yarn `{name}`: `colour` is written "#rrggbb", got "{colour}"',
                    next(p.value.span for p in decl.props if p.name.name == "colour"),
                    hint='six hexadecimal digits of red, green and blue, e.g. "#c0392b"',
                )
                colour = ""
            inlay = values.get("inlay", 0)
            assert isinstance(inlay, int)
            if inlay and name == sk.MAIN_YARN and decl is not None:
                self.diags.error(
                    "E322",
                    "`main` is the design's own yarn: it knits every stitch no `knit` gives "
                    "another yarn, and cannot be an inlay",
                    next(p.span for p in decl.props if p.name.name == "inlay"),
                    hint="declare the inlay as a yarn of its own: `yarn elastic { carrier: 7, "
                    "inlay: 4 }`",
                )
                inlay = 0
            out[name] = sk.Yarn(
                name,
                carrier,
                carry,
                decl.span if decl else None,
                tuck,
                colour.lower(),
                plating,
                inlay,
            )
        return out

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

    # -- name checks in bodies


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
    module: ast.Module,
    path: str,
    diags: Diagnostics,
    defines: dict[str, ast.Node] | None = None,
    max_stitches: int = sk.MAX_STITCHES,
) -> sk.Skeleton | None:
    """AST → skeleton IR. Returns None only if the module could not be resolved at all.
    `max_stitches` is the E512 budget (`knitc --max-stitches`)."""
    loader = _Loader(diags)
    skel = _Resolver(module, path, diags, defines or {}, loader, max_stitches).run()
    if skel is not None:
        sk.verify(skel, diags)
    return skel
