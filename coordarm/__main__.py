"""``python -m coordarm``: the command line."""
import sys

try:
    from coordarm.cli import console
except KeyboardInterrupt:  # Ctrl-C while importing, before the handlers are installed
    print("coordarm: interrupted", file=sys.stderr)
    sys.exit(130)

console()
