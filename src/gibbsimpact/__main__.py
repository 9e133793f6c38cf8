"""``python -m gibbsimpact`` runs the command line (gibbsimpact.cli)."""

import sys

from .cli import main

sys.exit(main())
