"""SOL 200 decks: the cards must agree with their design relations at the initial design.

Reference: Nastran's SOL 200 analyses the value C0 + Σ COEFF·XINIT of a DVPREL1/DVMREL1 field;
a deck whose card says otherwise is refused (one line), one that agrees is read, and outside
SOL 200 the design cards change nothing. The equation relations are noted, not evaluated.
"""

from __future__ import annotations

import pytest

from torchrom.errors import InputError

from .fe_decks import model_of, new_deck


def _plate(sol: int, t_design: float, e_design: float | None = None):
    m = new_deck()
    m.sol = sol
    m.add_mat1(1, 7.0e10, None, 0.3, rho=2700.0)
    for k, (x, y) in enumerate([(0, 0), (1, 0), (1, 1), (0, 1)]):
        m.add_grid(k + 1, [float(x), float(y), 0.0])
    m.add_pshell(9, mid1=1, t=0.01, mid2=1)
    m.add_cquad4(1, 9, [1, 2, 3, 4])
    m.add_spc1(1, "123456", [1, 4])
    m.add_desvar(1, "T", t_design / 2.0)
    m.add_dvprel1(11, "PSHELL", 9, "T", [1], [2.0])
    if e_design is not None:
        m.add_desvar(2, "E", e_design)
        m.add_dvmrel1(21, "MAT1", 1, "E", [2], [1.0])
    return m


def test_sol200_cards_that_agree_with_the_design_are_read():
    fe = model_of(_plate(200, 0.01, 7.0e10))
    assert fe.n_dof > 0


@pytest.mark.parametrize("t, e, message", [
    (0.012, None, r"SOL 200: DVPREL1 11: PSHELL 9 T is 0\.012 at the initial design .*card has "
                  r"0\.01"),
    (0.01, 7.2e10, r"SOL 200: DVMREL1 21: MAT1 1 E is 7\.2e\+10 at the initial design"),
])
def test_sol200_cards_that_disagree_are_refused(t, e, message):
    with pytest.raises(InputError, match=message):
        model_of(_plate(200, t, e))


def test_design_cards_outside_sol200_change_nothing():
    assert model_of(_plate(103, 0.012)).n_dof == model_of(_plate(103, 0.01)).n_dof


def test_equation_relations_are_noted():
    m = _plate(200, 0.01)
    m.add_deqatn(5, ["F(A) = 2.0 * A"])
    m.add_dvprel2(12, "PSHELL", 9, "T", 5, dvids=[1])
    notes = model_of(m).notes
    assert any(n.startswith("DVPREL2 12 (PSHELL 9 T): equation relation not evaluated")
               for n in notes)
