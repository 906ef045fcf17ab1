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
