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


def _mine(st: os.stat_result) -> bool:
    return st.st_uid == os.getuid() and not st.st_mode & 0o077


def _folder() -> str | None:
    """The cache folder, made if its parent is there and the user's own; None (no file)
    when the cache is off, the base folder is relative (XDG says to ignore it) or there is
    no home to resolve, or the folder is not the user's alone."""
    if os.environ.get("KNITC_NO_CACHE"):
        return None
    base = os.environ.get("XDG_CACHE_HOME") or ""
    if not os.path.isabs(base):
        home = os.path.expanduser("~")
        if not os.path.isabs(home):  # no HOME and no passwd entry: never the cwd
            return None
        base = os.path.join(home, ".cache")
    folder = os.path.join(base, "knitc")
    try:
        if not os.path.lexists(folder):
            if not os.path.lexists(base):  # a new account has no ~/.cache: XDG says to
                _make_own(base)  # make it, mode 0700, as every other tool would
            _make_own(folder)
        st = os.stat(folder, follow_symlinks=False)
    except OSError:
        return None
    return folder if stat.S_ISDIR(st.st_mode) and _mine(st) else None


def _make_own(path: str) -> None:
    """Make the folder `path` (mode 0700) if its parent is the user's own: a root run must
    not leave root's folders in another user's home (sudo keeps HOME)."""
    if os.stat(os.path.dirname(path)).st_uid != os.getuid():
        raise OSError(f"{os.path.dirname(path)} is not the user's own")
    os.mkdir(path, 0o700)


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
            return _load(path, callbacks)
        except Exception:  # missing, unreadable or not ours: build the tables below
            pass
    parser = Lark(grammar, **options, lexer_callbacks=callbacks)
    if path is not None:
        _write(path, parser)
    return parser


def _load(path: str, callbacks: dict[str, Callable[..., Any]]) -> Lark:
    """The parser from the file at `path`, which must be a regular file of the user's own,
    not reached through a symlink (the folder was checked; this closes the gap between that
    check and the open)."""
    fd = os.open(path, os.O_RDONLY | getattr(os, "O_NOFOLLOW", 0))
    with os.fdopen(fd, encoding="utf-8") as f:
        st = os.fstat(f.fileno())
        if not stat.S_ISREG(st.st_mode) or not _mine(st):
            raise OSError(f"{path} is not the user's own regular file")
        doc = json.load(f, object_hook=_decode)
    return Lark._load_from_dict(doc["data"], doc["memo"], lexer_callbacks=callbacks)


def _write(path: str, parser: Lark) -> None:
    """Write the tables atomically (a reader sees the old file or the whole new one), and
    remove the files of other grammars or Lark versions (and temporary files a killed run
    left), so the folder holds one set of tables."""
    data, memo = parser.memo_serialize([TerminalDef, Rule])
    # (a copy: memo_serialize hands out the live parser's own options)
    data = {**data, "options": {k: v for k, v in data["options"].items() if k != "lexer_callbacks"}}
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
        return
    folder, name = os.path.split(path)
    try:
        stale = [
            e
            for e in os.listdir(folder)
            if e != name and e.startswith(("knit-lalr-", ".knit-lalr-"))
        ]
        for e in stale:
            os.unlink(os.path.join(folder, e))
    except OSError:
        pass
