"""``torchrom static``: the deck's own static subcases (torchrom/commands/static.py over
torchrom/fe/static_cases.py).

References: Euler–Bernoulli cantilever closed forms (tip force w = P L³ / (3 E I), tip moment
θ = M L / (E I), w = M L² / (2 E I): exact for nodal loads with the cubic beam element, so to
rounding), superposition for a LOAD combination, gravity on a CONM2 (its weight m g at the tip),
and the shallow two-bar (von Mises) truss of Green-strain rods, whose apex load for an apex
deflection w is P = E A (h − w) w (2h − w) / L0³ (total Lagrangian, St Venant–Kirchhoff): exact,
so the Newton solution is checked to 1e-7. Bad input runs the real command in subprocesses.
"""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest

from torchrom.cli import main

E, L, I2, A = 7.0e10, 3.0, 2.0e-6, 1.0e-3
P, M, MASS, G = 250.0, 40.0, 5.0, 9.81

CANTILEVER = """SOL {sol}
CEND
SPC = 1
{nlparm}
SUBCASE 1
  LABEL = tip force
  LOAD = 10
SUBCASE 2
  LOAD = 20
SUBCASE 3
  LOAD = 30
SUBCASE 4
  LOAD = 40
BEGIN BULK
GRID    1               0.0     0.0     0.0
GRID    2               1.0     0.0     0.0
GRID    3               2.0     0.0     0.0
GRID    4               3.0     0.0     0.0
CBAR    1       1       1       2       0.0     1.0     0.0
CBAR    2       1       2       3       0.0     1.0     0.0
CBAR    3       1       3       4       0.0     1.0     0.0
PBAR    1       1       1.-3    4.-6    2.-6    1.-6
MAT1    1       7.+10           0.3     0.0
CONM2   10      4               5.0
SPC1    1       123456  1
FORCE   10      4               250.0   0.0     0.0     1.0
MOMENT  20      4               40.0    0.0     1.0     0.0
GRAV    30              9.81    0.0     0.0     -1.0
LOAD    40      2.0     1.5     10      -1.0    20
NLPARM  7       4
ENDDATA
"""


def _deck(tmp_path, sol=101, nlparm="", name="beam.bdf", text=CANTILEVER):
    path = tmp_path / name
    path.write_text(text.format(sol=sol, nlparm=nlparm))
    return path


def _static(capsys, *argv):
    rc = main(["static", *map(str, argv)])
    return rc, capsys.readouterr()


def _tip(sub, step=-1):
    return np.array(sub["steps"][step]["displacements"]["4"])


def test_linear_subcases_match_closed_forms(tmp_path, capsys):
    """Tip force, tip moment, gravity on a tip CONM2 and a LOAD combination, one SUBCASE each:
    tip T3/R2 to 1e-9 of the closed forms; the JSON keys every grid by ID, the clamped grid
    does not move, and --grids prints the chosen grid."""
    out = tmp_path / "static.json"
    rc, cap = _static(capsys, _deck(tmp_path), "--grids", "4", "--json", out)
    assert rc == 0, cap.err
    assert "SUBCASE 1 (tip force): LOAD 10" in cap.out and "        4" in cap.out
    res = json.loads(out.read_text())
    assert (res["sol"], res["analysis"], res["loads"], res["frame"]) == (101, "linear", "dead",
                                                                           "basic")
    subs = {s["subcase"]: s for s in res["subcases"]}
    assert sorted(subs) == [1, 2, 3, 4] and subs[1]["label"] == "tip force"
    EI = E * I2
    w_force, th_force = P * L**3 / (3 * EI), -P * L**2 / (2 * EI)  # R2 = −dw/dx
    w_moment, th_moment = -M * L**2 / (2 * EI), M * L / EI
    w_grav = -MASS * G * L**3 / (3 * EI)
    th_grav = MASS * G * L**2 / (2 * EI)
    expected = {1: (w_force, th_force), 2: (w_moment, th_moment), 3: (w_grav, th_grav),
                4: (2 * (1.5 * w_force - w_moment), 2 * (1.5 * th_force - th_moment))}
    for k, (w, th) in expected.items():
        tip = _tip(subs[k])
        assert tip[2] == pytest.approx(w, rel=1e-9), k
        assert tip[4] == pytest.approx(th, rel=1e-9), k
        assert np.abs(tip[[0, 1, 3, 5]]).max() <= 1e-12 * abs(w)
        assert subs[k]["steps"][0]["load_factor"] == 1.0 and subs[k]["converged"]
        assert subs[k]["steps"][0]["displacements"]["1"] == [0.0] * 6
        assert len(subs[k]["steps"][0]["displacements"]) == 4


