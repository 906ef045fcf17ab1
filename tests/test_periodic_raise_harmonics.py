"""torchrom.periodic.raise_harmonics: refused harmonic-balance rows re-solved at more harmonics.

The re-solve from an orbit cut to its first harmonic is checked against a second method: the
harmonic balance solved from its cold start directly at the raised H (HarmonicBalanceMethod
with harmonics = max_harmonics = H). Both solve the same equations at the same H to Newton's
tolerance, so the amplitudes and frequencies agree to ~1e-8 relative (asserted 1e-6: the
two Newton runs stop at different residuals below their tolerance).
"""

from __future__ import annotations

import dataclasses

import numpy as np
import torch

from torchrom.periodic import HarmonicBalanceMethod
from torchrom.periodic.fourier import resize_harmonics
from torchrom.periodic.raise_harmonics import raise_rows, raised_harmonics
from torchrom.periodic.solve import HBOptions, orbit_amplitude
from torchrom.sim import LCOCriteria
from torchrom.study.cases import case_system

from .aeroelastic_fixtures import section_model

OUTPUTS = ["A_Tz", "A_Ty"]


def test_raised_harmonics_doubles_plus_one_up_to_the_cap():
    assert list(raised_harmonics(np.array([1, 3, 9, 13, 27]), 27)) == [3, 7, 19, 27, 27]
    # a cap below H leaves H (nothing is lowered); cap 0: nothing is raised
    assert list(raised_harmonics(np.array([9]), 5)) == [9]
    assert list(raised_harmonics(np.array([5]), 0)) == [5]


def _cut_orbits(H: int):
    model = section_model()
    cases = [{"altitude_ft": 6000.0, "gamma": g, "alpha": 0.05} for g in (0.0, 1e-4)]
    system = case_system(model, cases)[0].to(dtype=torch.float64)
    C = np.stack([model.rom.outputs[o] for o in OUTPUTS])
    lco = LCOCriteria(max_amplitude=10.0)
    res = HarmonicBalanceMethod().run(system, outputs=OUTPUTS, lco=lco)
    X, w = res.orbits
    cut = resize_harmonics(resize_harmonics(torch.as_tensor(X), 1), (X.shape[1] - 1) // 2)
    amp = orbit_amplitude(cut @ torch.as_tensor(C).T, res.status)
    extra = {**res.extra, "harmonics": np.ones_like(res.extra["harmonics"])}
    bad = dataclasses.replace(res, orbits=(cut.numpy(), w), amplitude=amp, extra=extra)
    direct = HarmonicBalanceMethod(options=HBOptions(start_harmonics=3, harmonics=H,
                                                     max_harmonics=H)
                                   ).run(system, outputs=OUTPUTS, lco=lco)
    return system, C, bad, direct


def test_a_cut_orbit_re_solved_at_h_is_the_orbit_solved_at_h():
    system, C, bad, direct = _cut_orbits(7)
    assert list(direct.extra["harmonics"]) == [7, 7]
    out, kept = raise_rows(system, bad, np.arange(2), C, 0, 7)
    assert list(kept) == [0, 1]
    assert list(out.extra["harmonics"]) == [3, 3]  # 2H + 1 from H = 1
    out, kept = raise_rows(system, out, kept, C, 0, 7)
    assert list(out.extra["harmonics"]) == [7, 7]
    np.testing.assert_allclose(out.amplitude, direct.amplitude, rtol=1e-6)
    np.testing.assert_allclose(out.frequency_hz, direct.frequency_hz, rtol=1e-6)
    # the stability columns are those of the new orbit (the same monodromy as the direct one's)
    np.testing.assert_allclose(out.extra["floquet_multiplier"].astype(float),
                               direct.extra["floquet_multiplier"].astype(float), rtol=1e-4)
    assert list(out.extra["stable"]) == list(direct.extra["stable"])
    # at the cap nothing more is raised
    again, kept = raise_rows(system, out, np.arange(2), C, 0, 7)
    assert kept.size == 0 and again is out
