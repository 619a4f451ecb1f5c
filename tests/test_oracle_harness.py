"""The Knitout oracle harness itself: it passes good programs and fails bad ones for the
right reason (tests/oracle.py, tests/oracle_runner.py, tests/fixtures/knitout/).

The fixture programs are hand-written: two valid ones (a flat swatch with a chain bind-off,
a half-gauge tube) and four broken on purpose, each with one defect. The inline programs
below cover the hazard warnings, the hook, stripping, header checks and the runner's own
robustness. All of them go through the oracle in two subprocess runs.
"""

from __future__ import annotations

from pathlib import Path

import pytest

import oracle_runner
from oracle import (
    FIXTURES,
    HAZARD_WARNINGS,
    OracleReport,
    assert_clean,
    run_oracle,
    run_oracle_on_text,
)

VALID = ["flat_swatch.k", "half_gauge_tube.k"]
BROKEN = [
    "bad_carrier_not_in.k",
    "bad_xfer_wrong_rack.k",
    "bad_loops_left.k",
    "bad_carrier_left_in.k",
]


def line_of(path: Path, text: str) -> int:
    """1-based number of the first line of `path` that is exactly `text`."""
    lines = path.read_text().splitlines()
    return lines.index(text) + 1


@pytest.fixture(scope="module")
def fixture_reports() -> dict[str, OracleReport]:
    names = VALID + BROKEN
    reports = run_oracle([FIXTURES / n for n in names])
    return dict(zip(names, reports))


# --------------------------------------------------------------------------------------------
# Fixtures: valid ones pass, broken ones fail for their own reason.
# --------------------------------------------------------------------------------------------
@pytest.mark.parametrize("name", VALID)
def test_valid_fixture_is_clean(fixture_reports, name):
    report = fixture_reports[name]
    assert_clean(report)
    assert report.ok and not report.errors and not report.warnings
    assert report.loops_left == 0 and report.carriers_active == () and report.hook_in_use is False
    assert report.carriage_passes and report.carriage_passes > 10
    assert report.no_ops == 0


def test_flat_swatch_counts(fixture_reports):
    r = fixture_reports["flat_swatch.k"]
    # Loops: 10 cast-on tucks + 10 rows of 10 + 9 bind-off knits + 2 tail knits. Stitches:
    # one per knit, but each bind-off knit goes through the two loops stacked on its needle.
    assert r.knit_graph == {"loops": 10 + 100 + 9 + 2, "stitches": 100 + 2 * 9 + 2}
    assert r.stripped == {"width_header": 1, "x_extension": 1}


def test_tube_counts(fixture_reports):
    r = fixture_reports["half_gauge_tube.k"]
    assert r.knit_graph == {"loops": 220, "stitches": 200}  # 20 tucks + 10 rounds of 20
    # 4 cast-on passes + 2 per round; the back pass of one round and the front pass of the
    # next go in opposite directions, so they never merge.
    assert r.carriage_passes == 4 + 2 * 10 + 1  # + the drops


def test_carrier_never_brought_in(fixture_reports):
    path = FIXTURES / "bad_carrier_not_in.k"
    r = fixture_reports[path.name]
    assert not r.ok
    [err] = r.errors
    assert (err.kind, err.type) == ("machine", "Use_Inactive_Carrier_Error")
    assert "carrier 5" in err.message
    assert err.line == line_of(path, "knit - f10 5") and err.source == "knit - f10 5"
    with pytest.raises(AssertionError, match=r"line \d+: Use_Inactive_Carrier_Error"):
        assert_clean(r)


def test_xfer_at_wrong_racking(fixture_reports):
    path = FIXTURES / "bad_xfer_wrong_rack.k"
    r = fixture_reports[path.name]
    assert not r.ok
    [err] = r.errors
    # A misaligned xfer is a plain ValueError inside the oracle (research §1.4, point 5).
    assert err.kind == "machine" and "racking 0" in err.message
    assert err.line == line_of(path, "xfer b6 f5")
    with pytest.raises(AssertionError, match="Cannot Xfer from b6 to f5"):
        assert_clean(r)