def test_nonlinear_load_steps_of_nlparm_and_of_steps(tmp_path, capsys):
    """SOL 106 with NLPARM NINC 4: four load steps at λ = 1/4 .. 1; the co-rotational CBAR
    cantilever's tip follows the elastica (α = λ P L²/EI up to 0.016): the geometric
    nonlinearity lowers the tip by 2.9e-5 of the linear value at λ = 1, and the three-element
    mesh matches the elastica to 1.0e-6 (measured), so 3e-6 separates the two; --steps
    overrides NINC; --linear overrides the SOL."""
    from .test_fe_corotational import elastica_tip

    deck = _deck(tmp_path, sol=106, nlparm="NLPARM = 7")
    out = tmp_path / "nl.json"
    rc, cap = _static(capsys, deck, "--json", out)
    assert rc == 0, cap.err
    res = json.loads(out.read_text())
    assert res["analysis"] == "nonlinear"
    sub = res["subcases"][0]
    assert [s["load_factor"] for s in sub["steps"]] == [0.25, 0.5, 0.75, 1.0]
    alpha = P * L**2 / (E * I2)
    for s in sub["steps"]:
        assert s["converged"]
        w = elastica_tip(s["load_factor"] * alpha)[2] * L
        assert s["displacements"]["4"][2] == pytest.approx(w, rel=3e-6)
    # and it is not the linear answer: at λ = 1 the two differ by ten times the tolerance
    w_linear = P * L**3 / (3 * E * I2)
    assert abs(sub["steps"][-1]["displacements"]["4"][2] / w_linear - 1) > 2e-5
    rc, cap = _static(capsys, deck, "--steps", "2", "--json", out, "--force")
    assert rc == 0 and len(json.loads(out.read_text())["subcases"][0]["steps"]) == 2
    rc, cap = _static(capsys, deck, "--linear", "--json", out, "--force")
    assert rc == 0 and json.loads(out.read_text())["analysis"] == "linear"


# shallow two-bar truss: half-span a, rise h, apex grid 3 loaded downwards
TRUSS_A, TRUSS_H, TRUSS_EA = 1.0, 0.1, 1.0e6
TRUSS = """SOL 106
CEND
SPC = 1
NLPARM = 1
SUBCASE 1
  LOAD = 1
BEGIN BULK
GRID    1               -1.0    0.0     0.0
GRID    2               1.0     0.0     0.0
GRID    3               0.0     0.0     0.1
CROD    1       1       1       3
CROD    2       1       2       3
PROD    1       1       1.0
MAT1    1       1.0+6           0.3
SPC1    1       123456  1       2
SPC1    1       2       3
FORCE,1,3,,{load},0.0,0.0,-1.0
NLPARM  1       {ninc}
ENDDATA
"""


def _truss_load(w: float) -> float:
    """Apex load of the two-bar Green-strain truss at apex deflection w (module docstring)."""
    L0 = np.hypot(TRUSS_A, TRUSS_H)
    return TRUSS_EA * (TRUSS_H - w) * w * (2 * TRUSS_H - w) / L0**3


