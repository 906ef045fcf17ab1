"""Resource bounds checked before any work (torchrom.bounds, issue 26): each absurd size of a
configuration or an option is refused in seconds with one line that gives the estimate and the
override (--allow-large / [run] allow_large), and nothing is written; the override lifts a soft
bound. All inputs are tiny models, so the module runs in seconds."""

from __future__ import annotations

import time

import numpy as np
import pytest

from tests.test_bad_input import CONFIG, DECK, _cli, _one_line_error
from torchrom import bounds
from torchrom.errors import InputError
from torchrom.limits import usable_cpus


def _config(tmp_path, text):
    cfg = tmp_path / "sweep.toml"
    cfg.write_text(text)
    return cfg


# -- the bounds themselves --
def test_check_count_names_estimate_bound_and_override():
    with pytest.raises(InputError) as info:
        bounds.check_count("f.toml: [cases]", "cases", 10**7, bounds.MAX_CASES)
    msg = str(info.value)
    assert "1e+07" in msg and "1000000" not in msg.split("bound of")[0]
    assert "--allow-large" in msg and "[run] allow_large" in msg
    bounds.check_count("x", "cases", 10**7, bounds.MAX_CASES, override=True)  # lifted


def test_allow_large_is_process_wide_and_resettable():
    try:
        bounds.set_allow_large(True)
        bounds.check_count("x", "cases", 10**9, bounds.MAX_CASES)
    finally:
        bounds.set_allow_large(False)
    with pytest.raises(InputError):
        bounds.check_count("x", "cases", 10**9, bounds.MAX_CASES)


def test_memory_beyond_what_is_available_is_refused_even_when_allowed():
    free = bounds.available_memory()
    assert free > 0
    with pytest.raises(InputError, match="more than the .* available"):
        bounds.check_memory("x", "a tensor", 2.0 * free, override=True)
    with pytest.raises(InputError, match="--allow-large"):
        bounds.check_memory("x", "a tensor", 0.75 * free)
    bounds.check_memory("x", "a tensor", 0.75 * free, override=True)


def test_hb_bytes_counts_the_3h_fourier_matrices():
    """H = 5000 on a 2-mode ROM: the Jacobian (n(2H+1)+1)² × 3 × 8 B = 9.6 GB and the three
    (12H+1) × (6H+1) Fourier matrices of the truncation residual, 43.2 GB (the 25 GB
    allocation of the issue was one of them plus its work space)."""
    jac = 3 * (2 * 10001 + 1) ** 2 * 8
    fourier = 3 * 60001 * 30001 * 8
    assert bounds.hb_bytes(2, 5000, 1) == pytest.approx(jac + fourier, rel=1e-12)


def test_threads_bound_follows_the_cores():
    cores = usable_cpus()  # the cores this process may use (tests/test_limits.py)
    bounds.check_threads("x", bounds.THREADS_PER_CORE * cores)
    bounds.check_threads("x", "auto")
    with pytest.raises(InputError, match="threads"):
        bounds.check_threads("x", bounds.THREADS_PER_CORE * cores + 1)
    with pytest.raises(InputError, match="per core"):  # a hard bound: thread stacks, no gain
        bounds.check_threads("x", 100000, override=True)


# -- configurations and options over a bound: refused before any work --
MANY = "alpha = {start = 0.0, stop = 1.0, num = %d}"
OVER = {
    # name: (replacements old -> new in CONFIG, words of the message)
    "1e9 cases": ([("alpha = [0.0, 0.3]", MANY % 10**9)], ("[cases]", "1e+09", "--allow-large")),
    "1e7 cases": ([("alpha = [0.0, 0.3]", MANY % 10**7)], ("[cases]", "1e+07", "--allow-large")),
    "1e7 samples": ([("alpha = [0.0, 0.3]", "alpha = {distribution = 'uniform', low = 0.0, "
                      "high = 1.0}\nsamples = 10000000")], ("[cases]", "1e+07")),
    "iterations 1e8": ([("t_end = 4.0", "t_end = 4.0\niterations = 100000000")],
                       ("[integrator] iterations", "1e+08", "--allow-large")),
    "case-steps": ([("t_end = 4.0", "t_end = 4.0e5"), ("alpha = [0.0, 0.3]", MANY % 10**4)],
                   ("cases x steps x iterations", "--allow-large")),
    "threads": ([("t_end = 4.0", "t_end = 4.0\nthreads = 100000")], ("[integrator] threads",)),
}


@pytest.mark.parametrize("name", sorted(OVER))
def test_over_a_bound_is_refused_up_front(name, tmp_path, capsys):
    replacements, words = OVER[name]
    text = CONFIG
    for old, new in replacements:
        assert old in text
        text = text.replace(old, new)
    cfg = _config(tmp_path, text)
    out = tmp_path / "out"
    t0 = time.perf_counter()
    rc, err = _cli(capsys, ["sweep", cfg, "--out", out])
    assert rc == 2
    _one_line_error(err, *words)
    assert not out.exists()
    assert time.perf_counter() - t0 < 30  # refused, not attempted


