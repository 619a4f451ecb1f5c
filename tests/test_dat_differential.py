"""knitc's Knitout -> DAT against the CMU converter itself, on generated programs: a local,
opt-in differential check (the recorded fixtures in tests/fixtures/dat/ are what every run
compares with).

The converter (``knitout-to-dat.js``, run with node) is not part of the repository, so these
tests run only when ``KNITC_CMU_CONVERTER`` names a copy of it and ``node`` is on the PATH;
otherwise they skip, saying so. They first check that the copy reproduces the recorded
fixtures (else it is not the converter they were made with), then compare knitc's bytes with
the converter's on the shipped designs and on random machine programs
(`test_knitout_read.machine_programs`, which stay within what both accept).

The other independent implementation, knitout-to-dat-python (PyPI 0.0.4, a Python port of
the converter), is not used: it is no oracle for these bytes. It differs from the converter
on every fixture it can read, and it cannot share the oracle environment (it needs
knitout-interpreter 0.1.2; the oracle pins 0.1.8, with which it fails on import). The
evidence is in tests/fixtures/dat/README.md, "knitout-to-dat-python".
"""

from __future__ import annotations

import os
import shutil
import subprocess
import tempfile
from pathlib import Path

import pytest
from hypothesis import HealthCheck, assume, given, settings

from knitc.backends.dat_format import encode
from knitc.backends.dat_write import to_dat
from knitc.backends.knitout import write_knitout
from knitc.backends.knitout_read import parse_knitout
from knitc.codegen.machine import MachineProgram
from knitc.driver import compile_source
from test_knitout_read import machine_programs

ROOT = Path(__file__).resolve().parent.parent
FIXTURES = sorted((ROOT / "tests" / "fixtures" / "dat").glob("*.k"))
DESIGNS = sorted((ROOT / "examples").glob("*.knit"))

CONVERTER = os.environ.get("KNITC_CMU_CONVERTER", "")
NODE = shutil.which("node")

pytestmark = pytest.mark.skipif(
    not (CONVERTER and Path(CONVERTER).is_file() and NODE),
    reason="set KNITC_CMU_CONVERTER to a copy of the CMU knitout-to-dat.js (and have node) "
    "to compare knitc's DATs with the converter's",
)


def converter_dat(text: str) -> bytes:
    """The converter's DAT of Knitout `text` (its console output is ignored)."""
    assert NODE is not None
    with tempfile.TemporaryDirectory() as tmp:
        src, out = Path(tmp) / "in.k", Path(tmp) / "out.dat"
        src.write_text(text, encoding="utf-8")
        proc = subprocess.run(
            [NODE, CONVERTER, str(src), str(out)], capture_output=True, text=True, timeout=120
        )
        assert proc.returncode == 0 and out.exists(), proc.stdout[-2000:] + proc.stderr[-2000:]
        return out.read_bytes()


def knitc_dat(text: str) -> bytes:
    return encode(to_dat(parse_knitout(text, "in.k")))


@pytest.mark.parametrize("path", FIXTURES, ids=lambda p: p.stem)
def test_the_converter_is_the_one_the_fixtures_were_made_with(path: Path) -> None:
    assert converter_dat(path.read_text(encoding="utf-8")) == path.with_suffix(".dat").read_bytes()


@pytest.mark.parametrize("path", DESIGNS, ids=lambda p: p.stem)
def test_shipped_designs_convert_to_the_converters_bytes(path: Path) -> None:
    result = compile_source(path.read_text(encoding="utf-8"), str(path), until="machine")
    assert result.ok and result.program is not None
    text = write_knitout(result.program)
    assert knitc_dat(text) == converter_dat(text)


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(machine_programs(max_steps=30))
def test_generated_programs_convert_to_the_converters_bytes(prog: MachineProgram) -> None:
    # knitc's one deliberate difference in the pass data: a pair led by carrier 10 is 10X
    # (e.g. 106), the converter writes 1X (16, the code of carriers 1 and 6): see
    # dat_write.carrier_code. Seen in 3 of 1,000 generated programs, the only differences.
    assume(not any(len(op.carriers) == 2 and op.carriers[0] == 10 for op in prog.ops))
    text = write_knitout(prog, one_carrier_per_line=False)
    assert knitc_dat(text) == converter_dat(text), text
