"""torchrom.progress: a bar on a terminal, plain 10 % lines with elapsed/ETA in a log file."""

import io

import pytest

from torchrom import progress
from torchrom.progress import Progress, format_seconds


class _Tty(io.StringIO):
    def isatty(self):
        return True


@pytest.fixture(autouse=True)
def _normal_verbosity():
    progress.set_verbosity(progress.NORMAL)
    yield
    progress.set_verbosity(progress.NORMAL)


def test_format_seconds():
    assert format_seconds(0) == "0:00"
    assert format_seconds(61.4) == "1:01"
    assert format_seconds(3725) == "1:02:05"


def test_log_file_gets_one_line_per_ten_percent_with_elapsed_and_eta():
    out = io.StringIO()
    with Progress(100, "cases done", stream=out) as bar:
        for done in range(1, 101):
            bar.update_to(done)
    lines = out.getvalue().splitlines()
    assert len(lines) == 10  # one per decile crossed, not one per update
    assert lines[0].startswith("cases done: 10/100 cases (10 %), elapsed ")
    assert all("ETA" in ln and "elapsed" in ln for ln in lines)
    assert "\r" not in out.getvalue()  # no bar redraws in a file


def test_coarse_chunks_give_one_line_each():
    out = io.StringIO()
    with Progress(59, "cases", stream=out) as bar:
        for done in (8, 16, 24, 59):
            bar.update_to(done)
    assert len(out.getvalue().splitlines()) == 4


def test_terminal_gets_a_tqdm_bar_and_quiet_nothing():
    tty = _Tty()
    with Progress(10, "cases", stream=tty) as bar:
        bar.update_to(10)
    assert "\r" in tty.getvalue() and "10/10" in tty.getvalue()
    progress.set_verbosity(progress.QUIET)
    for stream in (_Tty(), io.StringIO()):
        with Progress(10, "cases", stream=stream) as bar:
            bar.update_to(5)
            bar.write("message")
            bar.update_to(10)
        assert stream.getvalue() == ""


def test_verbose_prints_every_update_even_on_a_terminal():
    progress.set_verbosity(progress.VERBOSE)
    tty = _Tty()
    with Progress(100, "cases", stream=tty) as bar:
        for done in (1, 2, 3):
            bar.update_to(done)
    assert len(tty.getvalue().splitlines()) == 3 and "\r" not in tty.getvalue()


def test_a_terminal_without_a_width_gets_an_80_column_bar():
    """A pseudo-terminal that reports a size of 0 x 0 (``script`` without a terminal, some
    containers) made tqdm draw an empty bar; it gets 80 columns."""
    import os

    master, slave = os.openpty()
    try:
        assert os.get_terminal_size(slave).columns == 0  # a new pseudo-terminal has no size
        with open(slave, "w", encoding="utf-8", closefd=False) as tty:
            with Progress(10, "cases done", stream=tty) as bar:
                bar.update_to(10)
        text = os.read(master, 1 << 16).decode()
    finally:
        os.close(master)
        os.close(slave)
    draws = [d for d in text.replace("\r\n", "\n").split("\r") if "10/10" in d]
    assert draws and all(len(d.rstrip("\n")) <= progress.DEFAULT_COLUMNS for d in draws)
    assert "█" * 10 in draws[-1]  # the bar itself is drawn, not only the counter


def test_lines_written_while_a_bar_is_drawn_go_above_it():
    """AboveBars (the command line's stdout/stderr): a line printed while a bar is drawn
    clears the bar, is written, and the bar is drawn again below it; a partial line waits for
    its newline, or for the bar to close."""
    tty = _Tty()
    out = progress.AboveBars(tty)
    with Progress(4, "cases done", stream=out) as bar:
        bar.update_to(1)
        out.write("warning: ")
        assert "warning" not in tty.getvalue()  # held until its line is complete
        print("linear elements", file=out)
        bar.update_to(2)
        out.write("unfinished")
        bar.update_to(4)
    out.flush()
    text = tty.getvalue()
    before, line, after = text.partition("warning: linear elements\n")
    assert line, text
    drawn, blank, rest = before.split("\r")[-3:]
    assert "0/4" in drawn and blank == " " * len(blank) and rest == ""  # the bar blanked out
    assert after.startswith("\rcases done:") and "1/4" in after.split("\r")[1]  # drawn again
    # the partial line is released once the bar has closed (its last draw, then a newline)
    assert text.endswith("cases/s]\nunfinished") and text.count("unfinished") == 1
    assert not progress._open_bars


