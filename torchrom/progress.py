"""Progress of long loops, suited to where the output goes: a terminal or a log file.

Every long command (``sweep``, ``paper``, ``identify``, ``aero``, ``calibrate``,
``bifurcation``) reports through :class:`Progress`:

- on a terminal (stderr is a TTY) a tqdm bar;
- in a Jupyter kernel (a notebook, JupyterLab, VS Code; :func:`in_notebook`) tqdm's notebook
  bar, a widget, where ipywidgets is installed, else tqdm's text bar in the cell's output
  (which renders its carriage returns; :func:`notebook_bar_class`);
- otherwise (a log file, a pipe, CI) plain lines on stderr, one whenever the work crosses another
  10 % of its total (so one per chunk when there are fewer than ten chunks), each with the
  elapsed time and the estimated time left (linear in the work done), e.g.
  ``  cases done: 24/59 (41 %), elapsed 0:42, ETA 1:01``;
- ``--quiet`` (verbosity 0): nothing; ``--verbose`` (verbosity 2): a line at every update, also
  on a terminal (instead of the bar).

On a terminal the bar is redrawn in place (a carriage return, no newline) at the terminal's
width, measured at each redraw, so it never wraps onto a second line. Whatever else is printed
while a bar is drawn (a stage message, a Python warning, a log line) goes above it: the command
line writes stdout and stderr through :class:`AboveBars`, which clears the open bars, writes the
complete line and redraws them, so a message never lands on the bar's line. No colour and no
other escape sequence is written (one bar at a time, which is all a command draws, needs only
carriage returns), so ``NO_COLOR`` and ``TERM=dumb`` are honoured as they are.

A long command made of stages (``paper``) numbers them with an overall ETA
(:class:`StageCounter`: ``stage 3/9: the LCO sweep (ETA 1 min 20 s)``), so no stage is silent
even where it has no countable loop of its own.

The verbosity is process-wide (:func:`set_verbosity`, set by the command line from
``--quiet``/``--verbose``); :func:`info` prints a stage message unless quiet. Bars delegated to
tqdm; the line format is hand-written.
"""

from __future__ import annotations

import os
import sys
import time
import weakref
from contextlib import contextmanager
from typing import IO

QUIET, NORMAL, VERBOSE = 0, 1, 2
_state = {"verbosity": NORMAL}


def set_verbosity(level: int) -> None:
    """0 quiet, 1 normal, 2 verbose (see the module docstring)."""
    _state["verbosity"] = int(level)


def verbosity() -> int:
    return _state["verbosity"]


def info(message: str) -> None:
    """A stage message on stdout (dropped when quiet)."""
    if verbosity() > QUIET:
        print(message, flush=True)


def note(message: str) -> None:
    """A progress message on stderr (dropped when quiet), e.g. a calibration round."""
    if verbosity() > QUIET:
        print(message, file=sys.stderr, flush=True)


def format_seconds(seconds: float) -> str:
    """``m:ss`` (or ``h:mm:ss``) of a non-negative duration."""
    s = max(0, int(round(seconds)))
    h, rest = divmod(s, 3600)
    m, s = divmod(rest, 60)
    return f"{h}:{m:02d}:{s:02d}" if h else f"{m}:{s:02d}"


def format_duration(seconds: float) -> str:
    """A duration in words for a stage line: ``45 s``, ``1 min 20 s``, ``1 h 05 min``."""
    s = max(0, int(round(seconds)))
    if s < 60:
        return f"{s} s"
    if s < 3600:
        return f"{s // 60} min {s % 60:02d} s" if s % 60 else f"{s // 60} min"
    return f"{s // 3600} h {(s % 3600) // 60:02d} min"


DEFAULT_COLUMNS = 80  # a bar's width on a terminal that reports none


def _terminal_columns(stream) -> int | None:
    """The width of the terminal ``stream`` writes to, or None when it reports none."""
    try:
        return os.get_terminal_size(stream.fileno()).columns or None
    except (AttributeError, OSError, ValueError):
        return None


def in_notebook() -> bool:
    """Whether this process is a Jupyter kernel whose front end draws widgets (notebook,
    JupyterLab, VS Code, Colab): tqdm.autonotebook's test (ipykernel's shell loaded; not
    qtconsole or Spyder), asked at each call rather than once at import."""
    if "ipykernel.zmqshell" not in sys.modules:
        return False
    if any(k == "QT_API" or k.startswith("SPYDER") for k in os.environ):
        return False
    get_ipython = getattr(sys.modules.get("IPython"), "get_ipython", None)
    shell = get_ipython() if get_ipython is not None else None
    name = type(shell).__name__.lower()
    return shell is not None and "qt" not in name and "spyder" not in name


