"""One fuzzing process: atheris (libFuzzer) on one target, until libFuzzer stops it.

Run by run.py, never by hand: `python engine.py TARGET SAMPLE_DIR -- LIBFUZZER_ARGS...`.
libFuzzer owns the budgets: `-timeout` (seconds per input: a hang), `-rss_limit_mb` (a
memory blow-up), `-max_total_time` (the run), `-seed`; an input that raises, hangs or
blows up is written under `-artifact_prefix` and the process exits non-zero. libFuzzer
ends the process itself (it never returns from `atheris.Fuzz`), which is why the oracle
sample is checked by run.py afterwards, from the designs this process saved.
"""

from __future__ import annotations

import hashlib
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path[:0] = [str(HERE), str(HERE.parent)]  # targets, designs and tests/ helpers

import atheris  # noqa: E402

SAMPLE_LIMIT = 40
"""Compiled designs kept for the independent machine: the first ones and then every 16th."""


def _sampler(sample_dir: Path):
    count = {"ok": 0}

    def save(text: str, defines: list[str]) -> None:
        count["ok"] += 1
        n = count["ok"]
        kept = sum(1 for _ in sample_dir.glob("*.knit"))
        if kept < SAMPLE_LIMIT and (n <= 10 or n % 16 == 0):
            name = hashlib.sha1(text.encode("utf-8", "surrogatepass")).hexdigest()[:12]
            (sample_dir / f"{name}.defines").write_text("\n".join(defines), encoding="utf-8")
            (sample_dir / f"{name}.knit").write_text(text, encoding="utf-8", errors="surrogatepass")

    return save


def main() -> None:
    target, sample = sys.argv[1], Path(sys.argv[2])
    sep = sys.argv.index("--")
    sample.mkdir(parents=True, exist_ok=True)
    from atheris.import_hook import HookManager

    # Comparison tracing (libFuzzer's data-flow feedback) leaks in atheris 3.0 when the
    # compared values are numpy arrays: a compiling target's process grew by ~0.7 MB per
    # input until the RSS limit stopped it. The targets that shape (compile, design, and the
    # language server's editor) use branch coverage only.
    dataflow = target not in ("compile", "design", "editor")
    with HookManager({"knitc"}, set(), True, trace_dataflow=dataflow):
        import targets

        import knitc.cli  # noqa: F401
        from knitc import driver  # noqa: F401

        _preload()
    targets.sample = _sampler(sample)
    if target == "design":
        import designs

        fn = designs.fuzz_one()
    else:
        fn = targets.TARGETS[target]

    def one(data: bytes) -> None:
        fn(data)

    atheris.Setup([_self_command(target, sample), *sys.argv[sep + 1 :]], one)
    atheris.Fuzz()


def _self_command(target: str, sample: Path) -> str:
    """argv[0] for libFuzzer: in `-merge=1` mode it runs argv[0] again as a program, with only
    its own flags, so argv[0] must be an executable that runs this engine on this target."""
    import os
    import shlex
    import tempfile

    fd, path = tempfile.mkstemp(prefix=f"engine-{target}-", suffix=".sh", dir=sample)
    with os.fdopen(fd, "w") as f:
        args = " ".join(map(shlex.quote, [sys.executable, __file__, target, str(sample), "--"]))
        f.write(f'#!/bin/sh\nexec {args} "$@"\n')
    os.chmod(path, 0o700)
    return path


def _preload() -> None:
    """Import every knitc module under instrumentation: the CLI imports its passes lazily,
    and a module first imported outside `instrument_imports` gives no coverage feedback."""
    import importlib
    import pkgutil

    import knitc

    for info in pkgutil.walk_packages(knitc.__path__, "knitc."):
        if not info.name.endswith("__main__"):  # it runs the CLI
            importlib.import_module(info.name)


if __name__ == "__main__":
    main()
