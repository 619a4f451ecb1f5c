"""Property tests of resolution and the skeleton verifier, on generated source text.

`programs()` writes random VALID garments as text: trees of sheets, tubes, joints and
splits (chains, splits and merges) with consistent sizes, widths written through params,
`-D` overrides, `@node.prop` references and profiles, random interface states and casting,
optional yarn starts, several garments per file, and items in random order. It keeps the
sizes it meant every interface to have, so the properties can check what the compiler
inferred against what was generated.

The second property mutates such programs character by character: whatever the damage,
`compile_source` must answer with diagnostics, never with an exception.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from knitc.driver import compile_source
from knitc.frontend.skeleton import ItfId

SETTINGS = settings(
    max_examples=100,
    deadline=None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large],
)


@dataclass
class GNode:
    name: str
    kind: str  # sheet | tube | joint | split
    paths: list[str]  # interface paths, in the compiler's order
    sizes: dict[str, int]  # expected stitches per interface path
    props: list[str] = field(default_factory=list)
    length: int | None = None


@dataclass
class Program:
    text: str
    defines: list[str]
    nodes: dict[str, GNode]
    connections: list[tuple[ItfId, ItfId]]
    components: list[list[str]]  # node names of each garment, in generation order
    declared_starts: dict[int, ItfId]  # component index -> declared start
    node_order: list[str]  # declaration order in the text
    closed: set[ItfId]


class _Gen:
    """Builds one program; `draw` is hypothesis' draw function."""

    def __init__(self, draw):
        self.draw = draw
        self.items: list[tuple[str, str]] = []  # (kind, text)
        self.defines: list[str] = []
        self.nodes: dict[str, GNode] = {}
        self.connections: list[tuple[ItfId, ItfId]] = []
        self.counter = 0
        self.budget = 0
        self.comp_nodes: list[str] = []

    def fresh(self, prefix: str) -> str:
        self.counter += 1
        return f"{prefix}{self.counter}"

    # -- expressions that evaluate to a known integer
    def param(self, value: int) -> str:
        name = self.fresh("p")
        if self.draw(st.booleans()):
            # Declared with a wrong value; the -D override sets the right one.
            wrong = value + self.draw(st.integers(1, 50))
            self.items.append(("param", f"param {name} = {wrong}"))
            self.defines.append(f"{name}={value}")
        else:
            self.items.append(("param", f"param {name} = {value}"))
        return f"#{name}"

    def expr(self, value: int, self_length: int | None = None) -> str:
        lengths = [n for n in self.nodes.values() if n.length is not None]
        choices = ["lit", "param", "param_plus", "double", "round"]
        if lengths:
            choices.append("other_length")
        if self_length is not None:
            choices.append("own_length")
        how = self.draw(st.sampled_from(choices))
        if how == "lit":
            return str(value)
        if how == "param":
            return self.param(value)
        if how == "param_plus":
            d = self.draw(st.integers(-5, 5))
            return f"{self.param(value - d)} + {d}" if d >= 0 else f"{self.param(value - d)} - {-d}"
        if how == "double":
            return f"{self.param(value)} * 2 / 2"
        if how == "round":
            return f"round({value} + 0.{self.draw(st.integers(0, 4))})"
        if how == "own_length":
            return _plus("@length", value - self_length)
        other = self.draw(st.sampled_from(lengths))
        return _plus(f"@{other.name}.length", value - other.length)

    # -- nodes
    def add_node(self, node: GNode) -> None:
        self.nodes[node.name] = node
        self.comp_nodes.append(node.name)
        self.budget -= 1
        sep = self.draw(st.sampled_from(["  ", ", ", "\n  "]))
        body = sep.join(node.props)
        self.items.append(("node", f"{node.kind} {node.name} {{ {body} }}"))

    def ref(self, node: GNode, path: str) -> str:
        if path.startswith("branches/"):
            k = int(path.split("/")[1])
            idx = self.draw(st.sampled_from([str(k), "param", f"{k} * 1"]))
            if idx == "param":
                idx = self.param(k)
            return f"{node.name}.branches[{idx}]"
        return f"{node.name}.{path}"

    def connect(self, a: GNode, pa: str, b: GNode, pb: str) -> None:
        self.connections.append((ItfId(a.name, pa), ItfId(b.name, pb)))
        if self.draw(st.booleans()):
            a, pa, b, pb = b, pb, a, pa
        self.items.append(("connect", f"{self.ref(a, pa)} -> {self.ref(b, pb)}"))

    def even_size(self) -> int:
        return 2 * self.draw(st.integers(1, 20))

    def sheetlike(self, entry_size: int | None, entry_path: str) -> GNode:
        kind = self.draw(st.sampled_from(["flat", "cylinder", "tube"]))
        sides = 1 if kind == "flat" else 2
        other_path = "top" if entry_path == "bottom" else "bottom"
        sizes = {
            entry_path: entry_size if entry_size is not None else self.even_size(),
            other_path: self.even_size(),
        }
        length = self.draw(st.integers(1, 60))
        if length == 1 or self.draw(st.booleans()):
            # one course: both interfaces are that course, so they have one size
            sizes[other_path] = sizes[entry_path]
        wb, wt = sizes["bottom"] // sides, sizes["top"] // sides
        node = GNode(
            self.fresh("n"),
            "tube" if kind == "tube" else "sheet",
            ["bottom", "top"],
            sizes,
            length=length,
        )
        props = [f"length: {self.expr(length) if self.draw(st.booleans()) else length}"]
        if kind != "tube":
            props.append(f"type: {kind}")
        if wb == wt and self.draw(st.booleans()):
            width = self.expr(wb, length)
        else:
            pts = [f"0: {self.expr(wb, length)}"]
            if self.draw(st.booleans()):
                pts.append(f"0.5: {self.draw(st.integers(1, 60))}")
            pts.append(f"1: {self.expr(wt, length)}")
            width = "[" + ", ".join(pts) + "]"
        props.append(f"width: {width}")
        props += self.draw(
            st.lists(
                st.sampled_from(
                    [
                        "gauge: half",
                        "gauge: full",
                        "shaper: sides",
                        "shaper: left",
                        "alignment: right",
                        "increase: split",
                    ]
                ),
                max_size=2,
                unique_by=lambda s: s.split(":")[0],
            )
        )
        node.props = props
        self.add_node(node)
        return node

    # -- trees
    def grow(self, parent: GNode, parent_path: str, size: int, depth: int, fixed: bool) -> None:
        """A subtree whose entry interface connects to `parent.parent_path` (`size` stitches).

        `fixed` says whether the compiler can infer the size at `parent.parent_path` without
        looking into this subtree. If not, the subtree must fix its entry size itself: a split
        entered through a branch cannot (a branch's size only comes from its neighbour), so
        it is only generated where the parent side already fixes the size.
        """
        kinds = ["sheet"]
        if depth < 4 and self.budget > 0:
            kinds += ["joint", "split"]
        kind = self.draw(st.sampled_from(kinds))
        if kind == "sheet":
            entry = self.draw(st.sampled_from(["bottom", "top"]))
            node = self.sheetlike(size, entry)
            self.connect(parent, parent_path, node, entry)
            other = "top" if entry == "bottom" else "bottom"
            if depth < 4 and self.budget > 0 and self.draw(st.booleans()):
                self.grow(node, other, node.sizes[other], depth + 1, True)
        elif kind == "joint":
            entry = self.draw(st.sampled_from(["bottom", "top"]))
            other = "top" if entry == "bottom" else "bottom"
            rows = self.draw(st.integers(1, 30))
            props = [f"rows: {self.expr(rows)}"]
            if self.draw(st.booleans()):
                props.append(f"width: {self.draw(st.integers(1, 20))}")
            if self.draw(st.booleans()):
                props.append(f"layout: {self.draw(st.sampled_from(['auto', '0.25', '1']))}")
            node = GNode(
                self.fresh("n"), "joint", ["bottom", "top"], {"bottom": size, "top": size}, props
            )
            self.add_node(node)
            self.connect(parent, parent_path, node, entry)
            # A joint copies sizes both ways; with both ends free it would have none.
            self.grow(node, other, size, depth + 1, fixed)
        else:
            self.split(parent, parent_path, size, depth, fixed)

    def split(self, parent: GNode, parent_path: str, size: int, depth: int, fixed: bool) -> None:
        units = size // 2
        via_base = self.draw(st.booleans()) if fixed else True
        if via_base:
            degree = self.draw(st.integers(1, min(3, units)))
            cuts = (
                sorted(
                    self.draw(
                        st.lists(
                            st.integers(1, units - 1),
                            min_size=degree - 1,
                            max_size=degree - 1,
                            unique=True,
                        )
                    )
                )
                if degree > 1
                else []
            )
            bounds = [0, *cuts, units]
            branch_sizes = [2 * (b - a) for a, b in zip(bounds, bounds[1:], strict=False)]
            entry = "base"
        else:
            degree = self.draw(st.integers(1, 3))
            k = self.draw(st.integers(0, degree - 1))
            branch_sizes = [size if i == k else self.even_size() for i in range(degree)]
            entry = f"branches/{k}"
        paths = ["base"] + [f"branches/{i}" for i in range(degree)]
        sizes = {"base": sum(branch_sizes)}
        sizes.update({f"branches/{i}": s for i, s in enumerate(branch_sizes)})
        props = [f"degree: {self.expr(degree)}"]
        if self.draw(st.booleans()):
            props.append(f"folded: {self.draw(st.sampled_from(['true', 'false']))}")
        if self.draw(st.booleans()):
            props.append(f"alignment: {self.draw(st.sampled_from(['uniform', 'left']))}")
        node = GNode(self.fresh("n"), "split", paths, sizes, props)
        self.add_node(node)
        self.connect(parent, parent_path, node, entry)
        for p in paths:
            if p == entry:
                continue
            # Every branch needs a neighbour that fixes its size; the base may stay free
            # (it holds the sum of the branches, which is known once they are).
            if p.startswith("branches/"):
                self.grow(node, p, sizes[p], depth + 1, False)
            elif self.draw(st.booleans()):
                self.grow(node, p, sizes[p], depth + 1, True)

    def component(self) -> list[str]:
        self.comp_nodes = []
        self.budget = self.draw(st.integers(0, 8))
        root = self.sheetlike(None, "bottom")
        for path in ("top", "bottom"):
            if self.budget > 0 and self.draw(st.booleans()):
                self.grow(root, path, root.sizes[path], 1, True)
        return list(self.comp_nodes)