def test_nonlinear_truss_closed_form_and_unconverged_steps_reported(tmp_path, capsys):
    """The Green-strain truss: the apex deflection of P(0.3 h) is 0.3 h (to 1e-7); under 1.3×
    its limit load P(h (1 − 1/√3)) the steps past the limit point fail, are halved, and the
    subcase ends with a row marked not converged (exit status 0, the converged steps kept)."""
    w = 0.3 * TRUSS_H
    deck = tmp_path / "truss.bdf"
    load = _truss_load(w)
    deck.write_text(TRUSS.format(load=f"{load:.12e}", ninc=4))
    out = tmp_path / "truss.json"
    rc, cap = _static(capsys, deck, "--json", out)
    assert rc == 0, cap.err
    sub = json.loads(out.read_text())["subcases"][0]
    apex = -sub["steps"][-1]["displacements"]["3"][2]
    assert _truss_load(apex) == pytest.approx(load, rel=1e-7)
    assert apex == pytest.approx(w, rel=1e-7)
    limit = _truss_load(TRUSS_H * (1 - 1 / np.sqrt(3)))
    deck.write_text(TRUSS.format(load=f"{1.3 * limit:.12e}", ninc=4))
    rc, cap = _static(capsys, deck, "--json", out, "--force")
    assert rc == 0, cap.err
    sub = json.loads(out.read_text())["subcases"][0]
    assert not sub["converged"] and "NOT CONVERGED" in cap.out
    last = sub["steps"][-1]
    assert not last["converged"] and last["displacements"] is None
    done = [s for s in sub["steps"] if s["converged"]]
    assert done and all(s["load_factor"] * 1.3 < 1.0 for s in done)  # below the limit load
    assert done[-1]["load_factor"] * 1.3 > 0.9  # halving went close to it


BAD = [
    ("no_subcase", lambda t: t.replace("SUBCASE 1\n  LABEL = tip force\n  LOAD = 10\n", "")
     .replace("SUBCASE 2\n  LOAD = 20\n", "").replace("SUBCASE 3\n  LOAD = 30\n", "")
     .replace("SUBCASE 4\n  LOAD = 40\n", ""), "no static subcase"),
    ("unknown_load", lambda t: t.replace("LOAD = 30", "LOAD = 99"),
     "SUBCASE 3: LOAD = 99: no load set 99"),
    ("sol_103", lambda t: t.replace("SOL {sol}", "SOL 103"), "SOL 103: not a static solution"),
    ("missing_card", lambda t: t.replace("-1.0    20", "-1.0    50"),
     "LOAD 40: field L: load set 50 not found"),
    ("unknown_nlparm", lambda t: t.replace("SOL {sol}", "SOL 106").replace("{nlparm}",
                                                                          "NLPARM = 8"),
     "SUBCASE 1: NLPARM = 8: no NLPARM card with that ID"),
]


@pytest.mark.parametrize("name, change, message", BAD, ids=[b[0] for b in BAD])
def test_bad_static_input_is_one_line(tmp_path, name, change, message):
    """No static subcase, an unknown LOAD, a SOL that is not static, a LOAD combination naming a
    missing set, an unknown NLPARM: exit 2, one line naming the deck and what was expected, no
    JSON."""
    deck = _deck(tmp_path, text=change(CANTILEVER))
    out = tmp_path / "out.json"
    run = subprocess.run([sys.executable, "-m", "torchrom", "static", str(deck), "--json",
                          str(out)], capture_output=True, text=True, timeout=300)
    assert run.returncode == 2, run.stdout + run.stderr
    lines = run.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("torchrom static: error: "), run.stderr
    assert message in lines[0] and "beam.bdf" in lines[0]
    assert not out.exists()


def test_grids_option_checks_its_grids(tmp_path, capsys):
    """--grids names a grid the deck lacks, or is not a list of IDs: one line, exit 2."""
    deck = _deck(tmp_path)
    rc, cap = _static(capsys, deck, "--grids", "4,77")
    assert rc == 2 and "--grids: grid 77 not found in beam.bdf" in cap.err
    with pytest.raises(SystemExit) as exc:
        main(["static", str(deck), "--grids", "4,x"])
    assert exc.value.code == 2 and "expected grid IDs" in capsys.readouterr().err


