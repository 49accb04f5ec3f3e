"""Identifier API: seeding, frozen mode, persistence, batch = single, typed errors."""

from __future__ import annotations

import json

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from simgap.identifiers import (
    KINDS,
    BatchIdentifier,
    Identifier,
    IdentifierConfig,
    IdentifierDivergedError,
    IdentifierError,
    load_identifier,
    make_identifier,
    network_forward,
    preset,
)
from simgap.identifiers.activation import tanh as fast_tanh
from simgap.identifiers.network import init_weights


def _stream(seed: int, k: int, n: int = 4, m: int = 2):
    """A smooth, bounded pseudo-trajectory with a residual for the identifiers to chase."""
    rng = np.random.default_rng(seed)
    t = np.arange(k + 1) * 0.002
    phase = rng.uniform(0, 2 * np.pi, size=n)
    x = np.sin(2 * np.pi * 0.5 * t[:, None] + phase) + 0.01 * rng.normal(size=(k + 1, n))
    u = np.cos(2 * np.pi * 0.3 * t[:k, None] + rng.uniform(0, 2 * np.pi, size=m))
    f = np.gradient(x, t, axis=0)[:k] * 0.8
    return x, u, f


def _run(ident, x, u, f, start=0, stop=None):
    stop = u.shape[0] if stop is None else stop
    out = []
    for k in range(start, stop):
        out.append(ident.step(x[k], u[k], f[k], x[k + 1]))
    return np.array(out)


def test_presets_match_tables_4_3_and_4_4():
    m = {k: preset("manipulator", k) for k in KINDS}
    assert (m["instantaneous"].eta1, m["instantaneous"].eta2) == (1e2, 8e3)
    assert (m["minibatch"].eta1, m["minibatch"].eta2) == (1e3, 5e4)
    assert (m["integral"].eta1, m["integral"].eta2) == (4e1, 6e3)
    c = m["integral"]
    assert (c.a_d, c.rho1, c.rho2, c.lam, c.w0_scale, c.v0_scale, c.n_hidden) == \
        (-40.0, 1e-2, 1e-2, 2.0, 1e-2, 1e-2, 20)
    assert (c.buffer_size, c.batch_size, c.update_period) == (2000, 64, 10)
    b = {k: preset("bicycle", k) for k in KINDS}
    assert (b["instantaneous"].eta1, b["instantaneous"].eta2) == (5e2, 1.0)
    assert (b["minibatch"].eta1, b["minibatch"].eta2) == (5e2, 0.2)
    assert (b["integral"].eta1, b["integral"].eta2) == (5e2, 0.1)
    c = b["integral"]
    assert (c.w0_scale, c.v0_scale, c.rho1, c.rho2, c.lam) == (1e1, 1e-2, 1e-5, 1e-5, 10.0)
    assert (c.buffer_size, c.batch_size, c.update_period) == (200, 32, 5)
    ident = make_identifier("integral", 2, 2, 0.01, config=c)  # errata: (4, 20, 2)
    assert ident.V.shape == (20, 4) and ident.W.shape == (2, 20)


def test_same_seed_same_initial_weights_for_all_kinds():
    idents = [make_identifier(k, 4, 2, 0.002, seed=7) for k in KINDS]
    for other in idents[1:]:
        np.testing.assert_array_equal(other.W, idents[0].W)
        np.testing.assert_array_equal(other.V, idents[0].V)
    w0, v0 = init_weights(7, 4, 20, 6, 1e-2, 1e-2)
    np.testing.assert_array_equal(idents[0].W, w0)
    assert np.abs(w0).max() <= 1e-2 and np.abs(v0).max() <= 1e-2
    assert not np.array_equal(make_identifier("integral", 4, 2, 0.002, seed=8).W, w0)


@pytest.mark.parametrize("kind", KINDS)
def test_identical_seeds_give_bit_identical_runs(kind):
    x, u, f = _stream(0, 400)
    a = _run(make_identifier(kind, 4, 2, 0.002, seed=1), x, u, f)
    b = _run(make_identifier(kind, 4, 2, 0.002, seed=1), x, u, f)
    np.testing.assert_array_equal(a, b)
    assert np.any(a != a[0])  # it actually learned something


def test_fast_tanh_matches_numpy():
    rng = np.random.default_rng(0)
    a = np.concatenate([np.linspace(-30, 30, 100001), np.logspace(-300, 1.5, 500),
                        -np.logspace(-300, 1.5, 500), rng.normal(size=100000) * 3,
                        rng.uniform(-0.2, 0.2, 100000),
                        [0.0, -0.0, 0.01, -0.01, 0.05, -0.05, 20.0, -20.0, 5e-324]])
    got = fast_tanh(a)
    ref = np.tanh(a)
    np.testing.assert_allclose(got, ref, rtol=2e-15, atol=0)
    assert np.abs(got - ref).max() <= 2.3e-16
    assert np.array_equal(np.signbit(got), np.signbit(ref))  # odd, including -0.0
    special = fast_tanh(np.array([np.nan, np.inf, -np.inf, 1e308, -1e308]))
    assert np.isnan(special[0]) and list(special[1:]) == [1.0, -1.0, 1.0, -1.0]
    # and the network uses it: a 1-unit network with unit weights is tanh itself
    np.testing.assert_array_equal(network_forward(np.ones((1, 1)), np.ones((1, 1)),
                                                  a[:, None])[:, 0], got)


