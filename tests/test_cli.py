"""The `knitc` command line, run in-process through `knitc.cli.main` (plus one subprocess run
of the installed entry point)."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

import knitc
from knitc.cli import main
from oracle import assert_clean, run_oracle


def _has_module_fmt() -> bool:
    try:
        from knitc.frontend.fmt import format_module  # noqa: F401
    except ImportError:
        return False
    return True


def _has_layer_fmt() -> bool:
    try:
        from knitc.frontend.fmt import format_layer_stmt  # noqa: F401
    except ImportError:
        return False
    return True


needs_fmt = pytest.mark.skipif(
    not _has_module_fmt(), reason="knitc.frontend.fmt.format_module does not exist yet"
)
needs_layer_fmt = pytest.mark.skipif(
    not _has_layer_fmt(),
    reason="knitc.frontend.fmt.format_layer_stmt does not exist yet; "
    "knitc.frontend.skeleton.to_json imports it, so --emit skeleton cannot run",
)

GOOD = "param n = 2\ntube a { width: #n }\ntube b { width: #n }\na.top -> b.bottom\n"
WARN = "tube a { width: 4 }\ntube b { width: 5 }\na.top -> b.bottom\n"  # W502
BAD = "sheet a { length: 0 }\n"  # E313
SYNTAX = "sheet a { length 3 }\n"  # E101


@pytest.fixture
def write(tmp_path):
    def _write(text: str, name: str = "f.knit"):
        p = tmp_path / name
        p.write_text(text, encoding="utf-8")
        return str(p)

    return _write


def run(capsys, *argv):
    code = main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


# ---- version and help --------------------------------------------------------------------------


def test_version(capsys):
    code, out, err = run(capsys, "--version")
    assert code == 0
    assert out.strip() == f"knitc {knitc.__version__}"


def test_help_mentions_examples(capsys):
    code, out, _ = run(capsys, "--help")
    assert code == 0
    assert "examples:" in out
    assert "knitc check" in out
    assert "--emit" in out and "-D" in out


def test_subcommand_help(capsys):
    code, out, _ = run(capsys, "check", "--help")
    assert code == 0 and "knitc check" in out
    code, out, _ = run(capsys, "fmt", "--help")
    assert code == 0 and "--check" in out


@pytest.mark.parametrize(
    "argv",
    [
        [],
        ["--emit", "nonsense", "x.knit"],
        ["-W", "all", "x.knit"],
        ["check"],
        ["fmt"],
        ["--bogus", "x.knit"],
    ],
)
def test_usage_errors_exit_2(capsys, argv):
    code, _, err = run(capsys, *argv)
    assert code == 2
    assert "usage" in err


# ---- check -------------------------------------------------------------------------------------


def test_check_clean_file(capsys, write):
    code, out, err = run(capsys, "check", write(GOOD))
    assert code == 0
    assert out == "" and err == ""


def test_check_error_file(capsys, write):
    path = write(BAD)
    code, out, err = run(capsys, "check", path)
    assert code == 1
    assert out == ""
    assert f"{path}:1:19: error[E313]" in err
    assert "knitc: 1 error" in err


def test_check_syntax_error(capsys, write):
    code, _, err = run(capsys, "check", write(SYNTAX))
    assert code == 1
    assert "error[E101]" in err


def test_check_with_warning_passes(capsys, write):
    code, _, err = run(capsys, "check", write(WARN))
    assert code == 0
    assert "warning[W502]" in err
    assert "knitc: 1 warning" in err


def test_werror_makes_warning_fail(capsys, write):
    path = write(WARN)
    code, _, err = run(capsys, "check", "-W", "error", path)
    assert code == 1
    assert "error[W502]" in err
    code, _, _ = run(capsys, "-W", "error", "check", path)
    assert code == 1
    code, _, _ = run(capsys, "-W", "error", path)
    assert code == 1


def test_quiet_hides_warnings(capsys, write):
    code, out, err = run(capsys, "check", "--quiet", write(WARN))
    assert code == 0
    assert out == "" and err == ""


def test_quiet_still_shows_errors(capsys, write):
    code, _, err = run(capsys, "check", "-q", write(BAD))
    assert code == 1
    assert "error[E313]" in err
    assert "knitc: 1 error" not in err  # no summary in quiet mode


def test_missing_input_file(capsys, tmp_path):
    missing = str(tmp_path / "nope.knit")
    for argv in (["check", missing], [missing], ["--emit", "ast", missing]):
        code, out, err = run(capsys, *argv)
        assert code == 1
        assert "error[E001]" in err
        assert "Traceback" not in err and "internal error" not in err
        assert out == ""


def test_directory_as_input(capsys, tmp_path):
    code, _, err = run(capsys, "check", str(tmp_path))
    assert code == 1
    assert "error[E001]" in err and "Traceback" not in err


def test_non_utf8_input(capsys, tmp_path):
    p = tmp_path / "latin1.knit"
    p.write_bytes(b"// caf\xe9\nsheet a {}\n")
    code, _, err = run(capsys, "check", str(p))
    assert code == 1
    assert "error[E001]" in err and "Traceback" not in err


def test_define_before_subcommand(capsys, write):
    path = write("param n = 2\nsheet a { length: #n }\n")
    assert run(capsys, "-D", "n=3", "check", path)[0] == 0
    assert run(capsys, "check", "-D", "n=3", path)[0] == 0
    code, _, err = run(capsys, "-D", "n=0", "check", path)
    assert code == 1 and "E313" in err
    code, _, err = run(capsys, "-D", "m=3", "check", path)
    assert code == 1 and "E402" in err


def test_define_value_named_check(capsys, write):
    # `-D check=...` must not be mistaken for the subcommand.
    path = write("param check = 2\nsheet a { length: #check }\n")
    code, _, err = run(capsys, "-D", "check=0", "check", path)
    assert code == 1 and "E313" in err


def test_define_reaches_emitted_ast_stage(capsys, write):
    path = write("param n = 2\n")
    code, _, err = run(capsys, "-D", "n=(", "--emit", "ast", path)
    assert code == 2 and "E408" in err  # a command-line mistake (README: exit 2)


# ---- --emit ------------------------------------------------------------------------------------


def test_emit_ast_to_stdout(capsys, write):
    code, out, err = run(capsys, "--emit", "ast", write(GOOD))
    assert code == 0, err
    data = json.loads(out)
    assert data["node"] == "Module"
    assert [i["node"] for i in data["items"]] == ["ParamDecl", "NodeDecl", "NodeDecl", "Connect"]


def test_emit_ast_with_output_file(capsys, write, tmp_path):
    out_path = tmp_path / "out.json"
    code, out, _ = run(capsys, "--emit", "ast", "-o", str(out_path), write(GOOD))
    assert code == 0
    assert out == ""
    data = json.loads(out_path.read_text(encoding="utf-8"))
    assert data["node"] == "Module"
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".knitc-")]


def test_emit_ast_is_deterministic(capsys, write):
    path = write(GOOD)
    first = run(capsys, "--emit", "ast", path)[1]
    second = run(capsys, "--emit", "ast", path)[1]
    assert first == second and first


@needs_layer_fmt
def test_emit_skeleton_to_stdout(capsys, write):
    code, out, err = run(capsys, "--emit", "skeleton", write(GOOD))
    assert code == 0, err
    data = json.loads(out)
    assert {
        "machine",
        "params",
        "nodes",
        "interfaces",
        "connections",
        "starts",
        "components",
        "layers",
        "definitions",
    } == set(data)
    assert data["params"] == {"n": 2}


@needs_layer_fmt
def test_emit_skeleton_with_define_and_output(capsys, write, tmp_path):
    out_path = tmp_path / "skel.json"
    code, out, _ = run(capsys, "-D", "n=5", "--emit", "skeleton", "-o", str(out_path), write(GOOD))
    assert code == 0 and out == ""
    data = json.loads(out_path.read_text(encoding="utf-8"))
    assert data["params"] == {"n": 5}
    assert {i["id"]: i["size"] for i in data["interfaces"]}["a.top"] == 10


@needs_layer_fmt
def test_emit_skeleton_is_deterministic(capsys, write):
    path = write(GOOD)
    assert run(capsys, "--emit", "skeleton", path)[1] == run(capsys, "--emit", "skeleton", path)[1]


@pytest.mark.parametrize("stage", ["ast", "skeleton"])
def test_errors_leave_no_output_file(capsys, write, tmp_path, stage):
    out_path = tmp_path / "out.json"
    src = BAD if stage == "skeleton" else SYNTAX
    code, out, err = run(capsys, "--emit", stage, "-o", str(out_path), write(src))
    assert code == 1
    assert out == ""
    assert not out_path.exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["f.knit"]


@pytest.mark.parametrize("stage", ["ast", "skeleton"])
def test_errors_leave_existing_output_untouched(capsys, write, tmp_path, stage):
    out_path = tmp_path / "out.json"
    out_path.write_text("previous contents\n", encoding="utf-8")
    src = BAD if stage == "skeleton" else SYNTAX
    code, _, _ = run(capsys, "--emit", stage, "-o", str(out_path), write(src))
    assert code == 1
    assert out_path.read_text(encoding="utf-8") == "previous contents\n"


def test_werror_leaves_no_output_file(capsys, write, tmp_path):
    out_path = tmp_path / "out.json"
    code, _, _ = run(capsys, "-W", "error", "--emit", "ast", "-o", str(out_path), write(WARN))
    # Warnings only appear after resolution; for --emit ast the run stops at the AST.
    assert code == 0
    out_path.unlink()
    code, _, _ = run(capsys, "-W", "error", "--emit", "skeleton", "-o", str(out_path), write(WARN))
    assert code == 1
    assert not out_path.exists()


def test_plain_compile_without_emit(capsys, write):
    code, out, err = run(capsys, write(GOOD))
    assert code == 0 and out == "" and err == ""


def test_compile_to_dat_by_extension_or_target(capsys, write, tmp_path):
    out_path = tmp_path / "x.dat"
    code, out, err = run(capsys, "-o", str(out_path), write(GOOD))
    assert code == 0, err
    assert out_path.read_bytes()[8:10] == (1000).to_bytes(2, "little")  # a DAT header
    code, out, err = run(capsys, "--target", "dat", write(GOOD))
    assert code == 1 and "-o FILE.dat" in err and "Traceback" not in err  # binary: no stdout


def test_compile_to_knitout_writes_the_file(capsys, write, tmp_path):
    out_path = tmp_path / "x.k"
    code, out, err = run(capsys, "-o", str(out_path), write(GOOD))
    assert code == 0, err
    text = out_path.read_text()
    assert text.startswith(";!knitout-2\n") and "\nknit " in text
    [report] = run_oracle([out_path])
    assert_clean(report)


# ---- fmt ---------------------------------------------------------------------------------------


@needs_fmt
def test_fmt_check_canonical_and_not(capsys, write):
    from knitc.frontend.fmt import format_module
    from knitc.frontend.parser import parse

    messy = "param   n=2\n\n\n\ntube a{width:#n length : 3}\n"
    canonical = format_module(parse(messy, "f.knit"))
    assert canonical != messy
    bad = write(messy, "messy.knit")
    good = write(canonical, "canon.knit")
    code, out, err = run(capsys, "fmt", "--check", bad)
    assert code == 1
    assert out == ""
    assert "messy.knit" in err
    code, out, err = run(capsys, "fmt", "--check", good)
    assert code == 0 and out == "" and err == ""
    code, _, _ = run(capsys, "fmt", "--check", good, bad)
    assert code == 1


@needs_fmt
def test_fmt_prints_and_rewrites(capsys, write, tmp_path):
    messy = "param   n=2\ntube a{width:#n}\n"
    path = write(messy, "m.knit")
    code, out, _ = run(capsys, "fmt", path)
    assert code == 0
    assert out and out != messy
    assert (tmp_path / "m.knit").read_text(encoding="utf-8") == messy  # unchanged
    code, _, _ = run(capsys, "fmt", "-i", path)
    assert code == 0
    assert (tmp_path / "m.knit").read_text(encoding="utf-8") == out
    assert run(capsys, "fmt", "--check", path)[0] == 0


@needs_fmt
def test_fmt_on_syntax_error_and_missing_file(capsys, write, tmp_path):
    path = write(SYNTAX)
    code, _, err = run(capsys, "fmt", "-i", path)
    assert code == 1 and "E101" in err
    assert (tmp_path / "f.knit").read_text(encoding="utf-8") == SYNTAX
    code, _, err = run(capsys, "fmt", "--check", str(tmp_path / "nope.knit"))
    assert code == 1 and "E001" in err and "Traceback" not in err


def test_fmt_check_and_in_place_are_exclusive(capsys, write):
    code, _, err = run(capsys, "fmt", "--check", "-i", write(GOOD))
    assert code == 2


# ---- the installed entry point -----------------------------------------------------------------


def test_module_entry_point_runs():
    proc = subprocess.run(
        [sys.executable, "-m", "knitc", "--version"], capture_output=True, text=True, timeout=60
    )
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.strip() == f"knitc {knitc.__version__}"


def test_output_file_named_like_a_subcommand(capsys, write, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    path = write(GOOD)
    code, _, _ = run(capsys, "--emit", "ast", "--output", "check", path)
    assert code == 0
    assert (tmp_path / "check").is_file()


def test_outputs_keep_modes_write_through_links_and_never_replace_devices(tmp_path, capsys):
    import os
    import stat

    from knitc.cli import main, write_atomic

    design = tmp_path / "t.knit"
    design.write_text("tube t {length: 2}\n")
    os.chmod(design, 0o600)
    assert main(["fmt", "-i", str(design)]) == 0
    assert stat.S_IMODE(os.stat(design).st_mode) == 0o600  # fmt -i keeps a private design
    real, link = tmp_path / "real.k", tmp_path / "link.k"
    link.symlink_to(real.name)
    write_atomic(str(link), "x\n")
    assert link.is_symlink() and real.read_text() == "x\n"
    fifo = tmp_path / "pipe"
    os.mkfifo(fifo)
    fd = os.open(fifo, os.O_RDONLY | os.O_NONBLOCK)  # a reader, so the write does not block
    write_atomic(str(fifo), "y\n")
    assert os.read(fd, 10) == b"y\n" and stat.S_ISFIFO(os.stat(fifo).st_mode)
    os.close(fd)


def test_a_byte_order_mark_is_not_a_character_of_the_design(tmp_path, capsys):
    from knitc.cli import main

    f = tmp_path / "bom.knit"
    f.write_bytes(b"\xef\xbb\xbftube t { length: 2 }\n")
    assert main(["check", str(f)]) == 0
    assert main(["fmt", "--check", str(f)]) == 0


# ---- limits and folders (docs/security.md) -----------------------------------------------------


def test_max_stitches_lowers_and_raises_the_budget(capsys, write):
    path = write("tube a { length: 4 width: 4 }\n")  # 32 stitches
    code, _, err = run(capsys, "check", "--max-stitches", "31", path)
    assert code == 1 and "error[E512]" in err and "the limit is 31" in err
    assert "raise it with --max-stitches" in err
    assert run(capsys, "check", "--max-stitches", "32", path)[0] == 0
    assert run(capsys, "--max-stitches", "31", "--until", "skeleton", path)[0] == 1


@pytest.mark.parametrize("value", ["0", "-5", "many"])
def test_max_stitches_must_be_a_positive_whole_number(capsys, write, value):
    code, _, err = run(capsys, "check", "--max-stitches", value, write(GOOD))
    assert code == 2 and "--max-stitches" in err


def test_include_may_come_before_the_subcommand(capsys, tmp_path):
    (tmp_path / "lib").mkdir()
    (tmp_path / "lib" / "l.knit").write_text("pattern p() { set P where all() }\n")
    (tmp_path / "d").mkdir()
    design = tmp_path / "d" / "x.knit"
    design.write_text('import "../lib/l.knit"\ntube a { length: 2 width: 2 }\n')
    assert run(capsys, "check", str(design))[0] == 1  # E226 without the folder
    assert run(capsys, "--include", str(tmp_path / "lib"), "check", str(design))[0] == 0


def test_an_output_device_is_written_in_place_and_fmt_keeps_a_symlinked_design(tmp_path, capsys):
    import os
    import stat

    from knitc.cli import write_atomic

    write_atomic("/dev/null", "x\n")  # never replaced by a regular file (as root it could be)
    assert stat.S_ISCHR(os.stat("/dev/null").st_mode)
    real, link = tmp_path / "real.knit", tmp_path / "link.knit"
    real.write_text("tube t {length: 2}\n")
    link.symlink_to(real.name)
    assert main(["fmt", "-i", str(link)]) == 0
    assert link.is_symlink() and real.read_text() == "tube t { length: 2 }\n"


def test_an_output_through_a_symlink_to_the_input_is_refused(capsys, write, tmp_path):
    path = write(GOOD)
    (tmp_path / "out.k").symlink_to(path)
    code, _, err = run(capsys, path, "-o", str(tmp_path / "out.k"))
    assert code == 1 and "error[E002]" in err and "is the input file" in err
    assert (tmp_path / "f.knit").read_text() == GOOD


def test_the_process_command_ends_with_its_status_and_all_its_output(capsys, tmp_path):
    """`knitc` run as a process ends it without the interpreter's teardown
    (`_process.end`): the exit status, every byte written to stdout (a pipe, so buffered)
    and stderr, and the output file are all there, as from `main([...])` in process."""
    good, bad = tmp_path / "good.knit", tmp_path / "bad.knit"
    good.write_text(GOOD)
    bad.write_text("tube t { width: }\n")
    knitc_cmd = [sys.executable, "-m", "knitc"]
    done = subprocess.run([*knitc_cmd, str(good), "-o", "-"], capture_output=True, text=True)
    assert main([str(good), "-o", "-"]) == 0
    mine = capsys.readouterr()
    assert done.returncode == 0 and (done.stdout, done.stderr) == (mine.out, mine.err)
    done = subprocess.run([*knitc_cmd, "check", str(bad)], capture_output=True, text=True)
    assert main(["check", str(bad)]) == 1
    assert done.returncode == 1 and done.stderr == capsys.readouterr().err
    out = tmp_path / "good.k"
    done = subprocess.run([*knitc_cmd, str(good), "-o", str(out)], capture_output=True)
    assert done.returncode == 0 and out.read_text() == mine.out
    [report] = run_oracle([out])
    assert_clean(report)


def test_a_closed_stdout_pipe_ends_quietly(tmp_path):
    """A reader that goes away (`knitc f.knit -o - | head -1`) is not an error: no
    traceback, no "Exception ignored" from a last flush."""
    good = tmp_path / "good.knit"
    good.write_text(GOOD)
    proc = subprocess.Popen(
        [sys.executable, "-m", "knitc", str(good), "-o", "-"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
    )
    assert proc.stdout is not None and proc.stderr is not None
    proc.stdout.close()
    err = proc.stderr.read().decode()
    assert proc.wait() == 0
    assert "Traceback" not in err and "Exception ignored" not in err


def test_gc_thresholds_batch_only_for_the_process_command_line(tmp_path):
    """A one-shot `knitc` process collects only young cycles (its objects live to its end);
    `main([...])` in a caller's process, and `knitc lsp`, keep the server's thresholds."""
    import gc

    from knitc import cli

    f = tmp_path / "t.knit"
    f.write_text("tube t { length: 2, width: 4 }\n")
    # (the process command ends the process itself: what it leaves is seen from atexit)
    code = (
        f"import atexit, gc, sys\nfrom knitc import cli\nsys.argv = ['knitc', 'check', {str(f)!r}]\n"
        "atexit.register(lambda: print(gc.get_threshold()))\ncli.main()\nprint('returned')\n"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True
    ).stdout
    assert out.strip() == str(cli.BATCH_GC_THRESHOLDS)
    before = gc.get_threshold()
    try:
        assert cli.main(["check", str(f)]) == 0
        assert gc.get_threshold() == cli.GC_THRESHOLDS
    finally:
        gc.set_threshold(*before)
