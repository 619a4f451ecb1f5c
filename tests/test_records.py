"""`knitc.records.record` against `dataclasses.dataclass`: the same class written with each
decorator behaves the same (construction, equality, hash, repr, frozen-ness, copies), and
knitc's own classes all use `record`, whose start-up cost is one compiled method a class."""

from __future__ import annotations

import copy
import dataclasses
import pickle
import re
from dataclasses import FrozenInstanceError, dataclass, field
from pathlib import Path

import pytest
from hypothesis import given
from hypothesis import strategies as st

from knitc.records import record

COMPILER = Path(__file__).resolve().parent.parent / "compiler" / "knitc"


def _pair(**kw):
    """The same three-field class, made by `dataclass` and by `record` with `kw`."""

    def body():
        class C:
            a: int
            b: str = "x"
            c: float = field(default=0.5, compare=False, repr=False)

        return C

    return dataclass(**kw)(body()), record(**kw)(body())


# module-level twins, so that pickling finds them by name
@dataclass(frozen=True)
class DFrozen:
    a: int
    b: tuple[int, ...] = ()


@record(frozen=True)
class RFrozen:
    a: int
    b: tuple[int, ...] = ()


@record(frozen=True, slots=True)
class RSlots:
    a: int
    b: tuple[int, ...] = ()


KINDS = [
    {},
    {"frozen": True},
    {"eq": False},
    {"repr": False},
    {"frozen": True, "slots": True},
    {"slots": True},
    {"frozen": True, "eq": False},
    {"kw_only": True},
]


@pytest.mark.parametrize("kw", KINDS, ids=lambda kw: ",".join(kw) or "default")
@given(
    a1=st.integers(-3, 3),
    a2=st.integers(-3, 3),
    b1=st.sampled_from(["x", "y"]),
    b2=st.sampled_from(["x", "y"]),
    c1=st.floats(allow_nan=True),
    c2=st.floats(allow_nan=True),
)
def test_a_record_behaves_as_the_dataclass(kw, a1, a2, b1, b2, c1, c2):
    D, R = _pair(**kw)
    d1, d2 = D(a=a1, b=b1, c=c1), D(a=a2, b=b2, c=c2)
    r1, r2 = R(a=a1, b=b1, c=c1), R(a=a2, b=b2, c=c2)
    assert (r1 == r2) == (d1 == d2)
    assert (r1 != r2) == (d1 != d2)
    assert (r1 == r1) and (d1 == d1)
    assert (r1 == "x") == (d1 == "x")
    if kw.get("repr", True):
        assert repr(r1).replace(R.__qualname__, "C") == repr(d1).replace(D.__qualname__, "C")
    else:
        assert repr(r1).startswith("<") and repr(d1).startswith("<")  # (object's own)
    assert (R.__hash__ is None) == (D.__hash__ is None)
    if D.__hash__ is not None and d1 == d2:
        assert hash(r1) == hash(r2)
    assert [f.name for f in dataclasses.fields(R)] == [f.name for f in dataclasses.fields(D)]
    assert dataclasses.astuple(r1) == dataclasses.astuple(d1)
    assert dataclasses.astuple(dataclasses.replace(r1, a=a2)) == (a2, b1, c1)
    frozen = kw.get("frozen", False)
    for obj in (r1, d1):
        if frozen:
            with pytest.raises(FrozenInstanceError):
                obj.a = 9
            with pytest.raises(FrozenInstanceError):
                del obj.b
            assert obj.a == a1
        else:
            obj.a = 9
            assert obj.a == 9


def test_frozen_means_no_new_attributes_either():
    for obj in (DFrozen(1), RFrozen(1)):
        with pytest.raises((FrozenInstanceError, AttributeError)):
            obj.other = 2  # type: ignore[union-attr]
    with pytest.raises((FrozenInstanceError, AttributeError)):
        RSlots(1).other = 2  # type: ignore[attr-defined]


@pytest.mark.parametrize("cls", [RFrozen, RSlots])
def test_frozen_records_copy_and_travel(cls):
    x = cls(1, (2, 3))
    for y in (copy.copy(x), copy.deepcopy(x), pickle.loads(pickle.dumps(x))):
        assert y == x and hash(y) == hash(x) and y is not x
        with pytest.raises(FrozenInstanceError):
            y.a = 5


def test_a_frozen_record_is_a_default_and_a_key():
    @record
    class Holder:
        inner: RFrozen = RFrozen(1)  # (a dataclass refuses an unhashable default)

    assert Holder().inner == RFrozen(1)
    assert {RFrozen(1, (2,)): "k"}[RFrozen(1, (2,))] == "k"


def test_post_init_sets_derived_fields_of_a_frozen_record():
    @record(frozen=True, slots=True)
    class P:
        xs: tuple[int, ...]
        total: int = field(init=False, compare=False)

        def __post_init__(self) -> None:
            object.__setattr__(self, "total", sum(self.xs))

    p = P((1, 2))
    assert p.total == 3 and p == P((1, 2))
    with pytest.raises(FrozenInstanceError):
        p.total = 4  # type: ignore[misc]


def test_methods_of_the_class_body_are_kept():
    @record(frozen=True)
    class Own:
        a: int

        def __eq__(self, other: object) -> bool:
            return True

        def __hash__(self) -> int:
            return 7

        def __repr__(self) -> str:
            return "own"

    assert Own(1) == Own(2) and hash(Own(1)) == 7 and repr(Own(1)) == "own"

    @record
    class EqOnly:
        a: int

        def __eq__(self, other: object) -> bool:
            return False

    assert EqOnly.__hash__ is None  # (as Python and the dataclass decorator leave it)


def test_subclasses_compare_their_own_fields():
    @record(frozen=True)
    class Base:
        a: int

    @record(frozen=True)
    class Sub(Base):
        b: int = 0

    assert Sub(1, 2) != Sub(1, 3) and Sub(1, 2) == Sub(1, 2)
    assert Base(1) != Sub(1, 0)  # (different classes, as with dataclasses)
    assert repr(Sub(1, 2)).endswith("Sub(a=1, b=2)")


def test_a_recursive_repr_ends():
    @record
    class Cell:
        items: list

    c = Cell([])
    c.items.append(c)
    assert repr(c).endswith("Cell(items=[...])")


def test_knitc_classes_are_records():
    """Every class of the compiler is made by `record`: a plain `@dataclass` compiles up to
    six methods at every start-up (`knitc.records`)."""
    offenders = [
        f"{path.relative_to(COMPILER)}:{n}"
        for path in sorted(COMPILER.rglob("*.py"))
        for n, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1)
        if re.match(r"\s*@(dataclasses\.)?dataclass\b", line)
    ]
    assert offenders == []
