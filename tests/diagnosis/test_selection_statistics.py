"""Selection statistics (issue 13): usable-row split, held-out tests with an honest floor,
"cannot test", per-channel ranking, joint identifiability, sign-flipping offsets, signed
corrections."""

from __future__ import annotations

import numpy as np
import pytest

from simgap.diagnosis.effects import Effect
from simgap.diagnosis.fit import Fitter, Term
from simgap.diagnosis.forms import Prepared
from simgap.diagnosis.residual import Smoother

N = 6000
DT = 0.01


class Fake:
    """A bare form: rows carry their index, effects read closure arrays by index."""

    def __init__(self, channels=("c",), rates=None):
        self.channels = channels
        self._rates = rates or {}

    def prepared(self, residual, noise):
        """The prepared data of a residual (N, C): signals = the row index."""
        t = np.arange(N) * DT
        return Prepared(t=t, residual=residual, noise_rms=noise, signals={"i": np.arange(N)},
                        raw={}, smoother=Smoother(5, DT), resampled=False, column_noise={},
                        inputs=np.zeros((N, 0)), fit_mask=np.ones(residual.shape, dtype=bool),
                        state=np.zeros((N, 0)), state_derivative=np.zeros((N, 0)),
                        derivatives=())

    def context(self, prepared, terms=()):
        return None

    def locate_variables(self, prepared):
        return {k: (v, "rad/s") for k, v in self._rates.items()}


def _fitter(form, residual, noise, **kwargs):
    return Fitter(form, form.prepared(residual, noise), **kwargs)


def _effect(name, reg, lower=-np.inf, channels=1, index=0):
    """A one-parameter effect whose regressor is ``reg`` (read by row index)."""
    def fn(lin, nl, sig, i, sys):
        out = np.zeros((len(sig["i"]), channels))
        out[:, index if i is None else i] = lin[0] * reg[sig["i"]]
        return out
    return Effect(name=name, label=name, scope="joint", lin=("a",), lin_units=("-",),
                  lin_lower=(lower,), fn=fn)


def test_split_uses_usable_rows_and_interleaves_validation():
    """A decaying log whose late part is masked: the split is on usable rows (main: 70 % of
    the time, which left a test part with nothing to test), validation blocks are spread
    over the fit part, and no row sits within a filter window of a gap."""
    from simgap.diagnosis import validation

    t = np.arange(N) * DT
    mask = np.ones((N, 1))
    mask[int(0.6 * N):] = 0.0                    # the decay has stopped: all masked
    seg = (t > 20.0).astype(int)                 # a gap at 20 s
    rows = validation.usable_rows(N, 5, mask, seg)
    assert rows.max() < 0.6 * N
    assert not np.any(np.abs(t[rows] - 20.0) < 5 * DT)
    sp = validation.split_rows(t, rows, seg, 0.7)
    assert len(sp.test) >= 0.25 * len(rows) and np.all(mask[sp.test, 0] == 1)
    assert t[sp.valid].min() < 0.25 * t[sp.fit].max() < 0.75 * t[sp.fit].max() < \
        t[sp.valid].max()
    # no validation block straddles the gap
    for b in np.unique(sp.valid_block):
        assert len(np.unique(seg[sp.valid[sp.valid_block == b]])) == 1
    assert set(sp.train) | set(sp.valid) == set(sp.fit)


def test_small_real_effect_named_beside_a_large_unexplained_channel():
    """Per-channel floors: channel 1 holds a small real effect, channel 0 a large structure
    error no candidate explains. Summed SSE (main) hid the effect under channel 0's error;
    each channel scaled by its own remaining error names it."""
    rng = np.random.default_rng(1)
    x = np.sin(0.9 * np.arange(N) * DT) + 0.5 * np.sin(2.9 * np.arange(N) * DT)
    walk = np.cumsum(rng.normal(0, 1.0, N))
    r = np.column_stack([30.0 * (walk - walk.mean()) / walk.std(),
                         0.4 * x + rng.normal(0, 0.1, N)])
    sysm = Fake(channels=("c0", "c1"))
    term = Term(_effect("small", x, channels=2, index=1), 1, "c1")
    sel = _fitter(sysm, r, np.array([0.1, 0.1])).select([term])
    assert [t.label for t in sel.fit.terms] == ["small@c1"]
    assert abs(sel.fit.lin[0][0] - 0.4) < 0.05
    (entry,) = sel.tried
    assert entry["decision"] == "named" and entry["p_value"] < 1e-3
    assert 0 < entry["gain"] <= 1 and entry["test"].startswith("held-out")


