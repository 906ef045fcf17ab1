"""User-facing errors.

Every error a user can cause by bad input (a file, a card, a field, a parameter) is raised as a
:class:`TorchromError` whose message is one line naming the file/card/field/parameter and what was
expected. The command line prints that line and exits with status 2; nothing else is caught there,
so a genuine bug still shows its traceback.
"""

from __future__ import annotations


class TorchromError(Exception):
    """A one-line, user-facing error about bad input or an impossible request."""

    def __init__(self, message: str):
        # One line, and no control character of an untrusted name or field reaches the terminal
        from .text import printable

        super().__init__(printable(" ".join(str(message).split())))


class InputError(TorchromError, ValueError):
    """Bad input data: a malformed file, card, field, tensor or parameter."""


class ConvergenceError(TorchromError, RuntimeError):
    """A numerical procedure did not converge (the message says which and how far it got)."""
