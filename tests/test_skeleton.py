"""The skeleton IR: size inference, the verifier's size checks and warnings, and the JSON dump
behind `knitc --emit skeleton`."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from knitc.driver import compile_source, emit_json
from knitc.frontend import skeleton as sk

REPO = Path(__file__).resolve().parents[1]


def _has_layer_fmt() -> bool:
    try:
        from knitc.frontend.fmt import format_layer_stmt  # noqa: F401
    except ImportError:
        return False
    return True


needs_layer_fmt = pytest.mark.skipif(
    not _has_layer_fmt(),
    reason="knitc.frontend.fmt.format_layer_stmt does not exist yet; "
    "knitc.frontend.skeleton.to_json imports it, so the skeleton JSON cannot be built",
)


def compile_(text: str, defines=(), werror=False):
    return compile_source(text, "t.knit", defines=list(defines), werror=werror)


def codes(result) -> list[str]:
    return [d.code for d in result.diagnostics]


def ok(text: str, defines=()) -> sk.Skeleton:
    r = compile_(text, defines)
    assert not r.diagnostics.has_errors, r.diagnostics.render()
    return r.skeleton


def sizes(skel: sk.Skeleton) -> dict[str, tuple[int | None, int | None]]:
    return {str(i.id): (i.size, i.sides) for i in skel.interfaces.values()}


# ---- sizes of primitives -------------------------------------------------------------------


def test_flat_sheet_and_tube_sizes():
    s = sizes(
        ok("sheet f { width: 7 }\ntube t { width: 7 }\nsheet c { type: cylinder  width: 7 }\n")
    )
    assert s["f.bottom"] == s["f.top"] == (7, 1)
    assert s["t.bottom"] == s["t.top"] == (14, 2)
    assert s["c.bottom"] == s["c.top"] == (14, 2)


def test_profile_ends_give_bottom_and_top_sizes():
    s = sizes(ok("tube t { width: [0: 4, 0.5: 20, 1: 6] }\nsheet f { width: [0: 9, 1: 3] }\n"))
    assert s["t.bottom"] == (8, 2) and s["t.top"] == (12, 2)
    assert s["f.bottom"] == (9, 1) and s["f.top"] == (3, 1)


def test_fractional_widths_round_half_up():
    s = sizes(ok("sheet f { width: [0: 4.5, 1: 5.5] }\ntube t { width: 2.5 }\n"))
    # Python's round would give 4 and 6 (and 2); knitc rounds halves up like the original.
    assert s["f.bottom"] == (5, 1) and s["f.top"] == (6, 1)
    assert s["t.bottom"] == (6, 2)


def test_default_sheet_width():
    assert sizes(ok("sheet f {}"))["f.top"] == (10, 1)


# ---- inference across joints and splits ------------------------------------------------------


def test_size_across_a_joint():
    s = sizes(
        ok(
            "tube a { width: 6 }\njoint j { rows: 4 }\ntube b { width: 6 }\n"
            "a.top -> j.bottom\nj.top -> b.bottom\n"
        )
    )
    assert s["j.bottom"] == s["j.top"] == (12, 2)


def test_joint_with_one_neighbour_copies_its_size():
    s = sizes(ok("tube a { width: 6 }\njoint j {}\nj.bottom -> a.top\n"))
    assert s["j.bottom"] == (12, 2)
    assert s["j.top"] == (12, 2)


def test_chain_of_joints_in_any_declaration_order():
    s = sizes(
        ok(
            "joint j3 {}\njoint j2 {}\njoint j1 {}\ntube a { width: 4 }\n"
            "j2.top -> j3.bottom\nj1.top -> j2.bottom\na.top -> j1.bottom\n"
        )
    )
    for j in ("j1", "j2", "j3"):
        assert s[f"{j}.bottom"] == s[f"{j}.top"] == (8, 2)


def test_joint_between_unequal_neighbours_is_an_error():
    r = compile_(
        "tube a { width: 6 }\njoint j {}\ntube b { width: 7 }\n"
        "a.top -> j.bottom\nj.top -> b.bottom\n"
    )
    assert "E509" in codes(r)


def test_folded_split_base_is_sum_of_branches():
    # A merge, as in the glove: fingers into the palm.
    s = sizes(
        ok(
            "tube f1 { width: 3 }\ntube f2 { width: 4 }\ntube f3 { width: 2 }\n"
            "split m { degree: 3 }\n"
            "f1.top -> m.branches[0]\nf2.top -> m.branches[1]\nf3.top -> m.branches[2]\n"
        )
    )
    assert s["m.branches[0]"] == (6, 2)
    assert s["m.branches[1]"] == (8, 2)
    assert s["m.branches[2]"] == (4, 2)
    assert s["m.base"] == (18, 2)


def test_folded_split_base_size_flows_on():
    s = sizes(
        ok(
            "tube f1 { width: 3 }\ntube f2 { width: 4 }\nsplit m {}\njoint j {}\n"
            "tube palm { width: 7 }\n"
            "f1.top -> m.branches[0]\nf2.top -> m.branches[1]\n"
            "m.base -> j.bottom\nj.top -> palm.bottom\n"
        )
    )
    assert s["m.base"] == s["j.bottom"] == s["j.top"] == (14, 2)


def test_split_through_joints_on_both_sides():
    # Nothing next to the split fixes its size directly; it flows through joints.
    s = sizes(
        ok(
            "tube a { width: 2 }\ntube b { width: 3 }\njoint ja {}\njoint jb {}\n"
            "split m {}\njoint jm {}\n"
            "a.top -> ja.bottom\nja.top -> m.branches[0]\n"
            "b.top -> jb.bottom\njb.top -> m.branches[1]\n"
            "m.base -> jm.bottom\n"
        )
    )
    assert s["m.base"] == (10, 2)
    assert s["jm.top"] == (10, 2)


def test_unfolded_split_sides():
    s = sizes(
        ok(
            "split s { degree: 2  folded: false }\nsheet a { width: 4 }\n"
            "sheet b { width: 6 }\ntube c { width: 5 }\n"
            "s.branches[0] -> a.bottom\ns.branches[1] -> b.bottom\ns.base -> c.top\n"
        )
    )
    assert s["s.branches[0]"] == (4, 1)
    assert s["s.branches[1]"] == (6, 1)
    assert s["s.base"] == (10, 2)


def test_glove_like_split_sizes():
    skel = ok((REPO / "examples" / "glove.knit").read_text(encoding="utf-8"))
    s = sizes(skel)
    # Defaults: finger_w 7, pinky 6, wrist_w 30, thumb_w 8 (see the comment in glove.knit).
    assert s["fingers.base"][0] == 2 * (3 * 7 + 6)
    assert s["thumb_join.base"][0] == 2 * (4 * 7 + 1 + 8)
    assert s["cuff.bottom"][0] == 60


def test_split_branches_exceed_base():
    r = compile_(
        "tube big { width: 4 }\nsplit s {}\ntube x { width: 3 }\ntube y { width: 3 }\n"
        "big.top -> s.base\ns.branches[0] -> x.bottom\ns.branches[1] -> y.bottom\n"
    )
    assert "E504" in codes(r)


@pytest.mark.parametrize(
    "text",
    [
        "split s {}\n",
        "joint j {}\n",
        "split s {}\ntube a { width: 3 }\ns.branches[0] -> a.bottom\n",
    ],
)
def test_size_that_cannot_be_inferred(text):
    assert "E505" in codes(compile_(text))


def test_auto_sheet_takes_sides_from_neighbours():
    s = sizes(
        ok("tube a { width: 3 }\nsheet b { type: auto  width: [0: 3, 1: 5] }\na.top -> b.bottom\n")
    )
    assert s["b.bottom"] == (6, 2)
    assert s["b.top"] == (10, 2)
    s = sizes(ok("sheet a { width: 3 }\nsheet b { type: auto  width: 3 }\na.top -> b.bottom\n"))
    assert s["b.bottom"] == s["b.top"] == (3, 1)


# ---- warnings ----------------------------------------------------------------------------------


def test_w501_tube_closed_two_to_one():
    r = compile_("tube a { width: 4 }\nsheet b { width: 4 }\na.top -> b.bottom\n")
    assert codes(r) == ["W501"]
    assert r.ok
    d = r.diagnostics.items[0]
    assert "8" in d.message and "4" in d.message
    assert d.span.line == 3


def test_w502_size_mismatch():
    r = compile_("tube a { width: 4 }\ntube b { width: 5 }\na.top -> b.bottom\n")
    assert codes(r) == ["W502"]
    assert r.ok


def test_w502_when_flat_is_twice_the_tube():
    # 2:1 the other way round (the flat side is the big one) is not a tube closing.
    r = compile_("sheet a { width: 16 }\ntube b { width: 4 }\na.top -> b.bottom\n")
    assert codes(r) == ["W502"]


def test_sizes_compare_across_gauges():
    r = compile_("tube a { width: 4 }\ntube b { width: 5  gauge: half }\na.top -> b.bottom\n")
    assert codes(r) == ["W502"]
    assert not codes(
        compile_("tube a { width: 4 }\ntube b { width: 4  gauge: half }\na.top -> b.bottom\n")
    )


def test_no_size_warning_for_a_node_with_errors():
    r = compile_("tube a { width: 4  length: 0 }\ntube b { width: 5 }\na.top -> b.bottom\n")
    assert codes(r) == ["E313"]


def test_w503_closing_a_flat_interface():
    r = compile_("sheet a { width: 4 }\na.top closed\n")
    assert codes(r) == ["W503"]
    assert not codes(compile_("tube a { width: 4 }\na.top closed\n"))


def test_werror_promotes_warnings():
    text = "tube a { width: 4 }\ntube b { width: 5 }\na.top -> b.bottom\n"
    r = compile_(text, werror=True)
    assert codes(r) == ["W502"]
    assert not r.ok
    assert r.diagnostics.items[0].is_error


def test_matching_sizes_are_silent():
    r = compile_(
        "sheet a { width: 8 }\ntube b { width: 4  length: 3 }\n"
        "tube c { width: [0: 4, 1: 9] }\nsheet d { type: cylinder  width: 9 }\n"
        "b.top -> c.bottom\nc.top -> d.bottom\n"
    )
    assert codes(r) == []


# ---- JSON dump --------------------------------------------------------------------------------

GARMENT = """\
import std.stitches (rib)
param w = 6
param len = 20
machine { gauge: half  carriers: [2, 3] }
tube cuff { length: #len  width: #w }
joint heel { rows: 4 }
split s { degree: 2 }
tube l { width: 2 }
tube r { width: [0: 4, 1: 3] }
cuff.top -> heel.bottom
heel.top -> s.base
s.branches[0] -> l.bottom
s.branches[1] -> r.bottom
cuff.bottom closed(zigzag) { cast_on: tuck }
start cuff.bottom
pattern cuff { apply rib(1, 1) }
"""

JSON_KEYS = {
    "machine",
    "params",
    "nodes",
    "interfaces",
    "connections",
    "starts",
    "components",
    "layers",
    "definitions",
}


@needs_layer_fmt
def test_skeleton_json_keys_and_values():
    r = compile_(GARMENT)
    assert r.ok, r.diagnostics.render()
    data = json.loads(emit_json(r, "skeleton"))
    assert set(data) - {"yarns"} == JSON_KEYS  # (yarns: a design that declares them)
    assert set(data["machine"]) == {
        "model",
        "needles",
        "gauge",
        "racking",
        "carriers",
        "increase",
        "cast_on",
        "cast_off",
    }
    assert data["machine"]["gauge"] == "half"
    assert data["machine"]["carriers"] == [2, 3]
    assert data["params"] == {"w": 6, "len": 20}
    assert [n["name"] for n in data["nodes"]] == ["cuff", "heel", "s", "l", "r"]
    for n in data["nodes"]:
        assert set(n) == {"name", "kind", "props", "interfaces", "span"}
    cuff = data["nodes"][0]
    assert cuff["kind"] == "tube"
    assert cuff["props"]["width"] == 6  # a constant width is a number
    assert cuff["props"]["type"] == "cylinder"
    assert cuff["props"]["gauge"] == "half"
    assert data["nodes"][4]["props"]["width"] == [[0, 4], [1, 3]]
    assert data["nodes"][2]["interfaces"] == ["base", "branches/0", "branches/1"]
    assert cuff["span"][0] == "t.knit" and cuff["span"][1] == 5
    itfs = {i["id"]: i for i in data["interfaces"]}
    for i in itfs.values():
        assert set(i) == {
            "id",
            "node",
            "path",
            "state",
            "closing",
            "cast_on",
            "cast_off",
            "size",
            "sides",
        }
    assert itfs["cuff.bottom"]["state"] == "closed"
    assert itfs["cuff.bottom"]["closing"] == "zigzag"
    assert itfs["cuff.bottom"]["cast_on"] == "tuck"
    assert itfs["s.base"] == {
        "id": "s.base",
        "node": "s",
        "path": "base",
        "state": "connected",
        "closing": None,
        "cast_on": "auto",
        "cast_off": "auto",
        "size": 12,
        "sides": 2,
    }
    assert itfs["s.branches[1]"]["path"] == "branches/1"
    assert itfs["s.branches[1]"]["size"] == 8
    assert [(c["a"], c["b"]) for c in data["connections"]] == [
        ("cuff.top", "heel.bottom"),
        ("heel.top", "s.base"),
        ("s.branches[0]", "l.bottom"),
        ("s.branches[1]", "r.bottom"),
    ]
    assert data["starts"] == [{"interface": "cuff.bottom", "inferred": False}]
    assert data["components"] == [["cuff", "heel", "s", "l", "r"]]
    assert len(data["layers"]) == 1 and data["layers"][0]["target"] == "cuff"
    assert "rib" in data["layers"][0]["stmt"]
    assert data["definitions"] == {"patterns": ["rib"], "actions": [], "shapers": []}


@needs_layer_fmt
def test_skeleton_json_is_deterministic():
    first = emit_json(compile_(GARMENT), "skeleton")
    second = emit_json(compile_(GARMENT), "skeleton")
    assert first == second
    assert first.endswith("\n")


@needs_layer_fmt
@pytest.mark.parametrize("name", ["sheet", "tube", "sock", "glove", "sweater"])
def test_examples_dump_deterministically(name):
    text = (REPO / "examples" / f"{name}.knit").read_text(encoding="utf-8")
    a = compile_source(text, f"examples/{name}.knit")
    b = compile_source(text, f"examples/{name}.knit")
    assert a.ok, a.diagnostics.render()
    ja, jb = emit_json(a, "skeleton"), emit_json(b, "skeleton")
    assert ja == jb
    data = json.loads(ja)
    assert set(data) - {"yarns"} == JSON_KEYS  # (yarns: a design that declares them)
    assert len(data["starts"]) == len(data["components"])


@needs_layer_fmt
def test_skeleton_json_inferred_start():
    data = json.loads(
        emit_json(
            compile_("tube b { width: 2 }\ntube a { width: 2 }\na.top -> b.bottom\n"), "skeleton"
        )
    )
    assert data["starts"] == [{"interface": "b.top", "inferred": True}]
    assert data["components"] == [["b", "a"]]


@needs_layer_fmt
def test_skeleton_json_never_crashes_on_strange_params():
    r = compile_("param x = (-8) ^ 0.5\n")
    if r.ok:
        json.loads(emit_json(r, "skeleton"))


def test_ast_json_is_deterministic():
    a = emit_json(compile_source(GARMENT, "t.knit", until="ast"), "ast")
    b = emit_json(compile_source(GARMENT, "t.knit", until="ast"), "ast")
    assert a == b
    data = json.loads(a)
    assert data["node"] == "Module"
    assert data["items"][0]["node"] == "Import"
