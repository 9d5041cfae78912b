"""The ``hypate`` command line: the only place that parses argv. Each command module
defines ``register(subparsers)``; :mod:`.main` lists them."""
