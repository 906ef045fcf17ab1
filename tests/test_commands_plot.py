"""``torchrom plot``: the general form (any table: x, y, hue, facet; units from the column
metadata) and its errors (the paper figures are tested in test_paper_findings.py)."""

import pandas as pd

from torchrom.cli import main


def _table() -> pd.DataFrame:
    rows = [{"altitude_ft": h, "gamma": g, "branch": b, "status": "lco" if h < 9000 else "decay",
             "amplitude": (9000 - h) / 1000 * (1 + b) / (1 + 1e3 * g)}
            for h in (4000.0, 6000.0, 8000.0, 10000.0) for g in (1e-4, 1e-3) for b in (0, 1)]
    t = pd.DataFrame(rows)
    t.attrs["units"] = {"amplitude": "ft", "branch": "-"}
    return t


def test_general_plot_with_hue_and_facet(tmp_path, capsys):
    _table().to_parquet(tmp_path / "t.parquet")
    out = tmp_path / "f.png"
    assert main(["plot", str(tmp_path / "t.parquet"), "--x", "altitude_ft", "--y", "amplitude",
                 "--hue", "gamma", "--facet", "branch", "--out", str(out)]) == 0
    assert out.stat().st_size > 10_000 and "wrote" in capsys.readouterr().out
    # labels carry units: check through the plotting function's axes
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from torchrom.study.plots import parameter_plot

    captured = {}
    orig = plt.Figure.savefig

    def spy(fig, *a, **k):
        captured["labels"] = [ax.get_ylabel() for ax in fig.axes if ax.get_visible()]
        captured["titles"] = [ax.get_title() for ax in fig.axes if ax.get_visible()]
        captured["legend"] = [t.get_text() for lg in fig.legends for t in lg.get_texts()]
        return orig(fig, *a, **k)

    plt.Figure.savefig = spy
    try:
        parameter_plot(pd.read_parquet(tmp_path / "t.parquet"), tmp_path / "g.png",
                       x="altitude_ft", y="amplitude", hue="gamma", facet="branch")
    finally:
        plt.Figure.savefig = orig
    assert captured["labels"][0] == "LCO amplitude (ft)"
    assert captured["titles"] == ["branch = 0", "branch = 1"]
    assert "γ = 0.0001 s" in captured["legend"]
    assert "converged LCO (filled)" in captured["legend"]
    assert "diverged" not in captured["legend"]  # only statuses that are drawn


def test_plot_needs_x_or_figure_and_known_columns(tmp_path, capsys):
    _table().to_parquet(tmp_path / "t.parquet")
    assert main(["plot", str(tmp_path / "t.parquet"), "--out", str(tmp_path / "a.png")]) == 2
    assert "give either --x" in capsys.readouterr().err
    assert main(["plot", str(tmp_path / "t.parquet"), "--x", "nope", "--out",
                 str(tmp_path / "a.png")]) == 2
    assert "no column 'nope'" in capsys.readouterr().err


def test_table2_figure_from_a_modes_table(tmp_path):
    modes = pd.DataFrame({"mode": [1, 2, 3], "frequency_hz": [1.69, 3.99, 9.9],
                          "kind": ["bending", "torsion", "bending"]})
    modes.to_csv(tmp_path / "modes.csv", index=False)
    assert main(["plot", str(tmp_path / "modes.csv"), "--figure", "table2", "--out",
                 str(tmp_path / "t2.png")]) == 0


def test_a_table_without_an_lco_is_refused_in_one_line(tmp_path):
    """Issue 37: a table where every case decayed gave an empty figure and exit 0. Now one line,
    exit 2 and no figure, for the general form and the LCO figures (a real process: what a
    user runs)."""
    import os
    import subprocess
    import sys
    from pathlib import Path

    import torchrom
    from tests.test_paper_findings import paper_like_table

    decayed = paper_like_table()
    decayed["status"] = "decay"
    decayed.to_csv(tmp_path / "decayed.csv", index=False)
    env = {**os.environ, "PYTHONPATH": str(Path(torchrom.__file__).parents[1])}
    for form in (["--x", "altitude_ft"], ["--figure", "fig12"]):
        run = subprocess.run([sys.executable, "-m", "torchrom", "plot", "decayed.csv", *form,
                              "--out", "f.png"], cwd=tmp_path, env=env, capture_output=True,
                             text=True, timeout=300)
        assert run.returncode == 2, run.stderr
        assert run.stderr == ("torchrom plot: error: no case with an LCO in decayed.csv: nothing "
                              "to plot\n")
        assert not (tmp_path / "f.png").exists() and list(tmp_path.iterdir()) == [
            tmp_path / "decayed.csv"]


# -- the deformed wing (issue 47) ------------------------------------------------------------------
import pytest  # noqa: E402

from .shape_fixtures import cli, goland_chain  # noqa: E402


@pytest.fixture(scope="module")
def chain(tmp_path_factory):
    return goland_chain(tmp_path_factory.mktemp("shapes"))


def test_mode_picture_and_lco_gif(chain):
    """``plot ROM --mode 2`` writes a PNG; ``plot ROM --sweep DIR --row 0 --out X.gif`` a GIF
    of exactly --frames frames that loops; an existing picture is kept without --force."""
    from PIL import Image

    d = chain
    assert cli(d, "plot", "run/rom.npz", "--mode", "2", "--out", "mode2.png") == 0
    assert Image.open(d / "mode2.png").format == "PNG"
    assert cli(d, "plot", "run/goland.bdf", "--mode", "1", "--out", "deck1.png",
               "--view", "30", "-120") == 0
    assert cli(d, "plot", "run/rom.npz", "--sweep", "lco", "--row", "0", "--frames", "6",
               "--out", "lco.gif") == 0
    gif = Image.open(d / "lco.gif")
    assert gif.format == "GIF" and gif.n_frames == 6 and gif.info.get("loop") == 0
    before = (d / "mode2.png").read_bytes()
    assert cli(d, "plot", "run/rom.npz", "--mode", "3", "--out", "mode2.png") == 2
    assert (d / "mode2.png").read_bytes() == before


def test_flutter_plot_draws_the_flutter_mode_beside_vg(chain):
    """``flutter ROM AERO --plot`` puts the flutter mode beside the V-g / V-f diagrams (a
    figure twice as wide: 14 x 7 in at 120 dpi) when the ROM keeps its shapes, and the V-g
    diagram alone (7 x 7 in) for a ROM without them."""
    from PIL import Image

    from torchrom.rom import NonlinearROM

    d = chain
    assert cli(d, "flutter", "run/rom.npz", "run/aero.npz", "--method", "pk", "--plot",
               "vg.png") == 0
    assert Image.open(d / "vg.png").size == (1680, 840)
    NonlinearROM.load(d / "run/rom.npz").replace(shapes=None).save(d / "old.npz")
    assert cli(d, "flutter", "old.npz", "run/aero.npz", "--method", "pk", "--plot",
               "vg_old.png") == 0
    assert Image.open(d / "vg_old.png").size == (840, 840)