def notebook_bar_class():
    """The bar class for a notebook: ``tqdm.notebook.tqdm`` (a widget) where ipywidgets is
    installed, else tqdm's text bar (no ipywidgets dependency; a notebook's output renders its
    carriage returns, and tqdm's warning about the missing widgets is not raised)."""
    from tqdm import notebook, std

    return notebook.tqdm if notebook.IProgress is not None else std.tqdm


_open_bars: list[Progress] = []  # bars now drawn, in the order they were opened
_above_streams: weakref.WeakSet = weakref.WeakSet()  # AboveBars streams holding a partial line


@contextmanager
def _bars_cleared():
    """The open bars erased for the duration (something is written on their line), then drawn
    again below it."""
    bars = [p._bar for p in _open_bars if p._bar is not None]
    for b in bars:
        b.clear()
    try:
        yield
    finally:
        for b in bars:
            b.refresh()


class AboveBars:
    """A text stream that writes its lines above the open progress bars when it is a terminal
    (see the module docstring); a partial line waits for its newline (or for the last bar to
    close). Everything else (``isatty``, ``fileno``, ...) is the wrapped stream's, ``beneath``."""

    def __init__(self, stream):
        self.beneath = stream
        self._partial = ""

    def write(self, text: str) -> int:
        if not (_open_bars or self._partial) or not self._is_tty():
            return self.beneath.write(text)
        lines, newline, self._partial = (self._partial + text).rpartition("\n")
        if newline:
            with _bars_cleared():
                self.beneath.write(lines + newline)
                self.beneath.flush()
        if self._partial:
            _above_streams.add(self)
        return len(text)

    def writelines(self, lines) -> None:
        for line in lines:
            self.write(line)

    def flush(self) -> None:
        if self._partial and not _open_bars:
            self._release()
        self.beneath.flush()

    def _release(self) -> None:
        """Write the partial line held back while a bar was drawn."""
        text, self._partial = self._partial, ""
        self.beneath.write(text)
        self.beneath.flush()

    def _is_tty(self) -> bool:
        return bool(getattr(self.beneath, "isatty", lambda: False)())

    def __getattr__(self, name):
        return getattr(self.beneath, name)


class Progress:
    """Progress of ``total`` units of work (see the module docstring for what is shown where).

    Use as a context manager; call :meth:`update_to` with the units done so far (monotone) and
    :meth:`write` for a message that must not break a bar. ``unit``: what is counted, plural
    (e.g. "cases", "FE solves"). ``stream`` defaults to stderr; ``bar``
    forces (True) or forbids (False) the tqdm bar instead of asking whether the stream is a TTY.
    """

    def __init__(self, total: int, desc: str, unit: str = "cases", *, stream: IO | None = None,
                 bar: bool | None = None):
        self.total = max(int(total), 0)
        self.desc = desc
        self.unit = unit
        self.stream = stream if stream is not None else sys.stderr
        self.done = 0
        self.level = verbosity()
        self._t0 = time.perf_counter()
        self._next_decile = 1
        is_tty = bool(getattr(self.stream, "isatty", lambda: False)())
        # a notebook's stderr is no TTY, but its cell output draws a bar (stderr by default
        # only: a stream the caller names is asked whether it is a terminal)
        notebook = bar is None and stream is None and not is_tty and in_notebook()
        use_bar = (is_tty or notebook if bar is None else bar) and self.level == NORMAL
        self._bar = None
        if use_bar and notebook:
            self._bar = notebook_bar_class()(total=self.total, desc=desc, unit=unit,
                                             file=self.stream)
            _open_bars.append(self)
        elif use_bar:
            from tqdm import tqdm

            # tqdm draws on the stream beneath AboveBars (its redraws must not wait for a
            # newline) at the terminal's width, measured at each redraw, so the bar never wraps
            # (a wrapped bar turns every update into a new line); a terminal that reports no
            # width (a pseudo-terminal of size 0) would get an empty bar: 80 columns then
            beneath = getattr(self.stream, "beneath", self.stream)
            known = _terminal_columns(beneath) is not None
            self._bar = tqdm(total=self.total, desc=desc, unit=unit, file=beneath,
                             dynamic_ncols=known, ncols=None if known else DEFAULT_COLUMNS)
            _open_bars.append(self)

    def __enter__(self) -> Progress:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def line(self) -> str:
        """The plain progress line for the work done so far."""
        elapsed = time.perf_counter() - self._t0
        pct = 100.0 * self.done / self.total if self.total else 100.0
        eta = elapsed * (self.total - self.done) / self.done if self.done else float("nan")
        eta_s = format_seconds(eta) if eta == eta else "?"
        return (f"{self.desc}: {self.done}/{self.total} {self.unit} ({pct:.0f} %), "
                f"elapsed {format_seconds(elapsed)}, ETA {eta_s}")

    def update_to(self, done: int) -> None:
        """Record that ``done`` units are finished."""
        done = min(int(done), self.total) if self.total else int(done)
        step = done - self.done
        self.done = done
        if self.level == QUIET or step <= 0:
            return
        if self._bar is not None:
            self._bar.update(step)
            return
        decile = int(10 * done / self.total) if self.total else 10
        if self.level == VERBOSE or decile >= self._next_decile:
            self._next_decile = decile + 1
            print(self.line(), file=self.stream, flush=True)

    def write(self, message: str) -> None:
        """A message printed above the bar (or as a plain line); dropped when quiet."""
        if self.level == QUIET:
            return
        if self._bar is not None:
            with _bars_cleared():
                print(message, file=self._bar.fp, flush=True)
        else:
            print(message, file=self.stream, flush=True)

    def close(self) -> None:
        if self._bar is not None:
            self._bar.close()
            self._bar = None
            _open_bars.remove(self)
            if not _open_bars:
                for stream in list(_above_streams):
                    stream._release()
                _above_streams.clear()


