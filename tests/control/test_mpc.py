import math

import numpy as np
import pytest

from simgap.control import MPCConfig, ResidualNetwork, SamplingMPC
from simgap.control.experiments import rmse
from simgap.control.mpc import rollout_costs
from simgap.envs.bicycle import BicycleTireEnv
from simgap.envs.scenarios import YawRateReference
from simgap.identifiers import make_identifier, preset

SMALL = MPCConfig(horizon=10, n_samples=64, n_iter=1)


def _reference_costs(x0, U, A, b, W, V, dt, n_sub, r_ref, w_r, w_du, u_prev, w_u=0.3):
    out = []
    for seq in U:
        x = x0.copy()
        c, last = 0.0, u_prev
        for k, d in enumerate(seq):
            for _ in range(n_sub):
                dx = A @ x + b * d + W @ np.tanh(V @ np.array([x[0], x[1], d, 0.0]))
                x = x + dt / n_sub * dx
            c += w_r * (x[1] - r_ref[k]) ** 2 + w_du * (d - last) ** 2 + w_u * d * d
            last = d
        out.append(c)
    return np.array(out)


def test_rollout_costs_matches_numpy_reference():
    rng = np.random.default_rng(1)
    A = rng.normal(size=(2, 2))
    b = rng.normal(size=2)
    W = rng.normal(size=(2, 5))
    V = rng.normal(size=(5, 4))
    U = rng.normal(0, 0.05, size=(7, 6))
    x0, r_ref = np.array([0.2, -0.1]), rng.normal(size=6)
    got = rollout_costs(x0, U, A, b, W, V, True, 0.02, 3, r_ref, 100.0, 10.0, 0.3, 0.01)
    want = _reference_costs(x0, U, A, b, W, V, 0.02, 3, r_ref, 100.0, 10.0, 0.01)
    np.testing.assert_allclose(got, want, rtol=1e-10)
    nominal = rollout_costs(x0, U, A, b, W, V, False, 0.02, 3, r_ref, 100.0, 10.0, 0.3, 0.01)
    np.testing.assert_allclose(
        nominal, _reference_costs(x0, U, A, b, 0 * W, V, 0.02, 3, r_ref, 100.0, 10.0, 0.01),
        rtol=1e-10)


def test_mpc_tracks_on_linear_tires_and_is_deterministic():
    ref = YawRateReference(amplitude=0.2, period=4.0)
    env = BicycleTireEnv(tire="linear", reference=ref)
    mpc = SamplingMPC(env.nominal_model, ref, config=SMALL, seed=3)
    obs, _ = env.reset(seed=0)
    err, acts = [], []
    for k in range(150):
        a = mpc(obs, k * env.dt)
        acts.append(a)
        obs, _, _, _, info = env.step(a)
        err.append(obs[1] - info["r_ref"])
    assert rmse(np.array(err)) < 0.02  # reference amplitude 0.2 rad/s
    mpc.reset()
    obs, _ = env.reset(seed=0)
    for k in range(20):
        a = mpc(obs, k * env.dt)
        np.testing.assert_array_equal(a, acts[k])
        obs, *_ = env.step(a)


def test_mpc_with_residual_network_uses_it():
    env = BicycleTireEnv()
    ident = make_identifier("minibatch", 2, 2, 0.01, config=preset("bicycle", "minibatch"))
    ref = YawRateReference()
    plain = SamplingMPC(env.nominal_model, ref, config=SMALL, seed=0)
    with_g = SamplingMPC(env.nominal_model, ref, ResidualNetwork(ident), config=SMALL, seed=0)
    x = np.array([0.1, 0.1])
    assert not np.array_equal(plain.plan(x, 0.5), with_g.plan(x, 0.5))


def test_mpc_validates():
    with pytest.raises(ValueError, match="horizon"):
        MPCConfig(horizon=0)
    with pytest.raises(ValueError, match="sigma"):
        MPCConfig(sigma=math.nan)
    env = BicycleTireEnv()
    mpc = SamplingMPC(env.nominal_model, YawRateReference(), config=SMALL)
    with pytest.raises(ValueError, match="finite"):
        mpc.plan(np.array([np.nan, 0.0]), 0.0)
    with pytest.raises(TypeError):
        SamplingMPC("bicycle", YawRateReference())


