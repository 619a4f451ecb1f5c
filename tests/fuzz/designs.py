"""Grammar-aware generation for the fuzzers: whole designs across the language.

`designs()` starts from `programs()` of test_props_resolve.py (random valid garments: trees
of sheets, tubes, joints and splits with consistent sizes, `-D` overrides, casting, starts)
and adds what that generator leaves out: pattern layers with every statement kind (`set`,
`use`, `apply`, `draw`/`stretch`/`tile`, `let`, `knit YARN` and the `std.colour` charts,
`backing KIND` and `intarsia`, with yarns declared on free, shared or the main carrier, some
plated or laid in) over random queries (every query of the
language's table, chained and combined, with ranges of every form), imported stdlib
patterns with random arguments, user actions (every machine operation, `if`/`for`), user
shapers on extra shaped pieces, and a `machine` block. Values are drawn from in-range and
out-of-range sets alike, so a generated design is sometimes an error: the target only
demands that knitc answers (exit 0 or 1) without a bug.

The strategy is driven by the fuzzer's bytes through hypothesis'
`fuzz_one_input`, so libFuzzer's coverage feedback steers the choices.
"""

from __future__ import annotations

from dataclasses import dataclass

from hypothesis import strategies as st

from strategies import INSTRUCTIONS
from test_props_resolve import programs
from test_stdlib_patterns import stdlib_patterns

ACTIONS = ["knit", "purl", "tuck", "miss", "kickback", "split"]
STD_PATTERNS = {m: stdlib_patterns(m) for m in ("std.stitches", "std.motifs")}
STD_COLOUR = ["peerie", "checks", "diamonds"]
YARNS = ["main", "red", "blue"]
BACKINGS = ["float", "tubular", "birdseye", "pique", "horizontal", "vertical", "none", "nope"]
STD_SHAPERS = ["zigzag", "edges"]
_HOSTILE = ["1e999", "10^20", "10^400", "1e-320", "0.0", "1e300 * 10", "0 - 10^30"]
NUMBERS = st.integers(0, 63).flatmap(
    lambda k: (
        st.sampled_from(_HOSTILE)  # one number in 64: the rest can reach the back end
        if k == 0
        else st.one_of(
            st.integers(-3, 12).map(str),
            st.sampled_from(["0.5", "0.25", "-0.5", "1.5", "end", "end - 1", "#n"]),
        )
    )
)


@dataclass
class Design:
    text: str
    defines: list[str]


def _range(draw) -> str:
    a = draw(NUMBERS)
    form = draw(st.sampled_from(["one", "ab", "asb", "ab"]))
    if form == "one":
        return a
    b = draw(NUMBERS)
    if form == "ab":
        return f"{a}:{b}"
    return f"{a}:{draw(st.sampled_from(['1', '2', '3', '0', '-1']))}:{b}"


def _grid(draw, cells: list[str]) -> str:
    w = draw(st.integers(1, 4))
    h = draw(st.integers(1, 3))
    rows = [" ".join(draw(st.sampled_from(cells)) for _ in range(w)) for _ in range(h)]
    return '"""\n    ' + "\n    ".join(rows) + '\n  """'


def _query(draw, nodes: list[str], depth: int = 0) -> str:
    leaves = [
        lambda: "all()",
        lambda: f"courses({_range(draw)})",
        lambda: f"wales({_range(draw)})",
        lambda: f"wales({_range(draw)}, {draw(st.sampled_from(['front', 'back']))})",
        lambda: f"select({_range(draw)}, {_range(draw)})",
        lambda: f"side({draw(st.sampled_from(['front', 'back']))})",
        lambda: "boundaries()",
        lambda: "named()",
        lambda: f'shape("{draw(st.sampled_from(nodes))}")',
        lambda: f'itf("{draw(st.sampled_from(nodes))}.{draw(st.sampled_from(["top", "bottom"]))}")',
        lambda: f"filter({_predicate(draw)})",
        lambda: f"noise({draw(NUMBERS)}, threshold = {draw(st.sampled_from(['0.3', '0.7', '2']))})",
        lambda: f"stitch_grid({draw(NUMBERS)}, {draw(NUMBERS)})",
        lambda: "wale_grid()",
        lambda: f"tile({_grid(draw, ['x', '.'])})",
        lambda: f"stretch({_grid(draw, ['x', '.', '1'])})",
    ]
    q = draw(st.sampled_from(leaves))()
    if depth < 2 and draw(st.booleans()):
        how = draw(st.sampled_from(["and", "or", "-", "not", ".neighbors", ".inverse", ".bound"]))
        if how == ".neighbors":
            q = f"{q}.neighbors({_range(draw)})"
        elif how == ".inverse":
            q = f"{q}.inverse()"
        elif how == ".bound":
            q = f"{q}.boundaries()"
        elif how == "not":
            q = f"not {q}"
        else:
            q = f"({q}) {how} ({_query(draw, nodes, depth + 1)})"
    return q


