"""EMPS under the nonlinear-system-identification benchmark protocol (issue 13).

Protocol (nonlinearbenchmark.org; official loader ``nonlinear_benchmarks.EMPS()``): train on
the estimation set ``DATA_EMPS`` and test on ``DATA_EMPS_PULSES``; the input is the
controller output ``vir`` (V), the output the motor position ``qm`` (m, load side); the
model *simulates* the test output from the test input alone (open loop, no measured output
fed back), and the first 20 test samples may be used to initialise the model's state. The
score is the RMSE of the simulated output, in the benchmark's unit (m), here over the test
samples after that initialisation window.

What is simulated here:

* **simgap augmented**: ``simgap diagnose`` on the estimation file only (the rigid-mass
  nominal of ``examples/emps_model.py`` plus the effects the diagnosis names and fits), then
  the augmented model's ``f(x, u)`` (x = (q, dq), u = gtau·vir in N), RK4 at the 1 ms sample
  period with the input held over each sample;
* **nominal**: the same without the named effects (rigid mass, no friction);
* **published physics**: the benchmark authors' IDIM-LS model (M, Fv, Fc, offset from the
  EMPS description) through the same integrator, for scale.

Initial state: q(0) = qm(0) and dq(0) = the slope of a straight line through the first 20
test samples (the allowed initialisation window).

The plant is a pure integrator under closed-loop control; an open-loop simulation from
``vir`` drifts, so every model's position error grows over the 24.8 s test set. Published
results for comparison are those quoted in issue 13 (LSTM 0.074, RNN 0.089, FIR-MLP 0.121,
GRU 0.220 "in the benchmark's units"); their source and evaluation window could not be
checked here.

    .venv/bin/python benchmarks/emps_protocol.py --out benchmarks/results/emps_protocol.json
    .venv/bin/python benchmarks/emps_protocol.py --test-seconds 2   # quick variant
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd
from _results import emit

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT.parent / "shared" / "data" / "real" / "emps"
MODEL_SPEC = f"{ROOT / 'examples' / 'emps_model.py'}:EMPS"
#: Samples at the start of the test set that may initialise the state (official loader).
INIT_WINDOW = 20
#: EMPS description, IDIM-LS: kg, N·s/m, N, N.
PUBLISHED_PHYSICS = {"M": 95.1089, "Fv": 203.5034, "Fc": 20.3935, "offset": -3.1648}
#: Simulation RMSE on the test set as quoted in issue 13 (benchmark's units, taken as m).
QUOTED = {"LSTM": 0.074, "RNN": 0.089, "FIR-MLP": 0.121, "GRU": 0.220}


def rk4(f, x0: np.ndarray, u: np.ndarray, dt: float) -> np.ndarray:
    """States (N, n) of x' = f(x, u_k) from x0, RK4 with the input held over each step."""
    xs = np.empty((len(u), len(x0)))
    x = np.asarray(x0, dtype=float)
    for k in range(len(u)):
        xs[k] = x
        uk = u[k:k + 1]
        k1 = f(x, uk)
        k2 = f(x + 0.5 * dt * k1, uk)
        k3 = f(x + 0.5 * dt * k2, uk)
        k4 = f(x + dt * k3, uk)
        x = x + dt / 6.0 * (k1 + 2 * k2 + 2 * k3 + k4)
        if not np.all(np.isfinite(x)):
            xs[k + 1:] = np.nan
            break
    return xs


def published_f(sigma: float):
    """The benchmark's IDIM-LS model, Coulomb smoothed as sign ≈ tanh(dq / sigma)."""
    p = PUBLISHED_PHYSICS

    def f(x, u):
        q, dq = x
        ddq = (u[0] - p["Fv"] * dq - p["Fc"] * np.tanh(dq / sigma) - p["offset"]) / p["M"]
        return np.array([dq, ddq])
    return f


