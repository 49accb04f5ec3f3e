import numpy as np
import pytest

pytest.importorskip("highway_env")

import gymnasium as gym  # noqa: E402
from gymnasium.utils.env_checker import check_env  # noqa: E402
from highway_env.vehicle.dynamics import BicycleVehicle  # noqa: E402

import simgap  # noqa: E402, F401  (registers the env ids)
from simgap.highway import HIGHWAY_LANE_KEEPING_ID, PacejkaBicycleVehicle  # noqa: E402
from simgap.highway.experiments import identify_lane_keeping  # noqa: E402


def _pair(mu=1.0, steering=0.0, vy=0.0, r=0.0):
    out = []
    for cls in (BicycleVehicle, PacejkaBicycleVehicle):
        v = cls(None, [0.0, 0.0], heading=0.1, speed=10.0)
        if cls is PacejkaBicycleVehicle:
            v.MU = mu
        v.lateral_speed, v.yaw_rate = vy, r
        v.act({"steering": steering, "acceleration": 0.0})
        out.append(v)
    return out


def test_pacejka_vehicle_matches_linear_at_small_slip_and_saturates():
    lin, mf = _pair(steering=1e-4)
    d_lin, d_mf = lin.derivative[:, 0], mf.derivative[:, 0]
    np.testing.assert_allclose(d_mf[:4], d_lin[:4], rtol=1e-12)
    np.testing.assert_allclose(d_mf[4:], d_lin[4:], rtol=1e-3)
    lin, mf = _pair(mu=0.3, steering=0.4)
    fzf, _ = mf.axle_loads
    af, ar = mf.slip_angles(10.0, 0.0, 0.0, 0.4)
    fyf, fyr = mf.tire_forces(af, ar)
    assert abs(fyf) <= 0.3 * fzf * (1 + 1e-12)
    assert abs(fyf) < 0.2 * 2 * lin.FRICTION_FRONT * af  # far below the linear force
    # the yaw acceleration follows the saturated force
    d = mf.derivative[:, 0]
    assert d[5] == pytest.approx((mf.LENGTH_A * fyf - mf.LENGTH_B * fyr) / mf.INERTIA_Z)
    with pytest.raises(ValueError, match="mu"):
        PacejkaBicycleVehicle(None, [0.0, 0.0], mu=-1.0)


def test_registered_env_passes_check_env_and_observes_after_the_step():
    env = gym.make(HIGHWAY_LANE_KEEPING_ID, config={"mu": 0.4})
    check_env(env.unwrapped, skip_render_check=True)
    base = env.unwrapped
    assert isinstance(base.vehicle, PacejkaBicycleVehicle) and base.vehicle.MU == 0.4
    obs, info = env.reset(seed=0)
    model = base.nominal_model
    x = model.state(obs)
    for _ in range(5):
        action = np.array([0.1])
        obs, reward, term, trunc, info = env.step(action)
        x_next = model.state(obs)
        np.testing.assert_array_equal(x_next, [base.vehicle.lateral_speed, base.vehicle.yaw_rate])
        # one explicit-Euler step of f + g_true reproduces the RK4 transition to O(dt²)
        pred = x + model.dt * (model.f(x, model.input(action)) + info["residual_true"])
        np.testing.assert_allclose(x_next, pred, atol=5e-3)
        x = x_next
    env.close()


def test_identifier_wrapper_identifies_the_axle_residual():
    """20 s of steering excitation on μ = 0.3: the axle-force estimate tracks the truth."""
    run = identify_lane_keeping(mu=0.3, seconds=20.0, identifier="instantaneous")
    sc = run.scores(last_seconds=10.0)
    assert np.all(np.abs(run.steering) <= np.pi / 3)
    assert np.all(np.array(sc["rms_true_N"]) > 0.05)  # tires nonlinear (N; highway m = 1 kg)
    assert np.all(np.array(sc["rms_error_N"]) < 0.9 * np.array(sc["rms_true_N"]))
    assert min(sc["correlation"]) > 0.5
