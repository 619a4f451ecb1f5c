"""Package list for setuptools; all other metadata lives in pyproject.toml.

pyproject.toml maps ``compiler/`` to the top level and ``grammars/`` and ``stdlib/`` to the
subpackages ``knitc.grammars`` and ``knitc.stdlib`` (``[tool.setuptools] package-dir``). A
pure pyproject.toml configuration cannot combine package discovery with those mapped
packages, so the list is computed here:

* every package under ``compiler/`` (new subpackages are picked up automatically; a
  directory without ``__init__.py`` is not a package and is NOT installed);
* ``knitc.grammars`` and ``knitc.stdlib``;
* every directory under ``stdlib/`` (``std``, ``std/...``) as a data-only namespace
  package ``knitc.stdlib.std...``: setuptools copies their ``*.knit`` files either way
  (package-data ``**/*.knit``), but warns loudly about directories it finds inside a
  package that are not listed as packages.
"""

from setuptools import find_namespace_packages, find_packages, setup

stdlib_dirs = find_namespace_packages(where="stdlib", exclude=["*__pycache__*"])

setup(
    packages=[
        *find_packages(where="compiler"),
        "knitc.grammars",
        "knitc.stdlib",
        *(f"knitc.stdlib.{name}" for name in stdlib_dirs),
    ]
)
