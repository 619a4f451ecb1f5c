"""knitc's fuzzing: run the targets for a while, then check a sample on the independent machine.

    python tests/fuzz/run.py --time 60                  every target, 60 s each (`make fuzz`)
    python tests/fuzz/run.py --time 1800 compile dat    some targets, 30 min each
    python tests/fuzz/run.py --reproduce dat crash-1f2e  run one target on saved inputs
    python tests/fuzz/run.py --time 600 --merge knitout  keep what reached new code in the corpus

Each target runs in its own process (engine.py: atheris, i.e. libFuzzer with coverage of the
`knitc` package), seeded from tests/fuzz/corpus/ and tests/fuzz/regressions/, with a fresh
random seed unless `--seed` is given (it is printed, so a run can be repeated). An input on
which knitc misbehaves (targets.py says what counts), runs longer than `--timeout` seconds or
grows past `--rss-limit-mb` stops the run: the reproducer is printed (as text when it is
text) and kept in `--artifacts`, and the exit status is 1. Make it a regression by copying
it into tests/fuzz/regressions/<kind>/ with a name that says what it was; tests/test_fuzz.py
runs every saved input on every `make test`.

After the runs, the designs the `design` and `compile` targets got through the whole
pipeline (a sample of them) are compiled again and run on the independent knitting machine
(tests/oracle.py), which must accept them, and their knit graph is held against the design
(tests/fabric.py): a program that every checker of knitc's own accepts is still a bug if the
machine refuses it or knits something else.
"""

from __future__ import annotations

import argparse
import os
import random
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path[:0] = [str(HERE), str(HERE.parent)]

import targets  # noqa: E402

ALL = ("parse", "compile", "design", "editor", "knitout", "dat")


def _reproduce(target: str, files: list[str]) -> int:
    if target == "design":
        import designs

        fn = designs.fuzz_one()
    else:
        fn = targets.TARGETS[target]
    status = 0
    for f in files:
        try:
            fn(Path(f).read_bytes())
        except targets.Bug as bug:
            print(f"{f}: BUG in knitc\n{bug}")
            status = 1
        else:
            print(f"{f}: ok")
    return status


def _show(path: Path) -> str:
    data = path.read_bytes()
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError:
        return f"(binary, {len(data)} bytes; hex of the first 256) {data[:256].hex()}"
    return text if len(text) <= 4000 else text[:4000] + f"\n… ({len(text)} characters)"


def _run_one(target: str, args: argparse.Namespace, seed: int, sample: Path) -> bool:
    work = Path(tempfile.mkdtemp(prefix=f"knitc-fuzz-{target}-"))  # new inputs go here
    artifacts = Path(args.artifacts) / target
    artifacts.mkdir(parents=True, exist_ok=True)
    seeds = targets.seed_dirs(target)
    cmd = [
        sys.executable, str(HERE / "engine.py"), target, str(sample), "--",
        f"-max_total_time={args.time}", f"-timeout={args.timeout}",
        f"-rss_limit_mb={args.rss_limit_mb}", f"-seed={seed}", "-max_len=65536",
        f"-artifact_prefix={artifacts}/", "-print_final_stats=1", str(work), *map(str, seeds),
    ]  # fmt: skip
    print(f"== fuzz {target}: {args.time} s, seed {seed}", flush=True)
    log = work.parent / f"{work.name}.log"
    with open(log, "wb") as out:
        rc = subprocess.call(cmd, stdout=out, stderr=subprocess.STDOUT)
    tail = log.read_text(errors="replace").splitlines()
    stats = [line for line in tail if line.startswith("stat::")]
    print("\n".join(stats))
    if args.merge:
        _merge(target, work, sample)
    shutil.rmtree(work, ignore_errors=True)
    if rc == 0:
        return True
    found = sorted(artifacts.glob("*"), key=lambda p: p.stat().st_mtime)
    print(f"!! fuzz {target} found a bug (exit {rc}); the engine's log ends:")
    print("\n".join(tail[-60:]))
    if found:
        print(f"-- reproducer ({found[-1]}):\n{_show(found[-1])}")
        print(f"-- run it again: python tests/fuzz/run.py --reproduce {target} {found[-1]}")
    return False


