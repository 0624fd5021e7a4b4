"""`python -m pegbt` is the `pegbt` command."""

from pegbt.cli import main

raise SystemExit(main())
