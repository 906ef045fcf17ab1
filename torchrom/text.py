"""Untrusted text made safe to print: titles, file names, card fields and error messages.

A configuration title, a deck's TITLE, a file name or a card field may hold terminal control
sequences (ESC [ ... for colours, ESC ] ... BEL for the window title, a carriage return that
overwrites the line, Unicode bidirectional overrides that reorder what is shown). Printed raw,
they change the terminal or hide part of a message. :func:`printable` replaces every such
character by its escape (``\\x1b``, ``\\u202e``); :class:`SafeStream` applies the same to all that
a command writes to stdout/stderr (keeping newlines, tabs and the carriage returns of a
progress bar), so no path to the terminal is missed.
"""

from __future__ import annotations

import re

# C0 controls but tab/newline/carriage return, DEL, C1 controls, bidi embeddings/overrides/isolates
_UNSAFE_IN_STREAM = re.compile("[\x00-\x08\x0b\x0c\x0e-\x1f\x7f-\x9f\u202a-\u202e\u2066-\u2069]")
# ... and in one field also tab, newline and carriage return (a field is one line)
_UNSAFE_IN_FIELD = re.compile("[\x00-\x1f\x7f-\x9f\u202a-\u202e\u2066-\u2069]")


def _escape(match: re.Match) -> str:
    c = ord(match.group())
    return f"\\x{c:02x}" if c < 0x100 else f"\\u{c:04x}"


def printable(text) -> str:
    """``str(text)`` with every control character escaped (one line, nothing the terminal
    interprets)."""
    return _UNSAFE_IN_FIELD.sub(_escape, str(text))


def terminal_safe(text: str) -> str:
    """``text`` with the control characters escaped but newlines, tabs and carriage returns."""
    return _UNSAFE_IN_STREAM.sub(_escape, text)


class SafeStream:
    """A text stream that writes :func:`terminal_safe` text to ``stream`` (everything else,
    e.g. ``isatty`` and ``flush``, is the wrapped stream's)."""

    def __init__(self, stream):
        self._stream = stream

    def write(self, text: str) -> int:
        self._stream.write(terminal_safe(text))
        return len(text)

    def writelines(self, lines) -> None:
        for line in lines:
            self.write(line)

    def __getattr__(self, name):
        return getattr(self._stream, name)
