"""What a user sees on a real terminal (issue 37): the command line run in a pseudo-terminal.

Piped output never showed these faults, so each test runs ``python -m torchrom`` with its
stdin/stdout/stderr on a pseudo-terminal of 80 x 24 and reads what reached the terminal:

- no escape sequence at all (pyNastran's logger, imported on a terminal, wrapped the streams in
  colorama's auto-reset, and each reset showed as the text ``\\x1b[0m``); torchrom writes no
  colour, so ``NO_COLOR`` and ``TERM=dumb`` get the same clean text;
- a command without a bar prints on a terminal exactly what it prints into a pipe;
- each progress bar stays on one terminal row, redrawn with carriage returns, and a warning
  printed while a bar is drawn stands on its own row above the bar.

What the terminal shows is worked out by :func:`_screen`, a minimal terminal: a carriage return
goes to column 0, a newline to the next row, and a character written past the last column wraps
onto a new row (as xterm's auto-wrap does), so a bar wider than the terminal shows up as extra
rows, as it did on the user's terminal.
"""

from __future__ import annotations

import fcntl
import os
import re
import select
import shutil
import struct
import subprocess
import sys
import termios
from pathlib import Path

import pytest

import torchrom
from tests.conftest import PT145_DECK, REPO

COLUMNS, ROWS = 80, 24
BEAM_DECK = REPO / "tests" / "decks" / "pynastran_beam_modes" / "beam_modes.dat"  # 10 CBAR
#: tqdm's counter and timing, e.g. ``20/20 [00:00<00:00``: what only a bar prints
BAR = re.compile(r"\d+/\d+ \[\d")


def _env(**extra) -> dict:
    return {**os.environ, "PYTHONPATH": str(Path(torchrom.__file__).parents[1]),
            "TERM": "xterm", **extra}


def _on_terminal(argv, cwd, **env) -> tuple[int, str]:
    """(exit status, everything written to the terminal) of ``torchrom argv`` run with its
    three streams on a new 80 x 24 pseudo-terminal."""
    master, slave = os.openpty()
    fcntl.ioctl(slave, termios.TIOCSWINSZ, struct.pack("HHHH", ROWS, COLUMNS, 0, 0))
    proc = subprocess.Popen([sys.executable, "-m", "torchrom", *map(str, argv)], stdin=slave,
                            stdout=slave, stderr=slave, cwd=cwd, env=_env(**env))
    os.close(slave)
    chunks = []
    try:
        while select.select([master], [], [], 120)[0]:
            try:
                data = os.read(master, 1 << 16)
            except OSError:  # EIO: the process has closed the terminal
                break
            if not data:
                break
            chunks.append(data)
    finally:
        os.close(master)
        if proc.poll() is None:
            proc.kill()
    return proc.wait(timeout=60), b"".join(chunks).decode()


def _piped(argv, cwd, **env) -> tuple[int, str]:
    """(exit status, stdout and stderr as they came) of ``torchrom argv`` writing into a pipe."""
    run = subprocess.run([sys.executable, "-m", "torchrom", *map(str, argv)], cwd=cwd,
                         env=_env(**env), stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                         text=True, timeout=600)
    return run.returncode, run.stdout


def _screen(text: str, columns: int = COLUMNS) -> list[str]:
    """The logical lines a terminal of ``columns`` columns shows for ``text``, each as the list
    of rows it takes (more than one when it wrapped). See the module docstring."""
    lines, rows, row, col = [], [], [], 0
    for ch in text:
        if ch == "\r":
            col = 0
        elif ch == "\n":
            rows.append("".join(row).rstrip())
            lines.append(rows)
            rows, row, col = [], [], 0
        else:
            if col == columns:  # past the last column: the terminal wraps onto a new row
                rows.append("".join(row).rstrip())
                row, col = [], 0
            row[col:col + 1] = [ch] if col < len(row) else [" "] * (col - len(row)) + [ch]
            col += 1
    if row:
        rows.append("".join(row).rstrip())
    if rows:
        lines.append(rows)
    return lines


def _assert_no_escapes(text: str) -> None:
    assert "\x1b" not in text, [ln for ln in text.splitlines() if "\x1b" in ln][:3]
    assert "\\x1b" not in text, [ln for ln in text.splitlines() if "\\x1b" in ln][:3]