def test_pure_noise_names_nothing_and_says_why():
    rng = np.random.default_rng(2)
    x = np.sin(0.9 * np.arange(N) * DT)
    r = rng.normal(0, 0.1, (N, 1))
    sel = _fitter(Fake(), r, np.array([0.1])).select([Term(_effect("e", x), 0, "c")])
    assert sel.fit.terms == []
    (entry,) = sel.tried
    assert entry["decision"] == "rejected" and "not significant" in entry["reason"]
    assert np.isfinite(entry["p_value"]) and entry["p_value"] > 1e-3


def test_cannot_test_when_the_held_out_part_holds_no_information():
    """A regressor that is zero on every validation block: "cannot test", not "useless".

    The single validation part (``cross_validate=False``); with cross-validation the other
    folds hold the regressor and test it (tests/diagnosis/test_selection_cv_s8.py)."""
    rng = np.random.default_rng(3)
    reg = np.zeros(N)
    sysm = Fake()
    r = rng.normal(0, 0.1, (N, 1))
    fitter = _fitter(sysm, r, np.array([0.1]), cross_validate=False)
    on = np.zeros(N, dtype=bool)
    on[fitter.train] = True
    for b in np.unique(fitter.split.valid_block):  # keep a window away from them
        rows = fitter.valid[fitter.split.valid_block == b]
        on[rows.min() - 10:rows.max() + 10] = False
    reg[on] = 1.0
    r[:, 0] += 0.5 * reg
    fitter = _fitter(sysm, r, np.array([0.1]), cross_validate=False)
    sel = fitter.select([Term(_effect("hidden", reg), 0, "c")])
    (entry,) = sel.tried
    assert entry["decision"] == "cannot test"
    assert "holds no information about hidden" in entry["reason"]
    assert sel.fit.terms == []


def test_offset_whose_sign_follows_the_direction_is_demoted():
    """r = 0.5·sign(v) (a Coulomb-like odd effect) on a motion that runs forward 87 % of the
    time: a constant bias fits +0.34 and gains on held-out data (named on main), but fitted
    on each direction it is +0.5 and −0.5: not a constant."""
    rng = np.random.default_rng(4)
    t = np.arange(N) * DT
    v = np.sin(0.7 * t) + 0.9
    r = (0.5 * np.sign(v) + rng.normal(0, 0.1, N))[:, None]
    ones = np.ones(N)
    sel = _fitter(Fake(rates={"v": v}), r, np.array([0.1])).select(
        [Term(_effect("bias", ones), 0, "c")])
    assert sel.fit.terms == []
    (entry,) = sel.tried
    assert entry["decision"] == "demoted" and "not a constant" in entry["reason"]
    assert any("v > 0" in w["text"] for w in sel.warnings)


def test_true_constant_offset_is_kept():
    rng = np.random.default_rng(5)
    t = np.arange(N) * DT
    v = np.sin(0.7 * t) + 0.7
    r = (0.3 + rng.normal(0, 0.1, N))[:, None]
    sel = _fitter(Fake(rates={"v": v}), r, np.array([0.1])).select(
        [Term(_effect("bias", np.ones(N)), 0, "c")])
    assert [t.label for t in sel.fit.terms] == ["bias@c"]


def test_jointly_unidentifiable_set_is_not_named_as_a_whole():
    """Two terms whose regressors are proportional: the joint analysis drops one and names
    the combination (pairwise checks of held-out contributions never saw the pair, since the
    second term cannot gain after the first)."""
    rng = np.random.default_rng(6)
    x = np.sin(0.9 * np.arange(N) * DT)
    r = (0.5 * x + rng.normal(0, 0.1, N))[:, None]
    fitter = _fitter(Fake(), r, np.array([0.1]))
    ta, tb = Term(_effect("a", x), 0, "c"), Term(_effect("b", 2.0 * x), 0, "c")
    both = fitter.fit([ta, tb])
    from simgap.diagnosis.fit import Selection
    sel = Selection(fit=both)
    kept = fitter._identify(both, sel, {})
    assert len(kept.terms) == 1
    assert sel.identifiability["combinations"]
    assert "cannot be determined" in sel.warnings[0]["text"]