def run(test_seconds: float | None) -> dict:
    from simgap._log import log
    from simgap.diagnosis import diagnose
    from simgap.diagnosis.user_models import load_model_file
    from simgap.models.base import MechanicalNominalModel

    model = load_model_file(MODEL_SPEC)
    from scipy.io import loadmat

    gtau = float(loadmat(DATA / "DATA_EMPS_PULSES.mat")["gtau"].squeeze())  # N/V
    log("diagnosing the estimation set (DATA_EMPS)")
    t0 = time.perf_counter()
    rep = diagnose(DATA / "emps_estimation.csv", MODEL_SPEC)
    diag_s = time.perf_counter() - t0
    aug = rep.augmented
    assert isinstance(aug, MechanicalNominalModel)
    test = pd.read_csv(DATA / "emps_validation_pulses.csv")
    t = test["t_s"].to_numpy()
    y = test["qm_m"].to_numpy()
    u = gtau * test["vir_V"].to_numpy()
    if test_seconds is not None:
        keep = t <= t[0] + test_seconds
        t, y, u = t[keep], y[keep], u[keep]
    dt = float(np.median(np.diff(t)))
    slope = np.polyfit(t[:INIT_WINDOW] - t[0], y[:INIT_WINDOW], 1)[0]
    x0 = np.array([y[0], slope])
    sigma = float(np.atleast_1d(aug.coulomb_sigma)[0])
    models = {"simgap_augmented": aug.f, "nominal": model.f,
              "published_physics": published_f(sigma)}
    results = {}
    for name, f in models.items():
        log(f"simulating the test set open loop: {name}")
        t0 = time.perf_counter()
        xs = rk4(f, x0, u, dt)
        err = xs[INIT_WINDOW:, 0] - y[INIT_WINDOW:]
        finite = np.isfinite(err)
        results[name] = {
            "rmse_m": float(np.sqrt(np.mean(err ** 2))) if finite.all() else None,
            "rmse_mm": float(1e3 * np.sqrt(np.mean(err ** 2))) if finite.all() else None,
            "max_abs_error_m": float(np.max(np.abs(err))) if finite.all() else None,
            "final_error_m": float(err[-1]) if finite.all() else None,
            "diverged": bool(not finite.all()),
            "simulate_s": round(time.perf_counter() - t0, 2)}
    return {
        "benchmark": "EMPS, nonlinear-system-identification benchmark protocol: train on "
                     "DATA_EMPS, simulate DATA_EMPS_PULSES open loop from vir, RMSE of qm",
        "gtau_N_per_V": gtau,
        "protocol": {"train": "emps_estimation.csv (DATA_EMPS.mat)",
                     "test": "emps_validation_pulses.csv (DATA_EMPS_PULSES.mat)",
                     "input": "vir (V), applied as gtau·vir (N)", "output": "qm (m)",
                     "init_window_samples": INIT_WINDOW,
                     "rmse_over": f"test samples {INIT_WINDOW}..{len(y) - 1}",
                     "test_seconds": float(t[-1] - t[0]),
                     "simulation": "open loop, RK4 at the 1 ms sample period, input held "
                                   "over each sample; x0 = (qm[0], slope of qm over the "
                                   "first 20 samples)"},
        "effects_named": [{"effect": e["effect"], "channel": e["channel"],
                           "parameters": e["parameters"]} for e in rep.effects],
        "diagnose_s": round(diag_s, 2),
        "results": results,
        "output_range_m": float(np.ptp(y)),
        "published_quoted_rmse": {"values": QUOTED,
                                  "unit": "the benchmark's output unit (m), as quoted",
                                  "source": "quoted in issue 13; not verified here"},
        "published_physics_parameters": PUBLISHED_PHYSICS,
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=None, help="also write the JSON here")
    ap.add_argument("--test-seconds", type=float, default=None,
                    help="simulate only the first seconds of the test set (quick check)")
    args = ap.parse_args()
    if not DATA.is_dir():
        sys.exit(f"error: {DATA}: the shared EMPS data folder is missing")
    emit(run(args.test_seconds), args.out)


if __name__ == "__main__":
    main()
