"""The update law (eq. 3.6-3.7), error signals (eq. 3.8, 3.9, 4.6), observer (eq. 3.1 with
the errata's sign) and baseline 2's SGD (eq. 4.2-4.4), against independent implementations."""

from __future__ import annotations

import numpy as np
import pytest

from simgap.identifiers import IdentifierConfig, make_identifier, preset


def _numpy_observer_step(W, V, x_hat, z, x, u, f, cfg, dt, kind):  # noqa: N803
    """Eq. 3.1 (corrected), 3.6-3.9, 4.1/4.5/4.6 written out with matrices."""
    n = x.size
    a_d = cfg.a_d * np.eye(n)
    xb = np.concatenate([x_hat, u])
    s = np.tanh(V @ xb)
    g = W @ s
    xt = x - x_hat
    e = xt if kind == "instantaneous" else z
    lam_mat = np.diag(s ** 2)
    row = e @ np.linalg.inv(a_d)  # eᵀ A_d⁻¹ (row vector)
    w_dot = -cfg.eta1 * np.outer(row, s) - cfg.rho1 * np.linalg.norm(xt) * W
    v_dot = (-cfg.eta2 * np.outer(row @ W @ (np.eye(s.size) - lam_mat), xb)
             - cfg.rho2 * np.linalg.norm(xt) * V)
    z_next = z + dt * (-cfg.lam * z + xt)
    x_hat_next = x_hat + dt * (f + g - a_d @ (x - x_hat))
    return W + dt * w_dot, V + dt * v_dot, x_hat_next, z_next, g


@pytest.mark.parametrize("kind", ["instantaneous", "integral"])
def test_observer_update_matches_matrix_form(kind):
    rng = np.random.default_rng(1)
    cfg = preset("manipulator", kind).replace(w0_scale=0.5, v0_scale=0.5)
    dt = 0.002
    ident = make_identifier(kind, 4, 2, dt, config=cfg, seed=3)
    W, V = ident.W, ident.V  # noqa: N806
    x_hat = rng.normal(size=4)
    z = np.zeros(4)
    ident.reset_observer(x_hat)
    for _ in range(5):
        x, u, f, xn = rng.normal(size=4), rng.normal(size=2), rng.normal(size=4), \
            rng.normal(size=4)
        W, V, x_hat, z, g_ref = _numpy_observer_step(W, V, x_hat, z, x, u, f, cfg, dt, kind)  # noqa: N806
        g = ident.step(x, u, f, xn)
        np.testing.assert_allclose(g, g_ref, rtol=1e-12, atol=1e-14)
        np.testing.assert_allclose(ident.W, W, rtol=1e-12, atol=1e-14)
        np.testing.assert_allclose(ident.V, V, rtol=1e-12, atol=1e-14)
        np.testing.assert_allclose(ident.x_hat, x_hat, rtol=1e-12, atol=1e-14)
        np.testing.assert_allclose(ident.z, z if kind == "integral" else 0.0, rtol=1e-12,
                                   atol=1e-14)
        np.testing.assert_allclose(ident.x_tilde, xn - x_hat, rtol=1e-12, atol=1e-14)