def _plus(base: str, d: int) -> str:
    return f"{base} + {d}" if d >= 0 else f"{base} - {-d}"


@st.composite
def programs(draw) -> Program:
    g = _Gen(draw)
    n_comp = draw(st.integers(1, 3))
    components = [g.component() for _ in range(n_comp)]
    connected = {e for c in g.connections for e in c}

    # Interface states, casting and starts on the free interfaces.
    closed: set[ItfId] = set()
    declared_starts: dict[int, ItfId] = {}
    for ci, comp in enumerate(components):
        free = [ItfId(n, p) for n in comp for p in g.nodes[n].paths if ItfId(n, p) not in connected]
        for i in free:
            node = g.nodes[i.node]
            how = draw(
                st.sampled_from(
                    [
                        "",
                        "",
                        "open",
                        "closed",
                        "closed(zigzag)",
                        "closed(zigzagreturn)",
                        "closed(collapse)",
                    ]
                )
            )
            block = draw(
                st.sampled_from(
                    [
                        "",
                        "",
                        "{ cast_on: tuck }",
                        "{ cast_off: direct }",
                        "{ cast_on: precast  cast_off: none }",
                    ]
                )
            )
            if how or block:
                g.items.append(("itf", f"{g.ref(node, i.path)} {how} {block}".rstrip()))
            if how.startswith("closed"):
                closed.add(i)
        if draw(st.booleans()):
            s = draw(st.sampled_from(free))
            declared_starts[ci] = s
            g.items.append(("start", f"start {g.ref(g.nodes[s.node], s.path)}"))
    if draw(st.booleans()):
        g.items.append(
            (
                "machine",
                draw(
                    st.sampled_from(
                        [
                            "machine { gauge: half }",
                            "machine { needles: 400  carriers: [1, 4] }",
                            "machine { increase: split  cast_on: tuck }",
                        ]
                    )
                ),
            )
        )
    if draw(st.booleans()):
        g.items.append(("import", "import std.stitches (rib)"))
    order = draw(st.permutations(range(len(g.items))))
    items = [g.items[i] for i in order]
    sep = draw(st.sampled_from(["\n", "\n\n", "  ", "\n// comment\n"]))
    text = sep.join(t for _, t in items) + "\n"
    node_order = [t.split()[1] for k, t in items if k == "node"]
    return Program(
        text, g.defines, g.nodes, g.connections, components, declared_starts, node_order, closed
    )


