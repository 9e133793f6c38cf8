"""``python -m gibbsimpact`` runs the command line (gibbsimpact.cli)."""

import sys

from .cli.commands import main

sys.exit(main())