def test_loops_left_on_needles(fixture_reports):
    r = fixture_reports["bad_loops_left.k"]
    assert r.ok and not r.errors and not r.warnings  # the oracle itself says nothing ...
    assert r.problem_kinds() == {"loops_left"}  # ... the harness does
    assert r.loops_left == 10 and r.needles_with_loops == tuple(f"f{n}" for n in range(1, 11))
    with pytest.raises(AssertionError, match=r"10 loop\(s\) left on 10 needle\(s\): f1 f2"):
        assert_clean(r)
    assert_clean(r, end_state=False)  # a fragment may leave its loops


def test_carrier_left_in(fixture_reports):
    r = fixture_reports["bad_carrier_left_in.k"]
    assert r.ok and not r.errors and not r.warnings
    assert r.problem_kinds() == {"carriers_in"}
    assert r.carriers_active == (3,) and r.loops_left == 0 and r.hook_in_use is False
    with pytest.raises(AssertionError, match="carrier\\(s\\) never taken out: 3"):
        assert_clean(r)


# --------------------------------------------------------------------------------------------
# Inline programs.
# --------------------------------------------------------------------------------------------
HEADER = """;!knitout-2
;;Machine: SWG091N2
;;Gauge: 15
;;Carriers: 1 2 3 4 5 6 7 8 9 10
;;Position: Center
"""
# Six stitches on f1..f6 with carrier 3, the hook released; the carrier ends left of f1.
CAST_ON = """inhook 3
tuck - f6 3
tuck - f4 3
tuck - f2 3
tuck + f1 3
tuck + f3 3
tuck + f5 3
knit - f6 3
knit - f5 3
knit - f4 3
knit - f3 3
knit - f2 3
knit - f1 3
releasehook 3
"""
FINISH = "outhook 3\n" + "".join(f"drop f{n}\n" for n in range(1, 7))

INLINE = {
    "clean": HEADER + CAST_ON + FINISH,
    # tucks pile up on f3: the 4th loop on one needle is a hazard.
    "too_many_loops": HEADER + CAST_ON + "tuck + f3 3\ntuck - f3 3\ntuck + f3 3\n" + FINISH,
    # from f1 straight to f30: a 29-needle float, and f30 holds nothing.
    "long_float": HEADER + CAST_ON + "knit + f30 3\n" + FINISH + "drop f30\n",
    "knit_on_empty": HEADER + CAST_ON + "knit + f7 3\n" + FINISH + "drop f7\n",
    # the hook is never released (and so the carrier cannot go out either).
    "hook_held": HEADER
    + CAST_ON.replace("releasehook 3\n", "")
    + "".join(f"drop f{n}\n" for n in range(1, 7)),
    # every stripped line kind, in a program that is otherwise the clean one.
    "stripped": HEADER.replace(
        ";;Position", ";;Width: 540\n;;X-Presser: auto\n;;Yarn-3: cotton red\n;;Position"
    )
    + ";!source: sweater.knit:12:3\nx-stitch-number 61\nx-speed-number 2\nstitch 30 30\n"
    + CAST_ON
    + "amiss f2\ntuck + f4\nkick + f8 3\n"
    + FINISH,
    "gauge_mismatch": HEADER.replace(";;Gauge: 15", ";;Gauge: 7") + CAST_ON + FINISH,
    "no_header": CAST_ON + FINISH,
    # blank lines and comments must not shift the reported line (the oracle's own numbering
    # counts parsed lines only).
    "line_numbers": HEADER + "\n\n; comment\n\n" + CAST_ON + "\n\nknit + f2 5\n" + FINISH,
    # a misaligned transfer onto f1, which the oracle's own check lets through.
    "xfer_to_f1": HEADER + CAST_ON + "xfer f2 b2\nxfer b2 f1\n" + FINISH,
    # lines the oracle cannot parse: reported together, with hints.
    "unparsable": HEADER + "in 3 4\nknit + f-1 3\nknit + F2 3\nknit + f3\n",
    "rack_too_far": HEADER + CAST_ON + "rack 5\nrack 0\n" + FINISH,
}


