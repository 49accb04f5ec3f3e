"""Shared machinery of ``Identifier`` and ``BatchIdentifier``.

N identifiers of one kind live in one (N, row_size) float64 array (layout in
:mod:`simgap.identifiers.kernels`) and are advanced by one numba kernel call.
"""

from __future__ import annotations

import json
from typing import Any

import numpy as np

from simgap.identifiers import kernels as K
from simgap.identifiers.config import (
    KIND_CODES,
    IdentifierConfig,
    check_kind,
    error_scale,
    preset,
)
from simgap.identifiers.errors import IdentifierDivergedError, IdentifierError
from simgap.identifiers.minibatch import DUE, FILLED
from simgap.identifiers.network import init_weights
from simgap.identifiers.scales import gated, whiteness
from simgap.models.base import wrap_angle

#: Observer-law batches from this many rows up run on all of numba's threads (the rows are
#: independent, so the result is the same bit for bit); smaller ones on the calling thread.
PARALLEL_MIN_ROWS = 256

#: The row index array of a single identifier's SGD burst (read by the kernel only).
_ROW0 = np.zeros(1, dtype=np.int64)

#: Format tag written into saved files (3: header slot ``HP_SRATE`` and the row's scale
#: block, :mod:`~simgap.identifiers.scales`).
FORMAT = "simgap-identifier/3"
#: The previous format, still read (:func:`upgrade_v2`).
FORMAT_V2 = "simgap-identifier/2"

#: Header slots (``K.HP_*``) filled from :class:`IdentifierConfig` fields, in the order of
#: the config's fields.
HEADER_FIELDS: dict[str, int] = {
    "n_hidden": K.HP_H, "a_d": K.HP_AD, "eta1": K.HP_ETA1, "eta2": K.HP_ETA2,
    "rho1": K.HP_RHO1, "rho2": K.HP_RHO2, "lam": K.HP_LAM, "update_period": K.HP_PERIOD,
    "max_weight_norm": K.HP_MAXN, "scale_rate": K.HP_SRATE, "a_d_clean": K.HP_ADC,
    "eta1_clean": K.HP_ETA1C, "eta2_clean": K.HP_ETA2C}
#: Every header slot fixed at construction (the config's, Δt, sizes, error-signal code, c_e):
#: a loaded state must carry exactly these values.
FIXED_SLOTS: np.ndarray = np.array(sorted(
    {*HEADER_FIELDS.values(), K.HP_DT, K.HP_N, K.HP_M, K.HP_MODE, K.HP_ESCALE,
     K.HP_ESCALEC}), dtype=np.int64)
#: What each fixed header slot holds (meta field or config field), for error messages.
_SLOT_NAMES: dict[int, str] = {
    **{slot: f"config {name}" for name, slot in HEADER_FIELDS.items()},
    K.HP_DT: "dt", K.HP_N: "n_states", K.HP_M: "n_inputs", K.HP_MODE: "the kind's code",
    K.HP_ESCALE: "the error scale c_e", K.HP_ESCALEC: "the clean-data error scale"}
#: Header size of format 2 files (before ``HP_SRATE``; no scale block at the row end).
_HP_SIZE_V2 = 20


def _check_int(name: str, v: Any) -> int:
    if isinstance(v, bool) or not isinstance(v, int | np.integer) or int(v) < 1:
        raise IdentifierError(f"{name} must be a positive integer, got {v!r}")
    return int(v)


