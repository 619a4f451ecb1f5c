"""The compact text form of an IR (`knitc --emit NAME --format text`).

Every IR already has a stable JSON dump (its module's `to_json`); the text form is that
dump printed one record per line, so the two can never disagree and a new field shows up
in both. A line is a head (the record's kind and id) followed by `key=value` fields in the
dump's order:

    course 0 node=t start=0 len=4 circular kind=interface gauge=1 names=[t.bottom]
    stitch 4 course=1 pos=0 side=0 needle=0 prev=7 next=5 wale_prev=[0] instr=K span=t.knit:1:1

A true flag is its bare key and a false one is left out; an empty list, an empty dict and
null are left out as well (`-1`, a "none" id, is kept: it is a value). Lists print as
`[a,b]`, pairs inside them as `a:b`, dicts as `{k=v}`, source spans as `file:line:col`.
Strings print bare unless they hold spaces or brackets, then as JSON strings. The text is
deterministic, so golden tests (`tests/filecheck/`) match on it line by line.
"""

from __future__ import annotations

import json
from typing import Any

SINGULAR = {
    "nodes": "node",
    "interfaces": "itf",
    "connections": "connect",
    "starts": "start",
    "components": "component",
    "layers": "layer",
    "courses": "course",
    "stitches": "stitch",
    "yarns": "yarn",
    "visits": "visit",
    "slices": "slice",
    "alignments": "align",
    "ops": "op",
    "params": "param",
}
"""The head of each record of a top-level list."""

_SPAN_KEYS = ("span", "origin")


def render(dump: dict[str, Any]) -> str:
    """The text form of an IR's JSON dump."""
    lines: list[str] = []
    for key, value in dump.items():
        if isinstance(value, list) and value and all(isinstance(v, dict) for v in value):
            head = SINGULAR.get(key, key)
            for i, record in enumerate(value):
                lines.append(_record(head, record, i))
        elif isinstance(value, dict) and value and all(isinstance(v, dict) for v in value.values()):
            for name, record in value.items():
                lines.append(_record(f"{SINGULAR.get(key, key)} {_atom(name)}", record, None))
        elif isinstance(value, dict):
            lines.append(_line(key, value))
        elif isinstance(value, list):
            head = SINGULAR.get(key, key)
            lines += [f"{head} {_value(v)}" for v in value]
        else:
            lines.append(f"{key} {_value(value)}")
    return "\n".join(line.rstrip() for line in lines) + "\n"


def _record(head: str, record: dict[str, Any], index: int | None) -> str:
    fields = dict(record)
    if "id" in fields:
        head = f"{head} {_atom(fields.pop('id'))}"
    elif "name" in fields:
        head = f"{head} {_atom(fields.pop('name'))}"
    elif index is not None:
        head = f"{head} {index}"
    if "op" in fields:
        head = f"{head} {_atom(fields.pop('op'))}"
    return _line(head, fields)


def _line(head: str, fields: dict[str, Any]) -> str:
    parts = [head]
    for k, v in fields.items():
        if v is False or v is None or v == [] or v == {}:
            continue
        if v is True:
            parts.append(k)
        elif k in _SPAN_KEYS and isinstance(v, list):
            parts.append(f"{k}={_span(v)}")
        else:
            parts.append(f"{k}={_value(v)}")
    return " ".join(parts)


def _span(v: list[Any]) -> str:
    if len(v) >= 3:
        return f"{v[0]}:{v[1]}:{v[2]}"
    return _value(v)


def _value(v: Any) -> str:
    if isinstance(v, dict):
        return "{" + " ".join(f"{k}={_value(x)}" for k, x in v.items()) + "}"
    if isinstance(v, list):
        return (
            "["
            + ",".join(
                ":".join(_value(y) for y in x) if isinstance(x, list) else _value(x) for x in v
            )
            + "]"
        )
    return _atom(v)


def _atom(v: Any) -> str:
    if v is True:
        return "true"
    if v is False:
        return "false"
    if v is None:
        return "-"
    if isinstance(v, str):
        if v == "" or any(c in v for c in ' \t\n[]{}=,:"') and not _path_like(v):
            return json.dumps(v)
        return v
    return json.dumps(v)


def _path_like(v: str) -> bool:
    """A file name or path (may hold `:`, never spaces)."""
    return " " not in v and "/" in v and not any(c in v for c in '[]{}=,"\n\t')
