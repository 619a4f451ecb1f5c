"""One compiled scanner for all of the contextual lexer's parser states.

Lark's contextual lexer gives every parser state a scanner of its own: one regular
expression of the terminals that state accepts, compiled by Python's `re` (whose compiler
is written in Python) when the state first lexes a token. A small design meets some forty
states, and compiling their scanners was the largest single cost of parsing it, larger
than the parse.

`share_root_scanner` lets every state first ask the scanner of *all* terminals (Lark's
root lexer, compiled once), and take its match when the terminal it matched is one the
state accepts. That match is the state's own: the state's scanner tries the same
terminals in the same order (Lark sorts them by priority, width and name), less those
it does not accept, so a terminal the root scanner reached first after all the earlier
ones failed is also the first the state's scanner reaches. Only a match of a terminal the
state does not accept falls back to the state's scanner (compiled then, as before), which
is rare in a design that parses. Keywords are the one difference between the scanners:
Lark folds a keyword into the NAME terminal that matches it and re-types the token
afterwards (its "unless" callback), and each state folds only the keywords it accepts, so
each state gets that callback here from the root's keyword list (a dict, not a compiled
scanner of its own). A state that accepts a keyword but not NAME keeps the keyword on its
own scanner; there the root returns NAME, which that state does not accept, and the state's
scanner decides, as long as NAME comes first in the order and matches wherever the keyword's
text stands (`_shareable` checks this of the grammar, and nothing is shared otherwise).
tests/test_parser.py holds the token stream, comments included, to Lark's own lexer on
every design, library module and fuzz input of the repository, whole and cut short.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from lark.lexer import BasicLexer, CallChain, ContextualLexer, Token, UnlessCallback


class _Keywords:
    """A state's keyword callback: a token whose text is a keyword the state accepts takes
    that keyword's type (what Lark's UnlessCallback does with a compiled scanner)."""

    def __init__(self, keywords: dict[str, str]) -> None:
        self.keywords = keywords

    def __call__(self, t: Token) -> Token:
        kind = self.keywords.get(t.value)
        if kind is not None:
            t.type = kind
        return t


def share_root_scanner(lexer: ContextualLexer) -> None:
    """Make each state of `lexer` try the root lexer's scanner first (module docstring)."""
    root = lexer.root_lexer
    assert isinstance(root, BasicLexer)
    root_match = root.match
    _ = root.scanner  # (built now, and with it the root's keyword folds)
    folded = {  # (a folding terminal with a user callback has a CallChain: `_shareable`)
        name: {t.pattern.value: t.name for t in cb.scanner.terminals}
        for name, cb in root.callback.items()
        if isinstance(cb, UnlessCallback)
    }
    if not _shareable(root, folded):
        return  # (Lark's own lexer, a scanner per state)
    done: set[int] = set()
    for state_lexer in lexer.lexers.values():
        if id(state_lexer) in done or not isinstance(state_lexer, BasicLexer):
            continue
        done.add(id(state_lexer))
        _share(state_lexer, root_match, folded)


def _shareable(root: BasicLexer, folded: dict[str, dict[str, str]]) -> bool:
    """Whether the grammar is one the module docstring's argument holds for. A state that
    accepts a keyword but not the NAME-like terminal the root folds it into finds it on its
    own scanner, as Lark would, only if the root, where the keyword's text matches, returns
    that terminal (or one the state's scanner also tries first): so the folding terminal
    must come before its keywords in the terminals' order and match wherever their text
    stands (no lookaround, no anchor). Keywords are re-typed here by exact text, as Lark's
    full match of a keyword without flags does; and a user callback on a folding terminal
    (chained with the keyword callback by Lark) is not re-made here."""
    order = {t.name: i for i, t in enumerate(root.terminals)}
    by_name = {t.name: t for t in root.terminals}
    if any(isinstance(cb, CallChain) for cb in root.callback.values()):
        return False
    for name, keywords in folded.items():
        regexp = by_name[name].pattern
        if regexp.flags or any(c in regexp.value for c in ("(?", "$", "^", "\\b", "\\B")):
            return False
        for kind in keywords.values():
            if by_name[kind].pattern.flags or order[kind] < order[name]:
                return False
    return True


def _share(
    lexer: BasicLexer,
    root_match: Callable[[Any, int], tuple[str, str] | None],
    folded: dict[str, dict[str, str]],
) -> None:
    accepts = frozenset(t.name for t in lexer.terminals)
    callback: dict[str, Any] = {}
    for name, keywords in folded.items():
        if name in accepts:
            mine = {v: k for v, k in keywords.items() if k in accepts}
            if mine:
                callback[name] = _Keywords(mine)
    callback.update(lexer.user_callbacks)  # (none on a folding terminal: `_shareable`)
    lexer.callback = callback

    def match(text: Any, pos: int) -> tuple[str, str] | None:
        res = root_match(text, pos)
        if res is not None and res[1] in accepts:
            return res
        return lexer.scanner.match(text, pos)  # (its own scanner and callbacks, built now)

    lexer.match = match  # type: ignore[method-assign]
