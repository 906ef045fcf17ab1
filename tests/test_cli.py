import subprocess
import sys

from torchrom.cli import main


def test_help_lists_commands(capsys):
    assert main([]) == 0
    out = capsys.readouterr().out
    assert "usage: torchrom" in out


def test_version_module_entry():
    res = subprocess.run(
        [sys.executable, "-m", "torchrom", "--version"], capture_output=True, text=True
    )
    assert res.returncode == 0
    assert res.stdout.startswith("torchrom ")
