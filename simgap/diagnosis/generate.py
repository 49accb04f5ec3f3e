"""Concealed-effect recordings: simulate a "real" system with hidden physics and record it.

The recordings follow ``spec/diagnosis.md`` (columns of ``spec/models.md``) and carry the
truth only in :attr:`Recording.meta` (and, from the CLI, a ``*.truth.json`` side file): the
diagnosis never reads either.

* ``manipulator2dof``: closed loop. A computed-torque (feedback linearisation, thesis eq.
  4.8-4.9, the law of ``simgap.envs.scenarios.FeedbackLinearizationController`` compiled into
  the simulation loop for speed) controller built on the *nominal* model tracks the envs'
  random-waypoint quintic reference (``RandomWaypointReference``) using the noisy
  measurements; the plant is the nominal arm plus the injected effects
  (:func:`simgap.models.manipulator.plant_step`, 20 RK4 sub-steps per 2 ms so that the stiff
  tanh friction is integrated accurately). ``tau`` is the torque the motor applied (the
  controller output, held over the sample period; an ``input_delay`` makes the plant feel
  it d seconds later, sub-steps split where the delayed command switches; a ``dead_zone``
  makes the joint feel u − clip(u, −d, d) of the logged command u).
* ``bicycle``: scripted steering (random sine segments, slalom, chirp or steps) at a slowly
  varying speed; ``delta_f``/``delta_r`` are the *commanded* angles (a steering lag makes the
  road-wheel angle lag them). Plant: :func:`simgap.models.bicycle.plant_step`.

Sensor noise is white Gaussian on the measured columns. Everything is drawn from one seeded
``numpy.random.Generator``: identical arguments give bit-identical recordings.

Injected effects use the vocabulary's names and parameters (``spec/diagnosis.md``); see
:data:`MANIPULATOR_EFFECTS` and :data:`BICYCLE_EFFECTS`. Two effects outside the vocabulary
exist for testing that nothing is forced into it: ``tire_relaxation`` (bicycle, ``length``
in m).

The plant is the envs' plant (the same :func:`~simgap.models.manipulator.plant_array` /
:func:`~simgap.models.bicycle.plant_array` built from the same effects; a test checks that
the env built from the augmented model has this plant array), stepped by the model kernels
directly in a compiled loop rather than through ``env.step`` (30,000 closed-loop steps in a
fraction of a second).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np
from numba import njit

from simgap.errors import GeneratorError
from simgap.limits import check_samples
from simgap.models import bicycle as bic
from simgap.models import manipulator as man
from simgap.models.effects import EffectInstance, PlantSchema
from simgap.models.integrators import rk4
from simgap.models.nbcache import guard_cache
from simgap.recordings import MIN_SAMPLES, Recording

#: Injectable manipulator effects: name -> (per joint?, parameter names), from the vocabulary.
MANIPULATOR_EFFECTS: dict[str, tuple[bool, tuple[str, ...]]] = {
    e.name: (e.scope == "channel", tuple(p.name for p in e.params))
    for e in man.PLANT_SCHEMA.vocabulary}
#: Injectable bicycle effects: name -> (per axle?, parameter names), from the vocabulary
#: (``tire_relaxation`` is outside the diagnosis vocabulary, for tests).
BICYCLE_EFFECTS: dict[str, tuple[bool, tuple[str, ...]]] = {
    e.name: (e.scope == "channel", tuple(p.name for p in e.params))
    for e in bic.PLANT_SCHEMA.vocabulary}
JOINTS = man.JOINTS
AXLES = bic.AXLES
#: float64 arrays per sample a generator and the CSV writer hold at once (memory estimate
#: checked by :func:`simgap.limits.check_samples` before allocating).
GENERATOR_ARRAYS = 64


@dataclass(frozen=True, kw_only=True)
class InjectedEffect:
    """One hidden effect: vocabulary name, channel (joint/axle, or ``None``) and parameters.

    Attributes:
        effect: vocabulary name, e.g. ``"coulomb_friction"``.
        channel: ``"joint1"``/``"joint2"`` or ``"front_axle"``/``"rear_axle"`` for per-joint
            or per-axle effects; ``None`` for whole-arm / whole-vehicle effects.
        params: parameter values by name in SI units (see the vocabulary table).
    """

    effect: str
    channel: str | None = None
    params: Mapping[str, float] = field(default_factory=dict)

    def to_dict(self) -> dict:
        """JSON-ready form."""
        return {"effect": self.effect, "channel": self.channel,
                "params": {k: float(v) for k, v in self.params.items()}}


def instances(effects: Sequence[InjectedEffect], schema: PlantSchema
              ) -> tuple[EffectInstance, ...]:
    """Check injected effects against the system's vocabulary and make plant instances.

    Raises:
        GeneratorError: one line naming an unknown effect, a channel the effect does not act
            on (e.g. ``joint1`` for a bicycle effect), or a missing, unknown or out-of-range
            parameter.
    """
    out = []
    for e in effects:
        spec = schema.effect(e.effect, GeneratorError)
        out.append(EffectInstance(e.effect, e.channel,
                                  spec.check(e.channel, e.params, schema.channels,
                                             GeneratorError)))
    return tuple(out)


# --------------------------------------------------------------------------- manipulator
def waypoint_reference(t: np.ndarray, seed: int, *,
                       q_low: Sequence[float] = (-0.3, -1.6),
                       q_high: Sequence[float] = (1.6, 1.6),
                       period_range: tuple[float, float] = (0.6, 1.6)
                       ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Random-waypoint quintic reference of :mod:`simgap.envs.scenarios`, sampled on ``t``.

    Args:
        t: time grid (s).
        seed: seed of :class:`~simgap.envs.scenarios.RandomWaypointReference`.
        q_low: lower corner of the waypoint box (rad).
        q_high: upper corner (rad).
        period_range: segment durations (s); shorter than the env default so that short
            recordings still hold many velocity reversals.

    Returns:
        q_ref, dq_ref, ddq_ref of shape (len(t), 2) (rad, rad/s, rad/s²).
    """
    from simgap.envs.scenarios import RandomWaypointReference

    ref = RandomWaypointReference(seed, low=tuple(q_low), high=tuple(q_high),
                                  period_range=period_range)
    packed = np.array([ref.sample(tk) for tk in t])
    return packed[:, 0:2], packed[:, 2:4], packed[:, 4:6]