# ---- property 1: valid programs resolve exactly as generated --------------------------------


@SETTINGS
@given(programs())
def test_generated_programs_resolve_as_generated(prog: Program):
    r = compile_source(prog.text, "gen.knit", defines=prog.defines)
    rendered = r.diagnostics.render()
    assert not r.diagnostics.has_errors, rendered + "\n" + prog.text
    # Only the "closing a flat interface has no effect" warning may appear; sizes agree.
    for d in r.diagnostics:
        assert d.code == "W503", rendered
    skel = r.skeleton
    assert skel is not None

    # Counts.
    assert list(skel.nodes) == prog.node_order
    assert {n: skel.nodes[n].kind for n in skel.nodes} == {n: g.kind for n, g in prog.nodes.items()}
    expected_itfs = {ItfId(n, p) for n, g in prog.nodes.items() for p in g.paths}
    assert set(skel.interfaces) == expected_itfs
    assert len(skel.connections) == len(prog.connections)
    assert {frozenset((c.a, c.b)) for c in skel.connections} == {
        frozenset(c) for c in prog.connections
    }

    # Sizes: every interface has exactly the size it was generated with.
    for n, g in prog.nodes.items():
        for p in g.paths:
            assert skel.interfaces[ItfId(n, p)].size == g.sizes[p], (n, p, prog.text)

    # States.
    connected = {e for c in prog.connections for e in c}
    for i, itf in skel.interfaces.items():
        if i in connected:
            assert itf.state == "connected"
        elif i in prog.closed:
            assert itf.state == "closed" and itf.closing in ("collapse", "zigzag", "zigzagreturn")
        else:
            assert itf.state == "open"

    # Components, in declaration order of their first node.
    pos = {n: i for i, n in enumerate(prog.node_order)}
    expected_comps = sorted(
        (sorted(c, key=pos.__getitem__) for c in prog.components), key=lambda c: pos[c[0]]
    )
    assert skel.components() == expected_comps

    # Exactly one start per garment: the declared one, or the first free interface.
    assert len(skel.starts) == len(expected_comps)
    declared = {frozenset(prog.components[ci]): s for ci, s in prog.declared_starts.items()}
    for comp, start in zip(expected_comps, skel.starts, strict=True):
        assert start.itf.node in comp
        want = declared.get(frozenset(comp))
        if want is not None:
            assert start.itf == want and not start.inferred
        else:
            first_free = next(
                ItfId(n, p)
                for n in comp
                for p in prog.nodes[n].paths
                if ItfId(n, p) not in connected
            )
            assert start.itf == first_free and start.inferred


