"""The C caller of Identifier.step (``simgap.identifiers._call``) against numba's dispatcher."""

from __future__ import annotations

import os
import shutil
import sysconfig

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from simgap.identifiers import (
    IdentifierDivergedError,
    IdentifierError,
    fastcall,
    make_identifier,
    preset,
)
from simgap.identifiers import kernels as K


def _pair(kind: str, **kw):
    """The same identifier twice: on the C caller, and on numba's dispatcher."""
    fast = make_identifier(kind, 4, 2, 0.002, seed=3, **kw)
    slow = make_identifier(kind, 4, 2, 0.002, seed=3, **kw)
    slow._hot = None
    slow._step_kernel = K.ready("observer_step_single")
    slow.__dict__.pop("step", None)  # the C caller's instance attribute: back to the method
    return fast, slow


def _c_compiler() -> str | None:
    cc = (sysconfig.get_config_var("CC") or "cc").split()[0]
    return shutil.which(cc)


def test_the_c_caller_is_built_and_used():
    # the extension is optional, but where pip had a C compiler it must have been built
    if not fastcall.available():
        if _c_compiler() is None or os.environ.get("SIMGAP_NO_C_CALLER"):
            pytest.skip(fastcall.UNAVAILABLE)
        pytest.fail(f"the fast path of Identifier.step is off: {fastcall.UNAVAILABLE}. setup.py "
                    f"builds simgap/identifiers/_call.c with {_c_compiler()}; reinstall with "
                    f"`make install` and read pip's build warning")
    ident = make_identifier("integral", 4, 2, 0.002)
    assert ident._hot is not None
    assert ident.step is ident._hot  # the C caller is the instance's step (no Python frame)
    assert make_identifier("minibatch", 4, 2, 0.002)._hot is None  # no C path for baseline 2
    assert "step" not in vars(make_identifier("minibatch", 4, 2, 0.002))


def test_the_c_step_survives_copies_and_is_collected():
    """Pickle / deepcopy rebind the C step to the copy's state; the reference cycle
    identifier → C step → its fallback → identifier is collected."""
    import copy
    import gc
    import pickle
    import weakref

    if not fastcall.available():
        pytest.skip(fastcall.UNAVAILABLE)
    ident = make_identifier("integral", 4, 2, 0.002, config=preset("auto", "integral", dt=0.002))
    rng = np.random.default_rng(1)
    stream = [(rng.normal(size=4), rng.normal(size=2), rng.normal(size=4), rng.normal(size=4))
              for _ in range(300)]
    for row in stream[:200]:
        ident.step(*row)
    twins = [copy.deepcopy(ident), pickle.loads(pickle.dumps(ident)), copy.deepcopy(ident)]
    for twin in twins:
        assert twin.step is twin._hot and twin.step is not ident.step
    for x, u, f, xn in stream[200:]:
        g = ident.step(x, u, f, xn)
        assert np.any(g != 0.0)
        for twin in twins[:2]:
            np.testing.assert_array_equal(twin.step(x, u, f, xn), g)
        # keyword arguments take the general path (the method's parameter names)
        np.testing.assert_array_equal(twins[2].step(x=x, u=u, f=f, x_next=xn), g)
    for twin in twins:
        np.testing.assert_array_equal(twin._persistent(), ident._persistent())
    with pytest.raises(TypeError):
        ident.step(x, u)  # the wrong count: the general path's TypeError
    ref = weakref.ref(ident)
    del ident, twins, twin
    gc.collect()
    assert ref() is None


@pytest.mark.parametrize("kind", ["instantaneous", "integral"])
def test_c_caller_and_dispatcher_give_the_same_bits(kind):
    fast, slow = _pair(kind)
    rng = np.random.default_rng(0)
    x = rng.normal(size=4)
    for k in range(400):
        if k == 150:
            fast.freeze(), slow.freeze()
        if k == 250:
            fast.unfreeze(), slow.unfreeze()
        u = rng.normal(size=2)
        f = rng.normal(size=4)
        x_next = x + 0.002 * f + 1e-3 * rng.normal(size=4)
        a, b = fast.step(x, u, f, x_next), slow.step(x, u, f, x_next)
        assert a.dtype == np.float64 and a.shape == (4,) and a.flags.owndata
        np.testing.assert_array_equal(a, b)
        x = x_next
    np.testing.assert_array_equal(fast._state, slow._state)
    assert fast.n_steps == 400 and fast.n_updates == 300


def test_each_step_returns_a_new_array():
    ident = make_identifier("integral", 4, 2, 0.002)
    x, u = np.ones(4), np.ones(2)
    g1 = ident.step(x, u, x, x)
    keep = g1.copy()
    g2 = ident.step(x, u, x, x)
    assert g2 is not g1 and not np.shares_memory(g1, g2)
    np.testing.assert_array_equal(g1, keep)


