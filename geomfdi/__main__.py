"""``python -m geomfdi``: the command line."""

from geomfdi.io.cli import main

raise SystemExit(main())
