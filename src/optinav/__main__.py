"""``python -m optinav``: the ``optinav`` command (for an environment whose scripts folder is not on PATH)."""

import sys

from optinav.cli.main import main

sys.exit(main())
