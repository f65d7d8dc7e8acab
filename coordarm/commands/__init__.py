"""One module per ``coordarm`` sub-command, each with ``register(subparsers)``; imported only by :mod:`coordarm.cli`."""
