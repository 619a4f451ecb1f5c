"""`python -m knitc.lsp`: the language server, as `knitc lsp`."""

from knitc.lsp import main

raise SystemExit(main())