def test_generator_covers_splits_and_joints():
    """The generator really produces the interesting shapes (guards against a vacuous test)."""
    seen: set[str] = set()

    @settings(
        max_examples=60, deadline=None, database=None, suppress_health_check=list(HealthCheck)
    )
    @given(programs())
    def collect(prog):
        seen.update(g.kind for g in prog.nodes.values())
        if len(prog.components) > 1:
            seen.add("multi")
        if prog.defines:
            seen.add("defines")

    collect()
    assert {"sheet", "tube", "joint", "split", "multi", "defines"} <= seen


# ---- property 2: damaged programs give diagnostics, never exceptions -----------------------

NASTY = list('{}[]()#@:.,-><=!+*/%^"\\ \n\t_0123456789abcKP') + [
    "->",
    "//",
    "/*",
    "*/",
    '"""',
    "1e999",
    "0.5",
    "branches[",
    "closed(",
    "start ",
    "param ",
    "sheet ",
    "split ",
    "joint ",
    "tube ",
    "#",
    "@",
    "@a.",
    "\u00e9",
    "\u2192",
    "\x00",
    "\r",
    "\ud800",
    "9" * 30,
    "1/0",
    "^",
    "not ",
    " and ",
    "[0: 1, 1: 2]",
    "true",
    "import std.",
]


