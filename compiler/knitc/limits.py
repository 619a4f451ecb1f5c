"""Limits every command checks where a value enters, kept in a module that imports nothing,
so that the command line can offer them without loading the pipeline."""

from __future__ import annotations

MAX_STITCHES = 2_000_000
"""Most stitches a design may have (sheets and tubes at their widest): a million compile in
under a minute and a gigabyte; beyond this a legal-looking design (`length: 100000`,
`width: 5000`) would exhaust memory instead of being refused (E512)."""

MACHINE_CARRIERS = 10
"""Yarn carriers of the machines knitc writes for (1 .. 10): an intarsia course with more
regions than the carriers left beside its resting yarn is refused (E732) before code
generation would run out of them."""