def test_screen_wraps_a_line_wider_than_the_terminal():
    """The minimal terminal itself: a carriage return overwrites, a long redraw wraps."""
    assert _screen("abc\rX\nnext\n") == [["Xbc"], ["next"]]
    wide = "x" * 85
    assert _screen(f"{wide}\r{wide}\n", columns=80) == [["x" * 80, "x" * 80, "x" * 5]]
    assert _screen("y" * 80 + "\r" + "z" * 80 + "\n", columns=80) == [["z" * 80]]


@pytest.mark.parametrize("argv", [("modes", BEAM_DECK), ("flutter", PT145_DECK)],
                         ids=["modes", "flutter"])
def test_terminal_shows_what_a_pipe_gets(argv, tmp_path):
    """``modes`` and ``flutter`` (pyNastran's logger imported on a terminal): the terminal gets
    exactly the lines a pipe gets, no ``\\x1b[0m`` after each of them."""
    rc, shown = _on_terminal(argv, tmp_path)
    assert rc == 0, shown
    _assert_no_escapes(shown)
    rc_piped, piped = _piped(argv, tmp_path)
    assert rc_piped == 0, piped
    assert shown.replace("\r\n", "\n").splitlines() == piped.splitlines()


def _beam_with_a_spring(folder) -> Path:
    """The CBAR beam deck with a grounded CELAS2 at its tip (grid 11, T3): springs stay linear
    in a nonlinear analysis (the CBARs are co-rotational), so identify warns once."""
    for f in BEAM_DECK.parent.glob("*.blk"):
        shutil.copy(f, folder / f.name)
    text = BEAM_DECK.read_text().replace("ENDDATA", "CELAS2,99,1.0e3,11,3\nENDDATA")
    deck = folder / BEAM_DECK.name
    deck.write_text(text)
    return deck


def test_bars_redraw_in_place_with_the_warning_above(tmp_path):
    """``identify`` of a deck with CBARs and a spring: two FE-solve bars, and the
    linear-element warning printed while the first is drawn. Each bar is one row of the
    terminal, redrawn with carriage returns and never wider than the terminal; the warning
    stands on its own line."""
    rc, shown = _on_terminal(["identify", _beam_with_a_spring(tmp_path), "--linear", "2",
                              "--dual", "1",
                              "--combinations", "1:1", "--out", "rom.npz"], tmp_path)
    assert rc == 0, shown
    _assert_no_escapes(shown)
    lines = _screen(shown.replace("\r\n", "\n"))
    bars = [rows for rows in lines if any(BAR.search(r) for r in rows)]
    assert [rows[0].split(":")[0].strip() for rows in bars] == ["dual modes", "tangents"]
    assert all(len(rows) == 1 and "100%" in rows[0] for rows in bars), bars
    for raw in shown.split("\n"):  # each redraw (between carriage returns) fits the terminal
        assert all(len(draw) <= COLUMNS for draw in raw.split("\r") if BAR.search(draw)), raw
    warned = [i for i, rows in enumerate(lines) if rows[0].startswith("torchrom identify: "
                                                                      "warning: beam_modes: ")]
    assert len(warned) == 1
    assert not any(BAR.search(r) for r in lines[warned[0]])
    assert "".join(lines[warned[0]]).endswith("eliminated as in a linear analysis")
    assert lines[warned[0] + 1] == bars[0]  # the warning came while the first bar was drawn


def test_sweep_bar_with_no_color_on_a_dumb_terminal(tmp_path):
    """``sweep`` with ``NO_COLOR`` and ``TERM=dumb``: one bar row for the two chunks (a carriage
    return is all a dumb terminal needs), no escape sequence."""
    from tests.test_bad_input import CONFIG

    (tmp_path / "sweep.toml").write_text(CONFIG)
    rc, shown = _on_terminal(["sweep", "sweep.toml", "--out", "out"], tmp_path, NO_COLOR="1",
                              TERM="dumb")
    assert rc == 0, shown
    _assert_no_escapes(shown)
    bars = [rows for rows in _screen(shown.replace("\r\n", "\n"))
            if any(BAR.search(r) for r in rows)]
    assert bars == [[bars[0][0]]] and "cases done: 100%" in bars[0][0] and "2/2" in bars[0][0]
    assert shown.count("cases done:") >= 3  # drawn at 0, 1 and 2 of 2: redrawn, on one row