def test_signed_nonlinear_correction_can_go_negative():
    """A nonlinear parameter with bounds that include zero (a signed correction): main
    fitted nonlinear parameters in log space and could not cross zero."""
    rng = np.random.default_rng(7)
    tt = np.arange(N) * DT
    x = np.sin(0.9 * tt) + 0.4 * np.sin(2.3 * tt)

    def fn(lin, nl, sig, i, sys):
        return (np.tanh(nl[0] * 3.0 * x[sig["i"]]))[:, None]

    eff = Effect(name="signed", label="signed", scope="joint", nl=("s",), nl_units=("-",),
                 nl_bounds=((-1.0, 1.0),), nl_grid=((-0.8, -0.3, 0.3, 0.8),), fn=fn)
    r = (np.tanh(-0.4 * 3.0 * x) + rng.normal(0, 0.05, N))[:, None]
    sel = _fitter(Fake(), r, np.array([0.05])).select([Term(eff, 0, "c")])
    assert [t.label for t in sel.fit.terms] == ["signed@c"]
    assert abs(sel.fit.nl[0][0] + 0.4) < 0.03


def test_friction_family_fitted_together_with_a_signed_viscous_correction():
    """A nominal damping that is too high (a negative viscous correction) beside a missing
    Coulomb friction, tuned so that Coulomb alone gains nothing: friction is tried as one
    family, named in one round, with the viscous correction negative."""
    rng = np.random.default_rng(8)
    tt = np.arange(N) * DT
    amp = 0.85
    v = amp * np.sin(1.3 * tt)
    fc = 0.3 * 2 * amp / np.pi          # Coulomb alone: Fc* = fc − 0.3·E|v| = 0
    r = (-0.3 * v + fc * np.tanh(v / 0.01) + rng.normal(0, 0.02, N))[:, None]
    coul = _effect("coulomb_friction", np.tanh(v / 0.01), lower=0.0)
    visc = _effect("viscous_friction", v, lower=-0.5)
    sel = _fitter(Fake(), r, np.array([0.02])).select(
        [Term(coul, 0, "c"), Term(visc, 0, "c")])
    fitted = {t.effect.name: float(lv[0]) for t, lv in zip(sel.fit.terms, sel.fit.lin,
                                                           strict=True)}
    assert set(fitted) == {"coulomb_friction", "viscous_friction"}
    assert abs(fitted["viscous_friction"] + 0.3) < 0.03 and abs(fitted["coulomb_friction"] -
                                                                fc) < 0.03
    assert sel.history[0]["term"] == "coulomb_friction@c+viscous_friction@c"
    assert {t["decision"] for t in sel.tried} == {"named"}


def test_likelihood_ratio_holds_its_level_on_correlated_noise():
    """Under "no gain" (a useless term fitted on other data, autocorrelated errors) the
    held-out test rejects at most about its level; a real gain is found."""
    from scipy.signal import lfilter

    from simgap.diagnosis.significance import likelihood_ratio

    rng = np.random.default_rng(9)
    n, hits = 400, 0
    x = np.sin(np.arange(n) * 0.05)
    for _ in range(300):
        e0 = lfilter([1.0], [1.0, -0.8], rng.normal(0, 1.0, n))
        delta = rng.normal(0, 3.0 / np.sqrt(n))      # training error of a useless term
        hits += likelihood_ratio(e0, e0 - delta * x, 1).p_value < 0.01
    assert hits <= 6
    e0 = lfilter([1.0], [1.0, -0.8], rng.normal(0, 1.0, n)) + 0.8 * x
    res = likelihood_ratio(e0, e0 - 0.8 * x, 1)
    assert res.testable and res.p_value < 1e-3 and 0 < res.share_removed < 1
    short = likelihood_ratio(e0[:8], e0[:8] - 0.8 * x[:8], 1)
    assert not short.testable and "effective samples" in short.reason


def test_rows_interpolated_across_a_gap_are_found_from_the_time_stamps():
    """Without a segment array from the signals, the recorded time stamps give the gaps:
    grid rows inside one are marked (never fitted) and the segments change across it."""
    from simgap.diagnosis.validation import gap_segments

    t_rec = np.concatenate([np.arange(0, 10, 0.01), np.arange(15, 20, 0.01)])
    t_grid = np.arange(0, 19.995, 0.01)
    seg, inside = gap_segments(t_rec, t_grid)
    assert inside.sum() == pytest.approx(499, abs=2)
    assert np.all((t_grid[inside] > 9.99) & (t_grid[inside] < 15.0))
    assert seg[t_grid < 9.995].max() == 0 and seg[t_grid >= 15.0].min() == 1
    jitter = np.sort(np.arange(0, 10, 0.01) + np.random.default_rng(0).normal(0, 0.002, 1000))
    assert not gap_segments(jitter, t_grid[:1000])[1].any()


