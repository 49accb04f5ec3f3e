"""The one network of all identifiers: ĝ = Ŵ tanh(V̂ x̄) (thesis Sec. 3.1).

Sizes: x̄ has p = n + m entries (identifier state or estimate, then input), the hidden
layer n_h units, the output n entries (state units/s). No bias terms. Every evaluation,
inside the update kernels and in :func:`network_forward` / ``Identifier.predict``, goes
through :func:`forward` (with the vectorised tanh of :mod:`~simgap.identifiers.activation`),
so the online output and a later re-evaluation of the same weights agree bit for bit.

Flat weight layout (one identifier, starting at offset ``ow`` of a float64 row):
``[ow : ow + n·n_h]`` is Ŵ (n × n_h, row-major), then ``n_h·p`` entries of V̂ᵀ (p × n_h,
row-major, i.e. V̂ stored column by column). Keeping the hidden index innermost in both
matrices makes every loop of the forward pass and of the update run over contiguous hidden
units, which LLVM vectorises.
"""

from __future__ import annotations

import numpy as np
from numba import njit
from numba import uint64 as _ix  # unsigned indices: no wrap-around check, loops vectorise

from simgap.identifiers.activation import tanh_into
from simgap.identifiers.errors import IdentifierError
from simgap.models.nbcache import guard_cache


@njit(cache=True, inline="always")
def mat_t_vec(M, om, rows, h, v, ov, y, oy):  # pragma: no cover - compiled
    """Product y = Mᵀ v for the row-major (rows × h) block ``M[om:]``: y_j = Σ_r M_rj v_r.

    ``v`` at ``v[ov : ov + rows]``, ``y`` written to ``y[oy : oy + h]``; summed over r in
    order, vectorised over j.
    """
    for j in range(h):
        y[_ix(oy + j)] = 0.0
    for r in range(rows):
        vr = v[_ix(ov + r)]
        base = om + r * h
        for j in range(h):
            y[_ix(oy + j)] += M[_ix(base + j)] * vr


@njit(cache=True, inline="always", error_model="numpy")
def forward_keep(th, ow, n, h, p, xb, oxb, a, oa, s, os, g, og):  # pragma: no cover
    """ĝ = Ŵ tanh(V̂ x̄) from the flat weights at ``th[ow:]``, keeping the pre-activations.

    Reads x̄ from ``xb[oxb : oxb + p]``; writes a = V̂ x̄ to ``a[oa : oa + n_h]``,
    σ = tanh(a) to ``s[os : os + n_h]`` (may be the same place) and ĝ to ``g[og : og + n]``
    (the buffers may be one array). Each pre-activation is summed over the inputs in order
    c = 0 … p−1, each output over the hidden units in order.
    """
    mat_t_vec(th, ow + n * h, p, h, xb, oxb, a, oa)  # a = V̂ x̄ (V̂ᵀ is stored)
    tanh_into(a, oa, s, os, h)
    for r in range(n):
        acc = 0.0
        base = ow + r * h
        for j in range(h):
            acc += th[_ix(base + j)] * s[_ix(os + j)]
        g[_ix(og + r)] = acc


@njit(cache=True, inline="always", error_model="numpy")
def forward(th, ow, n, h, p, xb, oxb, s, os, g, og):  # pragma: no cover - compiled
    """ĝ = Ŵ tanh(V̂ x̄) (:func:`forward_keep` with the pre-activations overwritten by σ)."""
    forward_keep(th, ow, n, h, p, xb, oxb, s, os, s, os, g, og)


@njit(cache=True, error_model="numpy")
def _forward_rows(th, n, h, p, xbar, out):  # pragma: no cover - compiled
    s = np.empty(h)
    for k in range(xbar.shape[0]):
        forward(th, 0, n, h, p, xbar[k], 0, s, 0, out[k], 0)


def pack_weights(W: np.ndarray, V: np.ndarray) -> np.ndarray:  # noqa: N803 - thesis names
    """Flat weight vector [vec(Ŵ); vec(V̂ᵀ)] (both row-major) as used by the kernels."""
    return np.concatenate([np.ascontiguousarray(W, dtype=np.float64).ravel(),
                           np.ascontiguousarray(np.asarray(V, dtype=np.float64).T).ravel()])


def network_forward(W: np.ndarray, V: np.ndarray, x_bar: np.ndarray) -> np.ndarray:  # noqa: N803
    """Evaluate ĝ = Ŵ tanh(V̂ x̄) (thesis Sec. 3.1).

    Args:
        W: output weights Ŵ, shape (n, n_h).
        V: hidden weights V̂, shape (n_h, p).
        x_bar: network input(s), shape (p,) or (K, p); finite.

    Returns:
        ĝ, shape (n,) or (K, n), in the state units per second of the identifier state.

    Raises:
        IdentifierError: on inconsistent shapes or non-finite inputs.
    """
    W = np.asarray(W, dtype=np.float64)
    V = np.asarray(V, dtype=np.float64)
    if W.ndim != 2 or V.ndim != 2 or W.shape[1] != V.shape[0]:
        raise IdentifierError(f"weights need shapes (n, n_h) and (n_h, p), got W {W.shape} "
                              f"and V {V.shape}")
    n, h = W.shape
    p = V.shape[1]
    xb = np.ascontiguousarray(x_bar, dtype=np.float64)
    single = xb.ndim == 1
    xb2 = xb.reshape(1, -1) if single else xb
    if xb2.ndim != 2 or xb2.shape[1] != p:
        raise IdentifierError(f"x_bar must have shape ({p},) or (K, {p}), got {xb.shape}")
    if not np.all(np.isfinite(xb2)):
        raise IdentifierError("x_bar contains non-finite values")
    out = np.empty((xb2.shape[0], n))
    _forward_rows(pack_weights(W, V), n, h, p, xb2, out)
    return out[0] if single else out


def init_weights(seed: int, n_out: int, n_hidden: int, n_in: int, w0_scale: float,
                 v0_scale: float) -> tuple[np.ndarray, np.ndarray]:
    """Random initial weights, the same for every identifier kind given the same seed.

    Entries are uniform: Ŵ_0 in [−w0_scale, w0_scale], V̂_0 in [−v0_scale, v0_scale]
    (Table 4.3 / 4.4 "random initialization" read as a scale), drawn by
    ``numpy.random.default_rng(seed)``: Ŵ first, then V̂.

    Args:
        seed: integer seed.
        n_out: n, the number of identifier states.
        n_hidden: n_h.
        n_in: p = n + m.
        w0_scale: scale of Ŵ_0 (state units/s).
        v0_scale: scale of V̂_0.

    Returns:
        (W0 of shape (n, n_h), V0 of shape (n_h, p)).
    """
    rng = np.random.default_rng(seed)
    w0 = rng.uniform(-w0_scale, w0_scale, size=(n_out, n_hidden))
    v0 = rng.uniform(-v0_scale, v0_scale, size=(n_hidden, n_in))
    return w0, v0


guard_cache(globals())  # drop cached kernels when a module they compile in changes
