"""The back end's diagnostics, from a full compile in a worker process.

Tracing, slicing, scheduling, code generation and the simulation take seconds on a sweater
(the front end takes milliseconds), so they run in a separate, warm process: the server
stays responsive while it works, a second core does the work, and a compilation a newer
edit made pointless can be stopped. Stopping is cooperative first (the worker checks
between stages whether its job is still wanted) and forced after `KILL_AFTER` seconds (a
huge design can spend long in one stage): the worker is then killed and a new one started.

One worker serves every document, one job at a time; a job replaces any waiting or running
job with the same key (a document's check, or its preview).
"""

from __future__ import annotations

import contextlib
import multiprocessing
import os
import sys
import threading
import time
import traceback
from collections.abc import Callable
from dataclasses import field
from multiprocessing.connection import Connection
from typing import Any

from knitc.diagnostics import Diagnostics
from knitc.lsp.settings import Settings
from knitc.records import record

KILL_AFTER = 2.0
"""Seconds a stopped job may take to reach a stage boundary before its worker is killed."""


@record(frozen=True)
class Job:
    key: tuple[str, str]
    """(document URI, "check" | "preview"): a newer job with the same key replaces it."""
    version: int | None
    path: str
    text: str
    settings: Settings
    out: str | None = None
    """The HTML file a preview job writes."""
    id: int = 0


@record
class Outcome:
    job: Job
    status: str
    """"done", "cancelled" or "failed" (a bug in knitc, or the worker died)."""
    diagnostics: Diagnostics | None = None
    detail: str = ""
    """For "failed": what went wrong; for a preview: the file written ("" for none)."""
    seconds: float = 0.0


class Cancelled(Exception):
    pass


# ---- the worker process ---------------------------------------------------------------------


def _worker_main(conn: Connection, cancel: Any) -> None:
    """Run jobs until the server closes the pipe. The server's standard output is its LSP
    stream, so nothing here may write to it."""
    devnull = os.open(os.devnull, os.O_WRONLY)
    os.dup2(devnull, 1)
    sys.stdout = open(os.devnull, "w")  # noqa: SIM115 - lives as long as the process
    from knitc import driver
    from knitc.cli import tune_gc
    from knitc.lsp.analysis import WARM_UP

    tune_gc()

    driver.compile_source(WARM_UP, "<warm-up>", until="machine")
    last: tuple[Job, driver.Result] | None = None
    while True:
        try:
            job = conn.recv()
        except (EOFError, OSError):
            return
        start = time.perf_counter()
        try:
            result = _compile(job, cancel, last)
            last = (job, result)
            detail = _preview(job, result) if job.key[1] == "preview" else ""
            out = Outcome(job, "done", result.diagnostics, detail)
        except Cancelled:
            out = Outcome(job, "cancelled")
        except Exception:  # a bug in knitc: report it, keep serving
            out = Outcome(job, "failed", detail=traceback.format_exc(limit=8))
        out.seconds = time.perf_counter() - start
        try:
            conn.send(out)
        except (EOFError, OSError):
            return


def _compile(job: Job, cancel: Any, last: tuple[Job, Any] | None) -> Any:
    from knitc import driver

    if last is not None and (last[0].text, last[0].path, last[0].settings) == (
        job.text,
        job.path,
        job.settings,
    ):
        return last[1]

    def check(_stage: str) -> None:
        if cancel.value == job.id:
            raise Cancelled

    s = job.settings
    return driver.compile_source(
        job.text,
        job.path,
        defines=s.defines,
        until="machine",
        include=s.include,
        max_stitches=s.max_stitches,
        on_stage=check,
    )


def _preview(job: Job, result: Any) -> str:
    """Write the viewer's page for a compiled design; the path, or "" when it did not get
    that far."""
    from knitc.view import html
    from knitc.view.source import from_result

    view = from_result(result)
    if view is None or job.out is None:
        return ""
    tmp = job.out + ".tmp"
    with open(tmp, "wb") as f:
        f.write(html.render(view))
    os.replace(tmp, job.out)
    return job.out


# ---- the server's side ----------------------------------------------------------------------


@record
class _Worker:
    process: Any
    conn: Connection