def close_bars() -> None:
    """Close the bars still open (a command that failed half-way left them): its error is then
    printed below them, not redrawn over."""
    for bar in list(_open_bars):
        bar.close()


class Stages:
    """Stage lines of one long task without a countable loop (e.g. reading a large deck:
    parsing, the mesh, the assembly): ``start(name)`` prints ``<desc>: <name> ...`` on stderr and
    the previous stage's elapsed time; ``done()`` ends the last one. Nothing when ``enabled`` is
    False or when quiet."""

    def __init__(self, desc: str, enabled: bool = True, *, stream: IO | None = None):
        self.desc = desc
        self.enabled = enabled and verbosity() > QUIET
        self.stream = stream if stream is not None else sys.stderr
        self._name: str | None = None
        self._t0 = time.perf_counter()

    def start(self, name: str) -> None:
        self.done()
        self._name, self._t0 = name, time.perf_counter()
        if self.enabled:
            print(f"{self.desc}: {name} ...", file=self.stream, flush=True)

    def done(self) -> None:
        if self._name is not None and self.enabled:
            print(f"{self.desc}: {self._name} done in "
                  f"{format_seconds(time.perf_counter() - self._t0)}", file=self.stream,
                  flush=True)
        self._name = None


class StageCounter:
    """Numbered stages of a long command with an overall ETA: ``start(name)`` logs
    ``stage 3/9: <name> (ETA 1 min 20 s)``, ``stop()`` ends it and keeps its wall-clock and CPU
    seconds (``wall``, ``cpu``: name -> seconds, in the order run).

    ``expected``: (name, seconds) of every stage, in order — the stage's share of a reference
    run; the ETA is what the stages not yet finished took there, scaled by how the finished
    ones compare with their reference (this machine's speed, its load, what was reused from a
    cache: a rerun whose stages come from the cache shows a short ETA after the first one).
    A stage not in ``expected`` counts one more and no reference time. ``log`` receives the
    lines (a stage message: dropped when quiet by the caller's log)."""

    def __init__(self, expected, log=info):
        self.expected = dict(expected)
        self.names = list(self.expected)
        self.log = log
        self.wall: dict[str, float] = {}
        self.cpu: dict[str, float] = {}
        self._name: str | None = None
        self._t0 = self._c0 = 0.0

    @property
    def total(self) -> int:
        return len(self.names)

    def eta(self, name: str) -> float:
        """Seconds left from the start of stage ``name`` (see the class docstring)."""
        done_ref = sum(self.expected.get(k, 0.0) for k in self.wall)
        done_real = sum(self.wall.values())
        speed = done_real / done_ref if done_ref > 0 else 1.0
        left = [k for k in self.names if k not in self.wall]
        return speed * sum(self.expected.get(k, 0.0) for k in left)

    def start(self, name: str) -> None:
        if self._name is not None:
            self.stop()
        if name not in self.expected:
            self.names.append(name)
        k = self.names.index(name) + 1
        self.log(f"stage {k}/{self.total}: {name} (ETA {format_duration(self.eta(name))})")
        self._name = name
        self._t0, self._c0 = time.perf_counter(), time.process_time()

    def stop(self) -> None:
        if self._name is None:
            return
        self.wall[self._name] = time.perf_counter() - self._t0
        self.cpu[self._name] = time.process_time() - self._c0
        self._name = None