@njit(cache=True)
def _manipulator_loop(theta, la_nom, q_ref, dq_ref, ddq_ref, noise_q, noise_dq, kp, kd, dt,
                      n_sub, s0, delay_steps, delay_frac, cuts,
                      dead):  # pragma: no cover - compiled
    n = q_ref.shape[0]
    states = np.empty((n, 4))
    meas = np.empty((n, 4))
    taus = np.empty((n, 2))
    s = s0.copy()
    u = np.empty(2)
    v = np.empty(2)
    for k in range(n):
        states[k] = s
        qm = s[:2] + noise_q[k]
        dqm = s[2:] + noise_dq[k]
        meas[k, :2] = qm
        meas[k, 2:] = dqm
        for i in range(2):
            v[i] = ddq_ref[k, i] + kd * (dq_ref[k, i] - dqm[i]) + kp * (q_ref[k, i] - qm[i])
        mm = man.mass_matrix(qm, la_nom)
        bias = man.coriolis_matrix(qm, dqm, la_nom) @ dqm + man.gravity_vector(qm, la_nom)
        mv = mm @ v
        u[0] = mv[0] + bias[0]
        u[1] = mv[1] + bias[1]
        taus[k] = u
        if cuts.shape[0] == 0:
            for j in range(2):  # the actuator's dead zone: the logged command is u
                if dead[j] > 0.0:
                    u[j] = man.dead_zone(u[j], dead[j])
            s = rk4(man.plant_derivative, s, u, theta, dt, n_sub)
            continue
        # transport delay d_j = (m_j + f_j)·dt of joint j's held command: over this sample
        # the command of row k − m_j − 1 acts until f_j·dt, then that of row k − m_j; the
        # sample is integrated in segments between the switch times ``cuts`` (fractions)
        for c in range(cuts.shape[0] - 1):
            a, b = cuts[c], cuts[c + 1]
            for j in range(2):
                row = k - delay_steps[j] - (1 if 0.5 * (a + b) < delay_frac[j] else 0)
                v[j] = taus[max(row, 0), j]
                if dead[j] > 0.0:
                    v[j] = man.dead_zone(v[j], dead[j])
            s = rk4(man.plant_derivative, s, v, theta, (b - a) * dt,
                    max(1, int(round(n_sub * (b - a)))))
    return states, meas, taus