@record
class Backend:
    """Runs jobs in the worker and tells `done` (from its own thread) how each ended."""

    done: Callable[[Outcome], None]
    _pending: dict[tuple[str, str], Job] = field(default_factory=dict)
    _cond: threading.Condition = field(default_factory=threading.Condition)
    _worker: _Worker | None = None
    _thread: threading.Thread | None = None
    _closed: bool = False
    _next_id: int = 0
    _stopped: set[int] = field(default_factory=set)
    """Ids of jobs nobody waits for any more (a cancelled request)."""
    _closed_uris: set[str] = field(default_factory=set)
    """Documents closed since their last job was submitted."""

    def submit(self, job: Job) -> Job:
        """Queue `job`, replacing the waiting or running job with its key."""
        with self._cond:
            self._next_id += 1
            job = Job(
                job.key, job.version, job.path, job.text, job.settings, job.out, self._next_id
            )
            self._pending[job.key] = job
            self._closed_uris.discard(job.key[0])
            self._start()
            self._cond.notify_all()
        return job

    def start(self) -> None:
        """Start the worker now, so that it is warm by the first job."""
        with self._cond:
            self._start()

    def _start(self) -> None:
        if self._thread is None and not self._closed:
            self._thread = threading.Thread(target=self._run, name="knitc-backend", daemon=True)
            self._thread.start()

    def discard(self, uri: str) -> None:
        """Forget the waiting jobs of a closed document (a running one is stopped)."""
        with self._cond:
            for key in [k for k in self._pending if k[0] == uri]:
                del self._pending[key]
            self._closed_uris.add(uri)
            self._cond.notify_all()

    def stop(self, job: Job) -> None:
        """Stop `job` if it is waiting or running (its request was cancelled)."""
        with self._cond:
            if self._pending.get(job.key) == job:
                del self._pending[job.key]
            self._stopped.add(job.id)
            self._cond.notify_all()

    def close(self) -> None:
        with self._cond:
            self._closed = True
            self._pending.clear()
            self._cond.notify_all()
        self._stop_worker()

    # -- the backend thread
    def _run(self) -> None:
        ctx = multiprocessing.get_context("spawn")
        cancel = ctx.Value("q", 0, lock=False)
        self._ensure_worker(ctx, cancel)
        running: Job | None = None
        while True:
            with self._cond:
                while not self._pending and not self._closed:
                    self._cond.wait()
                if self._closed:
                    return
                key = next(iter(self._pending))
                running = self._pending.pop(key)
            outcome = self._one(ctx, cancel, running)
            if outcome is not None:
                with contextlib.suppress(Exception):  # the server's callback must not kill us
                    self.done(outcome)

    def _one(self, ctx: Any, cancel: Any, job: Job) -> Outcome | None:
        worker = self._ensure_worker(ctx, cancel)
        try:
            worker.conn.send(job)
        except (OSError, EOFError):
            self._stop_worker()
            return Outcome(job, "failed", detail="the worker process could not be reached")
        stopped_at: float | None = None
        while True:
            try:
                if worker.conn.poll(0.02):
                    out: Outcome = worker.conn.recv()
                    return out
            except (OSError, EOFError):
                self._stop_worker()
                return Outcome(job, "failed", detail="the worker process ended")
            if not worker.process.is_alive():
                code = worker.process.exitcode
                self._stop_worker()
                return Outcome(job, "failed", detail=f"the worker process ended (exit {code})")
            with self._cond:
                superseded = (
                    job.key in self._pending
                    or self._closed
                    or job.id in self._stopped
                    or job.key[0] in self._closed_uris
                )
            if superseded and stopped_at is None:
                cancel.value = job.id
                stopped_at = time.monotonic()
            elif stopped_at is not None and time.monotonic() - stopped_at > KILL_AFTER:
                self._stop_worker()
                return Outcome(job, "cancelled", detail="killed")

    def _ensure_worker(self, ctx: Any, cancel: Any) -> _Worker:
        if self._worker is None or not self._worker.process.is_alive():
            self._stop_worker()
            ours, theirs = ctx.Pipe()
            process = ctx.Process(
                target=_worker_main, args=(theirs, cancel), name="knitc-lsp-worker", daemon=True
            )
            process.start()
            theirs.close()
            self._worker = _Worker(process, ours)
        return self._worker

    def _stop_worker(self) -> None:
        worker, self._worker = self._worker, None
        if worker is None:
            return
        with contextlib.suppress(Exception):
            worker.conn.close()
        if worker.process.is_alive():
            worker.process.kill()
        worker.process.join(timeout=5)

    @property
    def worker_pid(self) -> int | None:
        return self._worker.process.pid if self._worker is not None else None
