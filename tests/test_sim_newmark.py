"""Newmark / HHT-α / generalised-α: linear systems against the exact matrix exponential,
second-order convergence, lag-state condensation, solvers, precision, bad cases."""

import math

import numpy as np
import pytest
import scipy.linalg as sla
import torch

from torchrom.errors import InputError
from torchrom.rom import NonlinearROM
from torchrom.rom.analytic import van_der_pol_duffing
from torchrom.sim import CaseSystem, LCOCriteria, Newmark

RUN_TO_END = LCOCriteria(stop=False)
SCHEMES = [("newmark", 1.0), ("hht", 0.8), ("generalized_alpha", 0.7)]


def _linear_model(n=4, na=3, seed=0):
    rng = np.random.default_rng(seed)
    A = rng.standard_normal((n, n))
    M = A @ A.T / n + np.eye(n)
    Bm = rng.standard_normal((n, n))
    K = Bm @ Bm.T + 5 * np.eye(n)
    lag = {"lag_D": 0.5 * rng.standard_normal((n, na)), "lag_E": 0.5 * rng.standard_normal((na, n)),
           "lag_R": -np.diag(np.linspace(1.0, 8.0, na))}
    x0 = {"q0": 0.1 * rng.standard_normal(n), "v0": 0.1 * rng.standard_normal(n),
          "xi0": 0.1 * rng.standard_normal(na)}
    load = rng.standard_normal(n)
    return M, K, lag, x0, load


def _exact(M, K, C, lag, x0, load, T):
    """q(T) of M q̈ + C q̇ + K q + D ξ = F, ξ̇ = E q̇ + R ξ by the matrix exponential of the
    augmented first-order system (the constant load rides in an extra unit state)."""
    n = len(M)
    na = 0 if lag is None else lag["lag_R"].shape[0]
    m = 2 * n + na
    Mi = np.linalg.inv(M)
    A = np.zeros((m + 1, m + 1))
    A[:n, n:2 * n] = np.eye(n)
    A[n:2 * n, :n] = -Mi @ K
    A[n:2 * n, n:2 * n] = -Mi @ C
    if na:
        A[n:2 * n, 2 * n:m] = -Mi @ lag["lag_D"]
        A[2 * n:m, n:2 * n] = lag["lag_E"]
        A[2 * n:m, 2 * n:m] = lag["lag_R"]
    A[n:2 * n, m] = Mi @ load
    x = np.concatenate([x0["q0"], x0["v0"], x0["xi0"][:na], [1.0]])
    return (sla.expm(A * T) @ x)[:n]


def _errors(scheme, rho, with_lag, dts, T=2.0):
    M, K, lag, x0, load = _linear_model()
    alpha, beta = 0.05, 2e-3  # Rayleigh damping C = α M + β K (γ = β with D̄1 = K1)
    rom = NonlinearROM(M, K)
    lagkw = lag if with_lag else {}
    exact = _exact(M, K, alpha * M + beta * K, lag if with_lag else None, x0, load, T)
    errs = []
    for dt in dts:
        system = CaseSystem.build(rom, 1, alpha=alpha, gamma=beta, load=load, **lagkw)
        res = Newmark(dt=dt, scheme=scheme, rho_inf=rho).run(
            system, x0["q0"], x0["v0"], x0["xi0"] if with_lag else None, t_end=T, lco=RUN_TO_END)
        assert res.steps[0] == round(T / dt)
        errs.append(np.abs(res.q[0] - exact).max() / np.abs(exact).max())
    return np.array(errs)