def test_subcases_with_their_own_spc_sets(tmp_path, capsys):
    """A force P at x = a = 2 of the L = 3 cantilever, in SUBCASE 1 clamped (SPC 1: δ = P a³ /
    (3 E I)) and in SUBCASE 2 also propped at the tip (SPC 2: the prop's reaction
    R = P a² (3L − a) / (2 L³), δ = P a³ / (3 E I) − R a² (3L − a) / (6 E I)); each subcase's
    SPC set is its own model (to 1e-9)."""
    text = (CANTILEVER.replace("SUBCASE 1\n  LABEL = tip force\n  LOAD = 10\n",
                               "SUBCASE 1\n  LOAD = 50\n")
            .replace("SUBCASE 2\n  LOAD = 20\n", "SUBCASE 2\n  LOAD = 50\n  SPC = 2\n")
            .replace("SUBCASE 3\n  LOAD = 30\n", "").replace("SUBCASE 4\n  LOAD = 40\n", "")
            .replace("ENDDATA", "FORCE   50      3               250.0   0.0     0.0     1.0\n"
                     "SPC1    2       123456  1\nSPC1    2       3       4\nENDDATA"))
    out = tmp_path / "spc.json"
    rc, cap = _static(capsys, _deck(tmp_path, text=text), "--json", out)
    assert rc == 0, cap.err
    subs = json.loads(out.read_text())["subcases"]
    assert [(s["subcase"], s["spc"]) for s in subs] == [(1, 1), (2, 2)]
    a, EI = 2.0, E * I2
    R = P * a**2 * (3 * L - a) / (2 * L**3)
    expected = [P * a**3 / (3 * EI), P * a**3 / (3 * EI) - R * a**2 * (3 * L - a) / (6 * EI)]
    for sub, w in zip(subs, expected):
        assert sub["steps"][0]["displacements"]["3"][2] == pytest.approx(w, rel=1e-9)
    assert subs[1]["steps"][0]["displacements"]["4"][2] == 0.0


#: the cantilever with its tip grid's displacement frame (CD 5) turned 90 deg about x: CD 5's
#: z axis is basic -y and its y axis basic z (CORD2R: origin, a point on z, one in the xz plane)
ROTATED_TIP = (CANTILEVER
               .replace("GRID    4               3.0     0.0     0.0\n",
                        "GRID    4               3.0     0.0     0.0     5\n")
               .replace("ENDDATA", "CORD2R  5       0       0.0     0.0     0.0     0.0     "
                        "-1.0    0.0\n        1.0     0.0     0.0\nENDDATA"))


@pytest.mark.parametrize("rotated", [False, True], ids=["basic", "rotated CD"])
def test_load_option_is_the_closed_form_and_the_force_card(tmp_path, capsys, rotated):
    """``--load 4:T3=250`` (issue 46 item 7): one more subcase beside the deck's four,
    numbered 5 and labelled with the load; its tip deflection is P L^3 / (3 E I) (to 1e-9:
    exact for a nodal load with the cubic beam element) and equals SUBCASE 1's, the same load
    as a FORCE card with CID 0 (to 1e-12: the same load vector). The load is along the basic
    axes whatever the grid's CD frame: with the tip's CD turned 90 deg about x, T3 still
    bends the beam about its I2 axis in basic z (a CD-frame T3 would push along basic -y,
    about I1 = 2 I2, and leave basic z still). The JSON names the point loads and no LOAD."""
    out = tmp_path / "load.json"
    deck = _deck(tmp_path, text=ROTATED_TIP if rotated else CANTILEVER)
    rc, cap = _static(capsys, deck, "--load", "4:T3=250", "--json", out)
    assert rc == 0, cap.err
    assert "SUBCASE 5 (--load 4:T3=250): point loads along the basic axes, SPC 1" in cap.out
    subs = json.loads(out.read_text())["subcases"]
    assert [s["subcase"] for s in subs] == [1, 2, 3, 4, 5]
    extra = subs[-1]
    assert extra["load"] is None and extra["spc"] == 1 and extra["label"] == "--load 4:T3=250"
    assert extra["point_loads"] == [{"grid": 4, "component": "T3", "value": 250.0}]
    assert subs[0]["point_loads"] == []
    tip = _tip(extra)
    assert tip[2] == pytest.approx(P * L**3 / (3 * E * I2), rel=1e-9)
    assert tip == pytest.approx(_tip(subs[0]), rel=1e-12, abs=1e-15)
    assert abs(tip[1]) < 1e-12 * tip[2]