@pytest.mark.parametrize("kind", KINDS)
def test_frozen_weights_bitwise_unchanged_and_g_hat_equals_predict(kind):
    x, u, f = _stream(1, 1300)
    ident = make_identifier(kind, 4, 2, 0.002, seed=2)
    _run(ident, x, u, f, 0, 300)
    ident.freeze()
    W, V = ident.W, ident.V  # noqa: N806
    buf, cnt, z = ident._buf.copy(), ident._cnt.copy(), ident.z
    x_hats, x_bars, g_hats = [], [], []
    for k in range(300, 1300):
        g = ident.step(x[k], u[k], f[k], x[k + 1])
        np.testing.assert_array_equal(g, ident.predict(ident.x_bar))  # bit-exact
        x_hats.append(ident.x_hat)
        x_bars.append(ident.x_bar)
        g_hats.append(g)
    # re-evaluating the frozen network over the recorded history reproduces it exactly
    np.testing.assert_array_equal(ident.predict(np.array(x_bars)), np.array(g_hats))
    np.testing.assert_array_equal(ident.W, W)
    np.testing.assert_array_equal(ident.V, V)
    np.testing.assert_array_equal(ident.z, z)
    np.testing.assert_array_equal(ident._buf, buf)
    np.testing.assert_array_equal(ident._cnt, cnt)
    assert len({tuple(h) for h in x_hats}) > 900  # x̂ keeps running
    ident.unfreeze()
    _run(ident, x, u, f, 0, 20)
    assert not np.array_equal(ident.W, W)


@pytest.mark.parametrize("kind", KINDS)
def test_save_load_identical_continuation(kind, tmp_path):
    x, u, f = _stream(3, 700)
    ident = make_identifier(kind, 4, 2, 0.002, seed=5)
    _run(ident, x, u, f, 0, 333)
    path = ident.save(tmp_path / "ident.npz")
    with np.load(path, allow_pickle=False) as z:  # no pickle anywhere
        meta = json.loads(str(z["meta"]))
    assert meta["kind"] == kind and meta["config"]["eta1"] == ident.config.eta1
    other = Identifier.load(path)
    np.testing.assert_array_equal(_run(ident, x, u, f, 333, 700),
                                  _run(other, x, u, f, 333, 700))
    np.testing.assert_array_equal(ident.W, other.W)
    third = make_identifier(kind, 4, 2, 0.002, seed=5)
    third.load_state_dict(load_identifier(path).state_dict())
    np.testing.assert_array_equal(third.W, load_identifier(path).W)


@pytest.mark.parametrize("kind", ["instantaneous", "integral"])
def test_batch_rows_equal_single_identifiers(kind):
    n_env = 3
    streams = [_stream(10 + i, 300) for i in range(n_env)]
    singles = [make_identifier(kind, 4, 2, 0.002, seed=0) for _ in range(n_env)]
    batch = BatchIdentifier(kind, n_env, 4, 2, 0.002, seed=0)
    learn = np.array([True, False, True])
    for k in range(300):
        xs = np.stack([s[0][k] for s in streams])
        us = np.stack([s[1][k] for s in streams])
        fs = np.stack([s[2][k] for s in streams])
        xn = np.stack([s[0][k + 1] for s in streams])
        mask = learn if k == 150 else None  # row 1 skips one step
        gb = batch.step(xs, us, fs, xn, learn=mask)
        for i, ident in enumerate(singles):
            if mask is None or mask[i]:
                np.testing.assert_array_equal(gb[i], ident.step(xs[i], us[i], fs[i], xn[i]))
    for i, ident in enumerate(singles):
        np.testing.assert_array_equal(batch.W[i], ident.W)


def test_bad_inputs_raise_typed_errors_and_change_nothing(tmp_path):
    ident = make_identifier("integral", 4, 2, 0.002)
    x, u, f = np.zeros(4), np.zeros(2), np.zeros(4)
    ident.step(x, u, f, x)
    state = ident.state_dict()
    with pytest.raises(IdentifierError, match="expected x, f, x_next with 4"):
        ident.step(np.zeros(3), u, f, x)
    with pytest.raises(IdentifierError, match="non-finite"):
        ident.step(x, np.array([np.nan, 0.0]), f, x)
    np.testing.assert_array_equal(ident.state_dict()["state"], state["state"])
    ident.step([0.0, 0, 0, 0], [0, 0], np.zeros(4, dtype=np.float32), x)  # coerced
    with pytest.raises(IdentifierError, match="unknown identifier kind"):
        make_identifier("integrl", 4, 2, 0.002)
    with pytest.raises(IdentifierError, match="a_d must be a finite negative"):
        IdentifierConfig(a_d=40.0)
    with pytest.raises(IdentifierError, match="dt must be"):
        make_identifier("integral", 4, 2, 0.0)
    with pytest.raises(IdentifierError, match="x_bar must have shape"):
        ident.predict(np.zeros(5))
    (tmp_path / "junk.npz").write_bytes(b"not a zip")
    with pytest.raises(IdentifierError, match="junk.npz"):
        load_identifier(tmp_path / "junk.npz")
    with pytest.raises(IdentifierError, match="no such identifier file"):
        load_identifier(tmp_path / "missing.npz")


