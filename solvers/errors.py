"""Errors raised for bad user input.

Every input error names the offending field (a dotted key path such as
``panel.layers[0].thickness``) and the allowed range, so the CLI can print a one-line
message and exit with code 2 instead of a traceback.
"""
from __future__ import annotations


class InputError(ValueError):
    """Bad user input: ``field`` names the key path, ``message`` says what is allowed."""

    def __init__(self, field: str, message: str) -> None:
        self.field = field
        self.message = message
        super().__init__(f"{field}: {message}")

    def __reduce__(self):
        # pickled by its fields: raised in a pool worker, it reaches the parent as itself
        return type(self), (self.field, self.message)