def _predicate(draw) -> str:
    field = draw(
        st.sampled_from(["course", "wale", "course_end", "wale_end", "side", "gauge", "index"])
    )
    op = draw(st.sampled_from(["%", "+", "*", "/", "-"]))
    cmp = draw(st.sampled_from(["==", "<", ">=", "!="]))
    return f"{field} {op} {draw(NUMBERS)} {cmp} {draw(NUMBERS)}"


def _pattern_stmt(draw, nodes: list[str], actions: list[str], pats: list[tuple[str, str]]) -> str:
    where = "" if draw(st.integers(0, 4)) == 0 else f" where {_query(draw, nodes)}"
    kind = draw(
        st.sampled_from(["set", "set", "set", "use", "apply", "draw", "let", "knit", "colour"])
    )
    if kind == "colour":  # jacquard (E719 on a full-gauge tube), intarsia (E730, E731, E732)
        if draw(st.booleans()):
            return f"backing {draw(st.sampled_from(BACKINGS))}{where}"
        return f"intarsia{where}"
    if kind == "knit":  # stripes, fair isle, or a mixed course it refuses (E711)
        if draw(st.integers(0, 2)) == 0:
            chart = draw(st.sampled_from(STD_COLOUR))
            return f'apply {chart}("{draw(st.sampled_from([*YARNS, "nope"]))}"){where}'
        return f"knit {draw(st.sampled_from([*YARNS, 'nope']))}{where}"
    if kind == "set":
        return f"set {draw(st.sampled_from(INSTRUCTIONS))}{where}"
    if kind == "use":
        return f"use {draw(st.sampled_from(ACTIONS + actions))}{where}"
    if kind == "apply" and pats:
        _, name = draw(st.sampled_from(pats))
        n_args = draw(st.sampled_from([0, 0, 1, 1, 2, 3]))  # mostly in range, sometimes not
        args = ", ".join(str(draw(st.integers(1, 6))) for _ in range(n_args))
        return f"apply {name}({args}){where}"
    if kind == "let":
        return f"let sel{draw(st.integers(0, 3))} = {_query(draw, nodes)}"
    layer = draw(st.sampled_from(["draw", "stretch", "tile"]))
    cells = [*INSTRUCTIONS, ".", ".", "K", "P"]
    if layer == "stretch" and draw(st.integers(0, 5)):  # crosses cannot stretch (E315)
        cells = [c for c in cells if not c.startswith("X")]
    return f"{layer} {_grid(draw, cells)}{where}"


_ACTION_CALLS = [
    "knit(dir)",
    "knit(dir, opposite, carriers)",
    "tuck(dir)",
    "miss(dir)",
    "kickback(dir)",
    "split(dir, needle, opposite, carriers)",
    "xfer(needle, opposite)",
    "xfer(opposite, needle)",
    "rack(1)",
    "rack(0)",
    "rack(0.25)",
    "drop(needle)",
    "knit(dir, needle + 1, carriers)",
    "xfer(needle, opposite + 1)",
]


def _action(draw, name: str) -> str:
    def step() -> str:
        calls = draw(st.lists(st.sampled_from(_ACTION_CALLS), min_size=1, max_size=3))
        body = "  ".join(calls)
        if draw(st.booleans()):
            body = f"if stitch.course % 2 == 0 {{ {body} }} else {{ knit(dir) }}"
        if draw(st.integers(0, 5)) == 0:
            body = f"for i in range({draw(NUMBERS)}) {{ {body} }}"
        return body

    props = draw(st.sampled_from(["", "split_by_side: true", "transfer_back: false"]))
    steps = [f"main {{ {step()} }}"]
    if draw(st.booleans()):
        steps.insert(0, f"pre {{ {step()} }}")
    if draw(st.booleans()):
        steps.append(f"post {{ {step()} }}")
    return f"action {name} {{\n  {props}\n  " + "\n  ".join(steps) + "\n}"


def _shaper(draw, name: str) -> str:
    forms = [
        "let d = N - M\n  for i in range(M) {\n    if i < d { i -> (2 * i, 2 * i + 1) } else { i -> i + d }\n  }",
        "let d = N - M\n  for i in range(M) {\n    if i >= M - d { i -> (2 * i - M + d, 2 * i - M + d + 1) } else { i -> i }\n  }",
        "for i in range(M) { i -> i }",
        f"for i in range(M) {{ i -> i + {draw(st.integers(0, 2))} }}",
        "let d = N - M\n  for i in range(N) {\n    if i < 2 * d { if i % 2 == 0 { (i, i + 1) -> i / 2 } } else { i -> i - d }\n  }",
    ]
    return f"shaper {name}(M, N) {{\n  {draw(st.sampled_from(forms))}\n}}"