@pytest.mark.parametrize("seed", [0, 3])
def test_aliased_pair_is_decided_by_the_part_that_separates_them(seed):
    """A 4 s arm log whose joint 2 turns one way only during the fit part: Coulomb friction
    and a torque bias explain the same validation residual. The selection's pick between
    them was noise (main named the bias at seed 3, the kernel residual at seed 0); the later
    held-out part, where joint 2 reverses, must decide: Coulomb friction, Fc = 0.3 N·m."""
    from simgap.diagnosis.generate import InjectedEffect, generate_manipulator
    from simgap.diagnosis.pipeline import diagnose

    rec = generate_manipulator([InjectedEffect(effect="coulomb_friction", channel="joint2",
                                               params={"Fc": 0.3})], duration=4.0, seed=seed)
    effects = diagnose(rec, "manipulator2dof").data["effects"]
    assert [(e["effect"], e["channel"]) for e in effects] == [("coulomb_friction", "joint2")]
    assert effects[0]["parameters"]["Fc"] == pytest.approx(0.3, rel=0.03)


def test_fits_on_the_usable_rows_equal_the_full_grid_fit_there():
    """Issue 17 (memory): the selection's fits keep contributions on the usable rows only and
    the basis cache holds those rows; every number is the full-grid fit's, bit for bit, and
    the selection's final fit is on the full grid again."""
    rng = np.random.default_rng(3)
    x = np.sin(0.7 * np.arange(N) * DT)
    z = np.cos(1.3 * np.arange(N) * DT)
    r = (0.5 * x + 0.2 * z + rng.normal(0, 0.1, N))[:, None]
    fitter = _fitter(Fake(), r, np.array([0.1]))
    terms = [Term(_effect("a", x), 0, "c"), Term(_effect("b", z), 0, "c")]
    full, light = fitter.fit(terms), fitter.fit(terms, full=False)
    usable = np.sort(np.concatenate([fitter.fit_rows, fitter.test, fitter.split.guard]))
    assert full.rows is None and np.array_equal(light.rows, usable)
    assert len(usable) < N / 2                             # thinned: far fewer rows
    for p_full, p_light in zip(full.pred, light.pred, strict=True):
        assert p_full.shape == (N, 1) and np.array_equal(p_full[usable], p_light)
    assert (full.sse_train, full.sse_valid, full.sse_test) == \
        (light.sse_train, light.sse_valid, light.sse_test)
    assert np.array_equal(fitter._errors(full, fitter.test), fitter._errors(light, fitter.test))
    assert np.array_equal(np.concatenate(full.lin), np.concatenate(light.lin))
    expanded = fitter.full(light)
    assert expanded.rows is None
    assert all(np.array_equal(a, b) for a, b in zip(full.pred, expanded.pred, strict=True))
    cols, off, _ = fitter.basis(terms[0], np.zeros(0))
    assert cols.shape == (len(usable), 1, 1) and off.shape == (len(usable), 1)
    with pytest.raises(ValueError, match="usable rows"):
        fitter.at(np.array([usable[0] + 1]))
    sel = fitter.select(terms)
    assert sel.fit.rows is None and all(p.shape == (N, 1) for p in sel.fit.pred)


@pytest.mark.parametrize("model, effect", [
    ("manipulator2dof", ("coulomb_friction", "joint2", {"Fc": 0.2})),
    ("bicycle", ("tire_saturation", None, {"mu": 0.7}))])
def test_row_blocks_change_no_number(monkeypatch, model, effect):
    """Issue 17: M(q)·v in prepare and the test part's model derivative are evaluated in
    blocks of rows; tiny blocks (many of them) give the same report, bit for bit."""
    import json

    from simgap.diagnosis import compare, systems
    from simgap.diagnosis.generate import InjectedEffect, generate
    from simgap.diagnosis.pipeline import diagnose

    name, channel, params = effect
    rec = generate(model, [InjectedEffect(effect=name, channel=channel, params=params)],
                   seed=1, duration=6.0 if model == "manipulator2dof" else 12.0)

    def report() -> str:
        return json.dumps(diagnose(rec, model).data, sort_keys=True, default=str)

    whole = report()
    monkeypatch.setattr(systems, "MASS_BLOCK_ROWS", 97)
    monkeypatch.setattr(compare, "BLOCK_ROWS", 89)
    assert report() == whole


