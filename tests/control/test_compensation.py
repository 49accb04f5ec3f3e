import numpy as np
import pytest

from simgap.control import CompensatedFeedbackLinearization, ResidualNetwork, YawRateController
from simgap.control.compensation import _root_or_closest
from simgap.control.experiments import (
    TRUE_RESIDUAL,
    BicycleTask,
    TrueResidual,
    bicycle_tracking,
    manipulator_rmse,
    manipulator_tracking,
    rmse,
    yaw_error,
)
from simgap.envs.bicycle import BicycleTireEnv
from simgap.envs.manipulator import ManipulatorFrictionEnv
from simgap.envs.scenarios import FeedbackLinearizationController, YawRateReference
from simgap.identifiers import make_identifier, preset


def _ident(seed=0):
    return make_identifier("integral", 2, 2, 0.01, config=preset("bicycle", "integral"),
                           seed=seed)


def test_residual_network_frozen_copy_vs_online():
    ident = _ident()
    frozen = ResidualNetwork(ident)
    live = ResidualNetwork(ident, online=True)
    x, u = np.array([0.3, 0.1]), np.array([0.02, 0.0])
    np.testing.assert_array_equal(frozen(x, u), ident.predict(np.r_[x, u]))
    for _ in range(50):  # learn something: weights move
        ident.step(x, u, np.zeros(2), x + 0.01)
    np.testing.assert_array_equal(live(x, u), ident.predict(np.r_[x, u]))
    assert not np.array_equal(frozen(x, u), live(x, u))
    batch = frozen(np.tile(x, (5, 1)), u)
    assert batch.shape == (5, 2)
    np.testing.assert_allclose(batch[3], frozen(x, u), rtol=0, atol=1e-15)


def test_residual_network_rejects_bad_input():
    with pytest.raises(TypeError):
        ResidualNetwork("integral")
    with pytest.raises(ValueError, match="1-D or 2-D"):
        ResidualNetwork(_ident())(np.zeros((2, 2, 2)), np.zeros(2))


def test_fl_compensation_with_exact_residual_removes_friction_error():
    """u = u_FL − g_p with the true g must cancel the friction: sign and loop are right."""
    plain = manipulator_rmse(manipulator_tracking(None, 1.0))
    exact = manipulator_rmse(manipulator_tracking(TRUE_RESIDUAL, 1.0))
    assert plain > 0.01
    assert exact < 0.05 * plain


def test_fl_compensation_without_residual_is_the_plain_controller():
    env = ManipulatorFrictionEnv()
    fl = FeedbackLinearizationController(env.nominal_model, env.reference)
    comp = CompensatedFeedbackLinearization(fl)
    obs = np.array([0.9, 1.4, 0.3, -0.2])
    np.testing.assert_array_equal(comp(obs, 0.7), fl(obs, 0.7))
    with pytest.raises(ValueError, match="n_iter"):
        CompensatedFeedbackLinearization(fl, n_iter=0)
    with pytest.raises(TypeError):
        CompensatedFeedbackLinearization(lambda o, t: o)


def test_yaw_inversion_exact_on_linear_tires_and_residual_helps_on_low_mu():
    # Truth = nominal: the nominal inversion tracks almost perfectly.
    ref = YawRateReference(amplitude=0.2, period=4.0)
    env = BicycleTireEnv(tire="linear", reference=ref)
    ctrl = YawRateController(env.nominal_model, ref)
    obs, _ = env.reset(seed=0)
    err = []
    for k in range(200):
        obs, _, _, _, info = env.step(ctrl(obs, k * env.dt))
        err.append(obs[1] - info["r_ref"])
    assert rmse(np.array(err)) < 2e-3
    # Magic Formula on mu = 0.5: the exact residual beats the nominal inversion clearly.
    task = BicycleTask()
    plain = rmse(yaw_error(bicycle_tracking("inversion", task, 1.5)[0]))
    exact = rmse(yaw_error(bicycle_tracking("inversion", task, 1.5,
                                            identifier=TRUE_RESIDUAL)[0]))
    assert exact < 0.3 * plain


def test_true_residual_matches_env_info():
    env = BicycleTireEnv(mu=0.5)
    obs, _ = env.reset(seed=0, options={"state": (0.4, 0.2)})
    u = np.array([0.05, 0.0])
    _, _, _, _, info = env.step(u)
    np.testing.assert_allclose(TrueResidual(env)(obs, u), info["residual_true"], rtol=1e-12)
    with pytest.raises(ValueError, match="relaxation"):
        TrueResidual(BicycleTireEnv(relaxation_length=0.5))


def test_root_or_closest():
    grid = np.linspace(-1, 1, 5)
    assert _root_or_closest(grid, grid - 0.3) == pytest.approx(0.3)
    assert _root_or_closest(grid, grid + 5.0) == -1.0  # unreachable: closest end


def test_yaw_controller_validates():
    model = BicycleTireEnv().nominal_model
    with pytest.raises(ValueError, match="gain"):
        YawRateController(model, YawRateReference(), gain=0.0)
    with pytest.raises(TypeError):
        YawRateController(model, 3.0)
