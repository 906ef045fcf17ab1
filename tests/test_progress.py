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