@pytest.mark.parametrize("scheme,rho", SCHEMES)
@pytest.mark.parametrize("with_lag", [False, True], ids=["rayleigh", "lag_states"])
def test_linear_second_order_against_matrix_exponential(scheme, rho, with_lag):
    """Linear MDOF with Rayleigh damping, a constant load and (optionally) three first-order lag
    states: the error at t = 2 s against expm of the augmented system falls as dt² — measured
    order within ±0.1 of 2 over dt = 0.02, 0.01, 0.005 (ω_max dt ≤ 0.07: asymptotic range)."""
    errs = _errors(scheme, rho, with_lag, [0.02, 0.01, 0.005])
    orders = np.log2(errs[:-1] / errs[1:])
    assert np.all(np.abs(orders - 2.0) < 0.1), (errs, orders)
    # and the solution is actually close (not just converging): relative error < 1e-3 at dt 0.005
    assert errs[-1] < 1e-3


def test_newmark_is_exact_for_a_static_load():
    """The trapezoidal rule reproduces a constant state exactly: starting at the static solution
    K q = F the response stays there to rounding (an independent check of the load path)."""
    M, K, lag, x0, load = _linear_model()
    rom = NonlinearROM(M, K)
    q_static = np.linalg.solve(K, load)
    system = CaseSystem.build(rom, 1, alpha=0.1, gamma=1e-3, load=load)
    res = Newmark(dt=0.01).run(system, q_static, t_end=1.0, lco=RUN_TO_END)
    assert np.abs(res.q[0] - q_static).max() < 1e-13 * np.abs(q_static).max() * 100


def test_undamped_newmark_conserves_energy_and_has_trapezoidal_period():
    """Average acceleration has no numerical dissipation and a period elongation
    ω_h dt = 2 atan(ω dt / 2): a single undamped oscillator over 50 periods."""
    w, dt = 2 * math.pi, 0.02
    rom = NonlinearROM([[1.0]], [[w * w]])
    system = CaseSystem.build(rom, 1)
    res = Newmark(dt=dt, check_every=1000).run(system, [1.0], t_end=50.0, outputs=["q1"],
                                               lco=LCOCriteria(rtol=1e-5))
    assert res.status[0] == "lco"
    # the peaks are refined by cubic Hermite interpolation: error ≈ (ω dt)⁴/384 = 6e-7
    assert abs(res.amplitude[0, 0] - 1.0) < 2e-6
    # and so are the extremum times (jitter ≈ 1e-6 s, then a least-squares fit over 5 periods);
    # 2 atan(x/2)/x = 1 − x²/12 + ... is 1.3e-3 below 1 here, so the test can tell them apart
    f_expected = 2 * math.atan(w * dt / 2) / dt / (2 * math.pi)
    assert abs(res.frequency_hz[0] / f_expected - 1) < 1e-5
    assert abs(res.frequency_hz[0] - 1.0) > 1e-3


def _amplification_radius(p, wdt):
    """Spectral radius of the one-step map of M a + K q = 0 (state q, v dt, a dt²), written
    out from the scheme's definition (independent of the integrator code)."""
    A = np.zeros((3, 3))
    for k in range(3):
        q0, v0, a0 = np.eye(3)[k]
        qp = q0 + v0 + (0.5 - p.beta) * a0
        a1 = -(p.alpha_m * a0 + wdt**2 * ((1 - p.alpha_f) * qp + p.alpha_f * q0)) / (
            (1 - p.alpha_m) + wdt**2 * (1 - p.alpha_f) * p.beta)
        A[:, k] = [qp + p.beta * a1, v0 + (1 - p.gamma) * a0 + p.gamma * a1, a1]
    return float(np.abs(np.linalg.eigvals(A)).max())


@pytest.mark.parametrize("scheme,rho", SCHEMES)
def test_numerical_dissipation_matches_the_amplification_matrix(scheme, rho):
    """A mode with ω dt = 31 decays per step by the spectral radius of the scheme's one-step
    map (→ ρ∞ as ω dt → ∞; 1 for Newmark: no numerical dissipation). Measured over steps
    40..80 (after the transient of the non-normal map) to 1 % of the computed radius."""
    w, dt = 2 * math.pi * 500.0, 0.01
    rom = NonlinearROM([[1.0]], [[w * w]])
    system = CaseSystem.build(rom, 1)
    integ = Newmark(dt=dt, scheme=scheme, rho_inf=rho)
    norms = []
    for steps in (40, 80):
        res = integ.run(system, [1.0], t_end=steps * dt, lco=RUN_TO_END)
        norms.append(math.hypot(res.q[0, 0], res.v[0, 0] / w))
    rate = (norms[1] / norms[0]) ** (1 / 40)
    radius = _amplification_radius(integ.params, w * dt)
    assert abs(rate / radius - 1) < 0.01, (rate, radius)
    if scheme == "newmark":
        assert radius == pytest.approx(1.0, abs=1e-12)
    else:
        assert radius < 0.9


