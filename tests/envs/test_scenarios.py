"""References, the feedback-linearisation controller and the steering programs."""

from __future__ import annotations

import math

import numpy as np
import pytest

from simgap.envs import (
    BicycleTireEnv,
    FeedbackLinearizationController,
    ManipulatorFrictionEnv,
    QuinticReference,
    RandomWaypointReference,
    YawRateReference,
    chirp,
    open_loop,
    rollout,
    slalom,
    step_steer,
)


def _check_derivatives(ref, ts, h=1e-6):
    for t in ts:
        q_p, dq_p, _ = ref(t + h)
        q_m, dq_m, _ = ref(t - h)
        q, dq, ddq = ref(t)
        np.testing.assert_allclose((q_p - q_m) / (2 * h), dq, atol=1e-6)
        np.testing.assert_allclose((dq_p - dq_m) / (2 * h), ddq, atol=1e-4)


def test_quintic_reference_endpoints_periodicity_and_smoothness():
    ref = QuinticReference(period=2.0)
    start, end = np.array([math.pi / 4, math.pi / 2]), np.array([3 * math.pi / 4, -math.pi / 2])
    for t, q_exp in ((0.0, start), (2.0, end), (4.0, start), (6.0, end)):
        q, dq, ddq = ref(t)
        np.testing.assert_allclose(q, q_exp, atol=1e-12)
        np.testing.assert_allclose(dq, 0.0, atol=1e-12)
        np.testing.assert_allclose(ddq, 0.0, atol=1e-12)
    np.testing.assert_allclose(ref(1.0)[0], (start + end) / 2, atol=1e-12)
    np.testing.assert_allclose(ref.sample(1.3), ref.sample(5.3))  # period 2T
    rng = np.random.default_rng(0)
    _check_derivatives(ref, rng.uniform(0.01, 7.9, 20))
    with pytest.raises(ValueError, match="period"):
        QuinticReference(period=0.0)


def test_random_waypoint_reference_deterministic_and_bounded():
    a, b = RandomWaypointReference(seed=3), RandomWaypointReference(seed=3)
    ts = np.linspace(0, 60, 601)
    qa = np.array([a.sample(t) for t in ts])
    qb = np.array([b.sample(t) for t in ts[::-1]])[::-1]  # query order does not matter
    assert qa.tobytes() == qb.tobytes()
    assert not np.allclose(qa, np.array([RandomWaypointReference(seed=4).sample(t) for t in ts]))
    assert np.all(qa[:, :2] >= a.low - 1e-12) and np.all(qa[:, :2] <= a.high + 1e-12)
    assert np.ptp(qa[:, 0]) > 1.0
    _check_derivatives(a, np.random.default_rng(1).uniform(0.01, 59, 20))
    with pytest.raises(ValueError, match="period_range"):
        RandomWaypointReference(seed=0, period_range=(2.0, 1.0))


def test_feedback_linearization_tracks_without_friction_and_feels_friction():
    errs = {}
    for friction in ("none", "thesis"):
        env = ManipulatorFrictionEnv(friction=friction)
        ctl = FeedbackLinearizationController(env.nominal_model, env.reference)
        ro = rollout(env, ctl, 1500, seed=0)  # 3 s
        errs[friction] = np.abs(ro.next_obs[:, :2] - ro.info["reference"][:, :2]).max()
    # without friction only the zero-order hold of the 2 ms step remains
    assert errs["none"] < 5e-3
    assert errs["thesis"] > 10 * errs["none"]


def test_feedback_linearization_formula():
    env = ManipulatorFrictionEnv()
    m = env.nominal_model
    ref = QuinticReference()
    ctl = FeedbackLinearizationController(m, ref, Kp=(50.0, 60.0), Kd=(5.0, 6.0))
    obs = np.array([0.9, 1.2, 0.3, -0.4])
    t = 0.7
    q_d, dq_d, ddq_d = ref(t)
    v = ddq_d + np.array([5.0, 6.0]) * (dq_d - obs[2:]) + np.array([50.0, 60.0]) * (q_d - obs[:2])
    expected = m.M(obs[:2]) @ v + m.C(obs[:2], obs[2:]) @ obs[2:] + m.G(obs[:2])  # eq. 4.8-4.9
    np.testing.assert_allclose(ctl(obs, t), expected, rtol=1e-12)
    with pytest.raises(ValueError, match="Kp"):
        FeedbackLinearizationController(m, ref, Kp=-1.0)


@pytest.mark.parametrize(("make", "min_duration"), [(step_steer, 12.0), (slalom, 30.0),
                                                    (chirp, 12.0)])
def test_steering_programs_reach_nonlinear_range(make, min_duration):
    prog = make()
    assert prog.duration >= min_duration
    env = BicycleTireEnv(vx=20.0, mu=1.0)
    n = int(round(prog.duration / env.dt))
    ro = rollout(env, prog.act, n, seed=0)
    assert len(ro) == n and not ro.terminated.any()
    ay = env.vx * ro.next_obs[:, 1] + np.gradient(ro.next_obs[:, 0], env.dt)
    assert 5.0 <= np.abs(ay).max() <= 8.0  # m/s², the documented design range
    assert np.abs(ro.info["axle_force_residual_true"]).max() > 400.0  # N
    # both axles are steered, and the program is zero outside [0, duration]
    assert np.abs(ro.action[:, 1]).max() > 0
    np.testing.assert_array_equal(prog(-1.0), [0.0, 0.0])
    np.testing.assert_array_equal(prog(prog.duration + 1.0), [0.0, 0.0])
    assert prog(np.linspace(0, 5, 11)).shape == (11, 2)


def test_step_steer_shape_and_validation():
    prog = step_steer(front=0.05, rear=0.0, t_on=1.0, t_off=3.0, rise_time=0.2, duration=5.0)
    np.testing.assert_allclose(prog(0.5), [0.0, 0.0])
    np.testing.assert_allclose(prog(2.0), [0.05, 0.0])
    np.testing.assert_allclose(prog(4.0), [0.0, 0.0])
    with pytest.raises(ValueError, match="step_steer"):
        step_steer(t_on=5.0, t_off=4.0)
    np.testing.assert_allclose(open_loop(prog)(np.zeros(2), 2.0), [0.05, 0.0])


def test_yaw_rate_reference():
    ref = YawRateReference(amplitude=0.2, period=4.0)
    assert ref(1.0) == pytest.approx(0.2)
    with pytest.raises(ValueError, match="period"):
        YawRateReference(period=-1.0)