def manipulator_plant(effects: Sequence[InjectedEffect],
                      params: man.ManipulatorParams | None = None) -> np.ndarray:
    """Plant array of the nominal arm with the effects injected (:class:`Plant` ``.array``)."""
    return man.PLANT_SCHEMA.plant(params, instances(effects, man.PLANT_SCHEMA)).array


def generate_manipulator(effects: Sequence[InjectedEffect] = (), *, duration: float = 20.0,
                         rate: float = 500.0, seed: int = 0, noise_q: float = 1e-4,
                         noise_dq: float = 2e-3, noise_tau: float = 0.0, kp: float = 100.0,
                         kd: float = 20.0, n_sub: int = 20,
                         params: man.ManipulatorParams | None = None,
                         name: str | None = None) -> Recording:
    """Closed-loop recording of the arm with hidden effects.

    Args:
        effects: injected effects (vocabulary names).
        duration: length (s).
        rate: sampling rate (Hz); the controller runs at the same rate.
        seed: seed of the reference and the noise.
        noise_q: std of joint-angle noise (rad).
        noise_dq: std of joint-velocity noise (rad/s).
        noise_tau: std of torque measurement noise added to the logged tau (N·m).
        kp: proportional gain of the computed-torque controller (1/s²).
        kd: derivative gain (1/s).
        n_sub: RK4 sub-steps per sample.
        params: nominal parameters (the controller's model and the plant's base).
        name: recording name.

    Returns:
        A :class:`Recording` with columns ``t, q1, q2, dq1, dq2, tau1, tau2``.
    """
    if not (duration > 0 and rate > 0):
        raise GeneratorError("duration and rate must be positive")
    check_samples("duration", duration, rate, columns=GENERATOR_ARRAYS,  # before allocating
                  min_samples=MIN_SAMPLES)
    ref_seq, noise_seq = np.random.SeedSequence(seed).spawn(2)
    rng = np.random.default_rng(noise_seq)
    p = params or man.ManipulatorParams()
    plant = man.PLANT_SCHEMA.plant(p, instances(effects, man.PLANT_SCHEMA))
    theta = plant.array
    dt = 1.0 / rate
    delays = np.asarray(plant.folded.extras["input_delay"]) / dt
    delay_steps, delay_frac = np.floor(delays).astype(np.int64), delays - np.floor(delays)
    cuts = np.unique(np.concatenate([[0.0, 1.0], delay_frac])) if np.any(delays > 0) \
        else np.empty(0)
    n = int(round(duration * rate)) + 1
    t = np.arange(n) * dt
    q_ref, dq_ref, ddq_ref = waypoint_reference(t, int(ref_seq.generate_state(1)[0]))
    nq = rng.normal(0.0, noise_q, size=(n, 2))
    ndq = rng.normal(0.0, noise_dq, size=(n, 2))
    s0 = np.array([q_ref[0, 0], q_ref[0, 1], 0.0, 0.0])
    _, meas, taus = _manipulator_loop(theta, p.array, q_ref, dq_ref, ddq_ref, nq, ndq,
                                      float(kp), float(kd), dt, int(n_sub), s0,
                                      delay_steps, delay_frac, cuts,
                                      np.asarray(plant.folded.extras["dead_zone"]))
    tau_log = taus + rng.normal(0.0, noise_tau, size=taus.shape) if noise_tau > 0 else taus
    cols = {"t": t, "q1": meas[:, 0], "q2": meas[:, 1], "dq1": meas[:, 2], "dq2": meas[:, 3],
            "tau1": tau_log[:, 0], "tau2": tau_log[:, 1]}
    meta = {"model": "manipulator2dof", "seed": seed,
            "injected": [e.to_dict() for e in effects],
            "noise": {"q": noise_q, "dq": noise_dq, "tau": noise_tau}}
    return Recording(name=name or f"manipulator_seed{seed}", columns=cols, meta=meta)