@pytest.mark.parametrize("make", [
    lambda v: list(v),                                # not an array
    lambda v: v.astype(np.float32),                   # other dtype
    lambda v: np.repeat(v, 2)[::2],                   # not contiguous
    lambda v: v.reshape(1, -1),                       # 2-D
    lambda v: np.frombuffer(v.tobytes(), np.float64),  # read-only is fine as input
])
def test_other_inputs_take_the_general_path_with_the_same_result(make):
    fast, slow = _pair("integral")
    x, u, f = np.linspace(0, 1, 4), np.array([0.5, -0.5]), np.linspace(-1, 1, 4)
    xn = x + 0.002 * f
    def ref(v):  # what the general path converts the argument to
        return np.ascontiguousarray(make(v), dtype=np.float64).reshape(-1)

    np.testing.assert_array_equal(fast.step(make(x), make(u), make(f), make(xn)),
                                  slow.step(ref(x), ref(u), ref(f), ref(xn)))
    np.testing.assert_array_equal(fast._state, slow._state)


def test_failures_raise_the_typed_errors_and_change_nothing():
    ident = make_identifier("integral", 4, 2, 0.002)
    x, u = np.ones(4), np.ones(2)
    ident.step(x, u, x, x)
    before = ident._persistent().copy()
    with pytest.raises(IdentifierError, match="non-finite"):
        ident.step(x, u, np.array([0.0, np.nan, 0.0, 0.0]), x)
    with pytest.raises(IdentifierError, match="expected x, f, x_next with 4"):
        ident.step(x, np.ones(3), x, x)
    np.testing.assert_array_equal(ident._persistent(), before)
    # a step whose update would exceed the weight-norm bound
    cfg = preset("manipulator", "instantaneous")
    w0 = np.sqrt(np.sum(make_identifier("instantaneous", 4, 2, 0.002).W ** 2)
                 + np.sum(make_identifier("instantaneous", 4, 2, 0.002).V ** 2))
    wild = make_identifier("instantaneous", 4, 2, 0.002,
                           config=cfg.replace(max_weight_norm=1.001 * w0))
    wild.step(x, u, x, x)
    before = wild._persistent().copy()  # the state without the scratch columns
    with pytest.raises(IdentifierDivergedError, match="diverged"):
        wild.step(x * 100, u, x, x)  # x̃ = 99: the update would leave the bound
    np.testing.assert_array_equal(wild._persistent(), before)


def test_the_stepper_checks_its_state():
    if not fastcall.available():
        pytest.skip(fastcall.UNAVAILABLE)
    addr = K.c_observer_step().address
    with pytest.raises(TypeError, match="one row"):
        fastcall._call.Stepper(addr, np.zeros((2, 500)), 4)
    with pytest.raises(TypeError, match="float64"):
        fastcall._call.Stepper(addr, np.zeros((1, 500), dtype=np.float32), 4)
    with pytest.raises(ValueError, match="non-zero"):
        fastcall._call.Stepper(0, np.zeros((1, 500)), 4)
    # a row without scratch columns, or too short to hold the header: the kernel refuses
    for cols in (3, K.layout(4, 2, 20)["size"]):
        s = np.zeros((1, cols))
        if cols > K.HP_SIZE:
            s[0, K.HP_N], s[0, K.HP_M], s[0, K.HP_H] = 4, 2, 20
        step = fastcall._call.Stepper(addr, s, 4)
        assert step(np.zeros(4), np.zeros(2), np.zeros(4), np.zeros(4)) is None


_vals = st.floats(-1e3, 1e3, allow_nan=False, allow_infinity=False)


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(kind=st.sampled_from(["instantaneous", "integral"]),
       steps=st.lists(st.lists(_vals, min_size=14, max_size=14), min_size=1, max_size=25))
def test_both_paths_agree_on_random_bounded_inputs(kind, steps):
    fast, slow = _pair(kind)
    for v in steps:
        x, u, f, xn = (np.array(v[0:4]), np.array(v[4:6]), np.array(v[6:10]),
                       np.array(v[10:14]))
        outcomes = []
        for ident in (fast, slow):
            try:
                outcomes.append(ident.step(x, u, f, xn))
            except IdentifierError as exc:  # includes divergence
                outcomes.append(type(exc))
        if isinstance(outcomes[0], np.ndarray):
            np.testing.assert_array_equal(outcomes[0], outcomes[1])
            assert np.all(np.isfinite(outcomes[0]))
        else:
            assert outcomes[0] is outcomes[1]
    np.testing.assert_array_equal(fast._persistent(), slow._persistent())
