"""Hostile Knitout through `knitc k2dat` and `knitc lint`: every input ends in a located
diagnostic (exit 1) or a result (exit 0), never an internal error (exit 3), a hang or an
unbounded allocation.

Two layers, both deterministic and run in-process through `knitc.cli.main`:

* a table of hostile lines (huge numbers, non-finite spellings, control characters,
  truncated and malformed instructions), each put into a small valid program;
* a seeded mutation loop over the corpus (tests/fixtures/knitout, tests/fixtures/dat and a
  compiled example): flipped bits, a token replaced by a hostile one, truncated, duplicated,
  deleted and inserted lines, CR line ends, NULs and other separators, non-UTF-8 bytes.

Work is bounded by construction, not by a clock: the reader refuses every number beyond its
limit on the token (tests/test_knitout_read.py), so no mutation can make a bed, a raster or
an integer conversion grow with the size of a number.
"""

from __future__ import annotations

import random
from pathlib import Path

import pytest

from knitc.backends.knitout import write_knitout
from knitc.cli import main
from knitc.driver import compile_source

ROOT = Path(__file__).resolve().parent.parent
HEADER = ";!knitout-2\n;;Machine: SWG091N2\n;;Gauge: 15\n;;Carriers: 1 2 3 4 5 6 7 8 9 10\n"
BODY = "inhook 3\ntuck - f4 3\ntuck - f2 3\nknit + f2 3\nknit + f4 3\nreleasehook 3\n"
TAIL = "knit - f4 3\nknit - f2 3\nouthook 3\ndrop f2\ndrop f4\n"

HUGE = "9" * 5000
HOSTILE_TOKENS = [
    HUGE,
    "-" + HUGE,
    "+" + HUGE,
    HUGE + "." + HUGE,
    "0." + "0" * 5000 + "1",
    "f" + HUGE,
    "b-" + HUGE,
    "fs" + "0" * 5000 + "1",
    "1e400",
    "inf",
    "nan",
    "-0",
    ".",
    "+",
    "99999999999999999999",
    "\x00",
    "\x0b",
    "\x1c",
    "\u2028",
    "\x85",
    "\ufeff",
    "f1\x00",
    "é",
]

HOSTILE_LINES = [
    f"knit + f{HUGE} 3",
    f"tuck - b-{HUGE} 3",
    f"xfer f{HUGE} b{HUGE}",
    f"split + f1 b{HUGE} 3",
    f"drop f{HUGE}",
    f"rack {HUGE}",
    f"rack -{HUGE}.{HUGE}",
    "rack 1e400",
    "rack 0.1",
    "rack 9",
    f"stitch {HUGE} {HUGE}",
    "stitch 10.5 15",
    f"x-stitch-number {HUGE}",
    f"x-speed-number {HUGE}",
    "x-stitch-number 256",
    "x-speed-number 246",
    f"x-presser-mode {HUGE}",
    f"x-{HUGE} 1",
    f"in {HUGE}",
    "in 3 3",
    "knit + f9999 3",
    "knit + f-9999 3",
    f";;Width: {HUGE}",
    ";;Width: 541",
    f";;Position: {HUGE}",
    "knit + f1 3 " + " ".join(["3"] * 5000),
    "knit\x00+ f1 3",
    "knit + f1\r3",
    "\ufeffknit + f1 3",
    "knit + f１ 3",  # a full-width digit: not an ASCII needle number
    ";" * 5000,
    "knit + f1",
    "xfer",
    "split + f1",
]
"""Lines put after the cast-on of a small valid program (some are headers out of place)."""

HOSTILE_HEADERS = [
    f";!knitout-{HUGE}\n;;Carriers: 1 2 3\n",
    f";!knitout-2\n;;Width: {HUGE}\n;;Carriers: 1 2 3\n",
    f";!knitout-2\n;;Gauge: {HUGE}\n;;Carriers: 1 2 3\n",
    f";!knitout-2\n;;Gauge: 0.{HUGE}\n;;Carriers: 1 2 3\n",
    f";!knitout-2\n;;Carriers: {' '.join(str(k) for k in range(5000))}\n",
    f";!knitout-2\n;;Carriers: 1 2 {HUGE}\n",
    f";!knitout-2\n;;{HUGE}: 1\n;;Carriers: 1 2 3\n",
    f";!knitout-2\n;;Position: {HUGE}\n;;Carriers: 1 2 3\n",
    "\ufeff;!knitout-2\n;;Carriers: 1 2 3\n",
    ";!knitout-2\r\n;;Carriers: 1 2 3\r\n",
    "",
    "\x00",
]
"""Whole headers put before the small program's body."""


