"""Residual, noise floor, non-uniform sampling, locating."""

from __future__ import annotations

import numpy as np

from simgap.diagnosis import locate
from simgap.diagnosis.generate import InjectedEffect, generate_bicycle, generate_manipulator
from simgap.diagnosis.pipeline import diagnose
from simgap.diagnosis.residual import choose_window, noise_std, uniform_grid
from simgap.diagnosis.systems import MechanicalSystem
from simgap.models.manipulator import ManipulatorNominal
from simgap.recordings import Recording


def test_noise_std_estimate():
    rng = np.random.default_rng(0)
    t = np.linspace(0, 10, 5000)
    x = np.sin(t) + rng.normal(0, 0.01, t.size)
    assert abs(noise_std(x) - 0.01) < 0.001


def test_window_adapts_to_noise():
    t = np.arange(5000) * 0.002
    rng = np.random.default_rng(1)
    clean = np.sin(2 * np.pi * 0.5 * t)
    w_lo = choose_window([clean + rng.normal(0, 1e-4, t.size)], 0.002)
    w_hi = choose_window([clean + rng.normal(0, 1e-2, t.size)], 0.002)
    assert w_lo < w_hi and w_lo % 2 == 1 and w_hi <= 0.15 / 0.002 + 1


def test_clean_residual_matches_noise_floor():
    rec = generate_manipulator([], duration=6, seed=4)
    res = MechanicalSystem(ManipulatorNominal()).prepare(rec)
    ratio = np.sqrt(np.mean(res.residual**2, axis=0)) / res.noise_rms
    assert np.all((ratio > 0.8) & (ratio < locate.SIGNIFICANCE)), ratio


def test_injected_torque_is_the_residual():
    """The residual of a recording with a known bias is that bias (N·m) plus noise."""
    rec = generate_manipulator([InjectedEffect(effect="torque_bias", channel="joint1",
                                               params={"tau0": 0.3})], duration=6, seed=4)
    res = MechanicalSystem(ManipulatorNominal()).prepare(rec)
    assert abs(np.mean(res.residual[:, 0]) - 0.3) < 0.01
    assert abs(np.mean(res.residual[:, 1])) < 0.01


def test_non_uniform_time_is_resampled():
    rec = generate_manipulator([InjectedEffect(effect="coulomb_friction", channel="joint2",
                                               params={"Fc": 0.2})], duration=8, seed=5)
    rng = np.random.default_rng(0)
    keep = np.sort(rng.choice(rec.n, size=int(rec.n * 0.8), replace=False))
    cols = {k: v[keep] for k, v in rec.columns.items()}
    t, _, resampled = uniform_grid(cols["t"], cols)
    assert resampled and np.allclose(np.diff(t), np.diff(t)[0])
    rep = diagnose(Recording("jitter", cols), "manipulator2dof")
    assert rep.data["processing"]["resampled_to_uniform_grid"]
    fc = [e for e in rep.effects if e["effect"] == "coulomb_friction"]
    assert fc and fc[0]["channel"] == "joint2" and abs(fc[0]["parameters"]["Fc"] - 0.2) < 0.04


def test_locate_regions_words():
    rec = generate_bicycle([InjectedEffect(effect="tire_saturation", params={"mu": 0.6})],
                           duration=20, seed=2)
    rep = diagnose(rec, "bicycle")
    mm = rep.data["mismatch"]
    assert mm["significant"] and all(c["significant"] for c in mm["channels"])
    front = [r for r in mm["regions"] if r["channel"] == "front_axle"]
    assert front[0]["variable"] in ("alpha_f", "ay")
    assert "grows with |" in front[0]["text"] and "flips sign" in front[0]["text"]
    assert mm["segments"] and all(s["t_end"] > s["t_start"] for s in mm["segments"])


def test_segments_find_the_burst():
    t = np.arange(10000) * 0.001
    rng = np.random.default_rng(0)
    r = rng.normal(0, 0.01, t.size)
    r[(t > 4.0) & (t < 4.5)] += 0.2
    segs = locate.segments(t, r, 0.01, "joint1")
    assert len(segs) >= 1
    s = max(segs, key=lambda s: s["t_end"] - s["t_start"])
    assert 3.8 < s["t_start"] < 4.1 and 4.4 < s["t_end"] < 4.7


def test_regions_constant_offset():
    rng = np.random.default_rng(0)
    x = rng.normal(size=4000)
    regs = locate.regions("joint1", "N·m", 0.5 + rng.normal(0, 0.05, 4000),
                          {"dq1": (x, "rad/s")})
    assert regs[0]["variable"] == "constant" and "offset" in regs[0]["text"]


def test_collinear_effects_warn():
    """Two hypotheses that this data cannot tell apart: one is reported, with a warning."""
    from simgap.diagnosis.effects import Effect
    from simgap.diagnosis.fit import Fitter, Term
    from simgap.diagnosis.forms import Prepared
    from simgap.diagnosis.residual import Smoother

    rng = np.random.default_rng(0)
    n = 4000
    t = np.arange(n) * 0.01
    x = np.sin(0.7 * t) + 0.3 * np.sin(2.3 * t)

    class Fake:
        channels = ("c",)

        def context(self, prepared, terms=()):
            return None

        def locate_variables(self, prepared):
            return {}

    def prepared(residual, noise):
        return Prepared(t=t, residual=residual, noise_rms=noise, signals={"x": x, "t": t},
                        raw={}, smoother=Smoother(5, 0.01), resampled=False, column_noise={},
                        inputs=np.zeros((n, 0)), fit_mask=np.ones(residual.shape, dtype=bool),
                        state=np.zeros((n, 0)), state_derivative=np.zeros((n, 0)),
                        derivatives=())

    def fa(lin, nl, sig, i, sys):
        return (lin[0] * sig["x"])[:, None]

    def fb(lin, nl, sig, i, sys):  # nearly the same regressor: not separable on this data
        return (lin[0] * (sig["x"] + 0.02 * np.sin(5.0 * sig["t"])))[:, None]

    ea = Effect(name="alpha", label="alpha", scope="joint", lin=("a",), lin_units=("-",),
                lin_lower=(-np.inf,), fn=fa)
    eb = Effect(name="beta", label="beta", scope="joint", lin=("b",), lin_units=("-",),
                lin_lower=(-np.inf,), fn=fb)
    r = (0.5 * x + rng.normal(0, 0.05, n))[:, None]
    sel = Fitter(Fake(), prepared(r, np.array([0.05]))).select([Term(ea, 0, "c"),
                                                                 Term(eb, 0, "c")])
    assert len(sel.fit.terms) == 1
    assert sel.warnings and set(sel.warnings[0]["effects"]) == {"alpha", "beta"}
    text = sel.warnings[0]["text"]
    # the selection could not separate them; the later held-out part may (then it says
    # which one it prefers, and that one is named)
    assert "cannot be told apart" in text or "could not be told apart by the selection" in text
    if "separates them" in text:
        better = text.split("separates them: ")[1].split(" is better")[0]
        assert sel.fit.terms[0].effect.label == better