def test_above_bars_passes_through_a_pipe_or_without_a_bar():
    pipe, tty = io.StringIO(), _Tty()
    for stream in (pipe, tty):
        out = progress.AboveBars(stream)
        out.write("partial")
        assert stream.getvalue() == "partial"
    out = progress.AboveBars(pipe)
    with Progress(2, "cases", stream=_Tty()) as bar:
        bar.update_to(1)
        out.write(" more")  # a pipe is not the bar's terminal: written as it comes
        assert pipe.getvalue() == "partial more"


def test_close_bars_closes_what_a_failure_left_open():
    tty = _Tty()
    bar = Progress(3, "cases", stream=tty)
    bar.update_to(1)
    assert progress._open_bars == [bar]
    progress.close_bars()
    assert progress._open_bars == [] and bar._bar is None and tty.getvalue().endswith("\n")


def test_format_duration():
    assert progress.format_duration(0.4) == "0 s"
    assert progress.format_duration(45) == "45 s"
    assert progress.format_duration(80) == "1 min 20 s"
    assert progress.format_duration(120) == "2 min"
    assert progress.format_duration(3900) == "1 h 05 min"


def test_stage_counter_numbers_the_stages_and_scales_the_eta(monkeypatch):
    """Three stages of reference 10, 20 and 30 s. Before anything ran the ETA is the reference
    sum (60 s); the first stage took 20 s (twice its reference), so the ETA from the second on
    is twice the references left: 2 x (20 + 30) = 100 s, then 2 x 30 = 60 s if the second
    took 40 s. A stage the plan does not name is appended (its number counts it)."""
    clock = {"t": 0.0}
    monkeypatch.setattr(progress.time, "perf_counter", lambda: clock["t"])
    lines = []
    stages = progress.StageCounter([("a", 10.0), ("b", 20.0), ("c", 30.0)], log=lines.append)
    stages.start("a")
    clock["t"] += 20.0
    stages.start("b")
    clock["t"] += 40.0
    stages.start("c")
    clock["t"] += 1.0
    stages.start("extra")
    stages.stop()
    assert lines == ["stage 1/3: a (ETA 1 min)", "stage 2/3: b (ETA 1 min 40 s)",
                     "stage 3/3: c (ETA 1 min)", "stage 4/4: extra (ETA 0 s)"]
    assert stages.wall == {"a": 20.0, "b": 40.0, "c": 1.0, "extra": 0.0}
    assert set(stages.cpu) == set(stages.wall)


# -- notebooks: the kernel is faked (no IPython or ipywidgets needed) --
class _ZMQInteractiveShell:
    """What ``get_ipython()`` returns in a Jupyter kernel (the class name tqdm inspects)."""


class _QtShell:
    pass


def _fake_kernel(monkeypatch, shell_class=_ZMQInteractiveShell):
    import os
    import sys
    import types

    ipython = types.ModuleType("IPython")
    shell = shell_class() if shell_class is not None else None
    ipython.get_ipython = lambda: shell
    monkeypatch.setitem(sys.modules, "IPython", ipython)
    monkeypatch.setitem(sys.modules, "ipykernel.zmqshell", types.ModuleType("ipykernel.zmqshell"))
    for key in [k for k in os.environ if k == "QT_API" or k.startswith("SPYDER")]:
        monkeypatch.delenv(key)


