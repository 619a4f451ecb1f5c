"""The stage table drives the pipeline: names, stopping, resuming, verifying, timing."""

from __future__ import annotations

import pytest

from knitc import driver
from knitc.cli import main
from knitc.driver import EMITTABLE, STAGES, TARGETS, compile_source, resume

TUBE = "tube t { length: 4  width: 4 }\n"


def test_every_ir_stage_has_a_verifier_or_is_checked_by_diagnostics_and_a_dump():
    names = [s.name for s in STAGES]
    assert names == [
        "ast",
        "skeleton",
        "stitch-graph",
        "trace",
        "slices",
        "schedule",
        "yarn-stack",
        "machine",
    ]
    assert EMITTABLE == tuple(names)
    assert all(s.verify is not None for s in STAGES[2:])  # from the stitch graph on
    assert [t.name for t in TARGETS] == ["knitout", "dat"]


def test_a_misspelt_stage_is_an_error_not_a_full_run():
    with pytest.raises(ValueError, match="unknown stage 'sceduel'.*schedule"):
        compile_source(TUBE, "t.knit", until="sceduel")


@pytest.mark.parametrize("until", [s.name for s in STAGES])
def test_until_stops_after_that_stage(until):
    r = compile_source(TUBE, "t.knit", until=until)
    assert r.ok and r.stage_reached == until
    assert [name for name, _ in r.timings] == [s.name for s in STAGES][: len(r.timings)]
    assert r.timings[-1][0] == until


def test_resume_reuses_what_a_result_holds():
    r = compile_source(TUBE, "t.knit", until="skeleton")
    module, skeleton = r.module, r.skeleton
    resume(r, "machine")
    assert r.module is module and r.skeleton is skeleton and r.program is not None
    assert [name for name, _ in r.timings][2:] == [s.name for s in STAGES[2:]]
    resume(r, "knitout")
    assert isinstance(r.output, str) and r.output.startswith(";!knitout-2")


def test_targets_run_after_the_last_ir_stage():
    r = compile_source(TUBE, "t.knit", until="dat")
    assert r.stage_reached == "machine" and isinstance(r.output, bytes)


def test_a_verifier_violation_is_an_internal_error_naming_the_stage(monkeypatch):
    bad = driver.Stage("trace", STAGES[3].run, lambda r: ["stitch 0 visited twice"], STAGES[3].dump)
    monkeypatch.setattr(driver, "STAGES", STAGES[:3] + (bad,) + STAGES[4:])
    with pytest.raises(driver.InternalError, match="stage `trace`.*visited twice"):
        compile_source(TUBE, "t.knit", until="trace")


def test_cli_until_and_time_passes(tmp_path, capsys):
    f = tmp_path / "t.knit"
    f.write_text(TUBE)
    assert main(["--until", "schedule", "--time-passes", str(f)]) == 0
    out, err = capsys.readouterr()
    assert out == ""
    assert "seconds per stage" in err and "schedule" in err and "machine" not in err


def test_cli_output_dash_is_standard_output(tmp_path, capsys, monkeypatch):
    f = tmp_path / "t.knit"
    f.write_text(TUBE)
    monkeypatch.chdir(tmp_path)
    assert main([str(f), "-o", "-"]) == 0
    out, _ = capsys.readouterr()
    assert out.startswith(";!knitout-2") and not (tmp_path / "-").exists()


def test_the_facade_is_the_pipeline_and_imports_lazily():
    import subprocess
    import sys

    import knitc

    assert knitc.compile_source is compile_source and knitc.STAGES is STAGES
    assert set(knitc.__all__) >= {
        "compile_source",
        "compile_file",
        "resume",
        "StitchGraph",
        "MachineProgram",
        "Skeleton",
        "Trace",
        "Schedule",
    }
    assert set(knitc.__all__) == {"__version__", *knitc._PUBLIC}
    for name in knitc.__all__:
        getattr(knitc, name)
    probe = "import sys, knitc; print('numpy' in sys.modules, 'lark' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True)
    assert out.stdout.split() == ["False", "False"]


def test_ir_verifiers_run_when_asked_and_the_output_check_always(monkeypatch):
    """A designer's compile skips the IR verifiers (they check knitc, and cost a tenth to a
    quarter of a compile); `verify=True`, `--verify-each` or KNITC_VERIFY=1 runs them. The
    machine stage's check of the output runs either way."""
    seen: list[str] = []

    def spy(i: int):
        def verify(r):
            seen.append(STAGES[i].name)
            return STAGES[i].verify(r)

        return verify

    spied = tuple(
        driver.Stage(s.name, s.run, spy(i) if s.verify else None, s.dump)
        for i, s in enumerate(STAGES)
    )
    monkeypatch.setattr(driver, "STAGES", spied)
    monkeypatch.delenv(driver.VERIFY_ENV)
    compile_source(TUBE, "t.knit", until="machine")
    assert seen == ["machine"]
    seen.clear()
    compile_source(TUBE, "t.knit", until="machine", verify=True)
    assert seen == [s.name for s in STAGES if s.verify]
    seen.clear()
    monkeypatch.setenv(driver.VERIFY_ENV, "1")
    compile_source(TUBE, "t.knit", until="machine")
    assert seen == [s.name for s in STAGES if s.verify]
    seen.clear()
    compile_source(TUBE, "t.knit", until="machine", verify=False)
    assert seen == ["machine"]


def test_cli_verify_each(tmp_path, monkeypatch):
    monkeypatch.delenv(driver.VERIFY_ENV)
    bad = driver.Stage("trace", STAGES[3].run, lambda r: ["stitch 0 visited twice"], STAGES[3].dump)
    monkeypatch.setattr(driver, "STAGES", STAGES[:3] + (bad,) + STAGES[4:])
    f = tmp_path / "t.knit"
    f.write_text(TUBE)
    assert main(["check", str(f)]) == 0
    assert main(["check", "--verify-each", str(f)]) == 3
