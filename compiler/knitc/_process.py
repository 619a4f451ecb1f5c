"""What a knitc process (the command line, the language server and its worker) sets up
before numpy is first imported.

numpy's OpenBLAS starts one thread per core when numpy is imported, and the threads spin
while they wait for work: on a two-core machine that is about 0.1 s of CPU, nearly half a
small design's whole compile, for linear algebra a compile never does. One thread is
asked for unless the user chose a number (`OPENBLAS_NUM_THREADS`, or OpenMP's
`OMP_NUM_THREADS`, which OpenBLAS also reads). Only the CLI imports this module: a library
user's process is theirs to configure.
"""

from __future__ import annotations

import os

if "OPENBLAS_NUM_THREADS" not in os.environ and "OMP_NUM_THREADS" not in os.environ:
    os.environ["OPENBLAS_NUM_THREADS"] = "1"