@st.composite
def mutations(draw):
    prog = draw(programs())
    text = prog.text
    for _ in range(draw(st.integers(1, 6))):
        op = draw(st.sampled_from(["insert", "delete", "replace", "duplicate", "swap"]))
        i = draw(st.integers(0, len(text)))
        j = min(len(text), i + draw(st.integers(0, 12)))
        piece = draw(st.one_of(st.sampled_from(NASTY), st.text(max_size=3)))
        if op == "insert":
            text = text[:i] + piece + text[i:]
        elif op == "delete":
            text = text[:i] + text[j:]
        elif op == "replace":
            text = text[:i] + piece + text[j:]
        elif op == "duplicate":
            text = text[:j] + text[i:j] + text[j:]
        else:
            k = draw(st.integers(0, len(text)))
            a, b = sorted((i, k))
            text = text[:a] + text[b : j if j > b else b] + text[a:b] + text[max(j, b) :]
    defines = list(prog.defines)
    if defines and draw(st.booleans()):
        k = draw(st.integers(0, len(defines) - 1))
        d = defines[k]
        cut = draw(st.integers(0, len(d)))
        defines[k] = d[:cut] + draw(st.sampled_from(NASTY)) + d[cut:]
    return text, defines


@SETTINGS
@given(mutations())
def test_mutated_programs_never_raise(case):
    text, defines = case
    r = compile_source(text, "mut.knit", defines=defines)
    # Diagnostics are complete and renderable; an error always means "not ok".
    r.diagnostics.render()
    assert r.ok == (not r.diagnostics.has_errors)
    if r.ok:
        assert r.skeleton is not None


@SETTINGS
@given(st.text(max_size=200))
def test_arbitrary_text_never_raises(text):
    r = compile_source(text, "any.knit")
    r.diagnostics.render()


# ---- inputs known to have crashed the compiler (found while writing these properties) -------


@pytest.mark.parametrize(
    "text",
    [
        pytest.param("sheet a { width: 1e999 - 1e999 }\n", id="nan-width"),
        pytest.param("param x = 1e999 * 0\ntube a { width: [0: #x, 1: 3] }\n", id="nan-profile"),
        pytest.param("param x = " + "1" * 4301 + "\n", id="huge-int-literal"),
        pytest.param("param x = 9 ^ 9 ^ 9\n", id="huge-power"),
        pytest.param("param x = 1e999\nsheet a { width: #x  length: #x }\n", id="inf"),
        pytest.param(
            "joint j { layout: 1e999 - 1e999 }\ntube a {}\na.top -> j.bottom\n", id="nan-layout"
        ),
    ],
)
def test_known_crash_inputs_never_raise(text):
    r = compile_source(text, "crash.knit")
    r.diagnostics.render()
