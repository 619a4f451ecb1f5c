"""The summary line of a successful compile, the machine-time estimate and the progress
display."""

from __future__ import annotations

from knitc.cli import main
from knitc.driver import STAGES, compile_source
from knitc.summary import machine_seconds, progress, summary_line

TUBE = "tube t { length: 20  width: 10 }\n"


def test_a_compile_says_what_it_wrote(tmp_path, capsys):
    f = tmp_path / "t.knit"
    f.write_text(TUBE)
    out = tmp_path / "t.k"
    assert main([str(f), "-o", str(out)]) == 0
    err = capsys.readouterr().err
    assert err.startswith(f"knitc: wrote {out}: 400 stitches, 20 courses, 1 yarn, ")
    assert "carriage passes on" in err and "on the machine" in err
    assert main(["-q", str(f), "-o", str(out)]) == 0
    assert capsys.readouterr().err == ""


def test_machine_time_grows_with_the_work():
    short = compile_source(TUBE, "a.knit", until="machine").program
    long = compile_source(TUBE.replace("20", "40"), "b.knit", until="machine").program
    assert short is not None and long is not None
    assert 0 < machine_seconds(short) < machine_seconds(long)


def test_the_summary_names_every_figure():
    r = compile_source(TUBE, "t.knit", until="machine")
    line = summary_line(r, "t.k")
    for word in ("stitches", "courses", "yarn", "carriage passes", "needles", "machine"):
        assert word in line


def test_progress_is_told_every_stage_and_is_silent_when_off(capsys):
    seen: list[str] = []
    with progress(False, 8) as step:
        compile_source(
            TUBE, "t.knit", until="machine", on_stage=lambda n: (seen.append(n), step(n))
        )
    assert seen == [s.name for s in STAGES]  # (their names: test_driver)
    with progress(True, 8) as step:  # a real bar, started only after a second: none here
        compile_source(TUBE, "t.knit", until="machine", on_stage=step)
    assert capsys.readouterr().err == ""