def run_both(data: bytes, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """`k2dat` and `lint` of `data` end with 0 or 1 and no internal error."""
    src = tmp_path / "in.k"
    src.write_bytes(data)
    for argv in (
        ["k2dat", str(src), "-o", str(tmp_path / "out.dat"), "--quiet"],
        ["lint", str(src)],
    ):
        code = main(argv)
        _, err = capsys.readouterr()
        assert code in (0, 1) and "internal error" not in err, (
            f"knitc {argv[0]} exited {code} on {data[:300]!r}...:\n{err[-2000:]}"
        )
        if code == 1:
            assert "error[E" in err


@pytest.mark.parametrize("line", HOSTILE_LINES, ids=range(len(HOSTILE_LINES)))
def test_hostile_line(line: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    run_both((HEADER + BODY + line + "\n" + TAIL).encode(), tmp_path, capsys)


@pytest.mark.parametrize("header", HOSTILE_HEADERS, ids=range(len(HOSTILE_HEADERS)))
def test_hostile_header(header: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    run_both((header + BODY + TAIL).encode(), tmp_path, capsys)


def test_non_utf8_is_e001(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    src = tmp_path / "latin1.k"
    src.write_bytes((HEADER + BODY).encode() + b"; caf\xe9\n" + TAIL.encode())
    assert main(["lint", str(src)]) == 1
    assert "error[E001]" in capsys.readouterr().err


# ---- seeded mutation -------------------------------------------------------------------------


@pytest.fixture(scope="module")
def corpus() -> list[bytes]:
    files = sorted((ROOT / "tests" / "fixtures" / "knitout").glob("*.k"))
    files += [
        p
        for p in sorted((ROOT / "tests" / "fixtures" / "dat").glob("*.k"))
        if p.stat().st_size < 30_000  # keep the loop fast: the large ones add nothing new
    ]
    texts = [p.read_bytes() for p in files]
    sheet = ROOT / "examples" / "sheet.knit"
    result = compile_source(sheet.read_text(encoding="utf-8"), str(sheet), until="machine")
    assert result.ok and result.program is not None
    lines = write_knitout(result.program).split("\n")
    texts.append("\n".join(lines[:400] + lines[-200:]).encode())  # its start and its end
    return texts


def mutate(rng: random.Random, data: bytes) -> bytes:
    """One to four random edits of `data`, line-wise."""
    lines = data.split(b"\n")
    tokens = [t.encode() for t in HOSTILE_TOKENS] + [b"\xff\xfe", b"\xc3", b"\x00\x00"]
    for _ in range(rng.randint(1, 4)):
        k = rng.randrange(len(lines))
        edit = rng.randrange(9)
        if edit == 0:  # flip one bit
            b = bytearray(lines[k] or b" ")
            b[rng.randrange(len(b))] ^= 1 << rng.randrange(8)
            lines[k] = bytes(b)
        elif edit == 1:  # a token becomes a hostile one
            words = lines[k].split(b" ")
            words[rng.randrange(len(words))] = rng.choice(tokens)
            lines[k] = b" ".join(words)
        elif edit == 2:  # truncate
            lines[k] = lines[k][: rng.randrange(len(lines[k]) + 1)]
        elif edit == 3:
            lines.insert(k, lines[k])
        elif edit == 4 and len(lines) > 1:
            del lines[k]
        elif edit == 5:
            lines[k] += b"\r"
        elif edit == 6:
            sep = rng.choice([b"\t", b"  ", b"\x00", b"\x0c", b"\x0b", b"\xc2\x85"])
            lines[k] = lines[k].replace(b" ", sep)
        elif edit == 7:
            lines.insert(k, rng.choice(tokens))
        else:  # a number grows
            lines[k] = lines[k].replace(b"1", b"1" + b"0" * rng.choice([3, 5, 30, 5000]), 1)
    return b"\n".join(lines)


MUTANTS = 300
"""Mutants per run: about 10 s on one core."""


def test_mutated_knitout_never_crashes(
    corpus: list[bytes], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    rng = random.Random(14)
    for _ in range(MUTANTS):
        run_both(mutate(rng, rng.choice(corpus)), tmp_path, capsys)