def test_split_blocks_cover_the_operating_regions():
    """Issue 13, "blocked cross-validation over operating regions": on a free decay (the
    amplitude falls with time) and on a log that turns one way, then the other, every part
    holds the large amplitudes and both directions (main: the outer test part was the last
    30 % in time, small amplitudes of one direction only); the parts are disjoint, the
    confirmation blocks are guarded, no block straddles a gap and the split is
    deterministic."""
    from simgap.diagnosis import validation

    t = np.arange(N) * DT
    seg = (t > 0.5 * t[-1]).astype(int)                     # a gap half-way
    decay = np.exp(-t / (0.25 * t[-1])) * np.sin(2 * np.pi * 0.5 * t)
    turns = np.where(t < 0.5 * t[-1], 1.0, -1.0) * (1.0 + 0.3 * np.sin(0.7 * t))
    rows = validation.usable_rows(N, 5, np.ones((N, 1)), seg)
    for regions in (np.abs(decay), decay, turns):
        sp = validation.split_rows(t, rows, seg, 0.7, regions=regions[:, None])
        again = validation.split_rows(t, rows, seg, 0.7, regions=regions[:, None])
        assert all(np.array_equal(getattr(sp, f), getattr(again, f))
                   for f in ("train", "valid", "test", "guard"))
        parts = [sp.train, sp.valid, sp.test, sp.guard]
        assert sum(len(p) for p in parts) == len(rows)
        assert len(np.unique(np.concatenate(parts))) == len(rows)
        assert np.array_equal(np.sort(np.concatenate([sp.train, sp.valid])), sp.fit)
        blocks = sp.test[sp.confirm_block >= 0]
        assert 0.05 * len(rows) < len(blocks) < 0.15 * len(rows)
        assert np.all(t[sp.tail] > sp.t_split) and np.all(t[sp.fit] < sp.t_split)
        for b in np.unique(sp.confirm_block[sp.confirm_block >= 0]):
            assert len(np.unique(seg[sp.test[sp.confirm_block == b]])) == 1
        # the guard separates each confirmation block from the fit part
        pos = np.searchsorted(rows, blocks)
        fit_pos = np.searchsorted(rows, sp.fit)
        assert np.min(np.abs(fit_pos[:, None] - pos[None, :])) > validation.GUARD_ROWS
        # every part holds the large amplitudes and each direction
        size = np.abs(regions)
        big = size > np.quantile(size[rows], 0.67)
        for part in (sp.train, sp.valid, blocks):
            assert np.mean(big[part]) > 0.15
            assert np.mean(regions[part] > 0) > 0.15 and np.mean(regions[part] < 0) > 0.15 \
                or np.all(regions >= 0)
    # the tail (main: the whole outer test part) holds no large amplitude of the decay
    assert np.mean((np.abs(decay) > np.quantile(np.abs(decay)[rows], 0.67))[sp.tail]) < 0.05


def test_cut_in_time_kept_when_the_tail_spans_the_regions():
    """A stationary excitation (both directions, every amplitude throughout): the last 30 %
    of the usable rows already span the regions and stay the outer test part (the rollouts'
    contiguous part, the split of main); a decay or a log turning one way then the other
    does not, and gets region blocks."""
    from simgap.diagnosis import validation

    t = np.arange(N) * DT
    rows = validation.usable_rows(N, 5, np.ones((N, 1)), None)
    k = int(round(0.7 * len(rows)))
    steady = np.column_stack([np.sin(0.9 * t) + 0.5 * np.sin(2.9 * t), np.cos(1.7 * t)])
    assert validation.tail_covers(steady, rows[:k], rows[k:])
    sp = validation.split_rows(t, rows, None, 0.7, regions=steady)
    assert np.array_equal(sp.test, rows[k:]) and np.array_equal(sp.fit, rows[:k])
    assert np.all(sp.confirm_block == -1) and len(sp.guard) == 0
    plain = validation.split_rows(t, rows, None, 0.7)      # no regions: the time cut
    assert all(np.array_equal(getattr(sp, f), getattr(plain, f))
               for f in ("train", "valid", "valid_block", "fit", "test"))
    decay = np.exp(-t / (0.25 * t[-1])) * np.sin(2 * np.pi * 0.5 * t)
    turns = np.where(t < 0.5 * t[-1], 1.0, -1.0) * (1.0 + 0.3 * np.sin(0.7 * t))
    for x in (decay, turns):
        assert not validation.tail_covers(x, rows[:k], rows[k:])
        assert np.any(validation.split_rows(t, rows, None, 0.7, regions=x).confirm_block >= 0)
