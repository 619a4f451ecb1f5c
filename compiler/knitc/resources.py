"""Access to knitc's package data: the Lark grammar and the ``std`` standard library.

The grammar (``grammars/*.lark`` in the repository) and the standard library
(``stdlib/std/**/*.knit``) are installed as the subpackages ``knitc.grammars`` and
``knitc.stdlib`` (``package-dir`` in pyproject.toml). Always reach them through this module,
which uses :mod:`importlib.resources`, and never through paths computed from ``__file__``
or the repository layout: the layout of the repository and of an installed package differ
(``grammars/`` is not next to ``compiler/knitc/`` in the repository), and importlib.resources
finds the files in every way knitc can be installed:

* a regular (wheel) install, ``pip install .``: the files are copied into
  ``site-packages/knitc/grammars`` and ``site-packages/knitc/stdlib``;
* an editable install, ``pip install -e .``: setuptools' import hook maps
  ``knitc.grammars`` to ``<repo>/grammars`` and ``knitc.stdlib`` to ``<repo>/stdlib``, so
  edits to the grammar or the stdlib are seen without reinstalling;
* a zip or other non-filesystem importer, where no real path exists at all.
"""

from __future__ import annotations

from importlib.resources import files
from importlib.resources.abc import Traversable

__all__ = ["grammar_text", "stdlib_module", "stdlib_root"]

_GRAMMARS = "knitc.grammars"
_STDLIB = "knitc.stdlib"


def grammar_text(name: str = "knit.lark") -> str:
    """Return the text of the grammar file *name* shipped in ``knitc.grammars``.

    Reading the text (rather than passing a file path to Lark) works the same in wheel,
    editable and zipped installs. Raises :class:`FileNotFoundError` if there is no such
    grammar.
    """
    resource = files(_GRAMMARS).joinpath(name)
    if not resource.is_file():
        raise FileNotFoundError(f"knitc grammar {name!r} is not installed in {_GRAMMARS}")
    return resource.read_text(encoding="utf-8")


def stdlib_root() -> Traversable:
    """Return the root of the standard library, the directory that holds ``std/``.

    A module ``std.stitches`` is the file ``stdlib_root() / "std" / "stitches.knit"``.

    The result is an :class:`importlib.resources.abc.Traversable`, not necessarily a
    :class:`pathlib.Path`: in wheel and editable installs it is in fact a ``pathlib.Path``
    (to ``site-packages/knitc/stdlib`` and ``<repo>/stdlib`` respectively), but code should
    only rely on the Traversable API (``joinpath``, ``/``, ``iterdir``, ``is_file``,
    ``is_dir``, ``read_text``, ``name``). Where a real filesystem path is unavoidable, use
    :func:`importlib.resources.as_file`.
    """
    return files(_STDLIB)


def stdlib_module(module: str) -> Traversable:
    """Return the Traversable for the stdlib module *module*, e.g. ``"std.stitches"``.

    The result may not exist; check ``.is_file()``. This only maps the dotted name onto the
    stdlib tree (``std.stitches`` -> ``std/stitches.knit``); import resolution policy
    (search paths, diagnostics) belongs to the resolver.
    """
    parts = module.split(".")
    if not all(parts):
        raise ValueError(f"invalid module name {module!r}")
    *dirs, last = parts
    node = stdlib_root()
    for part in dirs:
        node = node.joinpath(part)
    return node.joinpath(last + ".knit")