def test_divergence_raises_and_keeps_last_good_state():
    cfg = IdentifierConfig(eta1=1e9, eta2=1e9, max_weight_norm=1e3)
    ident = make_identifier("instantaneous", 4, 2, 0.002, config=cfg)
    x, u, f = _stream(4, 50)
    ident.reset_observer(x[0] + 5.0)
    with pytest.raises(IdentifierDivergedError, match="max_weight_norm=1000"):
        for k in range(50):
            good = ident.state_dict()
            ident.step(x[k], u[k], f[k], x[k + 1])
    np.testing.assert_array_equal(ident.state_dict()["state"], good["state"])
    assert np.all(np.isfinite(ident.W))


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(kind=st.sampled_from(KINDS), seed=st.integers(0, 2**31),
       scale=st.floats(1e-3, 1e3), steps=st.integers(1, 40))
def test_bounded_inputs_never_give_non_finite_outputs(kind, seed, scale, steps):
    rng = np.random.default_rng(seed)
    cfg = preset("manipulator", kind).replace(update_period=3, batch_size=4)
    ident = make_identifier(kind, 4, 2, 0.002, config=cfg, seed=seed % 1000)
    for _ in range(steps):
        x, f, xn = (rng.uniform(-scale, scale, size=4) for _ in range(3))
        u = rng.uniform(-scale, scale, size=2)
        try:
            g = ident.step(x, u, f, xn)
        except IdentifierDivergedError:
            assert np.all(np.isfinite(ident.W)) and np.all(np.isfinite(ident.V))
            return
        for arr in (g, ident.x_hat, ident.x_tilde, ident.z, ident.W, ident.V,
                    ident.predict(ident.x_bar)):
            assert np.all(np.isfinite(arr))


def test_batch_save_load_continues_identically(tmp_path):
    rng = np.random.default_rng(9)
    data = [(rng.normal(size=(3, 4)), rng.normal(size=(3, 2)), rng.normal(size=(3, 4)),
             rng.normal(size=(3, 4))) for _ in range(60)]
    cfg = preset("manipulator", "minibatch").replace(update_period=4, batch_size=6)
    a = BatchIdentifier("minibatch", 3, 4, 2, 0.002, config=cfg, seed=2)
    for d in data[:25]:
        a.step(*d)
    b = BatchIdentifier.load(a.save(tmp_path / "batch.npz"))
    for d in data[25:]:
        np.testing.assert_array_equal(a.step(*d), b.step(*d))
    np.testing.assert_array_equal(a.W, b.W)
    with pytest.raises(IdentifierError, match="BatchIdentifier"):
        load_identifier(tmp_path / "batch.npz")


@pytest.mark.parametrize("kind", ["instantaneous", "integral", "minibatch"])
def test_read_only_and_broadcast_inputs_are_accepted(kind):
    # read-only arrays (np.frombuffer, broadcasts, pandas buffers) once recursed without end
    def ro(a):
        return np.frombuffer(np.asarray(a, dtype=np.float64).tobytes())

    x, u = np.linspace(0.1, 0.4, 4), np.array([0.3, -0.2])
    ref = make_identifier(kind, 4, 2, 0.002)
    one = make_identifier(kind, 4, 2, 0.002)
    np.testing.assert_array_equal(one.step(ro(x), ro(u), ro(x), ro(x)), ref.step(x, u, x, x))
    batch = BatchIdentifier(kind, 3, 4, 2, 0.002)
    xb, ub = np.broadcast_to(x, (3, 4)), np.broadcast_to(u, (3, 2))
    g = batch.step(xb, ub, xb, xb)
    np.testing.assert_array_equal(g, np.broadcast_to(ref.g_hat, (3, 4)))


@pytest.mark.parametrize("kind", ["integral", "minibatch"])
def test_copies_and_pickles_continue_identically_and_own_their_state(kind):
    import copy
    import pickle

    rng = np.random.default_rng(5)
    rows = [(rng.normal(size=4), rng.normal(size=2), rng.normal(size=4), rng.normal(size=4))
            for _ in range(60)]
    ident = make_identifier(kind, 4, 2, 0.002)
    for r in rows[:30]:
        ident.step(*r)
    for twin in (copy.deepcopy(ident), pickle.loads(pickle.dumps(ident))):
        twin.freeze()  # must act on the twin's own state, not on the original's
        ref = copy.deepcopy(ident)
        ref.freeze()
        for r in rows[30:]:
            np.testing.assert_array_equal(twin.step(*r), ref.step(*r))
        np.testing.assert_array_equal(twin.W, ref.W)
        np.testing.assert_array_equal(twin.g_hat, ref.g_hat)
        assert twin.n_steps == 60 and not np.shares_memory(twin._state, ident._state)
    assert ident.n_steps == 30 and not ident.frozen