def test_mpc_replan_period_applies_the_plan_open_loop():
    env = BicycleTireEnv()
    cfg = MPCConfig(horizon=10, n_samples=32, n_iter=1, replan_period=0.1)
    mpc = SamplingMPC(env.nominal_model, YawRateReference(), config=cfg, seed=1)
    x = np.array([0.05, 0.02])
    first = mpc(x, 0.0)
    plan = mpc._plan.copy()
    assert first[0] == plan[0]
    for k in range(1, 10):  # 0.01 … 0.09 s: open loop, the state is ignored
        assert mpc(x + k, k * 0.01)[0] == plan[int(k * 0.01 / cfg.dt_pred + 1e-9)]
    mpc(x, 0.1)  # re-plan
    assert not np.array_equal(mpc._plan, plan)


def _trained_network():
    """A frozen ĝ with weights learned on the saturating tire (not the initial ones)."""
    from simgap.wrappers import IdentifierWrapper

    env = IdentifierWrapper(BicycleTireEnv(mu=0.5), "minibatch",
                            config=preset("bicycle", "minibatch"), seed=2)
    env.reset(seed=0)
    rng = np.random.default_rng(0)
    for _ in range(400):
        env.step(np.array([rng.uniform(-0.08, 0.08), 0.0]))
    return ResidualNetwork(env.identifier), env.unwrapped.nominal_model


def test_fused_rollout_is_pinned_to_the_model_and_network_functions():
    """The fused MPC loop equals the reference functions it stands for.

    Reference: the nominal f of ``models.bicycle`` (``BicycleNominal.f`` = slip angles, linear
    tires, force balance) plus the identifier's network forward (``ResidualNetwork`` →
    ``identifiers.network_forward``), advanced by Euler sub-steps as the MPC documents, with
    ``models.integrators.integrate(..., method="euler")`` for the nominal-only and the
    exact-plant predictions. A change of the model physics (e.g. the slip-angle definition) or
    of the network that the fused copy does not follow breaks this test.
    """
    from simgap.control.mpc import rollout_costs_plant
    from simgap.models import bicycle as bic
    from simgap.models.integrators import integrate

    net, model = _trained_network()
    theta_nom = np.concatenate([model.params.array, [model.vx]])
    rng = np.random.default_rng(4)
    U = rng.normal(0.0, 0.06, size=(6, 8))
    x0, r_ref = np.array([0.3, 0.2]), rng.normal(0.0, 0.2, size=8)
    dt, n_sub, w_r, w_du, w_u, u_prev = 0.02, 3, 100.0, 10.0, 0.5, 0.01

    def cost(step):
        out = []
        for seq in U:
            x, c, last = x0.copy(), 0.0, u_prev
            for k, d in enumerate(seq):
                x = step(x, np.array([d, 0.0]))
                c += w_r * (x[1] - r_ref[k]) ** 2 + w_du * (d - last) ** 2 + w_u * d * d
                last = d
            out.append(c)
        return np.array(out)

    def with_net(x, u):
        for _ in range(n_sub):
            x = x + dt / n_sub * (model.f(x, u) + net(x, u))
        return x

    W, V = (np.ascontiguousarray(a) for a in net.weights)
    A, b = np.ascontiguousarray(model.A), np.ascontiguousarray(model.B[:, 0])
    fused = rollout_costs(x0, U, A, b, W, V, True, dt, n_sub, r_ref, w_r, w_du, w_u, u_prev)
    np.testing.assert_allclose(fused, cost(with_net), rtol=1e-9)
    plain = rollout_costs(x0, U, A, b, W, V, False, dt, n_sub, r_ref, w_r, w_du, w_u, u_prev)
    np.testing.assert_allclose(plain, cost(lambda x, u: integrate(
        bic.nominal_derivative, x, u, theta_nom, dt, n_sub, method="euler")), rtol=1e-9)
    assert np.abs(fused / plain - 1.0).max() > 1e-3  # the network is not negligible here
    # the exact-plant prediction: the env's plant kernel (the states agree bit for bit; the
    # cost sums may round differently in the compiled loop)
    env = BicycleTireEnv(mu=0.6)
    theta = env.plant_theta

    def exact(x, u):
        return integrate(bic.plant_derivative, np.concatenate([x, np.zeros(4)]), u, theta, dt,
                         n_sub, method="euler")[:2]

    np.testing.assert_allclose(
        rollout_costs_plant(x0, U, theta, dt, n_sub, r_ref, w_r, w_du, w_u, u_prev),
        cost(exact), rtol=1e-13)