# --------------------------------------------------------------------------- bicycle
def steering_program(t: np.ndarray, rng: np.random.Generator, kind: str, amplitude: float
                     ) -> np.ndarray:
    """Front steering command δ_f(t) (rad).

    Kinds: ``random`` (back-to-back full sine periods of random amplitude and frequency
    0.2-1.5 Hz), ``slalom`` (0.5 Hz sine), ``chirp`` (0.1 → 2 Hz), ``step`` (steps of random
    amplitude every 2-4 s), ``circles_left`` / ``circles_right`` (steady circles turning one
    way only: levels of 25-100 % of the amplitude held 3-5 s, joined by 1 s cosine ramps).
    """
    if kind in ("circles_left", "circles_right"):
        sign = 1.0 if kind == "circles_left" else -1.0
        out = np.zeros_like(t)
        t0, level = 0.0, 0.0
        while t0 < t[-1]:
            new = sign * amplitude * rng.uniform(0.25, 1.0)
            hold = rng.uniform(3.0, 5.0)
            ramp = (t >= t0) & (t < t0 + 1.0)
            out[ramp] = level + (new - level) * 0.5 * (1.0 - np.cos(np.pi * (t[ramp] - t0)))
            out[t >= t0 + 1.0] = new
            t0, level = t0 + 1.0 + hold, new
        return out
    if kind == "slalom":
        return amplitude * np.sin(2 * np.pi * 0.5 * t)
    if kind == "chirp":
        f0, f1 = 0.1, 2.0
        phase = 2 * np.pi * (f0 * t + (f1 - f0) * t**2 / (2 * max(t[-1], 1e-9)))
        return amplitude * np.sin(phase)
    if kind == "step":
        out = np.zeros_like(t)
        t0 = 0.5
        while t0 < t[-1]:
            seg = rng.uniform(2.0, 4.0)
            out[t >= t0] = amplitude * rng.uniform(-1.0, 1.0)
            t0 += seg
        return out
    if kind == "random":
        out = np.zeros_like(t)
        t0 = 0.0
        while t0 < t[-1]:
            f = rng.uniform(0.2, 1.5)
            a = amplitude * rng.uniform(0.2, 1.0) * rng.choice([-1.0, 1.0])
            m = (t >= t0) & (t < t0 + 1.0 / f)
            out[m] = a * np.sin(2 * np.pi * f * (t[m] - t0))
            t0 += 1.0 / f
        return out
    raise GeneratorError(f"unknown steering program {kind!r}; use random, slalom, chirp, step, "
                         "circles_left or circles_right")


@njit(cache=True)
def _bicycle_loop(theta, vx, delta, dt, n_sub):  # pragma: no cover - compiled
    n = vx.shape[0]
    states = np.empty((n, 6))
    s = np.zeros(6)
    s[4] = delta[0, 0]
    s[5] = delta[0, 1]
    th = theta.copy()
    for k in range(n):
        states[k] = s
        th[bic.VX] = vx[k]
        s = rk4(bic.plant_derivative, s, delta[k], th, dt, n_sub)
    return states


def bicycle_plant(effects: Sequence[InjectedEffect], vx: float,
                  params: bic.BicycleParams | None = None) -> np.ndarray:
    """Plant array of the nominal vehicle at ``vx`` (m/s) with the effects injected.

    ``tire_saturation`` without a channel is one road μ for both axles.
    """
    return bic.PLANT_SCHEMA.plant(params, instances(effects, bic.PLANT_SCHEMA),
                                  vx=bic.check_vx(vx)).array