@pytest.fixture(scope="module")
def inline() -> dict[str, OracleReport]:
    names = list(INLINE)
    reports = run_oracle_on_text([INLINE[n] for n in names])
    return dict(zip(names, reports))


def test_clean_inline_program(inline):
    assert_clean(inline["clean"])


@pytest.mark.parametrize(
    "name, warning",
    [
        ("too_many_loops", "Needle_Holds_Too_Many_Loops"),
        ("long_float", "Long_Float_Warning"),
        ("knit_on_empty", "Knit_on_Empty_Needle_Warning"),
    ],
)
def test_hazard_warnings_fail(inline, name, warning):
    r = inline[name]
    assert warning in HAZARD_WARNINGS
    assert r.ok and r.warnings_of(warning), r.warnings
    assert r.problem_kinds() == {"hazard"}
    with pytest.raises(AssertionError, match=warning):
        assert_clean(r)
    assert_clean(r, allow={w.type for w in r.warnings})


def test_hazard_warning_lines(inline):
    r = inline["long_float"]
    [w] = r.warnings_of("Long_Float_Warning")
    assert w.line == INLINE["long_float"].splitlines().index("knit + f30 3") + 1


def test_hook_not_released(inline):
    r = inline["hook_held"]
    assert r.ok and r.hook_in_use is True and r.hooked_carrier == 3
    assert r.problem_kinds() == {"hook", "carriers_in"}
    with pytest.raises(AssertionError, match="hook still holds carrier 3"):
        assert_clean(r)


def test_stripped_lines_are_counted(inline):
    r = inline["stripped"]
    assert_clean(r)
    assert r.stripped == {
        "width_header": 1,
        "x_header": 1,
        "yarn_header": 1,
        "source_comment": 1,
        "x_extension": 2,
        "stitch": 1,
        "amiss": 2,
        "kick": 1,
    }


def test_header_checks(inline):
    r = inline["gauge_mismatch"]
    assert [(e.kind, e.type, e.line) for e in r.errors] == [("header", "Header_Mismatch", 3)]
    r = inline["no_header"]
    assert {e.type for e in r.errors} == {"Missing_Magic_Line", "Missing_Carriers_Header"}
    with pytest.raises(AssertionError, match="Missing_Magic_Line"):
        assert_clean(r)


def test_error_lines_are_file_lines(inline):
    r = inline["line_numbers"]
    [err] = r.errors
    assert err.type == "Use_Inactive_Carrier_Error"
    assert err.line == INLINE["line_numbers"].splitlines().index("knit + f2 5") + 1
    assert err.source == "knit + f2 5"


def test_misaligned_xfer_onto_needle_1(inline):
    r = inline["xfer_to_f1"]
    assert not r.ok
    [err] = r.errors
    assert err.type == "Misaligned_Xfer" and err.source == "xfer b2 f1"


def test_unparsable_lines_reported_together(inline):
    r = inline["unparsable"]
    assert not r.ok and r.carriage_passes is None
    got = [(e.source, e.type, bool(e.hint)) for e in r.errors]
    assert got == [
        ("in 3 4", "Knitout_ParseError", True),
        ("knit + f-1 3", "Knitout_ParseError", True),
        ("knit + F2 3", "Unsupported_Needle_Name", False),
        ("knit + f3", "Knitout_ParseError", True),
    ]
    message = r.describe()
    assert "oracle limitation" in message and "write 'drop N'" in message


def test_rack_limit(inline):
    [err] = inline["rack_too_far"].errors
    assert err.type == "Max_Rack_Error" and err.source == "rack 5"


