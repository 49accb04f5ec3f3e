"""Step 5 of the diagnosis: nominal vs augmented on the held-out (later) part of a recording.

Two errors per model, both on the test part only (t ≥ split):

* one-step derivative error: RMS of (model derivative − measured derivative) at the
  recorded, filtered states and inputs — joint accelerations (rad/s²) for mechanical
  systems, (dvy/dt, dr/dt) for the bicycle;
* short-horizon simulation error: the test part is cut into back-to-back windows of
  ``horizon`` seconds; each window is simulated *open loop* (RK4 at the sampling period)
  from the recorded (filtered) state at its start with the recorded inputs held over each
  sample (and the recorded vx for the bicycle); RMS of (simulated − recorded) state over all
  windows and steps. Closed-loop recordings: the controller is not modelled — its recorded
  output is replayed — so within a window the model's errors are not corrected by feedback,
  which is what makes the short horizon a fair test of the dynamics.

``score`` condenses each model's simulation errors into one number: the RMS over states of
rollout RMSE / state std on the test part.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from simgap.diagnosis.forms import Prepared

#: Rows per block where the model derivative on the test part is evaluated in blocks.
BLOCK_ROWS = 1 << 15


@dataclass
class Comparison:
    """Errors of the nominal and augmented models on the test part.

    Attributes:
        split: (t0, t_split, t_end) in s.
        derivative_rmse: {"nominal": [...], "augmented": [...]} per derivative channel.
        rollout_rmse: {"nominal": [...], "augmented": [...]} per state.
        score: {"nominal": x, "augmented": y}, dimensionless.
        horizon: simulation window (s).
        example: arrays for the figure: t, recorded, nominal, augmented states over the
            consecutive windows.
    """

    split: tuple[float, float, float]
    derivative_rmse: dict[str, list[float]]
    rollout_rmse: dict[str, list[float]]
    score: dict[str, float]
    horizon: float
    example: dict[str, np.ndarray]


def simulate(form: Any, prepared: Prepared, starts: np.ndarray, steps: int,
             effects: Sequence[tuple]) -> np.ndarray:
    """Simulate windows open loop from the recorded states at rows ``starts``.

    Each window replays the recorded inputs (RK4 at the sampling period, the form's
    :meth:`~simgap.diagnosis.forms.ResidualForm.step`); a diverged state becomes NaN.

    Returns:
        States of shape (steps + 1, n_windows, n_states).
    """
    dt = prepared.dt
    s = prepared.state_at(starts)
    out = [s]
    for k in range(steps):
        s = form.step(prepared, s, starts + k, effects, dt)
        if not np.all(np.isfinite(s)):
            s = np.where(np.isfinite(s), s, np.nan)
        out.append(s)
    return np.stack(out)


def compare(system: Any, prepared: Prepared, effects: Sequence[tuple], t_split: float,
            horizon: float | None = None, example_windows: int | None = None
            ) -> Comparison:
    """Compare the nominal and the augmented model on the part after ``t_split``.

    Args:
        system: the residual form.
        prepared: the recording as the form prepared it.
        effects: fitted effects as (effect, index, lin, nl) tuples.
        t_split: start of the test part (s).
        horizon: simulation window (s); default the adapter's ``rollout_horizon``.
        example_windows: consecutive windows kept for the figure (default: all, the whole
            test part).
    """
    t = prepared.t
    dt = float(t[1] - t[0])
    horizon = float(horizon or system.rollout_horizon)
    edge = prepared.smoother.window
    test = np.where(t >= t_split)[0]
    test = test[(test >= edge) & (test < len(t) - edge)]
    meas = prepared.derivative_at(test)
    der = {}
    for label, eff in (("nominal", []), ("augmented", effects)):
        # per row, in blocks of rows: the model's transients (mass matrices, effect
        # regressors) stay of a fixed size on a long log; the same numbers per row
        pred = np.concatenate([system.derivative(prepared, test[a:a + BLOCK_ROWS], eff)
                               for a in range(0, len(test), BLOCK_ROWS)]) if len(test) \
            else system.derivative(prepared, test, eff)
        der[label] = [float(v) for v in np.sqrt(np.mean((pred - meas) ** 2, axis=0))]
        del pred
    steps = max(1, int(round(horizon / dt)))
    starts = np.arange(test[0], test[-1] - steps, steps)
    segment = prepared.segment
    if segment is not None and len(starts):  # a rollout never runs across a time gap
        starts = starts[segment[starts] == segment[np.minimum(starts + steps, len(t) - 1)]]
    if len(starts) == 0:
        starts = np.array([test[0]])
        steps = max(1, len(test) - 2)
    rec = np.stack([prepared.state_at(starts + k) for k in range(steps + 1)])
    scale = np.std(prepared.state_at(test), axis=0)
    scale = np.where(scale > 0, scale, 1.0)
    roll, score, sims = {}, {}, {}
    for label, eff in (("nominal", []), ("augmented", effects)):
        sim = simulate(system, prepared, starts, steps, eff)
        err = np.sqrt(np.nanmean((sim - rec) ** 2, axis=(0, 1)))
        roll[label] = [float(v) for v in err]
        score[label] = float(np.sqrt(np.mean((err / scale) ** 2)))
        sims[label] = sim
    n_ex = len(starts) if example_windows is None else min(example_windows, len(starts))
    ex_t = np.concatenate([t[starts[i]:starts[i] + steps + 1] for i in range(n_ex)])
    example = {"t": ex_t,
               "recorded": np.concatenate([rec[:, i] for i in range(n_ex)]),
               "nominal": np.concatenate([sims["nominal"][:, i] for i in range(n_ex)]),
               "augmented": np.concatenate([sims["augmented"][:, i] for i in range(n_ex)]),
               "breaks": t[starts[:n_ex]], "window_len": np.array(steps + 1)}
    return Comparison(split=(float(t[0]), float(t_split), float(t[-1])), derivative_rmse=der,
                      rollout_rmse=roll, score=score, horizon=horizon, example=example)
