"""``python -m coordarm``: the command line."""
import sys

from coordarm.cli import main

sys.exit(main())
