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


def test_help_is_fast_because_commands_import_lazily():
    """`torchrom --help` must not import torch/pyNastran (seconds): commands import in run()."""
    code = (
        "import sys; from torchrom.cli import build_parser; build_parser(); "
        "heavy = [m for m in ('torch', 'pyNastran', 'panelaero', 'pandas') if m in sys.modules]; "
        "print(','.join(heavy))"
    )
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert res.returncode == 0, res.stderr
    assert res.stdout.strip() == "", f"heavy modules imported by the parser: {res.stdout}"