def test_fixed_point_and_newton_reach_the_same_solution():
    """Both solvers converge to the solution of the same discrete equations: a nonlinear
    Van der Pol–Duffing oscillator agrees to 1e-11 after 1000 steps (with enough iterations)."""
    rom = van_der_pol_duffing(1.0, c1=-0.2, d3=0.5, k3=3.0)
    system = CaseSystem.build(rom, 2, gamma=1.0)
    q0 = [[0.5], [1.5]]
    kw = {"dt": 2e-3, "iterations": 6, "tol": 1e-10}
    a = Newmark(solver="newton", **kw).run(system, q0, t_end=2.0, lco=RUN_TO_END)
    b = Newmark(solver="fixed_point", **kw).run(system, q0, t_end=2.0, lco=RUN_TO_END)
    assert np.abs(a.q - b.q).max() < 1e-11
    assert (a.solver_error < 1e-10).all() and (b.solver_error < 1e-10).all()


def test_fixed_point_diverges_when_dt_is_too_large_for_the_stiffest_mode():
    """The paper's fixed-point iteration contracts only if β dt² ω_max² < 1: a 100 Hz mode at
    dt = 0.01 (β dt² ω² ≈ 10) is reported 'unconverged', modified Newton is fine."""
    rom = van_der_pol_duffing([1.0, 100.0], c1=-0.1, d3=0.5, k3=1.0)
    system = CaseSystem.build(rom, 1, gamma=1.0)
    fp = Newmark(dt=0.01, solver="fixed_point").run(system, [0.1, 0.0], t_end=1.0)
    nt = Newmark(dt=0.01).run(system, [0.1, 0.0], t_end=1.0)
    assert fp.status[0] == "unconverged"
    assert nt.status[0] != "unconverged" or nt.solver_error[0] < 1e-8


def test_contraction_ratio_estimate_matches_observed_convergence():
    """ρ ≈ ‖S⁻¹(β dt² ∂f/∂q + γ dt ∂f/∂q̇)‖ predicts how fast the corrections shrink: with one
    more iteration the reported error estimate falls by about ρ (factor-3 agreement; the
    estimate is a spectral radius at one state, the observation a maximum over an interval)."""
    rom = van_der_pol_duffing(1.0, c1=-0.5, d3=2.0, k3=400.0)
    system = CaseSystem.build(rom, 1, gamma=1.0)
    integ = Newmark(dt=0.02, iterations=3, tol=1.0)
    q = torch.tensor([[1.0]], dtype=torch.float64)
    v = torch.tensor([[6.0]], dtype=torch.float64)
    rho = float(integ.contraction_ratio(system, q, v)[0])
    assert 1e-3 < rho < 0.5
    err = []
    for iters in (3, 4):
        res = Newmark(dt=0.02, iterations=iters, tol=1.0, check_every=20).run(
            system, [1.0], t_end=0.4, lco=RUN_TO_END)
        err.append(res.solver_error[0])
    observed = err[1] / err[0]
    assert rho / 3 < observed < rho * 3, (rho, observed)


