"""Joint identifiability and the held-out predictive-gain test, on cases with known answers."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.signal import lfilter

from simgap.diagnosis.identifiability import analyse
from simgap.diagnosis.significance import predictive_gain
from simgap.errors import DiagnosisError


def _columns(n=2000, seed=0):
    rng = np.random.default_rng(seed)
    t = np.linspace(0, 10, n)
    a = np.sin(t) + 0.1 * rng.normal(size=n)
    b = np.cos(2.3 * t) + 0.1 * rng.normal(size=n)
    return a, b


def test_a_joint_symmetry_no_pair_shows_is_found():
    a, b = _columns()
    c = a + b                      # three regressors, no two collinear, jointly rank 2
    j = np.column_stack([a, b, c])
    pair_corr = max(abs(np.corrcoef(a, c)[0, 1]), abs(np.corrcoef(b, c)[0, 1]),
                    abs(np.corrcoef(a, b)[0, 1]))
    assert pair_corr < 0.8
    res = analyse(j, ["m", "Iz", "mu"])
    assert not res.identifiable
    assert len(res.unidentifiable) == 1
    assert set(res.unidentifiable[0].weights) == {"m", "Iz", "mu"}
    assert "cannot be determined" in res.unidentifiable[0].describe()
    full = analyse(np.column_stack([a, b]), ["m", "Iz"])
    assert full.identifiable and full.condition < 10


def test_verdict_does_not_depend_on_units_or_input_rounding():
    a, b = _columns(seed=1)
    c = a + b + 1e-7 * np.random.default_rng(2).normal(size=a.size)   # near-collinear
    base = analyse(np.column_stack([a, b, c]), ["x", "y", "z"])
    other_units = analyse(np.column_stack([1000 * a, b / 3.6, c * 57.29577951308232]),
                          ["x", "y", "z"])
    rounded = analyse(np.column_stack([np.round(a, 6), np.round(b, 6), np.round(c, 6)]),
                      ["x", "y", "z"])
    assert not base.identifiable and not other_units.identifiable and not rounded.identifiable
    np.testing.assert_allclose(base.singular_values, other_units.singular_values, rtol=1e-9)


def test_statistical_test_flags_a_direction_the_noise_swamps():
    a, b = _columns(seed=3)
    c = a + b + 0.02 * np.random.default_rng(4).normal(size=a.size)
    j = np.column_stack([a, b, c])
    values = [0.3, 0.2, 0.1]
    assert analyse(j, ["x", "y", "z"], noise_std=1e-4, values=values).identifiable
    assert not analyse(j, ["x", "y", "z"], noise_std=1.0, values=values).identifiable


def test_identifiability_rejects_bad_input():
    with pytest.raises(DiagnosisError, match="does not match"):
        analyse(np.zeros((10, 2)), ["a"])
    with pytest.raises(DiagnosisError, match="non-finite"):
        analyse(np.full((10, 1), np.nan), ["a"])


def test_gain_test_finds_a_real_gain_and_reports_its_size():
    rng = np.random.default_rng(5)
    n = 5000
    noise = rng.normal(0, 0.1, n)
    effect = 0.3 * np.sign(np.sin(np.linspace(0, 60, n)))
    res = predictive_gain(noise + effect, noise)
    assert res.testable and res.p_value < 1e-6
    assert res.share_removed == pytest.approx(0.9, abs=0.05)


def test_gain_test_holds_its_level_on_correlated_residuals():
    # Two equally good models with strongly correlated errors: a naive per-sample t-test
    # calls one of them better far too often; the blocked test stays near its level.
    hits_blocked = hits_naive = 0
    trials = 200
    from scipy import stats
    for seed in range(trials):
        rng = np.random.default_rng(100 + seed)
        e0 = lfilter([1.0], [1.0, -0.95], rng.normal(size=3000))
        e1 = lfilter([1.0], [1.0, -0.95], rng.normal(size=3000))
        res = predictive_gain(e0, e1)
        hits_blocked += res.p_value < 0.05
        d = e0**2 - e1**2
        hits_naive += stats.ttest_1samp(d, 0.0, alternative="greater").pvalue < 0.05
    assert hits_blocked / trials < 0.10
    assert hits_naive / trials > 0.15


def test_gain_test_says_when_it_cannot_test():
    rng = np.random.default_rng(6)
    e = lfilter([1.0], [1.0, -0.999], rng.normal(size=300))
    res = predictive_gain(e, 0.5 * e)
    assert not res.testable and "independent blocks" in res.reason
    with pytest.raises(DiagnosisError):
        predictive_gain(np.zeros(3), np.zeros(4))


def test_blocks_stay_inside_segments():
    rng = np.random.default_rng(7)
    e1 = rng.normal(size=1000)
    e0 = e1 + 0.5                  # the candidate removes a constant offset
    seg = np.repeat([0, 1], 500)
    whole = predictive_gain(e0, e1)
    split = predictive_gain(e0, e1, segments=seg)
    assert split.blocks <= whole.blocks
    assert split.testable and split.p_value < 1e-3


def test_correlated_pair_whose_sizes_cancel_is_still_determined():
    """Viscous and Coulomb friction on a back-and-forth motion (real EMPS at 100 Hz).

    Their regressors (q̇ and sign q̇) are correlated +0.94; with b·‖q̇‖ ≈ Fc·‖sign q̇‖ the
    signed projection of the fitted values on the weak direction is ≈ 0, yet each parameter
    is determined to a few per cent. A signed-projection test called the pair "not
    determined" and b alone then took the Coulomb force (b = 414 N·s/m instead of 205).
    """
    t = np.arange(0.0, 25.0, 0.01)
    v = 0.1 * np.clip(2.0 * np.sin(2 * np.pi * t / 6.2), -1.0, 1.0)   # trapezoid, m/s
    j = np.column_stack([v, np.sign(v), np.ones_like(v)])
    assert np.corrcoef(v, np.sign(v))[0, 1] > 0.9
    fc = 20.0
    b = fc * np.linalg.norm(j[:, 1]) / np.linalg.norm(j[:, 0])        # equal scaled sizes
    values = [b, fc, -3.0]
    noise = 0.02 * fc * np.sqrt(v.size)   # marginal standard errors of a few per cent
    se = noise * np.sqrt(np.diag(np.linalg.inv(j.T @ j)))
    assert np.all(se[:2] / np.abs(values[:2]) < 0.1)
    assert analyse(j, ["b", "Fc", "tau0"], noise_std=noise, values=values).identifiable
    # the same pair with sizes the noise swamps is still flagged
    small = [0.02 * b, 0.02 * fc, -3.0]
    assert not analyse(j, ["b", "Fc", "tau0"], noise_std=noise, values=small).identifiable