def test_missing_file_does_not_stop_the_batch(tmp_path):
    good = tmp_path / "good.k"
    good.write_text(INLINE["clean"])
    missing, good_report = run_oracle([tmp_path / "nope.k", good])
    assert not missing.ok and missing.errors[0].kind == "io"
    assert_clean(good_report)


def test_timeout(tmp_path):
    # ~2,000 knits, with a budget far too small to run them.
    body = "".join(
        "".join(
            f"knit {'-+'[r % 2]} f{n} 3\n" for n in (range(6, 0, -1) if r % 2 == 0 else range(1, 7))
        )
        for r in range(340)
    )
    path = tmp_path / "slow.k"
    path.write_text(HEADER + CAST_ON + body + FINISH)
    [r] = run_oracle([path], timeout=0.05)
    assert [e.kind for e in r.errors] == ["timeout"]


# --------------------------------------------------------------------------------------------
# Without the oracle: fail in CI, skip elsewhere.
# --------------------------------------------------------------------------------------------
def test_missing_oracle_fails_in_ci(monkeypatch, tmp_path):
    monkeypatch.setenv("KNITC_ORACLE_PYTHON", str(tmp_path / "no-python"))
    monkeypatch.setenv("CI", "true")
    with pytest.raises(pytest.fail.Exception, match="make oracle-venv"):
        run_oracle([FIXTURES / "flat_swatch.k"])


def test_missing_oracle_skips_locally(monkeypatch, tmp_path):
    monkeypatch.setenv("KNITC_ORACLE_PYTHON", str(tmp_path / "no-python"))
    monkeypatch.delenv("CI", raising=False)
    with pytest.raises(pytest.skip.Exception, match="make oracle-venv"):
        run_oracle([FIXTURES / "flat_swatch.k"])


# --------------------------------------------------------------------------------------------
# The runner's line classification, in knitc's own interpreter (no oracle needed).
# --------------------------------------------------------------------------------------------
@pytest.mark.parametrize(
    "line, kind",
    [
        (";;Width: 540", "width_header"),
        (";;X-Anything: 1", "x_header"),
        (";;Colour: red", "unknown_header"),
        (";;Yarn-3: cotton red", "yarn_header"),
        (";;Yarn-3: 2-30 red", None),
        (";;Machine: SWG091N2", None),
        (";;just a comment", None),
        (";!source: a.knit:1:1", "source_comment"),
        (";!knitout-2", None),
        ("x-stitch-number 61", "x_extension"),
        ("x-presser-mode auto ; comment", "x_extension"),
        ("stitch 30 30", "stitch"),
        ("kick + f3 3", "kick"),
        ("amiss f3", "amiss"),
        ("tuck + f3", "amiss"),
        ("tuck + f3 3", None),
        ("knit + f3", None),  # a drop: reported, never stripped
        ("in 3 4", None),
        ("; x-stitch-number 3", None),
    ],
)
def test_strip_kind(line, kind):
    assert oracle_runner.strip_kind(line) == kind
    assert kind is None or kind in oracle_runner.STRIP_KINDS


@pytest.mark.parametrize(
    "lines, bad",
    [
        (["xfer f2 b1"], ["xfer f2 b1"]),  # rack 0: f2 faces b2
        (["rack 1", "xfer f2 b1"], []),  # rack 1: b1 faces f2
        (["rack -1", "xfer b2 f1"], []),
        (["rack 0.25", "xfer b1 f1"], ["xfer b1 f1"]),
        (["rack 2", "xfer b5 f1", "rack 0", "xfer f5 b0"], ["xfer b5 f1", "xfer f5 b0"]),
        (["xfer f7 b5"], []),  # target 5: the oracle checks it itself
        (["split + f3 b1 3", "rack 2", "split - f3 b1 3"], ["split + f3 b1 3"]),
    ],
)
def test_runner_alignment_check(lines, bad):
    assert [e["source"] for e in oracle_runner.check_xfer_alignment(lines)] == bad