def test_float32_agrees_with_float64():
    """float32 runs the same algorithm: an LCO amplitude within 1e-4 relative of float64
    (float32 rounding ≈ 6e-8 per step accumulates over 10^4 steps in the phase, not the
    amplitude, which is attracted to the limit cycle)."""
    rom = van_der_pol_duffing(1.0, c1=-1.0, d3=0.8, k3=2.0)
    amps = []
    for dtype in (torch.float64, torch.float32):
        system = CaseSystem.build(rom, 1, gamma=1.0, dtype=dtype)
        res = Newmark(dt=0.005, iterations=3).run(system, [2.0], t_end=100.0, outputs=["q1"])
        assert res.status[0] == "lco"
        amps.append(res.amplitude[0, 0])
    assert abs(amps[1] / amps[0] - 1) < 1e-4


def _stiff_lag_cases():
    """Three cases of a two-mode Van der Pol–Duffing system with a strongly hardening first mode
    (k3 = 400: at the LCO the nonlinear tangent stiffness is several times the linear one, so
    the linear iteration matrix is a poor Jacobian at dt = 0.01) and one lag state each."""
    rom = van_der_pol_duffing([1.0, 2.7], c1=[-0.5, 0.3], d3=[2.0, 1.0], k3=[400.0, 50.0],
                              coupling=[[0.0, 20.0], [20.0, 0.0]])
    k = torch.tensor([1.0, 2.0, 3.0], dtype=torch.float64).view(3, 1, 1)
    lag_D = k * torch.tensor([[0.5], [0.2]], dtype=torch.float64)
    lag_E = torch.tensor([[[1.0, 0.0]]], dtype=torch.float64).expand(3, 1, 2)
    return CaseSystem.build(rom, 3, gamma=[0.5, 1.0, 2.0], lag_D=lag_D, lag_E=lag_E,
                            lag_R=-2.0 * k)


def _stiff_lag_run(**kw):
    return Newmark(dt=0.01, **kw).run(_stiff_lag_cases(), [[0.5, 0.0]] * 3, t_end=10.0,
                                      outputs=["q1"], lco=RUN_TO_END)


def test_refreshed_iteration_matrix_against_a_converged_reference():
    """Two corrections per step with the iteration matrix refreshed with the tangent of the
    nonlinear forces every 16 steps (the default) reproduce the amplitude of the discrete
    solution solved to 1e-12 (8 modified-Newton iterations) to 1e-4 relative (measured
    4e-6–1e-5 on the last period), 1.7–7x closer than the same two corrections on the linear
    iteration matrix. Their
    estimated error (about 1e-4 of |a|, a bound: the amplitude moves far less) passes a loose
    tolerance and is flagged by a tight one."""
    ref = _stiff_lag_run(iterations=8, refresh_every=0, tol=1.0)
    assert (ref.solver_error < 1e-12).all()
    amp = ref.last_amplitude[:, 0]
    fast = _stiff_lag_run(iterations=2, tol=1e-3)
    err_fast = np.abs(fast.last_amplitude[:, 0] / amp - 1)
    assert (err_fast < 1e-4).all(), err_fast
    assert (fast.solver_error < 1e-3).all() and (fast.steps == 1000).all()
    stale = _stiff_lag_run(iterations=2, refresh_every=0, tol=1.0)
    err_stale = np.abs(stale.last_amplitude[:, 0] / amp - 1)
    assert (err_stale > 1.5 * err_fast).all(), (err_stale, err_fast)
    tight = _stiff_lag_run(iterations=2, tol=1e-7)
    # flagged: the estimate exceeds tol; a case flagged at the first check stops there
    assert (tight.status == "unconverged").all() and (tight.solver_error > 1e-7).all()
    assert tight.steps.min() == 500


def test_single_iteration_error_estimate_uses_the_sampled_contraction_ratio():
    """One correction per step: the error left is its size times r/(1−r), r measured on every
    16th step (which iterates twice). The estimate flags these cases at the default tolerance,
    and without sampling (r = ½ assumed: the correction itself) it is larger still."""
    sampled = _stiff_lag_run(iterations=1)  # default tol 1e-6
    assert (sampled.status == "unconverged").all() and (sampled.solver_error > 1e-6).all()
    rough = _stiff_lag_run(iterations=1, sample_every=0, tol=1.0)
    measured = _stiff_lag_run(iterations=1, tol=1.0)
    assert (measured.solver_error > 1e-6).all()
    assert (rough.solver_error > measured.solver_error).all()


