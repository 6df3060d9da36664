"""`python -m evsim_app ...` runs the `evsim` command line."""

from .cli import main

raise SystemExit(main())
