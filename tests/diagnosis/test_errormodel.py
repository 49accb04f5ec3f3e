"""The per-column error model against artefacts whose truth is known."""

from __future__ import annotations

import numpy as np
import pytest

from simgap.diagnosis import artefacts
from simgap.diagnosis.errormodel import (
    autocorrelation_time,
    column_error_model,
    effective_samples,
    quantisation_step,
    white_noise_std,
)
from simgap.diagnosis.residual import noise_std
from simgap.recordings import Recording


def _motion(rate: float, duration: float = 20.0):
    t = np.arange(0.0, duration, 1.0 / rate)
    q = 0.8 * np.sin(2 * np.pi * 0.7 * t) + 0.3 * np.sin(2 * np.pi * 2.3 * t + 1.0)
    dq = 0.8 * 2 * np.pi * 0.7 * np.cos(2 * np.pi * 0.7 * t) \
        + 0.3 * 2 * np.pi * 2.3 * np.cos(2 * np.pi * 2.3 * t + 1.0)
    return t, q, dq


def test_white_noise_estimate_at_500hz_matches_truth():
    rng = np.random.default_rng(0)
    _, q, _ = _motion(500.0)
    sigma = 1e-3
    est, _ = white_noise_std(q + rng.normal(0.0, sigma, q.size))
    assert est == pytest.approx(sigma, rel=0.05)


def test_coarse_sampling_keeps_signal_out_of_the_noise():
    # 100 Hz with a 5 Hz component: the third-difference estimate is biased by the signal.
    rng = np.random.default_rng(1)
    t = np.arange(0.0, 20.0, 0.01)
    x = np.sin(2 * np.pi * 5.0 * t)
    sigma = 1e-3
    noisy = x + rng.normal(0.0, sigma, t.size)
    old = noise_std(noisy)
    new, order = white_noise_std(noisy)
    assert old > 3 * sigma            # the old estimate mistakes signal for noise here
    assert new == pytest.approx(sigma, rel=0.15)
    assert order > 3


def test_quantised_encoder_is_detected_with_its_floor():
    t, q, dq = _motion(500.0)
    rec = Recording("r", {"t": t, "q": q, "dq": dq})
    step = 2 * np.pi / 4096
    qrec = artefacts.ARTEFACTS["quantised_encoder"].apply(rec, {"dq": "q"},
                                                          np.random.default_rng(0))
    assert quantisation_step(qrec["q"]) == pytest.approx(step, rel=1e-9)
    m = column_error_model("q", qrec["q"])
    assert m.quantum == pytest.approx(step, rel=1e-9)
    assert m.floor_std == pytest.approx(step / np.sqrt(12.0), rel=1e-9)
    assert m.heavy_tailed and "quantised" in m.notes[0]
    # The unquantised column is not called quantised, nor heavy-tailed with white noise.
    noisy = q + np.random.default_rng(2).normal(0.0, 1e-3, q.size)
    clean_model = column_error_model("q", noisy)
    assert clean_model.quantum is None and not clean_model.heavy_tailed


def test_upstream_denoised_velocity_is_flagged():
    rng = np.random.default_rng(3)
    t, q, dq = _motion(500.0)
    noisy = dq + rng.normal(0.0, 0.05, dq.size)
    rec = Recording("r", {"t": t, "q": q, "dq": noisy})
    den = artefacts.upstream_denoise(rec, ["dq"])
    m = column_error_model("dq", den["dq"])
    assert m.heavy_tailed and "filtered" in m.notes[0]
    # Its MAD noise is far below its real error: the reason it must not be trusted.
    real_error = float(np.std(den["dq"] - dq))
    assert m.white_std < 0.3 * real_error
    assert not column_error_model("dq", noisy).heavy_tailed


def test_effective_samples_of_ar1_noise():
    rng = np.random.default_rng(4)
    phi, n = 0.9, 200_000
    from scipy.signal import lfilter
    e = lfilter([1.0], [1.0, -phi], rng.normal(size=n))
    expected_tau = (1 + phi) / (1 - phi)            # 19 samples
    assert autocorrelation_time(e) == pytest.approx(expected_tau, rel=0.15)
    assert effective_samples(rng.normal(size=n)) == pytest.approx(n, rel=0.05)


def test_artefacts_are_seeded_and_record_what_they_did():
    t, q, dq = _motion(500.0)
    rec = Recording("r", {"t": t, "q": q, "dq": dq, "u": np.cos(t)})
    for name, art in artefacts.ARTEFACTS.items():
        a = art.apply(rec, {"dq": "q"}, np.random.default_rng(7))
        b = art.apply(rec, {"dq": "q"}, np.random.default_rng(7))
        assert a.meta["artefacts"], name
        for c in a.columns:
            np.testing.assert_array_equal(a[c], b[c])
        assert np.all(np.diff(a.t) > 0), name
    short = artefacts.ARTEFACTS["short_15s"].apply(rec, {}, np.random.default_rng(0))
    assert short.t[-1] - short.t[0] <= 15.0
    gap = artefacts.ARTEFACTS["gap"].apply(rec, {}, np.random.default_rng(0))
    assert np.max(np.diff(gap.t)) > 4.0
    coarse = artefacts.ARTEFACTS["coarse_100hz"].apply(rec, {}, np.random.default_rng(0))
    assert np.median(np.diff(coarse.t)) == pytest.approx(0.01)


def test_kinks_of_the_signal_are_not_upstream_filtering():
    """Heavy tails from the signal (velocity kinks at 100 Hz) keep a white top band; an
    upstream median + wavelet denoiser removes it. Only the latter is ``filtered_upstream``."""
    rng = np.random.default_rng(5)
    t = np.arange(0.0, 20.0, 0.01)
    # a velocity with a kink (slope jump) at every zero: |sin|, as when friction reverses
    dq = np.abs(np.sin(2 * np.pi * 0.4 * t)) + rng.normal(0.0, 2e-3, t.size)
    kinked = column_error_model("dq", dq)
    assert kinked.heavy_tailed and kinked.kurtosis > 6.0   # the old test flagged it
    assert kinked.flatness > 0.8 and not kinked.filtered_upstream
    assert "kinks of the signal" in kinked.notes[0]
    rec = Recording("r", {"t": t, "q": np.cumsum(dq) * 0.01, "dq": dq})
    den = column_error_model("dq", artefacts.upstream_denoise(rec, ["dq"])["dq"])
    assert den.filtered_upstream and den.flatness < 0.5