def test_cuda_graph_code_path_on_cpu_is_the_eager_result():
    """cuda_graphs=True on a CPU runs the steps that a CUDA graph captures (state updated in
    place in static tensors) eagerly: bitwise the functional path, including the refreshes of
    the iteration matrix, the sampled steps and cases leaving the batch (LCO stop)."""
    system = _stiff_lag_cases()
    kw = {"t_end": 20.0, "outputs": ["q1"], "lco": LCOCriteria(rtol=1e-2)}
    for iterations in (1, 2):
        a = Newmark(dt=0.01, iterations=iterations, tol=1.0).run(system, [[0.5, 0.0]] * 3, **kw)
        b = Newmark(dt=0.01, iterations=iterations, tol=1.0, cuda_graphs=True).run(
            system, [[0.5, 0.0]] * 3, **kw)
        assert np.array_equal(a.q, b.q) and np.array_equal(a.xi, b.xi)
        assert list(a.status) == list(b.status) and np.array_equal(a.steps, b.steps)
        assert np.array_equal(a.solver_error, b.solver_error)


def test_singular_case_fails_alone():
    """A case whose mass matrix is singular is 'failed' at the start; the others run."""
    rom = NonlinearROM([[1.0]], [[4.0]])
    M_add = torch.tensor([[[0.0]], [[-1.0]], [[0.0]]], dtype=torch.float64)
    system = CaseSystem.build(rom, 3, alpha=0.1, M_add=M_add)
    res = Newmark(dt=0.01).run(system, [1.0], t_end=1.0, lco=RUN_TO_END)
    assert list(res.status) == ["unconverged", "failed", "unconverged"]
    assert res.steps[1] == 0 and res.steps[0] == 100


def test_bad_inputs_name_the_parameter():
    with pytest.raises(InputError, match="integrator.scheme"):
        Newmark(scheme="leapfrog")
    with pytest.raises(InputError, match="integrator.dt"):
        Newmark(dt=-1.0)
    with pytest.raises(InputError, match="rho_inf"):
        Newmark(scheme="hht", rho_inf=0.2)
    with pytest.raises(InputError, match="integrator.refresh_every"):
        Newmark(refresh_every=-1)
    with pytest.raises(InputError, match="integrator.sample_every"):
        Newmark(sample_every=1.5)
    with pytest.raises(InputError, match="integrator.cuda_graphs"):
        Newmark(cuda_graphs="always")
    rom = NonlinearROM([[1.0]], [[4.0]])
    with pytest.raises(InputError, match="CaseSystem.K_add"):
        CaseSystem.build(rom, 2, K_add=torch.zeros(3, 1, 1))
    system = CaseSystem.build(rom, 2)
    with pytest.raises(InputError, match="q0"):
        Newmark().run(system, torch.zeros(3, 1), t_end=1.0)
    with pytest.raises(InputError, match="not an output"):
        Newmark().run(system, [0.0], t_end=1.0, outputs=["tip"])


@pytest.mark.slow
def test_compiled_step_matches_eager():
    """torch.compile of the step (opt-in; needs a C compiler, ~30–60 s to compile on CPU) gives
    the eager result to rounding. The eager path, tested everywhere above, is the same code."""
    rom = van_der_pol_duffing([1.0, 1.7], c1=[-0.5, 0.1], d3=1.0, k3=[3.0, 1.0],
                              coupling=[[0.0, 2.0], [2.0, 0.0]])
    system = CaseSystem.build(rom, 3, gamma=[0.5, 1.0, 2.0])
    kw = {"t_end": 5.0, "lco": RUN_TO_END}
    eager = Newmark(dt=0.01).run(system, [0.3, 0.0], **kw)
    compiled = Newmark(dt=0.01, compile=True).run(system, [0.3, 0.0], **kw)
    assert np.abs(compiled.q - eager.q).max() < 1e-12 * np.abs(eager.q).max()


