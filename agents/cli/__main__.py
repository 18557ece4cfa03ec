"""`python -m agents.cli`: the same as the `clutter-gym` console script."""

import sys

from agents.cli.main import main

sys.exit(main())
