"""Ctrl-C that waits for finished work to be stored: :class:`DeferredInterrupt`.

A sweep stores each chunk as soon as it is computed. A Ctrl-C that arrives between the end of
a chunk's integration and the rename of its part file would lose the whole chunk although its
cases were reported done. Inside :meth:`DeferredInterrupt.hold` … :meth:`release` the first
SIGINT is only recorded and raised as ``KeyboardInterrupt`` by :meth:`release`, once the work
is safe; a second SIGINT raises at once (a way out of a long store). Outside a hold, SIGINT
raises immediately, as usual. Only the main thread can install a signal handler, and only
Python's default handler is replaced (an ignored SIGINT stays ignored, a caller's own handler
stays in place): otherwise the guard does nothing. Hand-written.
"""

from __future__ import annotations

import signal
import threading


class DeferredInterrupt:
    """Context manager installing the deferring SIGINT handler (see the module docstring)."""

    def __init__(self) -> None:
        self.holding = False
        self.pending = False
        self._previous = None

    def __enter__(self) -> DeferredInterrupt:
        if (threading.current_thread() is threading.main_thread()
                and signal.getsignal(signal.SIGINT) is signal.default_int_handler):
            self._previous = signal.signal(signal.SIGINT, self._handler)
        return self

    def __exit__(self, *exc) -> None:
        self.holding = self.pending = False
        if self._previous is not None:
            signal.signal(signal.SIGINT, self._previous)
            self._previous = None

    def _handler(self, signum, frame) -> None:
        if self.holding and not self.pending:
            self.pending = True
            return
        raise KeyboardInterrupt

    def hold(self) -> None:
        """From now on, defer the first Ctrl-C (finished work is about to be stored)."""
        self.holding = True

    def release(self) -> None:
        """The work is stored: raise the Ctrl-C deferred since :meth:`hold`, if any."""
        self.holding = False
        if self.pending:
            self.pending = False
            raise KeyboardInterrupt
