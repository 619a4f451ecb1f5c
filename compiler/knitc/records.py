"""`record`: the dataclass decorator of knitc's IRs, AST and results, made for start-up.

`@record(...)` takes `dataclasses.dataclass`'s arguments (those knitc uses) with their
meaning, and type checkers are told exactly that (`dataclass_transform`). The classes are
dataclasses (`fields`, `replace` and `asdict` work on them); what differs is where their
methods come from. On Python 3.11 the dataclass decorator writes every method it adds as
source text and compiles it, one `exec` per method and class: knitc's ~120 classes cost
~350 compilations, 30 ms of every process, a seventh of compiling a small design. Here
only `__init__`, whose signature is each class's own, is generated. The comparison, hash,
repr and frozen-ness are five functions shared by every record, which read a class's
fields through getters made once per class (`operator.attrgetter` builds the tuple of
values in C, as quickly as the generated code does):

- `eq`: `__eq__` compares the tuples of the fields with `compare=True` of two instances of
  the same class (`NotImplemented` otherwise), and `__hash__` follows the dataclass rule:
  None for a mutable record, the hash of that tuple for a frozen one, the class's own when
  its body defines one;
- `repr`: ``Name(a=1, b='x')`` of the fields with `repr=True`, ``...`` when it recurs;
- `frozen`: each field is written once, by `__init__` on the new instance; any later
  assignment or deletion raises `dataclasses.FrozenInstanceError`, as does setting a name
  that is not a field. (`__post_init__` sets derived fields with `object.__setattr__`, as
  with a frozen dataclass; the one difference: a field that `__init__` leaves unset, one
  with `init=False` and no default, can be set once later, where a frozen dataclass would
  refuse. knitc's such fields are all set in `__post_init__`.)

A method the class body defines itself is kept, as the dataclass decorator keeps it.
"""

from __future__ import annotations

import reprlib
from collections.abc import Callable
from dataclasses import Field, FrozenInstanceError, dataclass, field, fields
from operator import attrgetter
from typing import Any, TypeVar, dataclass_transform, overload

_T = TypeVar("_T")


def _getter(names: tuple[str, ...]) -> Callable[[Any], tuple[Any, ...]]:
    """The values of `names` of an object, as a tuple (also of one or none)."""
    if len(names) > 1:
        return attrgetter(*names)
    if names:
        one = attrgetter(names[0])
        return lambda obj: (one(obj),)
    return lambda obj: ()


def _eq(self: Any, other: Any) -> Any:
    cls = self.__class__
    if other.__class__ is cls:
        return cls._record_compare(self) == cls._record_compare(other)
    return NotImplemented


def _hash(self: Any) -> int:
    return hash(self.__class__._record_hash(self))


@reprlib.recursive_repr()
def _repr(self: Any) -> str:
    cls = self.__class__
    shown = ", ".join(f"{n}={v!r}" for n, v in zip(cls._record_shown, cls._record_repr(self)))
    return f"{self.__class__.__qualname__}({shown})"


def _set_once_dict(self: Any, name: str, value: Any) -> None:
    # a record without slots keeps its fields in the instance's dict (a default stays on
    # the class, so the dict is what says whether __init__ has set the field yet)
    if name in self.__dict__ or name not in self.__class__._record_fields:
        raise FrozenInstanceError(f"cannot assign to field {name!r}")
    object.__setattr__(self, name, value)


def _set_once_slots(self: Any, name: str, value: Any) -> None:
    # an empty slot reads as missing until __init__ fills it
    if name not in self.__class__._record_fields or hasattr(self, name):
        raise FrozenInstanceError(f"cannot assign to field {name!r}")
    object.__setattr__(self, name, value)


def _delete(self: Any, name: str) -> None:
    raise FrozenInstanceError(f"cannot delete field {name!r}")


@overload
def record(cls: type[_T], /) -> type[_T]: ...


@overload
def record(
    *,
    init: bool = True,
    repr: bool = True,
    eq: bool = True,
    frozen: bool = False,
    kw_only: bool = False,
    slots: bool = False,
) -> Callable[[type[_T]], type[_T]]: ...


@dataclass_transform(field_specifiers=(field, Field))
def record(
    cls: type[_T] | None = None,
    /,
    *,
    init: bool = True,
    repr: bool = True,
    eq: bool = True,
    frozen: bool = False,
    kw_only: bool = False,
    slots: bool = False,
) -> Any:
    """`dataclasses.dataclass(cls, init=..., repr=..., eq=..., frozen=..., kw_only=...,
    slots=...)`, with the shared methods described in the module's docstring."""

    def wrap(cls: type[_T]) -> type[_T]:
        own = cls.__dict__
        own_hash = own.get("__hash__")
        # (a body that defines __eq__ gets __hash__ = None from Python: that is not a hash
        # of its own, as the dataclass decorator reads it)
        explicit_hash = "__hash__" in own and not (own_hash is None and "__eq__" in own)
        if frozen and ("__setattr__" in own or "__delattr__" in own):
            raise TypeError(f"a frozen record cannot define __setattr__ or __delattr__: {cls}")
        made = dataclass(cls, init=init, repr=False, eq=False, kw_only=kw_only, slots=slots)
        fs = fields(made)  # type: ignore[arg-type]
        put: dict[str, Any] = {}
        if repr and "__repr__" not in own:
            shown = tuple(f.name for f in fs if f.repr)
            put.update(_record_shown=shown, _record_repr=_getter(shown), __repr__=_repr)
        if eq:
            put["_record_compare"] = _getter(tuple(f.name for f in fs if f.compare))
            if "__eq__" not in own:
                put["__eq__"] = _eq
            if not explicit_hash and not frozen:
                put["__hash__"] = None
            elif not explicit_hash:
                hashed = tuple(f.name for f in fs if (f.compare if f.hash is None else f.hash))
                put.update(_record_hash=_getter(hashed), __hash__=_hash)
        if frozen:
            put["_record_fields"] = frozenset(f.name for f in fs)
            put["__setattr__"] = _set_once_slots if slots else _set_once_dict
            put["__delattr__"] = _delete
        for name, value in put.items():
            setattr(made, name, value)
        return made

    return wrap if cls is None else wrap(cls)