def test_load_option_nonlinear_and_on_a_modes_deck(tmp_path, capsys):
    """--nonlinear: the --load subcase is solved as the deck's (Newton, dead load, the same
    --steps) and its tip equals SUBCASE 1's FORCE card to 1e-10 (the same load, the same
    path), within 1e-3 of P L^3 / (3 E I) (the deflection is 0.5 % of L: the geometric
    change is of order (w/L)^2 ~ 3e-5). Two --load of one component add up. A SOL 103 deck
    (no static subcase of its own) solves the --load subcase alone, linear unless
    --nonlinear, and says so."""
    out = tmp_path / "nl.json"
    rc, cap = _static(capsys, _deck(tmp_path, sol=106, nlparm="NLPARM = 7"), "--load",
                      "4:T3=150", "--load", "4:t3=100", "--steps", "4", "--json", out)
    assert rc == 0, cap.err
    subs = json.loads(out.read_text())["subcases"]
    extra = subs[-1]
    assert extra["converged"] and len(extra["steps"]) == 4
    assert _tip(extra) == pytest.approx(_tip(subs[0]), rel=1e-10, abs=1e-14)
    assert _tip(extra)[2] == pytest.approx(P * L**3 / (3 * E * I2), rel=1e-3)
    modes = _deck(tmp_path, text=CANTILEVER.replace("SOL {sol}", "SOL 103"), name="m.bdf")
    rc, cap = _static(capsys, modes, "--load", "4:T3=250", "--json", tmp_path / "m.json")
    assert rc == 0, cap.err
    assert "SOL 103 is not a static solution: only the --load subcase is solved" in cap.out
    (only,) = json.loads((tmp_path / "m.json").read_text())["subcases"]
    assert only["subcase"] == 1 and only["spc"] is None
    assert _tip(only)[2] == pytest.approx(P * L**3 / (3 * E * I2), rel=1e-9)


BAD_LOADS = [
    ("unknown grid", ["--load", "99:T3=1"], "--load 99:T3=1: grid 99 not found in beam.bdf"),
    ("unknown component", ["--load", "4:T7=1"],
     "argument --load: 4:T7=1: COMPONENT: expected one of T1, T2, T3, R1, R2, R3, got 'T7'"),
    ("not a number", ["--load", "4:T3=abc"],
     "argument --load: 4:T3=abc: VALUE: expected a finite number"),
    ("not GRID:C=V", ["--load", "4T3=1"], "expected GRID:COMPONENT=VALUE"),
    ("constrained", ["--load", "1:T3=5"],
     "--load 1:T3=5: grid 1 component T3 is constrained (SPC1 1)"),
    ("constrained in its CD frame", ["--load", "4:T3=5"],
     "--load 4:T3=5: grid 4 component T2 of its displacement frame (CD), which basic T3 "
     "loads, is constrained (SPC1 1)"),
    ("with --aoa", ["--load", "4:T3=5", "--aoa", "2", "--velocity", "10"],
     "--load: for the deck's structural subcases"),
]


@pytest.fixture(scope="module")
def cli_server():
    """Real command lines in forked processes (tests/cli_forkserver.py: imports paid once)."""
    from .cli_forkserver import ForkServer

    server = ForkServer()
    yield server
    server.close()


@pytest.mark.parametrize("name, argv, message", BAD_LOADS, ids=[b[0] for b in BAD_LOADS])
def test_bad_load_option_is_one_line(tmp_path, cli_server, name, argv, message):
    """A bad --load, through the real command in a separate process: exit 2, one line naming
    the option and what was expected, no traceback, no JSON (the CD-frame case: the rotated
    tip held in its CD T2, which is basic z)."""
    text = CANTILEVER if "CD" not in name else ROTATED_TIP.replace(
        "SPC1    1       123456  1", "SPC1    1       123456  1\nSPC1    1       2       4")
    deck = _deck(tmp_path, text=text)
    out = tmp_path / "out.json"
    rc, stdout, err = cli_server.run(["static", str(deck), *argv, "--json", str(out)],
                                     tmp_path)
    assert rc == 2, stdout + err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("torchrom static: error: "), err
    assert message in lines[0], lines[0]
    assert not out.exists()
