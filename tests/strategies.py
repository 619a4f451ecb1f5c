"""Hypothesis strategies for random, well-formed knitc ASTs.

"Well-formed" means: an AST that some source text parses to. Three things keep the
generated trees inside that set:

* names avoid every word that is a keyword somewhere (reserved or contextual) and every
  instruction mnemonic, so that a name never lexes as something else;
* numbers are non-negative, since `-1` parses as `Unary("-", Number(1))`; grids have no
  empty first or last row (the parser trims them); tuples have at least one item and a
  profile at least one point (`[]` is an empty list);
* a statement that starts with `(`, `[` or `-` never follows one that ends with an
  expression: newlines are insignificant, so `x = a` followed by `-b` *is* `x = a - b`.

Spans are left at their defaults; the AST compares without them.
"""

from __future__ import annotations

from hypothesis import strategies as st

from knitc.frontend import ast
from knitc.frontend.fmt import format_expr

# The 17 pattern instructions; those that look like names are kept out of generated names.
INSTRUCTIONS = tuple("K P T M S FR1 FR2 FL1 FL2 BR1 BR2 BL1 BL2 XR+ XR- XL+ XL-".split())
RESERVED = frozenset(
    "if else for in and or not true false".split()  # reserved where the parser sees them
    + "import param machine sheet tube joint split pattern action shaper start open closed set "
    "use apply where let pre main post draw stretch tile".split()  # contextual keywords
    + [i for i in INSTRUCTIONS if i.isalnum()]
)
GRID_CELLS = INSTRUCTIONS + (".", "-", "x", "o", "K2", "|", "//", "/*")
BINARY_OPS = ("+", "-", "*", "/", "%", "^", "==", "!=", "<", "<=", ">", ">=", "and", "or")

_FIRST = "abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ_"
# Names that are close to keywords or mnemonics without being one.
_TRICKY = tuple(
    "x i n _ XR XL Kx FR FR3 K_ iff orx format starts sets before after range bottom top "
    "width length".split()
)
names = st.one_of(
    st.sampled_from(_TRICKY),
    st.builds(
        lambda first, rest: first + rest,
        st.sampled_from(_FIRST),
        st.text(_FIRST + "0123456789", max_size=5),
    ).filter(lambda s: s not in RESERVED),
)


def idents() -> st.SearchStrategy[ast.Ident]:
    return st.builds(ast.Ident, names)


# ---- expressions -------------------------------------------------------------------------

numbers = st.builds(
    ast.Number,
    st.one_of(
        st.integers(min_value=0, max_value=10**20),
        st.floats(min_value=0, max_value=1e300),  # beyond 1e300 a literal is E110
    ),
)
texts = st.text(st.characters(exclude_categories=("Cs",)), max_size=8)
strings = st.builds(ast.String, texts)


@st.composite
def grids(draw) -> ast.Grid:
    cell = st.builds(ast.GridCell, st.sampled_from(GRID_CELLS))
    full_row = st.lists(cell, min_size=1, max_size=5).map(tuple)
    rows = draw(st.lists(st.one_of(full_row, st.just(())), max_size=4))
    first = draw(full_row)
    last = [draw(full_row)] if rows or draw(st.booleans()) else []
    return ast.Grid(tuple([first, *rows, *last]))


leaves = st.one_of(
    numbers,
    strings,
    st.builds(ast.Bool, st.booleans()),
    st.builds(ast.ParamRef, names),
    st.builds(ast.PropRef, st.none() | names, names),
    st.builds(ast.Name, names),
)


def _compound(children: st.SearchStrategy) -> st.SearchStrategy:
    small = st.lists(children, max_size=3).map(tuple)
    args = st.lists(
        st.one_of(
            children,
            st.builds(ast.Range, children, children, st.none() | children),
            st.builds(ast.KwArg, idents(), children),
        ),
        max_size=3,
    ).map(tuple)
    return st.one_of(
        st.builds(ast.ListExpr, small),
        st.builds(
            ast.Profile,
            st.lists(st.builds(ast.ProfilePoint, children, children), min_size=1, max_size=3).map(
                tuple
            ),
        ),
        st.builds(ast.TupleExpr, st.lists(children, min_size=1, max_size=3).map(tuple)),
        st.builds(ast.Unary, st.sampled_from(("-", "not")), children),
        st.builds(ast.Binary, st.sampled_from(BINARY_OPS), children, children),
        st.builds(ast.Call, children, args),
        st.builds(ast.Attr, children, idents()),
        st.builds(ast.Index, children, children),
    )


def exprs(max_leaves: int = 12, with_grids: bool = True) -> st.SearchStrategy:
    """Any expression. Grids are slow to generate, so nested ones are optional."""
    base = st.one_of(leaves, grids()) if with_grids else leaves
    return st.recursive(base, _compound, max_leaves=max_leaves)


def values(max_leaves: int = 6) -> st.SearchStrategy:
    """The expression of a property, statement or argument: now and then a grid in it."""
    return st.one_of(exprs(max_leaves, with_grids=False), exprs(max_leaves, with_grids=True))


def plain(max_leaves: int) -> st.SearchStrategy:
    return exprs(max_leaves, with_grids=False)


