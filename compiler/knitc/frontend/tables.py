"""The parser's LALR tables, kept between runs as JSON.

Building the tables from `knit.lark` is most of a small design's start-up (about 80 ms, more
than parsing, resolving and shaping it). Lark's own `cache=` option stores them as Python
objects that loading would rebuild, code included, which knitc never does (docs/security.md);
the tables are plain data, so they are written here as JSON and read back with Lark's loader
for serialized parsers (the one its standalone generator uses). Lark's serialized form has
integer-keyed dicts and tuples, which JSON lacks: they travel as tagged objects and come
back as they were.

The file lives in the user's own cache folder (`$XDG_CACHE_HOME/knitc`, else
`~/.cache/knitc`), used only when that folder is theirs alone (mode 0700), so no other user
can hand this process a grammar. Its name carries a hash of the grammar, the options and
Lark's version: a changed grammar or a new Lark builds afresh. Anything wrong with the file
(missing, truncated, from another version) means building the tables as before and writing
the file again; `KNITC_NO_CACHE=1` turns the file off altogether.
"""

from __future__ import annotations

import hashlib
import json
import os
import stat
import tempfile
from collections.abc import Callable
from typing import Any

import lark
from lark import Lark
from lark.grammar import Rule
from lark.lexer import TerminalDef

_INT_KEYS = "__int_keys__"
_TUPLE = "__tuple__"


def _encode(value: Any) -> Any:
    if isinstance(value, dict):
        if all(isinstance(k, str) for k in value):
            return {k: _encode(v) for k, v in value.items()}
        return {_INT_KEYS: [[k, _encode(v)] for k, v in value.items()]}
    if isinstance(value, tuple):
        return {_TUPLE: [_encode(v) for v in value]}
    if isinstance(value, list):
        return [_encode(v) for v in value]
    if value is None or isinstance(value, (str, int, float, bool)):
        return value
    raise TypeError(f"not table data: {type(value).__name__}")


def _decode(obj: dict[str, Any]) -> Any:
    if _INT_KEYS in obj:
        return {k: v for k, v in obj[_INT_KEYS]}
    if _TUPLE in obj:
        return tuple(obj[_TUPLE])
    return obj


def _folder() -> str | None:
    if os.environ.get("KNITC_NO_CACHE"):
        return None
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    folder = os.path.join(base, "knitc")
    try:
        os.makedirs(folder, mode=0o700, exist_ok=True)
        st = os.stat(folder, follow_symlinks=False)
    except OSError:
        return None
    mine = stat.S_ISDIR(st.st_mode) and st.st_uid == os.getuid() and not st.st_mode & 0o077
    return folder if mine else None


def table_file(grammar: str, options: dict[str, Any]) -> str | None:
    """Where the tables for this grammar, these options and this Lark are kept (None: not
    kept). `options` are the ones that shape the tables, not callbacks."""
    folder = _folder()
    if folder is None:
        return None
    key = json.dumps([grammar, sorted(options.items()), lark.__version__])
    digest = hashlib.sha256(key.encode("utf-8")).hexdigest()[:24]
    return os.path.join(folder, f"knit-lalr-{digest}.json")


def load_lark(
    grammar: str, options: dict[str, Any], callbacks: dict[str, Callable[..., Any]]
) -> Lark:
    """A Lark LALR parser for `grammar`, its tables read from the cache file when it is
    good and built (then written there) when not. `callbacks` are the lexer callbacks, which
    are code and so are never stored."""
    path = table_file(grammar, options)
    if path is not None:
        try:
            with open(path, encoding="utf-8") as f:
                doc = json.load(f, object_hook=_decode)
            return Lark._load_from_dict(doc["data"], doc["memo"], lexer_callbacks=callbacks)
        except Exception:  # missing, unreadable or not ours: build the tables below
            pass
    parser = Lark(grammar, **options, lexer_callbacks=callbacks)
    if path is not None:
        _write(path, parser)
    return parser


def _write(path: str, parser: Lark) -> None:
    """Write the tables atomically (a reader sees the old file or the whole new one)."""
    data, memo = parser.memo_serialize([TerminalDef, Rule])
    data["options"].pop("lexer_callbacks", None)
    try:
        text = json.dumps({"data": _encode(data), "memo": _encode(memo)}, separators=(",", ":"))
        fd, tmp = tempfile.mkstemp(dir=os.path.dirname(path), prefix=".knit-lalr-")
    except (OSError, TypeError):
        return  # the cache is an optimisation: a full disk or odd data costs only speed
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as f:
            f.write(text)
        os.replace(tmp, path)
    except OSError:
        try:
            os.unlink(tmp)
        except OSError:
            pass
