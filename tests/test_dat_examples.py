"""Every shipped design compiles to a DAT file that decodes back to the same passes (and to
Knitout the independent machine runs clean), and the
command line writes, converts and reads DAT files (`-o x.dat`, `k2dat`, `dat2k`)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from knitc.backends.dat_format import decode, encode, rows
from knitc.backends.dat_read import dat_to_program
from knitc.backends.dat_write import to_dat
from knitc.backends.knitout import write_knitout
from knitc.cli import main
from knitc.driver import compile_source
from oracle import assert_clean, run_oracle_on_text

ROOT = Path(__file__).resolve().parent.parent
DESIGNS = sorted((ROOT / "examples").glob("*.knit")) + sorted(
    (ROOT / "examples" / "knitskel").glob("*.knit")
)
FIXTURES = ROOT / "tests" / "fixtures" / "dat"


@pytest.mark.parametrize("path", DESIGNS, ids=lambda p: p.stem)
def test_every_design_round_trips_through_dat(path):
    r = compile_source(path.read_text(encoding="utf-8"), str(path), until="machine")
    assert r.program is not None, r.diagnostics.render()
    image = to_dat(r.program)
    data = encode(image)
    back = decode(data)
    assert rows(back) == rows(image)
    # the decoded passes are a program that writes the same DAT again
    again = encode(to_dat(dat_to_program(back)))
    assert rows(again) == rows(data)


def test_knitout_decoded_from_dats_runs_clean_on_the_independent_machine():
    """What `dat2k` writes is a program a machine can run: every fixture's DAT and every
    shipped design's DAT, read back, pass the independent machine."""
    datas = [f.read_bytes() for f in sorted(FIXTURES.glob("*.dat"))]
    for path in DESIGNS:
        r = compile_source(path.read_text(encoding="utf-8"), str(path), until="machine")
        datas.append(encode(to_dat(r.program)))
    texts = [write_knitout(dat_to_program(decode(d))) for d in datas]
    for report in run_oracle_on_text(texts):
        assert_clean(report)


def test_compiling_to_dat_writes_the_file_atomically(tmp_path, capsys):
    out = tmp_path / "tube.dat"
    assert main([str(ROOT / "examples" / "tube.knit"), "-o", str(out)]) == 0
    data = out.read_bytes()
    assert data[8:10] == (1000).to_bytes(2, "little") and len(decode(data).passes) > 10
    assert [p.name for p in tmp_path.iterdir()] == ["tube.dat"]  # no temporary left


def test_k2dat_reproduces_the_reference_converter_and_dat2k_reads_it(tmp_path, capsys):
    out = tmp_path / "rib.dat"
    assert main(["k2dat", str(FIXTURES / "rib_2x2.k"), "-o", str(out)]) == 0
    assert out.read_bytes() == (FIXTURES / "rib_2x2.dat").read_bytes()
    assert main(["dat2k", str(out)]) == 0
    text = capsys.readouterr().out
    assert text.startswith(";!knitout-2") and "knit" in text


def test_k2dat_reports_bad_knitout_at_its_line_and_writes_nothing(tmp_path, capsys):
    bad = tmp_path / "bad.k"
    bad.write_text(";!knitout-2\n;;Carriers: 1 2 3\nin 3\nknot + f1 3\n", encoding="utf-8")
    out = tmp_path / "bad.dat"
    assert main(["k2dat", str(bad), "-o", str(out)]) == 1
    err = capsys.readouterr().err
    assert f"{bad}:4:" in err and "error[" in err and "knot + f1 3" in err
    assert not out.exists()


def test_k2dat_refuses_what_a_shima_cannot_knit(tmp_path, capsys):
    """More than two carriers in one set, and a carrier left in, are errors at the line."""
    src = (
        ";!knitout-2\n;;Machine: SWG091N2\n;;Gauge: 15\n;;Carriers: 1 2 3 4 5 6 7 8 9 10\n"
        "in 1 2 3\nknit + f1 1 2 3\nout 1 2 3\n"
    )
    k = tmp_path / "three.k"
    k.write_text(src, encoding="utf-8")
    assert main(["k2dat", str(k), "-o", str(tmp_path / "three.dat")]) == 1
    err = capsys.readouterr().err
    assert "error[" in err and f"{k}:" in err
    assert not (tmp_path / "three.dat").exists()
    left_in = src.replace("in 1 2 3\nknit + f1 1 2 3\nout 1 2 3\n", "in 4\nknit + f1 4\n")
    k.write_text(left_in, encoding="utf-8")
    assert main(["k2dat", str(k), "-o", str(tmp_path / "left.dat")]) == 1
    assert "error[" in capsys.readouterr().err


def test_dat2k_prints_the_pass_table(capsys):
    assert main(["dat2k", "--passes", str(FIXTURES / "rib_2x2.dat")]) == 0
    table = json.loads(capsys.readouterr().out)
    want = rows((FIXTURES / "rib_2x2.dat").read_bytes())
    assert (table["width"], table["height"]) == (126, 38) and len(table["rows"]) == len(want)
    assert table["rows"] == [r.to_json() for r in want]


def test_dat2k_rejects_a_file_that_is_not_a_dat(tmp_path, capsys):
    junk = tmp_path / "junk.dat"
    junk.write_bytes(b"\x00" * 100)
    assert main(["dat2k", str(junk)]) == 1
    assert "error[E902]" in capsys.readouterr().err
