"""Additive "explained" shares of the held-out residual (Shapley decomposition).

The diagnosis names a set of effects with fitted contributions p₁ … pₙ. On the held-out
(test) rows, with every channel whitened by its noise floor, the squared error left by a
subset S of them is

    SSE(S) = ‖r − Σ_{i∈S} pᵢ‖²,

and the reduction that all of them achieve together is R = SSE(∅) − SSE(all). Each effect's
*share* is its Shapley value of that reduction divided by SSE(∅): the average, over every
order in which the effects could be added, of how much adding it lowers SSE. Because SSE is
a quadratic in the contributions the average has a closed form,

    φᵢ = 2⟨r, pᵢ⟩ − ‖pᵢ‖² − Σ_{j≠i} ⟨pᵢ, pⱼ⟩,

each effect's own reduction minus half of every overlap it has with another effect. The
shares are therefore additive by construction,

    Σᵢ φᵢ / SSE(∅) + SSE(all) / SSE(∅) = 1,

i.e. the named effects' shares plus the unexplained share are exactly 100 %, and they do not
depend on the order of selection. A share can be negative: an effect that, given the others,
makes the held-out error larger (the report then says so instead of clipping it).
No refitting is involved: the contributions are the fitted ones.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

#: How the shares are defined (printed in report.md / report.html).
METHOD = ("Shapley decomposition of the held-out squared-error reduction: each effect's "
          "share is its average reduction of the test part's noise-whitened squared "
          "residual over every order of adding the named effects (its own reduction minus "
          "half of each overlap with another effect), divided by the squared residual of "
          "the nominal model; the shares and the unexplained share add up to exactly 100 %")


def shapley_reductions(r: np.ndarray, preds: Sequence[np.ndarray]) -> np.ndarray:
    """Shapley values φᵢ of the squared-error reduction ‖r‖² − ‖r − Σ pᵢ‖².

    Args:
        r: residual on the rows and channels that count, any shape.
        preds: each effect's contribution on the same rows and channels (same shape).

    Returns:
        φ (n,), with Σ φ = ‖r‖² − ‖r − Σ pᵢ‖² (to rounding).
    """
    if not preds:
        return np.zeros(0)
    p = np.stack([np.asarray(x, dtype=float).ravel() for x in preds])
    rv = np.asarray(r, dtype=float).ravel()
    gram = p @ p.T
    own = 2.0 * (p @ rv) - np.diag(gram)
    overlap = gram.sum(axis=1) - np.diag(gram)
    return own - overlap


def explained_section(r: np.ndarray, preds: Sequence[np.ndarray],
                      effects: Sequence[dict[str, Any]], channels: Sequence[str],
                      noise_share: float) -> dict[str, Any]:
    """The report's ``explained`` section (additive shares; see the module docstring).

    Args:
        r: whitened held-out residual on the counted channels (rows, C').
        preds: whitened held-out contribution of each named effect (rows, C'), in the
            order of ``effects``.
        effects: the report's effect entries (``effect``, ``channel``), same order.
        channels: names of the counted channels.
        noise_share: share of SSE(∅) that white noise at the floor would leave.

    Returns:
        ``{"method", "channels", "effects": [{"effect", "channel", "share"}],
        "unexplained", "noise"}``; shares are fractions of SSE(∅) and add up with
        ``unexplained`` to 1.
    """
    base = float(np.sum(np.asarray(r, dtype=float) ** 2))
    phi = shapley_reductions(r, preds)
    shares = phi / base if base > 0 else np.zeros_like(phi)
    return {
        "method": METHOD,
        "channels": list(channels),
        "effects": [{"effect": e["effect"], "channel": e["channel"], "share": float(s)}
                    for e, s in zip(effects, shares, strict=True)],
        "unexplained": float(1.0 - shares.sum()) if base > 0 else 1.0,
        "noise": float(noise_share),
    }
