"""`python -m seagen.cli`: the same as the `seagen` command."""

import sys

from seagen.cli import main

sys.exit(main())
