"""The batched kernels: one row code for N = 1, serial batches and threaded batches."""

from __future__ import annotations

import numpy as np
import pytest

from simgap.identifiers import BatchIdentifier, IdentifierError, make_identifier, preset
from simgap.identifiers import kernels as K
from simgap.identifiers.core import PARALLEL_MIN_ROWS


def _inputs(rng: np.random.Generator, nn: int):
    x = rng.normal(size=(nn, 4)) * 0.5
    u = rng.normal(size=(nn, 2))
    f = rng.normal(size=(nn, 4)) * 0.1
    return x, u, f, x + 0.002 * f + 1e-4 * rng.normal(size=(nn, 4))


@pytest.mark.parametrize("kind", ["instantaneous", "integral"])
def test_threaded_kernel_is_bit_identical_to_the_serial_one(kind):
    nn = 300
    ident = BatchIdentifier(kind, nn, 4, 2, 0.002, config=preset("manipulator", kind), seed=3)
    s_serial = ident._state.copy()
    s_thread = ident._state.copy()
    rng = np.random.default_rng(0)
    act = np.full(nn, K.LEARN)
    act[::7] = K.SKIP  # not transitions
    act[1::11] = K.FROZEN
    s_serial[:, K.HP_ACT] = act
    s_thread[:, K.HP_ACT] = act
    for k in range(40):
        x, u, f, xn = (a.reshape(-1) for a in _inputs(rng, nn))
        if k == 20:
            x = x.copy()
            x[4 * 5 + 1] = np.nan  # row 5 fails and stays as it was
        before = s_serial[5].copy()
        r1 = K.ready("observer_step")(s_serial, x, u, f, xn)
        r2 = K.ready("observer_step_parallel")(s_thread, x, u, f, xn)
        assert r1 == r2 == (1 if k == 20 else 0)
        size = K.layout(4, 2, 20)["size"]  # the scratch columns after it differ, by design
        np.testing.assert_array_equal(s_serial[:, :size], s_thread[:, :size])
        if k == 20:
            assert s_serial[5, K.HP_STATUS] == K.STATUS_BAD_INPUT
            changed = np.flatnonzero(s_serial[5] != before)
            assert changed.tolist() == [K.HP_STATUS]
    steps = s_serial[:, K.HP_NSTEPS]
    assert np.all(steps[act == K.SKIP] == 0) and np.all(steps[act != K.SKIP] >= 39)
    updates = s_serial[:, K.HP_NUPDATES]
    assert np.all(updates[act != K.LEARN] == 0) and np.all(updates[act == K.LEARN] >= 39)


@pytest.mark.parametrize("kind", ["integral", "minibatch"])
def test_batch_rows_equal_single_identifiers_bit_for_bit(kind):
    """Row i of a (threaded, for the observer laws) batch = an Identifier fed row i."""
    nn = PARALLEL_MIN_ROWS + 8
    cfg = preset("manipulator", kind)
    batch = BatchIdentifier(kind, nn, 4, 2, 0.002, config=cfg, seed=1)
    singles = [make_identifier(kind, 4, 2, 0.002, config=cfg, seed=1) for _ in range(3)]
    rng = np.random.default_rng(4)
    for _ in range(60):
        x, u, f, xn = _inputs(rng, nn)
        gb = batch.step(x, u, f, xn)
        for i, ident in enumerate(singles):
            g = ident.step(x[i], u[i], f[i], xn[i])
            if kind != "minibatch":  # baseline 2 draws its mini-batches from one Generator
                np.testing.assert_array_equal(g, gb[i])
    if kind != "minibatch":
        np.testing.assert_array_equal(batch.W[:3], np.stack([s.W for s in singles]))
        assert singles[0].n_steps == 60 and singles[0].n_updates == 60


def test_single_identifier_rows_carry_scratch_columns_batches_do_not():
    one = make_identifier("integral", 4, 2, 0.002)
    many = BatchIdentifier("integral", 5, 4, 2, 0.002)
    size = K.layout(4, 2, 20)["size"]
    assert one._state.shape == (1, size + K.scratch_layout.py_func(4, 2, 20)[-1])
    assert many._state.shape == (5, size)
    # the state dict holds the state columns only, for both
    assert one.state_dict()["state"].shape == (1, size)


def test_wrong_sizes_are_rejected_by_the_kernel():
    ident = make_identifier("integral", 4, 2, 0.002)
    assert K.ready("observer_step")(ident._state, np.zeros(4), np.zeros(3), np.zeros(4),
                           np.zeros(4)) == -1
    with pytest.raises(IdentifierError, match="expected x, f, x_next with 4"):
        ident.step(np.zeros(4), np.zeros(3), np.zeros(4), np.zeros(4))


@pytest.mark.parametrize("kind", ["instantaneous", "integral", "minibatch"])
def test_tracked_weight_norms_stay_equal_to_the_exact_ones(kind):
    """The divergence bound uses ‖Ŵ‖², ‖V̂‖² updated by the rank-one identity, not recomputed."""
    ident = make_identifier(kind, 4, 2, 0.002, config=preset("manipulator", kind), seed=5)
    W0 = ident.W  # noqa: N806
    rng = np.random.default_rng(6)
    for _ in range(3000):
        x, u, f, xn = (a[0] for a in _inputs(rng, 1))
        ident.step(x, u, f, xn)
    W, V = ident.W, ident.V  # noqa: N806
    tracked = ident._state[0, K.HP_NORM2:K.HP_NORM2 + 2]
    np.testing.assert_allclose(tracked, [np.sum(W * W), np.sum(V * V)], rtol=1e-9)
    assert np.abs(W - W0).max() > 1e-6  # the weights did move


def test_threads_choice_gives_the_same_bits():
    runs = []
    for threads in (None, True, False):
        ident = BatchIdentifier("integral", 40, 4, 2, 0.002, seed=2, threads=threads)
        rng = np.random.default_rng(9)  # the same inputs for each choice
        for _ in range(20):
            ident.step(*_inputs(rng, 40))
        runs.append(ident.W)
    np.testing.assert_array_equal(runs[0], runs[1])
    np.testing.assert_array_equal(runs[0], runs[2])
    with pytest.raises(IdentifierError, match="threads must be"):
        BatchIdentifier("integral", 4, 4, 2, 0.002, threads=1)
