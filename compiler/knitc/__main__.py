"""``python -m knitc``: the same as the ``knitc`` command."""

from knitc.cli import main

raise SystemExit(main())