#: Largest road-wheel steering amplitude (rad) of the scripted programs: ≈ 29°, a car's lock.
#: Without it a low-speed recording (``vx = 3`` m/s) asked for up to 2.7 rad to reach
#: ``ay_peak``, which no vehicle steers and which the unit checks rightly read as degrees.
MAX_STEER = 0.5


def generate_bicycle(effects: Sequence[InjectedEffect] = (), *, duration: float = 40.0,
                     rate: float = 100.0, seed: int = 0, vx: float = 20.0,
                     vx_variation: float = 0.15, program: str = "random",
                     ay_peak: float = 8.5, noise_vy: float = 0.01, noise_r: float = 0.002,
                     noise_vx: float = 0.02, rear_steer: float = 0.0, n_sub: int = 4,
                     params: bic.BicycleParams | None = None,
                     name: str | None = None) -> Recording:
    """Scripted-steering recording of the single-track vehicle with hidden effects.

    Args:
        effects: injected effects (vocabulary names).
        duration: length (s).
        rate: sampling rate (Hz).
        seed: seed of the program and the noise.
        vx: mean longitudinal speed (m/s).
        vx_variation: relative amplitude of a slow (20 s period) speed variation.
        program: steering program (see :func:`steering_program`).
        ay_peak: steady-state lateral acceleration (m/s²) of the largest steering amplitude
            on the nominal (linear) vehicle; sets the amplitude, which is capped at
            :data:`MAX_STEER` (at low speed the requested ``ay_peak`` is then not reached).
        noise_vy: std of vy noise (m/s).
        noise_r: std of yaw-rate noise (rad/s).
        noise_vx: std of vx noise (m/s).
        rear_steer: rear command as a fraction of the front one (0: front steering only).
        n_sub: RK4 sub-steps per sample.
        params: nominal vehicle parameters (the plant's base).
        name: recording name.

    Returns:
        A :class:`Recording` with columns ``t, vx, vy, r, delta_f, delta_r``.
    """
    if not (duration > 0 and rate > 0):
        raise GeneratorError("duration and rate must be positive")
    check_samples("duration", duration, rate, columns=GENERATOR_ARRAYS,  # before allocating
                  min_samples=MIN_SAMPLES)
    rng = np.random.default_rng(seed)
    p = params or bic.BicycleParams()
    theta = bicycle_plant(effects, vx, p)
    dt = 1.0 / rate
    n = int(round(duration * rate)) + 1
    t = np.arange(n) * dt
    vx_t = vx * (1.0 + vx_variation * np.sin(2 * np.pi * t / 20.0 + rng.uniform(0, 2 * np.pi)))
    gain = vx**2 / (p.wheelbase + p.understeer_gradient() * vx**2)  # ay per rad, steady state
    df = steering_program(t, rng, program, min(ay_peak / gain, MAX_STEER))
    delta = np.ascontiguousarray(np.stack([df, rear_steer * df], axis=1))
    states = _bicycle_loop(theta, vx_t, delta, dt, int(n_sub))
    cols = {"t": t, "vx": vx_t + rng.normal(0.0, noise_vx, n),
            "vy": states[:, 0] + rng.normal(0.0, noise_vy, n),
            "r": states[:, 1] + rng.normal(0.0, noise_r, n),
            "delta_f": delta[:, 0], "delta_r": delta[:, 1]}
    meta = {"model": "bicycle", "seed": seed, "injected": [e.to_dict() for e in effects],
            "noise": {"vy": noise_vy, "r": noise_r, "vx": noise_vx}}
    return Recording(name=name or f"bicycle_seed{seed}", columns=cols, meta=meta)


def generate(model: str, effects: Sequence[InjectedEffect] = (), **kwargs) -> Recording:
    """Dispatch to the registered system's generator (:data:`simgap.systems.SYSTEMS`).

    Raises:
        GeneratorError: the system is unknown (the message lists the registered ones) or
            has no generator.
    """
    from simgap.systems import get_system

    spec = get_system(model, GeneratorError)
    if spec.generator is None:
        raise GeneratorError(f"system {model!r} has no concealed-effect generator")
    return spec.resolve("generator")(effects, **kwargs)


guard_cache(globals())  # drop cached kernels when a module they compile in changes