@pytest.mark.parametrize("kind", ["instantaneous", "integral"])
def test_normalised_observer_step_matches_matrix_form(kind):
    """Bound-normalised steps (the auto preset's): k1' = k1/(1 + ‖σ‖²) and
    k2' = k2/(‖x̄‖² (‖Ŵ D‖_F² + c_e² d²)), D = I − Λ, written out with matrices; d² = ‖δ‖²
    for baseline 1 and max(‖δ‖², ‖x̃‖²/(a_d λ)²) for the integral law."""
    from simgap.identifiers.config import error_scale

    rng = np.random.default_rng(4)
    dt = 0.01
    cfg = preset("auto", kind, dt=dt).replace(scale_rate=0.0, w0_scale=0.5, init="uniform",
                                              v0_scale=0.8)
    ce = error_scale(kind, cfg, dt)
    ident = make_identifier(kind, 2, 2, dt, config=cfg, seed=5)
    W, V = ident.W, ident.V  # noqa: N806
    x_hat = rng.normal(size=2)
    z = np.zeros(2)
    ident.reset_observer(x_hat)
    for _ in range(4):
        x, u, f, xn = (rng.normal(size=2) for _ in range(4))
        xb = np.concatenate([x_hat, u])
        s = np.tanh(V @ xb)
        e = (x - x_hat) if kind == "instantaneous" else z
        delta = e / cfg.a_d
        wd = np.sum((W * (1.0 - s ** 2)) ** 2)  # ‖Ŵ D‖_F², not ‖Ŵ‖_F²
        k1 = dt * cfg.eta1 / (1.0 + s @ s)
        d2 = delta @ delta
        if kind == "integral":  # bounded by the instantaneous error too
            xt = x - x_hat
            d2 = max(d2, (xt @ xt) / (cfg.a_d * cfg.lam) ** 2)
        k2 = dt * cfg.eta2 / ((xb @ xb) * (wd + ce * ce * d2))
        W_new = W - k1 * np.outer(delta, s)  # noqa: N806
        V_new = V - k2 * np.outer((1.0 - s ** 2) * (W.T @ delta), xb)  # noqa: N806
        x_hat = x_hat + dt * (f + W @ s - cfg.a_d * (x - x_hat))
        z = z + dt * (-cfg.lam * z + (x - xb[:2]))
        W, V = W_new, V_new  # noqa: N806
        ident.step(x, u, f, xn)
        np.testing.assert_allclose(ident.W, W, rtol=1e-12, atol=1e-14)
        np.testing.assert_allclose(ident.V, V, rtol=1e-12, atol=1e-14)
        np.testing.assert_allclose(ident.x_hat, x_hat, rtol=1e-12, atol=1e-14)


def test_minibatch_sgd_matches_torch_autograd():
    """One burst = one SGD step (eq. 4.4) on J_mb (eq. 4.3) over the drawn indices."""
    torch = pytest.importorskip("torch")
    rng = np.random.default_rng(2)
    cfg = preset("manipulator", "minibatch").replace(update_period=8, batch_size=5,
                                                    w0_scale=0.3, v0_scale=0.3)
    dt = 0.002
    ident = make_identifier("minibatch", 4, 2, dt, config=cfg, seed=4)
    W0, V0 = ident.W, ident.V  # noqa: N806
    xs, us, fs, xns = (rng.normal(size=(8, 4)), rng.normal(size=(8, 2)),
                       rng.normal(size=(8, 4)), rng.normal(size=(8, 4)))
    for k in range(7):
        ident.step(xs[k], us[k], fs[k], xns[k])
        np.testing.assert_array_equal(ident.W, W0)  # held between updates
    rng_copy = np.random.Generator(np.random.PCG64())
    rng_copy.bit_generator.state = ident._rng.bit_generator.state
    idx = rng_copy.integers(0, np.full((1, 1), 8), size=(1, 5))[0]
    ident.step(xs[7], us[7], fs[7], xns[7])  # 8th push: burst
    assert ident.n_updates == 1
    w = torch.tensor(W0, requires_grad=True)
    v = torch.tensor(V0, requires_grad=True)
    xb = torch.tensor(np.hstack([xs, us])[idx])
    pred = torch.tensor(xs[idx]) + dt * (torch.tensor(fs[idx]) + torch.tanh(xb @ v.T) @ w.T)
    j_mb = ((pred - torch.tensor(xns[idx])) ** 2).sum() / (2 * 5)
    j_mb.backward()
    np.testing.assert_allclose(ident.W, W0 - cfg.eta1 * w.grad.numpy(), rtol=1e-10, atol=1e-15)
    np.testing.assert_allclose(ident.V, V0 - cfg.eta2 * v.grad.numpy(), rtol=1e-10, atol=1e-15)


def test_z_filter_constant_error_converges_to_c_over_lambda():
    """Eq. 4.6 with x̃ ≡ c: z → c/λ (network off so nothing else moves)."""
    lam, dt = 2.0, 0.002
    cfg = IdentifierConfig(lam=lam, eta1=0.0, eta2=0.0, w0_scale=0.0)
    ident = make_identifier("integral", 3, 1, dt, config=cfg)
    c = np.array([0.3, -1.0, 2.5])
    ident.reset_observer(np.zeros(3))
    zero3, zero1 = np.zeros(3), np.zeros(1)
    for _ in range(int(10.0 / dt)):  # 20 time constants
        x = ident.x_hat + c  # keeps x̃_k = c exactly up to rounding
        ident.step(x, zero1, zero3, x)
    np.testing.assert_allclose(ident.z, c / lam, rtol=1e-8)
    np.testing.assert_allclose(ident.e, c / lam, rtol=1e-6)  # e = z_k (previous step)


