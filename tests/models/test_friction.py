"""Named friction terms and presets (thesis eq. 4.7)."""

from __future__ import annotations

import numpy as np
import pytest

from simgap.models import friction as fr


def test_terms_values_and_odd_symmetry():
    dq = np.linspace(-2, 2, 41)
    np.testing.assert_allclose(fr.coulomb(dq, 0.1, 6.67e-4), 0.1 * np.tanh(dq / 6.67e-4))
    np.testing.assert_allclose(fr.viscous(dq, 0.5), 0.5 * dq)
    s = fr.stribeck(dq, 0.3, 0.1, 0.05, 6.67e-4)
    np.testing.assert_allclose(s, -s[::-1], atol=1e-15)
    assert fr.stribeck(0.01, 0.3, 0.1, 0.05, 6.67e-4) == pytest.approx(
        0.2 * np.exp(-(0.2**2)) * np.tanh(0.01 / 6.67e-4))


def test_thesis_preset_is_eq_4_7():
    p = fr.FRICTION_MODELS["thesis"]
    dq = np.array([0.3, -0.01])
    np.testing.assert_allclose(p.torque(dq), 0.1 * np.tanh(dq / 6.67e-4) + 0.5 * dq)


def test_resolve_friction_errors():
    assert fr.resolve_friction("none") is None
    with pytest.raises(ValueError, match="unknown friction model 'bogus'"):
        fr.resolve_friction("bogus")
    with pytest.raises(ValueError, match="sigma"):
        fr.FrictionParams(sigma=0.0)