def args() -> st.SearchStrategy[tuple]:
    e = plain(6)
    return st.lists(
        st.one_of(
            e,
            st.builds(ast.Range, e, e, st.none() | e),
            st.builds(ast.KwArg, idents(), e),
        ),
        max_size=3,
    ).map(tuple)


# ---- statements --------------------------------------------------------------------------


def _ends_with_expr(stmt) -> bool:
    return isinstance(stmt, ast.Let | ast.Assign | ast.MapStmt | ast.ExprStmt)


def _starts_with_operator(stmt) -> bool:
    first = (
        stmt.src
        if isinstance(stmt, ast.MapStmt)
        else (stmt.expr if isinstance(stmt, ast.ExprStmt) else None)
    )
    return first is not None and format_expr(first)[:1] in ("(", "[", "-")


def _separable(stmts: list) -> tuple:
    """Drop statements that would merge with the one before them."""
    out: list = []
    for s in stmts:
        if out and _ends_with_expr(out[-1]) and _starts_with_operator(s):
            continue
        out.append(s)
    return tuple(out)


def _simple_stmts(e) -> st.SearchStrategy:
    return st.one_of(
        st.builds(ast.Let, idents(), e),
        st.builds(ast.Assign, idents(), e),
        st.builds(ast.MapStmt, e, e),
        st.builds(ast.ExprStmt, e),
    )


def _nested(children: st.SearchStrategy) -> st.SearchStrategy:
    e = plain(4)
    block = st.lists(children, max_size=3).map(_separable).map(ast.Block)
    else_if = st.builds(ast.If, e, block, st.none() | block)
    return st.one_of(
        st.builds(ast.For, idents(), e, block),
        st.builds(ast.If, e, block, st.none() | block | else_if),
    )


def stmts(max_leaves: int = 6) -> st.SearchStrategy:
    """Any program statement, `if` and `for` nested to any depth."""
    return st.recursive(_simple_stmts(values(4)), _nested, max_leaves=max_leaves)


def blocks(max_leaves: int = 6) -> st.SearchStrategy[ast.Block]:
    return st.lists(stmts(max_leaves), max_size=4).map(_separable).map(ast.Block)


where = st.none() | plain(5)

layer_stmts = st.one_of(
    st.builds(ast.SetStmt, st.sampled_from(INSTRUCTIONS), where),
    st.builds(ast.UseStmt, idents(), where),
    st.builds(ast.ApplyStmt, idents(), args(), where),
    st.builds(
        ast.GridStmt,
        st.sampled_from(("draw", "stretch", "tile")),
        st.one_of(grids(), values(4)),
        where,
    ),
    st.builds(ast.Let, idents(), values(6)),
)
layer_bodies = st.lists(layer_stmts, max_size=4).map(tuple)


# ---- items -------------------------------------------------------------------------------

props = st.builds(ast.Prop, idents(), values(6))
prop_lists = st.lists(props, max_size=4).map(tuple)
param_defs = st.lists(st.builds(ast.ParamDef, idents(), st.none() | plain(4)), max_size=3).map(
    tuple
)
itf_refs = st.builds(
    ast.ItfRef,
    idents(),
    st.one_of(st.sampled_from(("bottom", "top", "base", "branches")), names).map(ast.Ident),
    st.none() | plain(3),
)


@st.composite
def itf_stmts(draw) -> ast.ItfStmt:
    state = draw(st.sampled_from((None, "open", "closed")))
    closing = draw(st.none() | idents()) if state == "closed" else None
    block = draw(prop_lists) if state is None else draw(st.none() | prop_lists)
    return ast.ItfStmt(draw(itf_refs), state, closing, block)


imports = st.one_of(
    st.builds(
        ast.Import,
        st.lists(names, min_size=1, max_size=3).map(tuple),
        st.none(),
        st.none() | st.lists(idents(), min_size=1, max_size=3).map(tuple),
    ),
    st.builds(
        ast.Import,
        st.none(),
        texts,
        st.none() | st.lists(idents(), min_size=1, max_size=3).map(tuple),
    ),
)

action_items = st.lists(
    st.one_of(
        props,
        st.builds(ast.ActionStep, st.sampled_from(("pre", "main", "post")), blocks(4)),
    ),
    max_size=4,
).map(tuple)

items = st.one_of(
    imports,
    st.builds(ast.ParamDecl, idents(), exprs()),
    st.builds(ast.MachineDecl, prop_lists),
    st.builds(
        ast.NodeDecl, st.sampled_from(("sheet", "tube", "joint", "split")), idents(), prop_lists
    ),
    itf_stmts(),
    st.builds(ast.Connect, itf_refs, itf_refs),
    st.builds(ast.Start, itf_refs),
    st.builds(ast.PatternLayer, idents(), layer_bodies),
    st.builds(ast.PatternDef, idents(), param_defs, layer_bodies),
    st.builds(ast.ActionDef, idents(), action_items),
    st.builds(ast.ShaperDef, idents(), param_defs, blocks()),
)


def modules(min_items: int = 0) -> st.SearchStrategy[ast.Module]:
    """A whole file: up to six items of any kind."""
    return st.builds(ast.Module, st.lists(items, min_size=min_items, max_size=6).map(tuple))