def test_batch_memory_over_the_available(tmp_path, capsys, monkeypatch):
    """The integrator's B x n^2 matrices against the memory available (made tiny here: 2 cases
    x 2 modes take 640 B, over half of 1000 B): refused before any output, naming the batch."""
    monkeypatch.setattr(bounds, "available_memory", lambda device=None: 1000)
    cfg = _config(tmp_path, CONFIG)
    rc, err = _cli(capsys, ["sweep", cfg, "--out", tmp_path / "out"])
    assert rc == 2
    _one_line_error(err, "[run] batch_size", "2 cases", "--allow-large")
    assert not (tmp_path / "out").exists()


def test_workers_over_the_cores(tmp_path, capsys):
    cfg = _config(tmp_path, CONFIG)
    rc, err = _cli(capsys, ["sweep", cfg, "--out", tmp_path / "out", "--workers", "100000"])
    assert rc == 2
    _one_line_error(err, "--workers", "per core")
    assert not (tmp_path / "out").exists()


def test_cli_threads_over_the_cores(tmp_path, capsys):
    cfg = _config(tmp_path, CONFIG)
    for extra in ([], ["--allow-large"]):
        rc, err = _cli(capsys, ["sweep", cfg, "--out", tmp_path / "out", "--threads", "100000",
                                *extra])
        assert rc == 2  # the option's own check (1 to the cores), before the config's bound
        _one_line_error(err, "--threads", "cores of this machine")
    assert not (tmp_path / "out").exists()


def test_allow_large_key_lifts_the_case_bound(tmp_path, monkeypatch):
    """[run] allow_large = true: a grid over MAX_CASES (lowered to 10 here, so that the test
    builds 11 cases, not a million) is accepted by the loader; without it, refused."""
    from torchrom.study.config import load_sweep_config

    monkeypatch.setattr(bounds, "MAX_CASES", 10)
    text = CONFIG.replace("alpha = [0.0, 0.3]", "alpha = {start = 0.0, stop = 1.0, num = 11}")
    with pytest.raises(InputError, match="cases = 11, over the bound of 10"):
        load_sweep_config(_config(tmp_path, text))
    cfg = load_sweep_config(_config(tmp_path, text.replace("chunk_size = 1",
                                                           "allow_large = true")))
    assert cfg.allow_large and len(cfg.cases) == 11


def test_allow_large_option_lifts_the_iteration_bound(tmp_path, capsys):
    """--allow-large: 2000 fixed iterations per step (over the bound of 1000) run (short t_end)."""
    text = CONFIG.replace("t_end = 4.0", "t_end = 0.05\niterations = 2000")
    cfg = _config(tmp_path, text)
    rc, err = _cli(capsys, ["sweep", cfg, "--out", tmp_path / "o1"])
    assert rc == 2 and "--allow-large" in err
    rc, err = _cli(capsys, ["sweep", cfg, "--out", tmp_path / "o2", "--allow-large"])
    assert rc == 0, err
    assert (tmp_path / "o2" / "results.csv").exists()


@pytest.mark.parametrize("harmonics", [500, 5000])
def test_hb_harmonics_bounded(harmonics, tmp_path, capsys):
    """[hb] harmonics = 5000 (a 43 GB allocation traceback before): refused by memory; 500: by
    the count bound; both before any output."""
    text = CONFIG.replace("title = \"bad input\"", "title = \"bad input\"\nmethod = \"hb\"")
    text = text.replace("[lco]", f"[hb]\nharmonics = {harmonics}\nmax_harmonics = "
                        f"{harmonics}\n[lco]")
    cfg = _config(tmp_path, text)
    rc, err = _cli(capsys, ["sweep", cfg, "--out", tmp_path / "out"])
    assert rc == 2
    _one_line_error(err, "[hb] max_harmonics", "harmonic" if harmonics == 500 else "GB")
    assert not (tmp_path / "out").exists()


def test_branch_harmonics_bounded(tmp_path, capsys):
    text = CONFIG.replace("[cases]\nalpha = [0.0, 0.3]", "[branch]\nparameter = \"alpha\"\n"
                          "bounds = [0.0, 1.0]\n[cases]\nalpha = 0.3")
    cfg = _config(tmp_path, text)
    rc, err = _cli(capsys, ["branch", cfg, "--out", tmp_path / "out", "--harmonics", "20000"])
    assert rc == 2
    _one_line_error(err, "branch harmonics", "GB")
    assert not (tmp_path / "out").exists()


