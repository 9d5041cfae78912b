"""Subcommands of the ``hypate`` CLI.

Each module here defines ``register(subparsers)`` which adds one subcommand (or a group)
and sets ``func=run`` on its parser; ``run(args) -> int`` returns the exit code.
Modules are listed in :data:`scaling.cli.COMMAND_MODULES`.
"""
