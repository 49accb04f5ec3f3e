"""Physics of the 2-DOF arm (spec/models.md, thesis eq. 2.2-2.3, 4.7)."""

from __future__ import annotations

import numpy as np
import pytest

from simgap.models import manipulator as man
from simgap.models.friction import FRICTION_MODELS
from simgap.models.integrators import rk4

P = man.ManipulatorParams()
LA = P.array


def _random_states(n: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    return rng.uniform(-np.pi, np.pi, size=(n, 2)), rng.uniform(-3.0, 3.0, size=(n, 2))


@pytest.mark.parametrize("params", [P, man.ManipulatorParams(payload=0.7,
                                                             extra_inertia=(0.01, 0.02))])
def test_mass_matrix_symmetric_positive_definite(params):
    la = params.array
    qs, _ = _random_states(200, seed=1)
    for q in qs:
        m = man.mass_matrix(q, la)
        assert m[0, 1] == m[1, 0]
        assert np.linalg.eigvalsh(m).min() > 1e-3  # kg·m², well away from singular


def test_mass_matrix_matches_spec_formula():
    q = np.array([0.3, 1.1])
    m, ll, lc, i, im = P.m, P.l, P.lc, P.I, P.Im
    c2 = np.cos(q[1])
    m11 = m * lc**2 + i + m * (ll**2 + lc**2 + 2 * ll * lc * c2) + i + im
    m12 = m * (lc**2 + ll * lc * c2) + i
    m22 = m * lc**2 + i + im
    np.testing.assert_allclose(man.mass_matrix(q, LA), [[m11, m12], [m12, m22]], rtol=1e-14)


def test_mdot_minus_2c_is_skew_symmetric():
    qs, dqs = _random_states(100, seed=2)
    h = 1e-6
    for q, dq in zip(qs, dqs, strict=True):
        mdot = (man.mass_matrix(q + h * dq, LA) - man.mass_matrix(q - h * dq, LA)) / (2 * h)
        n = mdot - 2.0 * man.coriolis_matrix(q, dq, LA)
        assert np.abs(n + n.T).max() < 1e-8, n  # entries of order 0.1 kg·m²/s
    # and the check has teeth: C alone is not skew
    q, dq = qs[0], dqs[0]
    c = man.coriolis_matrix(q, dq, LA)
    assert np.abs(c + c.T).max() > 1e-3


def test_gravity_is_gradient_of_potential():
    qs, _ = _random_states(100, seed=3)
    h = 1e-6
    for q in qs:
        grad = np.array([(man.potential_energy(q + h * e, LA) - man.potential_energy(q - h * e, LA))
                         / (2 * h) for e in np.eye(2)])
        np.testing.assert_allclose(man.gravity_vector(q, LA), grad, atol=1e-7)


def _energy(s: np.ndarray, la: np.ndarray) -> float:
    q, dq = s[:2], s[2:]
    return 0.5 * dq @ man.mass_matrix(q, la) @ dq + man.potential_energy(q, la)


def test_energy_conserved_without_friction_and_input():
    """No friction, u = 0: total energy drifts < 1e-6 (relative) over 10 s."""
    theta = man.plant_array(P, friction=None)
    s = np.array([0.4, 1.2, 2.0, -3.0])
    u = np.zeros(2)
    # energy above the lowest-potential configuration: a non-degenerate scale (J)
    v_min = -((P.m * P.lc + P.m * P.l) * P.g + P.m * P.lc * P.g)
    e0 = _energy(s, LA)
    scale = e0 - v_min
    drift = 0.0
    for _ in range(5000):  # 10 s at dt = 2 ms, 20 RK4 sub-steps each
        s = man.plant_step(s, u, theta, 0.002, 20)
        drift = max(drift, abs(_energy(s, LA) - e0))
    assert np.abs(s[2:]).max() > 1.0  # it really moved
    assert drift / scale < 1e-6, drift / scale


def test_energy_not_conserved_with_friction():
    """The same check fails when friction is on (the energy test can fail)."""
    theta = man.plant_array(P, friction=FRICTION_MODELS["thesis"])
    s = np.array([0.4, 1.2, 2.0, -3.0])
    e0 = _energy(s, LA)
    for _ in range(500):
        s = man.plant_step(s, np.zeros(2), theta, 0.002, 20)
    assert e0 - _energy(s, LA) > 1e-2  # J dissipated


def test_nominal_f_agrees_with_qdq_dynamics_via_momentum():
    """Eq. 2.3: d/dt [q; M(q) dq] along the rigid-body motion equals the nominal f(q, p)."""
    theta = man.plant_array(P, friction=None)
    nominal = man.ManipulatorNominal(P)
    rng = np.random.default_rng(4)
    h = 1e-5
    for _ in range(20):
        s = np.concatenate([rng.uniform(-np.pi, np.pi, 2), rng.uniform(-2, 2, 2)])
        u = rng.uniform(-5, 5, 2)
        s_plus = man.plant_step(s, u, theta, h, 1)
        s_minus = man.plant_step(s, u, theta, -h, 1)
        xdot_fd = (nominal.state(s_plus) - nominal.state(s_minus)) / (2 * h)
        np.testing.assert_allclose(nominal.f(nominal.state(s), u), xdot_fd, rtol=1e-6, atol=1e-6)


def test_nominal_plus_zero_residual_reproduces_itself():
    """Plant = nominal (no friction): true_residual is 0 and integrating f in (q, p) follows
    the plant trajectory."""
    theta = man.plant_array(P, friction=None)
    nominal = man.ManipulatorNominal(P)
    rng = np.random.default_rng(5)
    for _ in range(50):
        s = np.concatenate([rng.uniform(-np.pi, np.pi, 2), rng.uniform(-3, 3, 2)])
        u = rng.uniform(-20, 20, 2)
        np.testing.assert_allclose(man.true_residual(s, u, theta, LA), 0.0, atol=1e-12)
    s = np.array([0.7, 1.5, 0.5, -0.4])
    x = nominal.state(s)
    u = np.array([1.5, -0.7])
    for _ in range(500):
        s = man.plant_step(s, u, theta, 0.002, 20)
        x = rk4(man.nominal_derivative, x, u, LA, 0.002, 20)
    np.testing.assert_allclose(nominal.observation(x), s, atol=1e-9)


def test_true_residual_is_minus_friction_torque():
    fr = FRICTION_MODELS["thesis"]
    theta = man.plant_array(P, friction=fr)
    rng = np.random.default_rng(6)
    for _ in range(50):
        s = np.concatenate([rng.uniform(-np.pi, np.pi, 2), rng.uniform(-3, 3, 2)])
        u = rng.uniform(-20, 20, 2)
        g = man.true_residual(s, u, theta, LA)
        tau = 0.1 * np.tanh(s[2:] / 6.67e-4) + 0.5 * s[2:]  # eq. 4.7, Table 4.2
        np.testing.assert_allclose(g[2:], -tau, atol=1e-10)
        np.testing.assert_allclose(g[:2], 0.0)


def test_true_residual_with_other_rigid_body_is_not_friction_only():
    true = man.ManipulatorParams(payload=0.5)
    theta = man.plant_array(true, friction=None)
    s = np.array([0.3, 0.8, 0.4, -0.2])
    g = man.true_residual(s, np.array([1.0, 0.5]), theta, LA)
    assert np.abs(g[2:]).max() > 0.1  # N·m: the payload's gravity and inertia show up


def test_nominal_state_observation_roundtrip():
    nominal = man.ManipulatorNominal()
    obs = np.array([0.2, -1.0, 0.7, 1.9])
    np.testing.assert_allclose(nominal.observation(nominal.state(obs)), obs, atol=1e-14)
    assert nominal.physical_residual(nominal.state(obs), np.array([0, 0, 1.0, -2.0])).tolist() \
        == [-1.0, 2.0]
