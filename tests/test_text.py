"""Untrusted text is printed without terminal control sequences (torchrom.text, issue 26)."""

from __future__ import annotations

import io

from tests.test_bad_input import CONFIG, _cli
from torchrom.text import SafeStream, printable, terminal_safe

HOSTILE = "\x1b[31mRED\x1b]0;pwned\x07\r\u202eevil"


def test_printable_escapes_every_control_character():
    out = printable(HOSTILE + "\nnext\tcol")
    assert out == "\\x1b[31mRED\\x1b]0;pwned\\x07\\x0d\\u202eevil\\x0anext\\x09col"
    assert all(c.isprintable() for c in out)
    assert printable("Goland wing, Mach 0.70: γ ≥ 0") == "Goland wing, Mach 0.70: γ ≥ 0"


def test_terminal_safe_keeps_lines_tabs_and_carriage_returns():
    assert terminal_safe("a\tb\r\nc\x1b[2J\x9b") == "a\tb\r\nc\\x1b[2J\\x9b"


def test_safe_stream_filters_writes_and_delegates_the_rest():
    buf = io.StringIO()
    s = SafeStream(buf)
    assert s.write("x\x1b[0m\n") == len("x\x1b[0m\n")
    s.writelines(["\x07", "ok"])
    assert buf.getvalue() == "x\\x1b[0m\n\\x07ok"
    assert s.isatty() is False and s.getvalue() == buf.getvalue()


def test_config_title_reaches_the_terminal_escaped(tmp_path, capsys):
    """A title with ESC sequences (colour, window title, BEL) and a bidi override: the sweep
    runs, and neither stdout nor stderr holds a raw control character."""
    cfg = tmp_path / "sweep.toml"
    cfg.write_text(CONFIG.replace('title = "bad input"',
                                  'title = "\\u001b[31mRED\\u001b]0;pwned\\u0007 \\u202eevil"'))
    from torchrom.cli import main

    rc = main(["sweep", str(cfg), "--out", str(tmp_path / "out")])
    captured = capsys.readouterr()
    assert rc == 0
    for text in (captured.out, captured.err):
        assert "\x1b" not in text and "\x07" not in text and "\u202e" not in text
    assert "\\x1b[31mRED" in captured.out


def test_error_messages_are_one_printable_line(tmp_path, capsys):
    """A file name holding control characters is named escaped in the one-line error."""
    bad = tmp_path / "evil\x1b[2Jname.toml"
    rc, err = _cli(capsys, ["sweep", bad, "--out", tmp_path / "out"])
    assert rc == 2 and "\x1b" not in err and "\\x1b[2Jname.toml" in err
