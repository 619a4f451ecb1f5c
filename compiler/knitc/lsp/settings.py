"""The server's settings: what the CLI takes as options, taken from the editor.

An editor sends them as `initializationOptions` and again in
`workspace/didChangeConfiguration`, as ``{"knitc": {...}}`` (or the inner object alone):

- ``defines``: parameter overrides, the CLI's ``-D NAME=VALUE``, as an object
  ``{"width": "40"}`` or a list ``["width=40"]``;
- ``include``: folders besides the design's own that its imports and images may read
  (``--include``), relative ones taken from the workspace root;
- ``maxStitches``: the stitch budget (``--max-stitches``).

A setting of the wrong type is dropped with a message naming it, never an exception: the
editor's settings file is input like any other.
"""

from __future__ import annotations

import os
from dataclasses import field
from typing import Any

from knitc.frontend.skeleton import MAX_STITCHES
from knitc.records import record


@record(frozen=True)
class Settings:
    defines: tuple[str, ...] = ()
    """`NAME=VALUE` texts, as the CLI's `-D`."""
    include: tuple[str, ...] = ()
    max_stitches: int = MAX_STITCHES
    problems: tuple[str, ...] = field(default=(), compare=False)
    """What was wrong with the settings given (each dropped), to show the user."""

    def define_map(self) -> dict[str, str]:
        """The overrides by parameter name (hover shows them)."""
        out: dict[str, str] = {}
        for d in self.defines:
            name, _, value = d.partition("=")
            out[name.strip()] = value.strip()
        return out


def from_json(value: Any, root: str | None = None) -> Settings:
    """Settings from what the client sent (None or {} for the defaults)."""
    if isinstance(value, dict) and isinstance(value.get("knitc"), dict):
        value = value["knitc"]
    if not isinstance(value, dict):
        return Settings()
    problems: list[str] = []
    defines: list[str] = []
    raw = value.get("defines", {})
    if isinstance(raw, dict):
        for k, v in raw.items():
            if not isinstance(v, str | int | float):
                problems.append(f"knitc.defines.{k}: expected a value text, got {_kind(v)}")
            else:
                defines.append(f"{k}={str(v).lower() if isinstance(v, bool) else v}")
    elif isinstance(raw, list) and all(isinstance(d, str) and "=" in d for d in raw):
        defines = list(raw)
    elif raw is not None:
        problems.append('knitc.defines: expected an object {name: value} or ["name=value"]')
    include: list[str] = []
    raw = value.get("include", [])
    if isinstance(raw, list) and all(isinstance(d, str) for d in raw):
        include = [d if os.path.isabs(d) or root is None else os.path.join(root, d) for d in raw]
    elif raw is not None:
        problems.append("knitc.include: expected a list of folders")
    limit = value.get("maxStitches", MAX_STITCHES)
    if limit is None:
        limit = MAX_STITCHES
    if isinstance(limit, bool) or not isinstance(limit, int) or limit < 1:
        problems.append(f"knitc.maxStitches: expected a positive whole number, got {limit!r}")
        limit = MAX_STITCHES
    return Settings(tuple(defines), tuple(include), limit, tuple(problems))


def _kind(v: Any) -> str:
    return "a list" if isinstance(v, list) else "an object" if isinstance(v, dict) else repr(v)
