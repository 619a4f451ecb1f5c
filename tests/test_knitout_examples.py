"""Every shipped design compiles to Knitout that the independent machine knits into the
designed fabric.

The Knitout comes from `knitc FILE -o OUT.k` in-process and is judged by
knitout-interpreter / virtual-knitting-machine (tests/oracle.py: its own venv, no knitc
code), whose knit graph is held against the design stitch by stitch (tests/fabric.py). A
design whose transfers cannot be planned fails with a located E602.
"""

from __future__ import annotations

from pathlib import Path

from fabric import assert_knits_as_designed
from knitc.backends.knitout import write_knitout
from knitc.cli import main
from knitc.driver import compile_file

REPO = Path(__file__).resolve().parent.parent
DESIGNS = sorted((REPO / "examples").glob("*.knit")) + sorted(
    (REPO / "examples" / "knitskel").glob("*.knit")
)


def _key(path: Path) -> str:
    return path.name if path.parent.name == "examples" else f"{path.parent.name}/{path.name}"


def _compile(path: Path, out: Path, capsys) -> tuple[int, str]:
    code = main([str(path), "-o", str(out), "-q"])
    return code, capsys.readouterr().err


def test_every_design_knits_its_design_on_the_independent_machine(tmp_path, capsys):
    # the CLI writes each design's Knitout; the same compile, in-process, gives the design
    # its fabric is held against (tests/fabric.py): clean on the machine is not enough
    results = []
    for path in DESIGNS:
        out = tmp_path / (_key(path).replace("/", "_") + ".k")
        code, err = _compile(path, out, capsys)
        assert code == 0, f"{_key(path)}:\n{err}"
        r = compile_file(str(path), until="machine")
        assert write_knitout(r.program) == out.read_text(), _key(path)
        results.append(r)
    assert len(results) >= 12
    assert_knits_as_designed(results, names=[_key(p) for p in DESIGNS])


def test_knitout_is_deterministic(tmp_path, capsys):
    path = REPO / "examples" / "tube.knit"
    a, b = tmp_path / "a.k", tmp_path / "b.k"
    assert _compile(path, a, capsys)[0] == 0 and _compile(path, b, capsys)[0] == 0
    assert a.read_bytes() == b.read_bytes()


def test_unplannable_transfers_fail_cleanly(tmp_path, capsys):
    # without racking no loop can shift along its bed: the decreases cannot be made
    src = tmp_path / "flat.knit"
    src.write_text("machine { racking: 0 }\nsheet s { length: 4  width: [0: 10, 1: 6] }\n")
    out = tmp_path / "flat.k"
    code, err = _compile(src, out, capsys)
    assert code == 1 and not out.exists()
    assert f"{src}:2:1: error[E602]: cannot generate machine code" in err
    assert "Traceback" not in err and "racking" in err
