"""What a knitc process (the command line, the language server and its worker) sets up
before numpy is first imported, and how a one-shot command ends (`end`).

numpy's OpenBLAS starts one thread per core when numpy is imported, and the threads spin
while they wait for work: on a two-core machine that is about 0.1 s of CPU, nearly half a
small design's whole compile, for linear algebra a compile never does. One thread is
asked for unless the user chose a number (`OPENBLAS_NUM_THREADS`, or OpenMP's
`OMP_NUM_THREADS`, which OpenBLAS also reads). Only the CLI imports this module: a library
user's process is theirs to configure.
"""

from __future__ import annotations

import os
import sys
from typing import NoReturn

if "OPENBLAS_NUM_THREADS" not in os.environ and "OMP_NUM_THREADS" not in os.environ:
    os.environ["OPENBLAS_NUM_THREADS"] = "1"


def end(code: int) -> NoReturn:
    """End a one-shot command's process with exit status `code`, without tearing the
    interpreter down.

    A normal exit clears every module and frees every object one by one after a last full
    garbage collection: numpy, Lark and knitc's own modules, and a compile's IRs, which
    all lived to the end anyway. That is about 0.03 s of CPU whatever the design (an eighth of
    `knitc check` on a ten-line design or of a small garment's compile; issue 16) and
    frees nothing the operating system does not free at once. What an exit must still do
    is done here first: the `atexit` handlers run (logging's shutdown; coverage saving
    what it measured in a child process), and stdout and stderr are flushed, a closed
    pipe included (as `BrokenPipeError` anywhere else, it is not an error). Output files
    are already closed (`cli.write_atomic`). With another thread alive (none in a command
    today) the process exits the normal way, which waits for it."""
    import atexit
    import threading

    if threading.active_count() > 1:
        sys.exit(code)
    atexit._run_exitfuncs()
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (OSError, ValueError):  # a closed pipe or a closed stream
            pass
    os._exit(code)