def test_error_dynamics_stable_with_network_off():
    """Network off, exact model: x̃_{k+1} = (1 + Δt a_d) x̃_k (eq. 3.2 discretised), so an
    initial error decays geometrically; with a constant residual g it settles at −g/a_d."""
    dt, a_d = 0.002, -40.0
    cfg = IdentifierConfig(a_d=a_d, eta1=0.0, eta2=0.0, w0_scale=0.0)
    ident = make_identifier("instantaneous", 2, 1, dt, config=cfg)
    a = np.array([[0.0, 1.0], [-4.0, -0.4]])  # a stable linear plant, f = A x (+ g)
    x = np.array([1.0, 0.0])
    ident.reset_observer(x + np.array([0.5, -0.5]))
    u = np.zeros(1)
    xt0 = np.array([-0.5, 0.5])
    for k in range(1, 1001):
        f = a @ x
        x_next = x + dt * f  # Euler plant: the observer's own discretisation, g = 0
        ident.step(x, u, f, x_next)
        np.testing.assert_allclose(ident.x_tilde, (1 + dt * a_d) ** k * xt0, rtol=1e-9,
                                   atol=1e-15)
        x = x_next
    g = np.array([0.0, 0.7])
    for _ in range(2000):
        f = a @ x
        x_next = x + dt * (f + g)
        ident.step(x, u, f, x_next)
        x = x_next
    np.testing.assert_allclose(ident.x_tilde, -g / a_d, rtol=1e-6, atol=1e-12)


@pytest.mark.parametrize("source", ["measured", "estimate"])
def test_minibatch_input_measured_or_observer_estimate(source):
    """Baseline 2's network input: [x_k; u_k], or [x̂_k; u_k] with x̂ the eq. 3.1 observer;
    the one-step prediction (eq. 4.2) stays on the measured x_k."""
    rng = np.random.default_rng(7)
    dt = 0.01
    cfg = preset("auto", "minibatch", dt=dt).replace(
        scale_rate=0.0, w0_scale=0.5, init="uniform", v0_scale=0.8, minibatch_input=source)
    ident = make_identifier("minibatch", 2, 2, dt, config=cfg, seed=2)
    W, V = ident.W, ident.V  # noqa: N806
    x_hat = None
    for _ in range(cfg.update_period - 1):  # before the first SGD burst: weights fixed
        x, u, f, xn = (rng.normal(size=2) for _ in range(4))
        if x_hat is None:
            x_hat = x  # a fresh observer starts at the measurement
        xb = np.concatenate([x_hat if source == "estimate" else x, u])
        g_ref = W @ np.tanh(V @ xb)
        g = ident.step(x, u, f, xn)
        np.testing.assert_allclose(g, g_ref, rtol=1e-12, atol=1e-14)
        np.testing.assert_allclose(ident.x_bar, xb, rtol=1e-12, atol=1e-14)
        np.testing.assert_allclose(ident.x_hat, x + dt * (f + g_ref), rtol=1e-12, atol=1e-14)
        x_hat = x_hat + dt * (f + g_ref - cfg.a_d * (x - x_hat))
        obs = ident._field("observer")[0]
        if source == "estimate":
            np.testing.assert_allclose(obs[:2], x_hat, rtol=1e-12, atol=1e-14)
        else:
            assert obs[-1] == 0.0  # no observer on measured inputs
    assert ident.observes == (source == "estimate")


def test_minibatch_input_defaults_and_validation():
    from simgap.identifiers import IdentifierError

    assert preset("auto", "minibatch", dt=0.01).minibatch_input == "estimate"
    for system in ("manipulator", "bicycle"):  # the thesis presets: eq. 4.2 as printed
        assert preset(system, "minibatch").minibatch_input == "measured"
    assert IdentifierConfig().minibatch_input == "measured"
    with pytest.raises(IdentifierError, match="minibatch_input"):
        IdentifierConfig(minibatch_input="x_hat")