# -- error-controlled steps and amplitude jumps ------------------------------------------------
def _vdp_cases():
    """Van der Pol oscillators at 1 Hz: LCO amplitude 2√(−c1/d3) by first-order averaging
    (observed within 2e-4 for these |c1|/ω ≤ 0.05), started at half of it."""
    c1 = -np.array([0.05, 0.1, 0.2, 0.3])
    d3 = np.array([0.5, 1.0, 2.0, 1.0])
    rom = van_der_pol_duffing(1.0, c1=0.0, d3=1.0, k3=1.0)
    return CaseSystem.build(rom, alpha=c1, gamma=d3, stiffness_nl=0.0), 2 * np.sqrt(-c1 / d3)


def _adaptive_run(step_tol):
    system, amp = _vdp_cases()
    integ = Newmark(dt=0.002, iterations=3, tol=1e-6, adaptive=True, step_tol=step_tol,
                    check_every=100, dt_max=0.1)
    res = integ.run(system, q0=amp[:, None] * 0.5, t_end=300.0, outputs=["q1"],
                    lco=LCOCriteria(rtol=1e-4, cycles=4))
    assert (res.status == "lco").all()
    return res, amp


def test_error_controlled_steps_keep_the_closed_form_amplitude():
    res, amp = _adaptive_run(1e-4)
    # tolerance: averaging (2e-4) + the LCO criterion (rtol 1e-4 per cycle, extrapolated)
    np.testing.assert_allclose(res.amplitude[:, 0], amp, rtol=1e-3)
    # the average-acceleration period error (ω dt)²/12 at the chosen steps: below 0.1 %
    np.testing.assert_allclose(res.frequency_hz, 1.0, rtol=1e-3)
    # the step grew from 2 ms (fewer than a fifth of the steps at 2 ms), and each case took
    # its own: equal step counts per interval, different simulated times
    assert (res.steps < 0.2 * res.time / 0.002).all()
    assert len(np.unique(np.round(res.time / res.steps, 6))) > 1


def test_step_tolerance_controls_the_frequency_error():
    # the weakest case (c1 = −0.05: its own frequency shift by averaging, −(c1/ω)²/16 ≈ 4e-6,
    # is far below the integration error)
    errors = [abs(_adaptive_run(tol)[0].frequency_hz[0] - 1.0) for tol in (1e-4, 1e-5)]
    # local error ∝ dt³: 10x tighter -> dt / 10^(1/3), period error (∝ dt²) / 4.6
    assert errors[1] < errors[0] / 3


def test_adaptive_options_are_checked():
    with pytest.raises(InputError, match="integrator.step_tol"):
        Newmark(adaptive=True, step_tol=0.0)
    with pytest.raises(InputError, match="integrator.dt_min, dt_max"):
        Newmark(dt=1e-3, dt_min=2e-3)
    with pytest.raises(InputError, match="integrator.extrapolate"):
        Newmark(extrapolate=-1)


def test_amplitude_jumps_reach_the_same_lco_sooner():
    # weakly attracting LCOs (the amplitude approaches its limit by a factor of about e^(c1)
    # per cycle: 0.95 at c1 = −0.05) started at half their amplitude
    system, amp = _vdp_cases()
    lco = LCOCriteria(rtol=1e-4, cycles=4)
    runs = [Newmark(dt=0.005, iterations=3, tol=1e-6, check_every=200, extrapolate=k).run(
        system, q0=amp[:, None] * 0.5, t_end=300.0, outputs=["q1"], lco=lco) for k in (0, 3)]
    assert all((r.status == "lco").all() for r in runs)
    np.testing.assert_allclose(runs[1].amplitude[:, 0], amp, rtol=1e-3)
    assert runs[1].time.sum() < 0.5 * runs[0].time.sum()
