"""knitc.stdlib: the knitc standard library (``std/**/*.knit``), shipped as package data.

This directory is installed as the subpackage ``knitc.stdlib`` (see ``package-dir`` in
pyproject.toml); ``import std.stitches`` in a .knit file resolves to ``std/stitches.knit``
here. Locate it with :func:`knitc.resources.stdlib_root`, never by a path relative to the
repository.
"""
