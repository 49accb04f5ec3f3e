"""Test scenarios that real logs bring and the default generators do not (issue 13).

The artefacts of :mod:`simgap.diagnosis.artefacts` spoil a generated recording; the
scenarios here change what is *recorded* and against which nominal model:

* :func:`decay` — **free decays with no input and a mis-estimated nominal damping**: a
  pendulum (:class:`~simgap.models.pendulum.PendulumNominal`) released from a deflection
  with u = 0, whose true damping is lower than the nominal's (the nominal is
  :data:`DAMPING_ERROR` = 15 % too high), with or without a real Coulomb friction. The
  right answer is a *signed* correction of the nominal's own damping (negative) and, when
  present, the Coulomb friction beside it: "less viscous + Coulomb", which a vocabulary
  with b ≥ 0 cannot express. The decay also puts the large amplitudes early and the small
  ones (or a standstill, masked) late: a 70/30 split in time leaves little to test.
* :func:`circles` — **one-direction steady manoeuvres**: the single-track vehicle on
  steady circles, one turn direction per run (levels held 3-5 s, :func:`~simgap.diagnosis.
  generate.steering_program` ``circles_left``/``circles_right``), the runs joined by a
  gap in the log. Known traps: a constant yaw bias whose sign follows the turn direction, a
  mass ratio and cornering-stiffness ratios that trade against the tire law (mass, yaw
  inertia and all tire forces scaled together leave the motion unchanged).

Each returns a :class:`Scenario`: the recording, the nominal model the diagnosis is given
and the effects a right diagnosis names (with their parameters in report units). Seeded:
identical arguments give bit-identical recordings.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy.integrate import solve_ivp

from simgap.diagnosis.generate import InjectedEffect, generate_bicycle
from simgap.errors import GeneratorError
from simgap.models.friction import coulomb
from simgap.models.manipulator import DEFAULT_SIGMA
from simgap.models.pendulum import PendulumNominal, PendulumParams
from simgap.recordings import Recording

#: The nominal's damping over the true one, minus 1: the nominal is 15 % too high.
DAMPING_ERROR = 0.15
#: Range of the true Coulomb friction of a decay (N·m): small against the gravity torque
#: (m g l ≈ 1 N·m) yet a few times the damping error's torque.
DECAY_COULOMB = (0.005, 0.015)
#: Gap between two runs of :func:`circles` (s).
RUN_GAP = 2.0


@dataclass(frozen=True)
class Scenario:
    """A recording, the nominal model to diagnose it with, and the right answer.

    Attributes:
        recording: the recording (truth only in ``meta``).
        model: what :func:`~simgap.diagnosis.pipeline.diagnose` is given as ``model``.
        expected: the effects a right diagnosis names, parameters in report units (a
            signed correction of a nominal coefficient is the correction, e.g. b < 0).
        truth: what was simulated (JSON-ready).
    """

    recording: Recording
    model: Any
    expected: list[InjectedEffect] = field(default_factory=list)
    truth: dict[str, Any] = field(default_factory=dict)


def decay_recording(truth: PendulumParams, *, coulomb_fc: float = 0.0, q0: float = 1.0,
                    duration: float = 30.0, rate: float = 500.0, seed: int = 0,
                    noise_q: float = 1e-4, noise_dq: float = 2e-3,
                    sigma: float = DEFAULT_SIGMA, name: str | None = None) -> Recording:
    """A pendulum released from rest at ``q0`` with no input (u = 0), recorded with noise.

    The truth is J ddq + b dq + mgl sin q + Fc tanh(dq/σ) = 0 (the plant's smooth Coulomb
    law), integrated by LSODA to 1e-10 relative accuracy.

    Args:
        truth: the true inertia, gravity torque and damping.
        coulomb_fc: true Coulomb friction Fc (N·m), ≥ 0.
        q0: initial deflection (rad).
        duration: length (s).
        rate: sampling rate (Hz).
        seed: seed of the measurement noise.
        noise_q: std of angle noise (rad).
        noise_dq: std of velocity noise (rad/s).
        sigma: Coulomb smoothing velocity (rad/s).
        name: recording name.

    Returns:
        A :class:`Recording` with columns ``t, q, dq, u`` (u ≡ 0).
    """
    if not (duration > 0 and rate > 0 and coulomb_fc >= 0):
        raise GeneratorError("duration and rate must be positive and coulomb_fc ≥ 0")
    n = int(round(duration * rate)) + 1
    t = np.arange(n) / rate
    j, mgl, b = truth.inertia, truth.mgl, truth.damping

    def rhs(_t: float, s: np.ndarray) -> list[float]:
        q, dq = s
        return [dq, -(b * dq + mgl * np.sin(q) + coulomb.py_func(dq, coulomb_fc, sigma)) / j]

    sol = solve_ivp(rhs, (0.0, float(t[-1])), [q0, 0.0], method="LSODA", t_eval=t,
                    rtol=1e-10, atol=1e-12)
    if not sol.success:
        raise GeneratorError(f"decay simulation failed: {sol.message}")
    rng = np.random.default_rng(seed)
    cols = {"t": t, "q": sol.y[0] + rng.normal(0.0, noise_q, n),
            "dq": sol.y[1] + rng.normal(0.0, noise_dq, n), "u": np.zeros(n)}
    meta = {"model": "pendulum", "seed": seed, "truth": {
        "inertia": j, "mgl": mgl, "damping": b, "coulomb_fc": coulomb_fc, "q0": q0},
        "noise": {"q": noise_q, "dq": noise_dq}}
    return Recording(name=name or f"decay_seed{seed}", columns=cols, meta=meta)


def decay(seed: int, *, coulomb_friction: bool, damping_error: float = DAMPING_ERROR,
          duration: float = 30.0) -> Scenario:
    """A free decay against a nominal whose damping is ``damping_error`` too high.

    The true pendulum (J ∈ [0.04, 0.06] kg·m², m g l ∈ [0.8, 1.2] N·m, b ∈ [0.008, 0.015]
    N·m·s/rad, released from 0.8-1.2 rad) is drawn from ``seed``; the nominal has the same
    J and m g l and the damping b·(1 + damping_error). With ``coulomb_friction`` the truth
    also has a Coulomb friction drawn from :data:`DECAY_COULOMB`.

    Args:
        seed: seed of the truth and the noise.
        coulomb_friction: whether the truth has a Coulomb friction.
        damping_error: nominal damping / true damping − 1 (0: a clean case, the nominal
            is right).
        duration: length (s).

    Returns:
        The :class:`Scenario`; expected: ``viscous_friction@joint1`` with b = b_true −
        b_nominal (< 0) unless ``damping_error`` is 0, and ``coulomb_friction@joint1`` with
        its Fc when present.
    """
    rng = np.random.default_rng(7000 + seed)
    truth = PendulumParams(inertia=float(rng.uniform(0.04, 0.06)),
                           mgl=float(rng.uniform(0.8, 1.2)),
                           damping=float(rng.uniform(0.008, 0.015)))
    q0 = float(rng.uniform(0.8, 1.2))
    fc = float(rng.uniform(*DECAY_COULOMB)) if coulomb_friction else 0.0
    nominal = PendulumParams(inertia=truth.inertia, mgl=truth.mgl,
                             damping=truth.damping * (1.0 + damping_error))
    rec = decay_recording(truth, coulomb_fc=fc, q0=q0, duration=duration, seed=seed)
    expected = []
    if damping_error != 0.0:
        expected.append(InjectedEffect(effect="viscous_friction", channel="joint1",
                                       params={"b": truth.damping - nominal.damping}))
    if fc > 0:
        expected.append(InjectedEffect(effect="coulomb_friction", channel="joint1",
                                       params={"Fc": fc}))
    return Scenario(recording=rec, model=PendulumNominal(nominal),
                    expected=expected,
                    truth={"damping": truth.damping, "nominal_damping": nominal.damping,
                           "coulomb_fc": fc, "inertia": truth.inertia, "mgl": truth.mgl,
                           "q0": q0})


def join_runs(runs: Sequence[Recording], gap: float = RUN_GAP, name: str | None = None
              ) -> Recording:
    """Runs logged one after the other, each shifted to start ``gap`` s after the last.

    Args:
        runs: recordings with the same columns.
        gap: pause between runs (s): the log holds no sample there.
        name: name of the joined recording (default: the first run's).

    Raises:
        GeneratorError: no runs, or runs with different columns.
    """
    if not runs:
        raise GeneratorError("join_runs: no runs")
    names = list(runs[0].columns)
    if any(list(r.columns) != names for r in runs):
        raise GeneratorError("join_runs: runs with different columns")
    parts: dict[str, list[np.ndarray]] = {k: [] for k in names}
    t0 = 0.0
    for r in runs:
        rel = r.t - r.t[0]
        for k in names:
            parts[k].append(rel + t0 if k == "t" else r[k])
        dt = float(np.median(np.diff(rel)))
        t0 += float(rel[-1]) + dt + gap
    meta = dict(runs[0].meta)
    meta["runs"] = len(runs)
    return Recording(name or runs[0].name, {k: np.concatenate(v) for k, v in parts.items()},
                     meta)


def circles(effects: Sequence[InjectedEffect], seed: int, *,
            directions: Sequence[str] = ("left", "right"), run_duration: float = 20.0,
            ay_peak: float = 6.0, vx: float = 20.0, turn_yaw_offset: float = 0.0
            ) -> Scenario:
    """Steady circles, one turn direction per run, runs joined by :data:`RUN_GAP`.

    With ``turn_yaw_offset`` each run also carries a constant yaw acceleration whose sign
    follows its turn direction (+ on left turns, − on right turns): an effect **out of the
    vocabulary** (no constant and no named law of the motion reproduces it on both
    directions), which a right diagnosis locates but explains by no named effect. It is
    recorded in ``truth`` only, never in ``expected``.

    Args:
        effects: injected effects (bicycle vocabulary).
        seed: seed of the first run (run k uses ``seed + 1000·k``).
        directions: turn direction of each run (``"left"`` or ``"right"``).
        run_duration: length of each run (s).
        ay_peak: steady lateral acceleration of the largest level on the nominal vehicle
            (m/s²).
        vx: mean speed (m/s).
        turn_yaw_offset: size of the direction-following yaw acceleration (rad/s²), ≥ 0;
            0 = none.

    Returns:
        The :class:`Scenario` (model ``"bicycle"``, expected = the injected effects).
    """
    if not (np.isfinite(turn_yaw_offset) and turn_yaw_offset >= 0):
        raise GeneratorError(f"circles: turn_yaw_offset must be ≥ 0, got {turn_yaw_offset!r}")
    runs = []
    for k, d in enumerate(directions):
        if d not in ("left", "right"):
            raise GeneratorError(f"circles: direction must be 'left' or 'right', got {d!r}")
        run_effects = list(effects)
        if turn_yaw_offset > 0:
            sign = 1.0 if d == "left" else -1.0
            run_effects.append(InjectedEffect(effect="yaw_bias",
                                              params={"dr0": sign * turn_yaw_offset}))
        runs.append(generate_bicycle(run_effects, duration=run_duration, seed=seed + 1000 * k,
                                     program=f"circles_{d}", ay_peak=ay_peak, vx=vx,
                                     vx_variation=0.05))
    rec = join_runs(runs, name=f"circles_seed{seed}")
    return Scenario(recording=rec, model="bicycle", expected=list(effects),
                    truth={"injected": [e.to_dict() for e in effects],
                           "directions": list(directions),
                           "turn_yaw_offset": float(turn_yaw_offset)})
