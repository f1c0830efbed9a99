"""`python -m robolab_ms.cli ARGS`: the `robolab` command."""

import sys

from robolab_ms.cli import main

sys.exit(main())