def upgrade_v2(meta: dict[str, Any], arrays: dict[str, np.ndarray]
               ) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
    """Format 2 meta and arrays as format 3 (same identifier, no running scales).

    Format 2 rows have a 20-slot header and no scale block: the header gains
    ``HP_SRATE`` and the noise-gate slots (all 0) and the row an all-zero scale block; the
    config gains ``scale_rate`` = 0 and ``a_d_clean`` = ``eta1_clean`` = ``eta2_clean`` = 0.
    Sizes are checked later, against the identifier built from the meta.
    """
    meta = dict(meta)
    cfg = dict(meta["config"])
    for name in ("scale_rate", "a_d_clean", "eta1_clean", "eta2_clean"):
        cfg.setdefault(name, 0.0)
    meta["config"] = cfg
    meta["format"] = FORMAT
    arrays = dict(arrays)
    old = np.asarray(arrays["state"])
    if old.ndim == 2 and old.shape[1] >= _HP_SIZE_V2:
        n, m = int(meta["n_states"]), int(meta["n_inputs"])
        new = np.zeros((old.shape[0], old.shape[1] + K.HP_SIZE - _HP_SIZE_V2
                        + K.block_size.py_func(n, n + m)))
        new[:, :_HP_SIZE_V2] = old[:, :_HP_SIZE_V2]
        new[:, K.HP_SIZE:K.HP_SIZE + old.shape[1] - _HP_SIZE_V2] = old[:, _HP_SIZE_V2:]
        arrays["state"] = new
    return meta, arrays


def sampling_rng(seed: int) -> np.random.Generator:
    """Return the Generator baseline 2 draws its mini-batch indices from.

    It is independent of the weight initialisation stream, ``default_rng(seed)``.
    """
    return np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(1,)))


