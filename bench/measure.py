"""Whole-process measurements for the side-by-side benches: a command's CPU seconds (user +
system, of that process and the children it waited for) and peak RSS, read from the kernel's
own accounting (`os.wait4`), and paired runs of two commands, alternated so that a busy
moment of the machine hits both, reported as medians and their ratio.

Why CPU and not wall time: the machine has two cores and other work on it; CPU seconds of
a single-threaded compiler are what its speed is, and they are what the peers are held to.
"""

from __future__ import annotations

import os
import statistics
import subprocess
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path


@dataclass(frozen=True, slots=True)
class Run:
    """One whole-process run of a command."""

    cpu_seconds: float
    wall_seconds: float
    peak_mb: float
    returncode: int
    stderr: str


def run(
    argv: Sequence[str | Path], *, cwd: Path | None = None, env: dict[str, str] | None = None
) -> Run:
    """Run `argv` to its end and return what the kernel counted for it."""
    t0 = time.perf_counter()
    proc = subprocess.Popen(
        [str(a) for a in argv], cwd=cwd, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE
    )
    # wait4 reaps the child itself: its rusage is the child's alone (RUSAGE_CHILDREN would
    # mix in every earlier child and give only the largest peak so far).
    assert proc.stderr is not None
    err = proc.stderr.read()
    _, status, usage = os.wait4(proc.pid, 0)
    proc.returncode = os.waitstatus_to_exitcode(status)
    proc.stderr.close()
    wall = time.perf_counter() - t0
    return Run(
        cpu_seconds=usage.ru_utime + usage.ru_stime,
        wall_seconds=wall,
        peak_mb=usage.ru_maxrss / 1024,
        returncode=proc.returncode,
        stderr=err.decode("utf-8", "replace"),
    )


def paired(
    ours: Sequence[str | Path],
    theirs: Sequence[str | Path],
    *,
    runs: int = 5,
    cwd: Path | None = None,
    env_ours: dict[str, str] | None = None,
    env_theirs: dict[str, str] | None = None,
) -> dict:
    """Run both commands `runs` times, alternating, and report medians and the ratio
    theirs / ours (above 1: knitc is that many times faster). A failing run of either side
    stops the pairing and is reported with its last line of stderr."""
    mine: list[Run] = []
    peer: list[Run] = []
    for i in range(runs):
        order = ((ours, env_ours, mine), (theirs, env_theirs, peer))
        for argv, env, into in order if i % 2 == 0 else order[::-1]:
            r = run(argv, cwd=cwd, env=env)
            if r.returncode != 0:
                tail = r.stderr.strip().splitlines()[-1:] or ["failed"]
                side = "knitc" if into is mine else "peer"
                return {"error": f"{side} exited {r.returncode}: {tail[0]}"}
            into.append(r)
    ours_cpu = statistics.median(r.cpu_seconds for r in mine)
    theirs_cpu = statistics.median(r.cpu_seconds for r in peer)
    return {
        "runs": runs,
        "knitc_cpu_seconds": round(ours_cpu, 3),
        "peer_cpu_seconds": round(theirs_cpu, 3),
        "ratio": round(theirs_cpu / ours_cpu, 2) if ours_cpu > 0 else None,
        "knitc_peak_mb": round(max(r.peak_mb for r in mine), 1),
        "peer_peak_mb": round(max(r.peak_mb for r in peer), 1),
    }


def single(
    argv: Sequence[str | Path],
    *,
    runs: int = 3,
    cwd: Path | None = None,
    env: dict[str, str] | None = None,
) -> dict:
    """The median CPU seconds and the peak RSS of `runs` runs of one command."""
    got: list[Run] = []
    for _ in range(runs):
        r = run(argv, cwd=cwd, env=env)
        if r.returncode != 0:
            tail = r.stderr.strip().splitlines()[-1:] or ["failed"]
            return {"error": f"exited {r.returncode}: {tail[0]}"}
        got.append(r)
    return {
        "runs": runs,
        "cpu_seconds": round(statistics.median(r.cpu_seconds for r in got), 3),
        "peak_mb": round(max(r.peak_mb for r in got), 1),
    }


def environ(**extra: str) -> dict[str, str]:
    """This process's environment with `extra` set: bytecode caching is forced on (a shell
    with PYTHONDONTWRITEBYTECODE would charge every run the compilation of its sources)."""
    env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
    env.update(extra)
    return env
