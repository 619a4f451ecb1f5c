"""Tests that need a tool the project installs outside Python (a browser, Node.js): without
it they skip, saying how to get it; under CI (the `CI` variable set, as `.ci/run` runs)
they fail instead, so CI cannot pass by skipping them."""

from __future__ import annotations

import os

import pytest


def in_ci() -> bool:
    return os.environ.get("CI", "").strip().lower() not in ("", "0", "false", "no")


def need(ok: bool, reason: str, what: str) -> None:
    """Skip (fail under CI) unless `ok`; `what` names the tests for the CI message."""
    __tracebackhide__ = True
    if ok:
        return
    if in_ci():
        pytest.fail(f"{reason} -- CI must run {what}, so this fails", pytrace=False)
    pytest.skip(reason)