class IdentifierBase:
    """N identifiers of one kind sharing hyper-parameters; not used directly."""

    def __init__(self, kind: str, n_states: int, n_inputs: int, dt: float, *,
                 config: IdentifierConfig | None = None, seed: int = 0,
                 n_envs: int = 1) -> None:
        self.kind = check_kind(kind)
        self.n_states = n = _check_int("n_states", n_states)
        self.n_inputs = m = _check_int("n_inputs", n_inputs)
        self.n_envs = _check_int("n_envs", n_envs)
        dt = float(dt)
        if not np.isfinite(dt) or dt <= 0:
            raise IdentifierError(f"dt must be a finite positive number of seconds, got {dt!r}")
        self.dt = dt
        if config is None:
            config = preset("manipulator", kind)
        if not isinstance(config, IdentifierConfig):
            raise IdentifierError(f"config must be an IdentifierConfig, got {type(config)}")
        self.config = config
        if isinstance(seed, bool) or not isinstance(seed, int | np.integer) or seed < 0:
            raise IdentifierError(f"seed must be a non-negative integer, got {seed!r}")
        self.seed = int(seed)
        self.n_hidden = h = config.n_hidden
        self.n_in = p = n + m
        self._nw = n * h
        self._nv = h * p
        self._lay = lay = K.layout(n, m, h)
        nn = self.n_envs
        # one identifier: scratch columns after the state (no allocation per kernel call)
        scratch = K.scratch_layout.py_func(n, m, h)[-1] if nn == 1 else 0
        self._state = np.zeros((nn, lay["size"] + scratch))
        hp = np.zeros(K.HP_SIZE)
        for name, slot in HEADER_FIELDS.items():
            hp[slot] = getattr(config, name)
        hp[K.HP_DT] = dt
        hp[K.HP_N] = n
        hp[K.HP_M] = m
        hp[K.HP_MODE] = (K.MB_ESTIMATE if kind == "minibatch"
                         and config.minibatch_input == "estimate" else KIND_CODES[kind])
        hp[K.HP_ESCALE] = error_scale(kind, config, dt)
        if config.a_d_clean != 0:
            hp[K.HP_ESCALEC] = error_scale(kind, config, dt, clean=True)
        self._hp = hp
        self._minibatch = kind == "minibatch"
        size = config.buffer_size if self._minibatch else 1
        self._buf = np.zeros((nn, size, p + n))
        self._cnt = np.zeros((nn, K.N_COUNTERS), dtype=np.int64)
        self._bind()
        # the general kernel of this kind (compiled on first use: K.ready); batches of at least
        # PARALLEL_MIN_ROWS rows are split over numba's threads
        if self._minibatch:
            self._kernel_name = "minibatch_step_single" if nn == 1 else "minibatch_step"
        else:
            self._kernel_name = ("observer_step_parallel" if nn >= PARALLEL_MIN_ROWS
                                 else "observer_step")
        self.reset()

    #: Attributes derived from ``_state`` (views into it, the fast-path caller): not copied
    #: by pickle / ``copy.deepcopy``, rebuilt by :meth:`_bind` (a copied view would no longer
    #: look into the copy's state).
    _DERIVED: tuple[str, ...] = ("_act",)

    def _bind(self) -> None:
        """(Re)build the attributes of :data:`_DERIVED` on ``self._state``."""
        self._act = self._state[:, K.HP_ACT]

    def __getstate__(self) -> dict[str, Any]:
        d = self.__dict__.copy()
        for key in self._DERIVED:
            d.pop(key, None)
        return d

    def __setstate__(self, d: dict[str, Any]) -> None:
        self.__dict__.update(d)
        self._bind()

    # ------------------------------------------------------------------ lifecycle
    def reset(self) -> None:
        """Go back to the state right after construction.

        Initial weights from the seed, x̂ uninitialised, z = 0, empty buffer, sampling
        Generator re-seeded, not frozen.
        """
        v0_scale = (np.sqrt(3.0 / self.n_in) if self.config.init == "lecun"
                    else self.config.v0_scale)
        w0, v0 = init_weights(self.seed, self.n_states, self.n_hidden, self.n_in,
                              self.config.w0_scale, v0_scale)
        ow = self._lay["ow"]
        self._state[:] = 0.0
        self._state[:, :K.HP_SIZE] = self._hp
        self._state[:, ow:ow + self._nw] = w0.ravel()
        self._state[:, ow + self._nw:ow + self._nw + self._nv] = v0.T.ravel()
        self._state[:, K.HP_NORM2] = np.sum(w0 * w0)
        self._state[:, K.HP_NORM2 + 1] = np.sum(v0 * v0)
        self._buf[:] = 0.0
        self._cnt[:] = 0
        self._rng = sampling_rng(self.seed)
        self._frozen = False
        self._masked = False
        self._act[:] = K.LEARN
        self._py_steps = 0
        self._py_updates = 0

    @property
    def n_steps(self) -> int:
        """Calls of ``step`` since construction / :meth:`reset` that succeeded."""
        return self._py_steps

    @property
    def n_updates(self) -> int:
        """Learning steps taken (SGD bursts for baseline 2)."""
        return self._py_updates

    @property
    def frozen(self) -> bool:
        """True while weights, buffer and z are held (x̂ keeps running)."""
        return self._frozen

    def freeze(self) -> None:
        """Stop every weight, buffer and z update; the observer x̂ keeps running."""
        self._frozen = True
        self._act[:] = K.FROZEN

    def unfreeze(self) -> None:
        """Resume learning."""
        self._frozen = False
        self._act[:] = K.LEARN

    # ------------------------------------------------------------------ kernel calls
    def _run(self, x: np.ndarray, u: np.ndarray, f: np.ndarray, x_next: np.ndarray, *,
             converted: bool = False) -> None:
        """Advance the active rows; raise a typed error naming the failed rows (unchanged)."""
        try:
            kernel = K.ready(self._kernel_name)
            if self._minibatch:
                r, due = kernel(self._state, x, u, f, x_next, self._buf, self._cnt)
            else:
                r = kernel(self._state, x, u, f, x_next)
                due = 0
        except TypeError:  # not writeable float64 C-contiguous 1-D: convert once and retry
            if converted:
                raise
            x, u, f, x_next = (self._coerce(a) for a in (x, u, f, x_next))
            return self._run(x, u, f, x_next, converted=True)
        if r != 0:
            self._raise(r, x, u, f, x_next)
        if due:
            self._burst()

    def _burst(self) -> None:
        """Baseline 2: draw the mini-batches of the due rows and take the SGD steps.

        Eq. 4.3-4.4; indices uniform with replacement over each row's filled buffer.
        """
        size = self.config.batch_size
        if self.n_envs == 1:  # row 0 is due; a scalar bound draws the same numbers, faster
            rows = _ROW0
            idx = self._rng.integers(0, int(self._cnt[0, FILLED]), size=(1, size))
        else:
            rows = np.flatnonzero(self._cnt[:, DUE])
            filled = self._cnt[rows, FILLED]
            idx = self._rng.integers(0, filled[:, None], size=(rows.size, size))
        nfail = K.ready("minibatch_sgd")(self._state, self._buf, self._cnt,
                                         np.ascontiguousarray(idx, dtype=np.int64),
                                         rows.astype(np.int64, copy=False))
        self._py_updates += 1
        if nfail:
            status = self._state[rows, K.HP_STATUS]
            bad = [int(i) for i, st in zip(rows, status, strict=True)
                   if st == K.STATUS_DIVERGED]
            self._state[:, K.HP_STATUS] = K.STATUS_OK
            raise IdentifierDivergedError(
                f"{self.kind} identifier: the SGD update of row(s) {bad} would give a weight "
                f"norm above max_weight_norm={self.config.max_weight_norm:g} or non-finite; "
                f"weights kept (lower eta1/eta2)")

    @staticmethod
    def _coerce(a: Any) -> np.ndarray:
        """``a`` as a flat, writeable float64 C-contiguous array, as numba requires.

        A read-only array (``np.frombuffer``, a broadcast) is copied.
        """
        b = np.ascontiguousarray(a, dtype=np.float64).reshape(-1)
        return b if b.flags.writeable else b.copy()

    def _raise(self, r: int, x: np.ndarray, u: np.ndarray, f: np.ndarray,
               x_next: np.ndarray) -> None:
        nn, n, m = self.n_envs, self.n_states, self.n_inputs
        if r < 0:
            raise IdentifierError(
                f"{self.kind} identifier: expected x, f, x_next with {nn * n} values "
                f"({nn}×{n}) and u with {nn * m} ({nn}×{m}); got sizes x={np.size(x)}, "
                f"u={np.size(u)}, f={np.size(f)}, x_next={np.size(x_next)}")
        status = self._state[:, K.HP_STATUS]
        bad_in = np.flatnonzero(status == K.STATUS_BAD_INPUT)
        bad = np.flatnonzero((status == K.STATUS_DIVERGED) | (status == K.STATUS_STATE_DIVERGED))
        status[:] = K.STATUS_OK  # the status flags a failed call, not a state to keep
        if bad_in.size:
            raise IdentifierError(f"{self.kind} identifier: non-finite value in x, u, f or "
                                  f"x_next (row(s) {bad_in.tolist()}); identifier unchanged")
        a_dt = self.config.a_d * self.dt
        raise IdentifierDivergedError(
            f"{self.kind} identifier diverged in row(s) {bad.tolist()}: the update would make "
            f"x̂ non-finite or a weight norm exceed max_weight_norm="
            f"{self.config.max_weight_norm:g}; last good state kept. Observer pole "
            f"1 + a_d·dt = 1 + ({self.config.a_d:g})·{self.dt:g} = {1 + a_dt:.3g} (stable "
            f"only for −2 < a_d·dt < 0; preset('auto', kind, dt=dt) keeps it in [0.75, 1)): "
            f"lower |a_d|, eta1/eta2 or dt")

    # ------------------------------------------------------------------ views
    def _W(self) -> np.ndarray:  # noqa: N802
        """Ŵ of every row, (N, n, n_h), in raw output units (diag(s) Ŵ with running scales)."""
        ow = self._lay["ow"]
        w = self._state[:, ow:ow + self._nw].reshape(self.n_envs, self.n_states,
                                                     self.n_hidden)
        if self.config.scale_rate > 0:
            w = w * np.sqrt(self._scale_stats()[1])[:, :, None]
        return w

    def _V(self) -> np.ndarray:  # noqa: N802
        """V̂ of every row, (N, n_h, p), in raw input units.

        With running scales V̂ diag(1/r); the columns of inputs without data are 0.
        """
        ov = self._lay["ow"] + self._nw
        vt = self._state[:, ov:ov + self._nv].reshape(self.n_envs, self.n_in, self.n_hidden)
        v = vt.transpose(0, 2, 1)
        if self.config.scale_rate > 0:
            m_in = self._scale_stats()[0]
            inv = np.divide(1.0, np.sqrt(m_in), out=np.zeros_like(m_in), where=m_in > 0)
            v = v * inv[:, None, :]
        return v

    def _scale_stats(self) -> tuple[np.ndarray, np.ndarray]:
        """Running mean squares (m_in (N, p), m_out (N, 1)) of :mod:`~simgap.identifiers.scales`."""
        ons = K.scale_block.py_func(self.n_states, self.n_inputs, self.n_hidden)
        p = self.n_in
        return (self._state[:, ons + 1:ons + 1 + p],
                self._state[:, ons + 1 + p:ons + 2 + p])

    def _field(self, which: str) -> np.ndarray:
        n, p = self.n_states, self.n_in
        lay = self._lay
        start, size = {"g": (lay["og"], n), "x_bar": (lay["oxb"], p),
                       "x_hat": (lay["oxh1"], n), "x_tilde": (lay["oxt1"], n),
                       "e": (lay["oe"], n), "z": (lay["oz"], n),
                       "observer": (lay["oxh"], 2 * n + 1)}[which]
        return self._state[:, start:start + size]

    def _z(self) -> np.ndarray:
        return self._field("z")

    def _initialised(self) -> np.ndarray:
        return self._state[:, self._lay["oini"]] != 0.0

    def _observer_gains(self) -> np.ndarray:
        """a_d the next step uses, per row (N,), 1/s: the noise gate's a_d(ρ⁺) or ``a_d``.

        With the gate on (``a_d_clean`` ≠ 0), a_d(ρ⁺) = a_d + ρ⁺ (a_d_clean − a_d) at the
        current statistics (:func:`~simgap.identifiers.scales.whiteness`), the kernel's
        formula (:func:`~simgap.identifiers.scales.gated`); otherwise the configured a_d.
        """
        cfg = self.config
        if cfg.a_d_clean == 0.0:
            return np.full(self.n_envs, float(cfg.a_d))
        ons = K.scale_block.py_func(self.n_states, self.n_inputs, self.n_hidden)
        return np.array([gated.py_func(float(cfg.a_d), float(cfg.a_d_clean),
                                       whiteness.py_func(row, ons, self.n_in))
                         for row in self._state])

    @property
    def observes(self) -> bool:
        """True if the rows run the observer x̂ (the observer laws; baseline 2 on x̂)."""
        return not self._minibatch or self.config.minibatch_input == "estimate"

    def _set_observer(self, sel: np.ndarray | slice, x0: np.ndarray | None) -> None:
        """x̂ = x0 and z = 0 in rows ``sel`` (x0 None: uninitialised, x̂ = the next x)."""
        n = self.n_states
        obs = self._field("observer")  # [x̂ (n) | z (n) | initialised]
        if x0 is None:
            obs[sel] = 0.0
            return
        obs[sel, :n] = x0
        obs[sel, n:2 * n] = 0.0
        obs[sel, 2 * n] = 1.0

    def wrap_observer(self, indices: np.ndarray) -> None:
        """Map the periodic entries ``indices`` of x̂ (every row) into (−π, π].

        Shifts by whole turns only, so the observer's error on an angle (with the measured
        angle fed as its representative nearest to x̂, as the wrappers do) is unchanged.
        Weights, z and the reported results of the last step are not touched.
        """
        obs = self._field("observer")
        obs[:, indices] = wrap_angle(obs[:, indices])

    def _predict_row(self, row: int, x_bar: Any) -> np.ndarray:
        xb = np.ascontiguousarray(x_bar, dtype=np.float64)
        single = xb.ndim == 1
        xb2 = xb.reshape(1, -1) if single else xb
        if xb2.ndim != 2 or xb2.shape[1] != self.n_in:
            raise IdentifierError(f"x_bar must have shape ({self.n_in},) or (K, {self.n_in}) "
                                  f"= [state; input], got {xb.shape}")
        if not np.all(np.isfinite(xb2)):
            raise IdentifierError("x_bar contains non-finite values")
        res = np.empty((xb2.shape[0], self.n_states))
        K.ready("predict_rows")(self._state[row], self.n_states, self.n_inputs, self.n_hidden,
                                xb2, res)
        return res[0] if single else res

    # ------------------------------------------------------------------ persistence
    def _meta(self) -> dict[str, Any]:
        return {"format": FORMAT, "kind": self.kind, "n_states": self.n_states,
                "n_inputs": self.n_inputs, "dt": self.dt, "seed": self.seed,
                "n_envs": self.n_envs, "config": self.config.to_dict(),
                "frozen": self._frozen, "n_steps": self.n_steps, "n_updates": self.n_updates,
                "rng_state": self._rng.bit_generator.state}

    def _arrays(self) -> dict[str, np.ndarray]:
        return {"state": self._persistent().copy(), "buffer": self._buf.copy(),
                "counters": self._cnt.copy()}

    def _persistent(self) -> np.ndarray:
        """The state rows without any scratch columns."""
        return self._state[:, :self._lay["size"]]

    def _load_arrays(self, meta: dict[str, Any], arrays: dict[str, np.ndarray],
                     source: str) -> None:
        for key, dst in (("state", self._persistent()), ("buffer", self._buf),
                         ("counters", self._cnt)):
            if key not in arrays:
                raise IdentifierError(f"{source}: missing array {key!r}")
            a = np.asarray(arrays[key])
            if a.shape != dst.shape:
                raise IdentifierError(f"{source}: array {key!r} has shape {a.shape}, expected "
                                      f"{dst.shape} for this identifier")
            if a.dtype.kind not in ("iu" if key == "counters" else "fiu"):
                raise IdentifierError(f"{source}: array {key!r} has dtype {a.dtype}, expected "
                                      f"{dst.dtype}")
            if key != "counters" and not np.all(np.isfinite(a)):
                raise IdentifierError(f"{source}: array {key!r} contains non-finite values")
        hp = np.asarray(arrays["state"])[:, :K.HP_SIZE]
        fixed = FIXED_SLOTS
        if not np.array_equal(hp[:, fixed], np.broadcast_to(self._hp[fixed], hp[:, fixed].shape)):
            slot = int(fixed[np.argmax(np.any(hp[:, fixed] != self._hp[fixed], axis=0))])
            raise IdentifierError(f"{source}: array 'state' holds {_SLOT_NAMES[slot]} = "
                                  f"{float(hp[0, slot])!r:.24} in its header, the meta/config "
                                  f"{float(self._hp[slot])!r:.24}")
        self._persistent()[:] = arrays["state"]
        self._buf[:] = arrays["buffer"]
        self._cnt[:] = arrays["counters"]
        rng = sampling_rng(self.seed)
        try:
            rng.bit_generator.state = meta["rng_state"]
        except (KeyError, TypeError, ValueError) as exc:
            raise IdentifierError(f"{source}: bad rng_state ({exc})") from None
        self._rng = rng
        if meta.get("frozen", False):
            self.freeze()
        else:
            self.unfreeze()
        self._py_steps = int(meta.get("n_steps", 0))
        self._py_updates = int(meta.get("n_updates", 0))

    def state_dict(self) -> dict[str, Any]:
        """Return everything needed for an identical continuation.

        ``meta`` (JSON-able dict: kind, sizes, dt, seed, config, frozen, counters,
        sampling-Generator state) and the raw arrays ``state`` (the state rows without their
        scratch part), ``buffer``, ``counters`` (copies; layout in
        :mod:`simgap.identifiers.kernels`).
        """
        d: dict[str, Any] = {"meta": json.loads(json.dumps(self._meta()))}
        d.update(self._arrays())
        return d

    def load_state_dict(self, d: dict[str, Any]) -> None:
        """Restore a :meth:`state_dict` taken from an identifier of the same kind and sizes."""
        if "meta" not in d:
            raise IdentifierError("state dict has no 'meta' entry")
        meta = d["meta"]
        for key in ("kind", "n_states", "n_inputs", "n_envs"):
            if meta.get(key) != getattr(self, key):
                raise IdentifierError(f"state dict is for {key}={meta.get(key)!r}, this "
                                      f"identifier has {key}={getattr(self, key)!r}")
        if meta.get("config") != self.config.to_dict():
            raise IdentifierError("state dict was saved with a different IdentifierConfig")
        self._load_arrays(meta, d, "state dict")