def test_a_notebook_is_recognised_by_its_kernel(monkeypatch):
    """ipykernel's shell loaded and IPython's shell a kernel's: a notebook; a plain interpreter,
    no shell, qtconsole (its shell class, or QT_API set) and Spyder are not (they draw no
    widgets: tqdm.autonotebook's rule)."""
    import sys

    assert "ipykernel.zmqshell" not in sys.modules  # this test process is no notebook
    assert not progress.in_notebook()
    _fake_kernel(monkeypatch)
    assert progress.in_notebook()
    monkeypatch.setenv("QT_API", "pyqt5")
    assert not progress.in_notebook()
    monkeypatch.delenv("QT_API")
    monkeypatch.setenv("SPYDER_ARGS", "[]")
    assert not progress.in_notebook()
    monkeypatch.delenv("SPYDER_ARGS")
    for shell in (_QtShell, None):
        _fake_kernel(monkeypatch, shell)
        assert not progress.in_notebook()


def test_the_notebook_bar_is_the_widget_only_where_ipywidgets_is(monkeypatch):
    from tqdm import notebook, std

    monkeypatch.setattr(notebook, "IProgress", None)
    assert progress.notebook_bar_class() is std.tqdm
    monkeypatch.setattr(notebook, "IProgress", object)
    assert progress.notebook_bar_class() is notebook.tqdm


def test_a_notebook_without_widgets_gets_the_text_bar_on_its_stderr(monkeypatch):
    """A kernel's stderr is no TTY: outside a notebook it gets the 10 % lines, in one the text
    bar (carriage returns, which a cell's output renders); a stream the caller names is asked
    whether it is a terminal, as before."""
    import sys

    from tqdm import notebook

    cell = io.StringIO()
    monkeypatch.setattr(sys, "stderr", cell)
    with Progress(10, "cases done") as bar:
        bar.update_to(10)
    assert "\r" not in cell.getvalue() and cell.getvalue().startswith("cases done: 10/10")
    _fake_kernel(monkeypatch)
    monkeypatch.setattr(notebook, "IProgress", None)
    cell.seek(0)
    cell.truncate()
    with Progress(10, "cases done") as bar:
        bar.update_to(10)
    assert "\r" in cell.getvalue() and "10/10" in cell.getvalue()
    named = io.StringIO()
    with Progress(10, "cases done", stream=named) as bar:
        bar.update_to(10)
    assert "\r" not in named.getvalue()
    progress.set_verbosity(progress.QUIET)
    cell.seek(0)
    cell.truncate()
    with Progress(10, "cases done") as bar:
        bar.update_to(10)
    assert cell.getvalue() == ""


def test_a_notebook_with_widgets_gets_tqdm_notebook_bar(monkeypatch):
    """Where ipywidgets is installed, ``tqdm.notebook.tqdm`` draws the bar (here a stand-in
    recording what it is given): the total, the label, each update, the messages above it
    and its closing."""
    from tqdm import notebook

    calls = []

    class Widget:
        def __init__(self, **kwargs):
            calls.append(("init", kwargs["total"], kwargs["desc"], kwargs["unit"]))
            self.fp = io.StringIO()

        def update(self, n):
            calls.append(("update", n))

        def clear(self):
            calls.append(("clear",))

        def refresh(self):
            calls.append(("refresh",))

        def close(self):
            calls.append(("close",))

    _fake_kernel(monkeypatch)
    monkeypatch.setattr(notebook, "IProgress", object)
    monkeypatch.setattr(notebook, "tqdm", Widget)
    with Progress(4, "cases done") as bar:
        bar.update_to(1)
        bar.write("chunk 1 done")
        bar.update_to(4)
        widget = bar._bar
    assert calls == [("init", 4, "cases done", "cases"), ("update", 1), ("clear",),
                     ("refresh",), ("update", 3), ("close",)]
    assert widget.fp.getvalue() == "chunk 1 done\n" and not progress._open_bars