def _machine(draw) -> str:
    props = draw(
        st.lists(
            st.sampled_from(
                [
                    "increase: split",
                    "increase: kickback",
                    "cast_on: tuck",
                    "cast_on: precast",
                    "cast_on: kickback",
                    "cast_off: direct",
                    "cast_off: reverse",
                    "cast_off: none",
                    "slice_shaping: 1",
                    "slice_shaping: 8",
                    "gauge: half",
                    "carriers: [3, 5]",
                    "carriers: 6",
                    "racking: 2",
                    "needles: 200",
                ]
            ),
            max_size=3,
            unique_by=lambda s: s.split(":")[0],
        )
    )
    return "machine { " + "  ".join(props) + " }" if props else ""


@st.composite
def designs(draw) -> Design:
    prog = draw(programs())
    nodes = list(prog.nodes)
    items: list[str] = [prog.text]
    pats: list[tuple[str, str]] = []
    for module, names in STD_PATTERNS.items():
        if draw(st.booleans()):
            chosen = draw(st.lists(st.sampled_from(names), min_size=1, max_size=3, unique=True))
            items.insert(0, f"import {module} ({', '.join(chosen)})")
            pats += [(module, n) for n in chosen]
    actions = []
    for i in range(draw(st.integers(0, 2))):
        actions.append(f"act{i}")
        items.append(_action(draw, f"act{i}"))
    for i in range(draw(st.integers(0, 2))):
        # a pattern definition of the design's own, its parameters read by its queries
        body = [
            f"set {draw(st.sampled_from(INSTRUCTIONS))} where filter(wale % a == 0)",
            f"set P where courses(0:b) and {_query(draw, nodes, 1)}",
            *(_pattern_stmt(draw, nodes, actions, pats) for _ in range(draw(st.integers(0, 2)))),
        ]
        items.append(f"pattern def{i}(a = 2, b = 1) {{\n  " + "\n  ".join(body) + "\n}")
        pats.append(("", f"def{i}"))
    for i in range(draw(st.integers(0, 2))):
        # an extra piece of its own, shaped by a user shaper or a stdlib one
        shaper = f"shp{i}"
        if draw(st.booleans()):
            items.append(_shaper(draw, shaper))
        else:
            shaper = draw(st.sampled_from(STD_SHAPERS))
            items.insert(0, f"import std.shapers ({shaper})")
        a, b = draw(st.integers(2, 12)), draw(st.integers(2, 24))
        kind = draw(st.sampled_from(["sheet", "tube"]))
        gauge = draw(st.sampled_from(["", "gauge: half", "gauge: full"]))
        items.append(
            f"{kind} x{i} {{ length: {draw(st.integers(1, 16))}  width: [0: {a}, 1: {b}]  "
            f"shaper: {shaper}  {gauge} }}"
        )
        nodes.append(f"x{i}")
    for _ in range(draw(st.integers(0, 3))):
        target = draw(st.sampled_from([*nodes, "before", "after"]))
        body = [_pattern_stmt(draw, nodes, actions, pats) for _ in range(draw(st.integers(1, 5)))]
        items.append(f"pattern {target} {{\n  " + "\n  ".join(body) + "\n}")
    if "machine {" not in prog.text and draw(st.booleans()):
        items.append(_machine(draw))
    text_so_far = "\n".join(items)
    if "knit " in text_so_far or '("' in text_so_far:  # the yarns its layers name
        items.insert(0, "import std.colour")
        for name in YARNS[1:]:
            carrier = draw(st.sampled_from(["", "carrier: 5", "carrier: 6", "carrier: 3"]))
            extra = draw(
                st.sampled_from(
                    ["", "carry_up: 0", "carry_up: 3", "tuck_every: 4", "plating: 8", "inlay: 3"]
                )
            )
            items.append(f"yarn {name} {{ {carrier}  {extra} }}")
    order = list(draw(st.permutations(items[1:])) if draw(st.booleans()) else items[1:])
    if "#n" in "".join(order):
        order.append(f"param n = {draw(st.integers(0, 6))}")
    text = "\n".join([items[0], *order]) + "\n"
    return Design(text, prog.defines)


def fuzz_one(save=None):
    """The `design` target as a function of the fuzzer's bytes: the bytes choose a design
    (hypothesis' `fuzz_one_input`), which must compile or be refused with diagnostics."""
    import targets
    from hypothesis import HealthCheck, given, settings

    @settings(database=None, deadline=None, suppress_health_check=list(HealthCheck))
    @given(designs())
    def check(d: Design) -> None:
        try:
            targets.compile_text(d.text, d.defines, save=save)
        except targets.Bug as bug:  # the reproducer is the design, not the fuzzer's bytes
            flags = " ".join(f"-D {x}" for x in d.defines)
            raise targets.Bug(
                f"{bug}\n--- the design (knitc {flags} design.knit):\n{d.text}"
            ) from None

    def one(data: bytes) -> None:
        check.hypothesis.fuzz_one_input(data)

    return one
