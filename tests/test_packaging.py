"""Packaging tests: the installed knitc carries its code, grammar and stdlib.

`make test` runs the suite against a real (non-editable) install in .venv, so these tests
catch packaging mistakes that an editable install or a source checkout would hide: a
subpackage without ``__init__.py`` (skipped by find_packages), a data file that no
package-data glob matches, or an install that is out of date with the source tree.
"""

from __future__ import annotations

import importlib.metadata
import importlib.resources
from importlib.resources.abc import Traversable
from pathlib import Path

import pytest

import knitc
from knitc import resources

REPO = Path(__file__).resolve().parents[1]
STALE_HINT = "the installed knitc does not match the source tree; reinstall it (`make test`)"


def _walk(node: Traversable, prefix: str = ""):
    """Yield (relative path, Traversable) for every file below *node*."""
    for child in node.iterdir():
        rel = f"{prefix}{child.name}"
        if child.is_dir():
            if child.name != "__pycache__":
                yield from _walk(child, rel + "/")
        else:
            yield rel, child


def _source_files(root: Path, pattern: str) -> set[str]:
    return {
        p.relative_to(root).as_posix()
        for p in root.glob(pattern)
        if p.is_file() and "__pycache__" not in p.parts
    }


def _installed_files(package: str, suffix: str) -> set[str]:
    return {rel for rel, _ in _walk(importlib.resources.files(package)) if rel.endswith(suffix)}


def test_version():
    assert knitc.__version__ == "0.1.0"
    assert importlib.metadata.version("knitc") == knitc.__version__


def test_console_script_declared():
    scripts = importlib.metadata.entry_points(group="console_scripts")
    (ep,) = [ep for ep in scripts if ep.name == "knitc"]
    assert ep.value == "knitc.cli:main"


def test_grammar_ships_with_the_package():
    text = resources.grammar_text()
    assert text.strip(), "knit.lark is empty"
    assert text == resources.grammar_text("knit.lark")


def test_missing_grammar_raises():
    with pytest.raises(FileNotFoundError):
        resources.grammar_text("no-such-grammar.lark")


def test_stdlib_root():
    root = resources.stdlib_root()
    assert root.is_dir()
    if _source_files(REPO / "stdlib", "std/**/*.knit"):
        assert root.joinpath("std").is_dir()


def test_stdlib_module_mapping():
    path = resources.stdlib_module("std.stitches")
    assert path.name == "stitches.knit"
    for src in _source_files(REPO / "stdlib", "std/**/*.knit"):
        dotted = src.removesuffix(".knit").replace("/", ".")
        assert resources.stdlib_module(dotted).is_file(), src
    with pytest.raises(ValueError):
        resources.stdlib_module("std..x")


@pytest.mark.parametrize(
    ("package", "source_dir", "pattern"),
    [
        ("knitc", "compiler/knitc", "**/*.py"),
        ("knitc.grammars", "grammars", "**/*.lark"),
        ("knitc.stdlib", "stdlib", "**/*.knit"),
        ("knitc.view", "compiler/knitc/view", "**/*.js"),  # the HTML viewer inlines these
        ("knitc.view", "compiler/knitc/view", "**/*.css"),
    ],
)
def test_installed_package_mirrors_source(package, source_dir, pattern):
    source = _source_files(REPO / source_dir, pattern)
    suffix = pattern.rsplit("*", 1)[1]
    installed = _installed_files(package, suffix)
    if package == "knitc":
        # knitc/grammars and knitc/stdlib are the mapped data packages, checked separately.
        installed = {f for f in installed if not f.startswith(("grammars/", "stdlib/"))}
    missing = sorted(source - installed)
    assert not missing, (
        f"source files not in the installed {package}: {missing}. A directory without "
        f"__init__.py is not a package and is not installed; a data file must match a "
        f"package-data glob in pyproject.toml. Otherwise {STALE_HINT}."
    )
    extra = sorted(installed - source)
    assert not extra, (
        f"installed {package} has files no longer in the source: {extra}; {STALE_HINT}."
    )
