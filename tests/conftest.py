"""Test-suite settings shared by every test module.

Hypothesis runs derandomized by default: each property test draws the same examples on
every run and every machine (seeded from the test itself, no example database), so `make
test` passes or fails the same way each time. Random exploration is the fuzzing step's job:
`make explore` (or `KNITC_HYPOTHESIS=explore`) runs the same properties with fresh random
examples each run, and keeps the failures it finds in `.hypothesis/`.

Every compile a test runs (in this process or in a `knitc` it starts) runs every IR
verifier between stages (`KNITC_VERIFY=1`): a designer's compile skips them
(`driver.verifying`), the suite never does.
"""

from __future__ import annotations

import os

from hypothesis import settings

os.environ["KNITC_VERIFY"] = "1"

settings.register_profile("deterministic", derandomize=True, database=None, print_blob=True)
settings.register_profile("explore", derandomize=False, print_blob=True)
settings.load_profile(os.environ.get("KNITC_HYPOTHESIS", "deterministic"))
