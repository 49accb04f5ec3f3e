from __future__ import annotations

import numpy as np
import pytest

from simgap.evaluation.errors import EvaluationError
from simgap.evaluation.metrics import reproducibility_metrics
from simgap.evaluation.reproducibility import Transitions, reproducibility_test
from simgap.identifiers import IdentifierConfig, make_identifier
from tests.evaluation.conftest import synthetic_transitions

CFG = IdentifierConfig(n_hidden=8, w0_scale=0.1, v0_scale=0.1, a_d=-20.0, eta1=20.0,
                       eta2=20.0, rho1=1e-3, rho2=1e-3, lam=2.0, buffer_size=200,
                       batch_size=16, update_period=5)


def _ident(kind: str, seed: int = 0):
    return make_identifier(kind, 2, 1, 0.01, config=CFG.replace(eta1=2e3, eta2=2e3)
                           if kind == "minibatch" else CFG, seed=seed)


@pytest.mark.parametrize("kind", ["instantaneous", "integral", "minibatch"])
def test_frozen_copy_equals_a_separate_run_frozen_at_tf(kind, transitions):
    res = reproducibility_test(_ident(kind), transitions, [2.0, 5.0])
    for fm in res.frozen:
        kf = fm.n_history
        assert kf == int(round(fm.t_freeze / transitions.dt))  # transitions with t_k < T_f
        other = _ident(kind)
        xbars = []
        for k in range(kf):
            other.step(transitions.x[k], transitions.u[k], transitions.f[k],
                       transitions.x_next[k])
            xbars.append(other.x_bar)
        other.freeze()
        np.testing.assert_array_equal(other.W, fm.W)
        np.testing.assert_array_equal(other.V, fm.V)
        np.testing.assert_array_equal(other.predict(np.array(xbars)), fm.g_frozen)
    # the online run went on learning after the first freeze time
    assert not np.array_equal(res.frozen[0].W, res.frozen[1].W)


def test_identifier_frozen_from_the_start_reproduces_its_history_exactly(transitions):
    ident = _ident("integral")
    ident.freeze()
    res = reproducibility_test(ident, transitions, [3.0])
    m = reproducibility_metrics(res)
    assert m["frozen_vs_online"]["3"] == 0.0
    k = res.frozen[0].n_history
    np.testing.assert_array_equal(res.frozen[0].g_frozen, res.g_online[:k])


def test_learning_identifier_does_not_reproduce_its_history(transitions):
    res = reproducibility_test(_ident("instantaneous"), transitions, [5.0])
    m = reproducibility_metrics(res)
    assert m["frozen_vs_online"]["5"] > 1e-3


class _Oracle:
    """Any object with the identifier protocol works; this one outputs the true residual."""

    n_states, n_inputs, kind = 2, 1, "oracle"

    def __init__(self) -> None:
        self.x_bar = np.zeros(3)
        self.x_tilde = np.zeros(2)

    def predict(self, xb):
        xb = np.atleast_2d(xb)
        g = np.stack([np.zeros(len(xb)), -0.5 * np.tanh(3.0 * xb[:, 1])], axis=1)
        return g

    def step(self, x, u, f, x_next):
        self.x_bar = np.concatenate([x, u])
        return self.predict(self.x_bar)[0]

    def freeze(self) -> None:
        pass


def test_any_identifier_duck_type_and_perfect_model_scores_zero(transitions):
    res = reproducibility_test(_Oracle(), transitions, [2.0, 6.0])
    m = reproducibility_metrics(res)
    assert m["accuracy"] < 1e-15
    assert all(v < 1e-15 for v in m["consistency"].values())
    assert res.kind == "oracle"


def test_same_seed_bit_identical(transitions):
    a = reproducibility_test(_ident("minibatch", seed=3), transitions, [4.0])
    b = reproducibility_test(_ident("minibatch", seed=3), transitions, [4.0])
    np.testing.assert_array_equal(a.g_online, b.g_online)
    np.testing.assert_array_equal(a.frozen[0].g_frozen, b.frozen[0].g_frozen)


def test_t_end_stops_the_online_run(transitions):
    res = reproducibility_test(_ident("integral"), transitions, [2.0], t_end=3.0)
    assert len(res.t) == 300


@pytest.mark.parametrize("times", [[], [0.0], [-1.0], [100.0], ["x"]])
def test_bad_freeze_times(times, transitions):
    with pytest.raises(EvaluationError, match="freeze"):
        reproducibility_test(_ident("integral"), transitions, times)


def test_size_mismatch_and_bad_options(transitions):
    wrong = make_identifier("integral", 3, 1, 0.01, config=CFG)
    with pytest.raises(EvaluationError, match="n_states"):
        reproducibility_test(wrong, transitions, [1.0])
    with pytest.raises(EvaluationError, match="frozen_inputs"):
        reproducibility_test(_ident("integral"), transitions, [1.0], frozen_inputs="bad")


def test_transitions_validation():
    tr = synthetic_transitions(20)
    with pytest.raises(EvaluationError, match="target"):
        Transitions(t=tr.t, x=tr.x, u=tr.u, f=tr.f, x_next=tr.x_next, target=tr.target[:5],
                    dt=tr.dt)
    bad = tr.x.copy()
    bad[3, 0] = np.nan
    with pytest.raises(EvaluationError, match="NaN"):
        Transitions(t=tr.t, x=bad, u=tr.u, f=tr.f, x_next=tr.x_next, target=tr.target,
                    dt=tr.dt)
    with pytest.raises(EvaluationError, match="increasing"):
        Transitions(t=tr.t[::-1], x=tr.x, u=tr.u, f=tr.f, x_next=tr.x_next,
                    target=tr.target, dt=tr.dt)