def test_identify_more_modes_than_dofs(tmp_path, capsys):
    """--linear 500 on an 18-DOF deck ran for minutes: refused, naming the DOFs."""
    deck = tmp_path / "wing.bdf"
    deck.write_text(DECK)
    t0 = time.perf_counter()
    rc, err = _cli(capsys, ["identify", deck, "--linear", "500", "--out", tmp_path / "rom.npz"])
    assert rc == 2
    _one_line_error(err, "500 linear", "18 DOFs")
    assert not (tmp_path / "rom.npz").exists()
    assert time.perf_counter() - t0 < 30


def test_modes_count_bounded(tmp_path, capsys):
    deck = tmp_path / "wing.bdf"
    deck.write_text(DECK)
    rc, err = _cli(capsys, ["modes", deck, "--n", "100000000"])
    assert rc == 2
    _one_line_error(err, "modes", "--allow-large")


def test_large_deck_reports_its_reading_stages(tmp_path, capsys, monkeypatch):
    """A deck above LARGE_DECK_BYTES prints its stages (parse, mesh, assembly) on stderr, each
    with its time; a small one prints none."""
    import torchrom.fe.bdf_read as bdf_read

    deck = tmp_path / "wing.bdf"
    deck.write_text(DECK)
    assert _cli(capsys, ["modes", deck])[0] == 0
    assert "parsing" not in capsys.readouterr().err
    monkeypatch.setattr(bdf_read, "LARGE_DECK_BYTES", 10)
    rc, err = _cli(capsys, ["modes", deck])
    assert rc == 0
    for stage in ("parsing", "building the mesh of 4 grids and 3 elements", "assembling"):
        assert f"reading wing.bdf: {stage}" in err and "done in" in err
    rc, err = _cli(capsys, ["modes", deck, "--quiet"])
    assert rc == 0 and "reading wing.bdf" not in err


@pytest.mark.parametrize("key", ["metric_points", "max_stages", "floquet_steps"])
def test_hb_effort_bounded(key, tmp_path, capsys):
    """metric_points / max_stages / floquet_steps = 1e9 ran past a minute: refused."""
    text = CONFIG.replace("title = \"bad input\"", "title = \"bad input\"\nmethod = \"hb\"")
    text = text.replace("[lco]", f"[hb]\n{key} = 1000000000\n[lco]")
    rc, err = _cli(capsys, ["sweep", _config(tmp_path, text), "--out", tmp_path / "out"])
    assert rc == 2
    _one_line_error(err, f"[hb] {key}", "--allow-large")


def test_solve_orbits_api_checks_its_memory():
    from torchrom.periodic import HBOptions
    from torchrom.periodic.solve import solve_orbits
    from torchrom.rom.analytic import van_der_pol_duffing
    from torchrom.sim import CaseSystem

    rom = van_der_pol_duffing([1.0, 2.0], c1=[-0.6, 0.05])
    opts = HBOptions(start_harmonics=3, harmonics=5, max_harmonics=20000)
    with pytest.raises(InputError, match="harmonic balance: max_harmonics.*GB"):
        solve_orbits(CaseSystem.build(rom), [1.0, 0.0], opts)


@pytest.mark.parametrize("argv", [
    ["calibrate", "{cfg}", "--target", "0.1", "--num", "100000000"],
    ["calibrate", "{cfg}", "--target", "0.1", "--rounds", "1000000000"],
    ["bifurcation", "{cfg}", "--refine", "1000000000"],
])
def test_command_totals_bounded(argv, tmp_path, capsys):
    """Totals a command derives from its options (rounds x values x base cases, refinement
    rounds x points, worker processes): refused before any work."""
    cfg = _config(tmp_path, CONFIG)
    rc, err = _cli(capsys, [a.format(cfg=cfg) for a in argv] + ["--out", tmp_path / "out"])
    assert rc == 2
    _one_line_error(err, "--allow-large")
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("argv, words", [
    (["flutter", "goland", "--boxes", "10000", "10000"], ("--boxes", "TB")),
    (["flutter", "goland", "--lags", "100000"], ("--lags", "--allow-large")),
    (["aero", "goland", "--mach", "0.5", "--boxes", "100", "100"], ("--boxes", "GB")),
])
def test_aerodynamic_sizes_bounded(argv, words, tmp_path, capsys):
    t0 = time.perf_counter()
    rc, err = _cli(capsys, [*argv, *(["--out", tmp_path / "a.npz"] if argv[0] == "aero" else [])])
    assert rc == 2
    _one_line_error(err, *words)
    assert time.perf_counter() - t0 < 30


def test_lattice_and_rfa_bounds_in_the_api():
    from torchrom.aero.panels import lattice
    from torchrom.aero.rfa import default_lag_roots

    with pytest.raises(InputError, match="CAERO1 7.*boxes"):
        lattice([0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], np.linspace(0, 1, 2001),
                np.linspace(0, 1, 2001), caero_id=7)
    with pytest.raises(InputError, match="RFA: lag states"):
        default_lag_roots(100000, 1.0)