def _merge(target: str, work: Path, sample: Path) -> None:
    """Add to tests/fuzz/corpus/ the inputs of this run that reach code the corpus does not
    (libFuzzer's `-merge=1`), so the next run starts from there."""
    corpus = targets.CORPUS / targets.CORPUS_OF[target]
    corpus.mkdir(parents=True, exist_ok=True)
    before = len(list(corpus.iterdir()))
    cmd = [sys.executable, str(HERE / "engine.py"), target, str(sample), "--", "-merge=1"]
    subprocess.call(
        [*cmd, str(corpus), str(work)], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL
    )
    print(f"== merged into {corpus}: {len(list(corpus.iterdir())) - before} new inputs")


def _check_sample(sample: Path, artifacts: Path) -> bool:
    """The designs the fuzzers compiled, on the independent machine, as fabric."""
    from fabric import assert_knits_as_designed
    from knitc.driver import compile_file

    files = sorted(sample.glob("*.knit"))
    if not files:
        print("== oracle sample: nothing compiled")
        return True
    results = []
    for f in files:
        defines = f.with_suffix(".defines")
        flags = defines.read_text().split() if defines.exists() else []
        results.append(compile_file(str(f), defines=flags, until="machine"))
    good = [(f, r) for f, r in zip(files, results, strict=True) if r.program is not None]
    print(f"== oracle sample: {len(good)} compiled designs on the independent machine")
    try:
        assert_knits_as_designed([r for _, r in good], names=[str(f) for f, _ in good])
    except AssertionError as exc:
        print(f"!! the independent machine disagrees:\n{exc}")
        kept = artifacts / "oracle"
        kept.mkdir(parents=True, exist_ok=True)
        for f, _ in good:
            if str(f) in str(exc):
                for part in (f, f.with_suffix(".defines")):
                    if part.exists():
                        shutil.copy(part, kept / part.name)
                print(f"-- the design ({kept / f.name}):\n{_show(f)}")
        return False
    return True


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("targets", nargs="*", help=f"targets to run (default: all of {', '.join(ALL)})")
    ap.add_argument("--time", type=int, default=60, help="seconds per target (default 60)")
    ap.add_argument("--seed", type=int, help="libFuzzer seed (default: a new one, printed)")
    ap.add_argument(
        "--timeout", type=int, default=60, help="seconds per input before it is a hang (60)"
    )
    ap.add_argument("--rss-limit-mb", type=int, default=2048, help="memory before it is a blow-up")
    ap.add_argument("--artifacts", default="fuzz-artifacts", help="where reproducers are kept")
    ap.add_argument("--no-oracle", action="store_true", help="skip the independent machine")
    ap.add_argument(
        "--merge", action="store_true", help="add the run's new coverage to tests/fuzz/corpus/"
    )
    ap.add_argument("--reproduce", metavar="TARGET", help="run TARGET once on each given file")
    args, rest = ap.parse_known_args(argv)
    if args.reproduce:
        return _reproduce(args.reproduce, rest or args.targets)
    if rest:
        ap.error(f"unknown arguments: {' '.join(rest)}")
    chosen = args.targets or list(ALL)
    for t in chosen:
        if t not in ALL:
            ap.error(f"unknown target {t!r} (one of {', '.join(ALL)})")
    seed = args.seed if args.seed is not None else random.SystemRandom().randrange(1, 2**31)
    sample = Path(tempfile.mkdtemp(prefix="knitc-fuzz-sample-"))
    ok = True
    for i, t in enumerate(chosen):
        ok = _run_one(t, args, seed + i, sample) and ok
    if not args.no_oracle and os.environ.get("KNITC_FUZZ_ORACLE", "1") != "0":
        ok = _check_sample(sample, Path(args.artifacts)) and ok
    shutil.rmtree(sample, ignore_errors=True)
    print("== fuzz: " + ("no bug found" if ok else "BUGS FOUND (see above)"))
    return 0 if ok else 1


if __name__ == "__main__":
    raise SystemExit(main())
