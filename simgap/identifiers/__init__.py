"""Online neural identifiers of the residual g(x, u) = dx/dt − f(x, u) (thesis Ch. 3, Sec. 4.2).

Three identifiers share one network ĝ = Ŵ tanh(V̂ x̄) (:mod:`~simgap.identifiers.network`)
and one update law (eq. 3.6-3.7, :mod:`~simgap.identifiers.laws`); they differ only in the
error signal e that drives it:

* ``"instantaneous"`` (baseline 1, eq. 3.8): e = x̃.
* ``"integral"`` (proposed, eq. 3.9 / 4.6): e = z, z_{k+1} = z_k + Δt (−λ z_k + x̃_k), z_0 = 0.
* ``"minibatch"`` (baseline 2, eq. 4.2-4.4): no observer; SGD every P_upd steps on M random
  samples of a sliding-window buffer (:mod:`~simgap.identifiers.minibatch`).

Public API
----------
::

    from simgap.identifiers import make_identifier, preset, load_identifier

    ident = make_identifier("integral", n_states=4, n_inputs=2, dt=0.002,
                            config=preset("manipulator", "integral"), seed=0)
    for k in range(K):
        g_hat = ident.step(x[k], u[k], f[k], x[k + 1])   # one transition, returns ĝ_k
    ident.freeze(); ident.predict(x_bar)              # x_bar (n+m,) or (N, n+m)
    ident.save("ident.npz"); same = load_identifier("ident.npz")

``make_identifier(kind, n_states, n_inputs, dt, *, config=None, seed=0) -> Identifier``
    ``kind`` is ``"instantaneous" | "integral" | "minibatch"``; ``config=None`` means
    ``preset("manipulator", kind)`` (Table 4.3). ``dt`` is the sampling period Δt (s).
    The same ``seed`` (and network sizes and init scales) gives bit-identical initial
    weights for all three kinds.

``preset(system, kind, *, dt=None) -> IdentifierConfig``
    ``system`` is ``"auto"`` (scale-free, for any env, needs ``dt``: bound-normalised
    gradients, a_d = −min(0.25/Δt, 20 s⁻¹), one adaptation bandwidth |a_d|/4 for every law,
    the integral law's own observer and z filter above that loop (−50 s⁻¹, 250 s⁻¹ at 2 ms);
    derivation in :func:`~simgap.identifiers.config.auto_preset`; the default of the
    wrappers), or the thesis reproduction presets ``"manipulator"`` (Table 4.3) and
    ``"bicycle"`` (Table 4.4, network (4, 20, 2) per the errata). The kinds, their kernel
    codes and table order come from one table, :data:`~simgap.identifiers.laws.LAWS`.

:class:`Identifier` (attributes are NumPy arrays; copies are safe to keep):

* ``step(x, u, f, x_next) -> g_hat``: one transition x_k --u_k--> x_{k+1}, with
  ``f = f(x_k, u_k)`` the nominal derivative (state units/s). Returns ĝ_k (state units/s).
* ``predict(x_bar) -> g_hat``: the network with the *current* weights, no state change.
* ``x_bar``, ``g_hat``, ``e``, ``x_hat``, ``x_tilde``, ``z``, ``W``, ``V``, ``frozen``,
  ``n_steps`` (transitions seen), ``n_updates`` (weight updates made).
* ``freeze()`` / ``unfreeze()``; ``reset_observer(x0)`` (x̂ = x0, z = 0; weights and buffer
  kept; ``x0=None``: x̂ = the x of the next step); ``reset()`` (everything back to the
  state after construction); ``state_dict()`` / ``load_state_dict(d)``;
  ``save(path)`` / ``Identifier.load(path)``
  (= ``load_identifier(path)``): one ``.npz`` of arrays with the config as JSON inside, no
  pickle.

Time indexing of one ``step`` (what each attribute holds afterwards)
--------------------------------------------------------------------
Observer-based kinds (``instantaneous``, ``integral``), explicit Euler of the joint ODE
(eq. 3.1 with the errata's sign, eq. 4.1 / 4.5 / 4.6), every rate evaluated at time k:

1. if the observer is not initialised (fresh identifier): x̂_k = x_k (x̃_k = 0);
2. ``x_bar`` = x̄_k = [x̂_k; u_k] (the network input of eq. 3.1);
3. ``g_hat`` = ĝ_k = Ŵ_k tanh(V̂_k x̄_k): evaluated with the weights *before* this step's
   update, so ``g_hat == predict(x_bar)`` exactly whenever the identifier is frozen;
4. x̃_k = x_k − x̂_k; ``e`` = e_k = x̃_k (instantaneous) or z_k (integral);
5. unless frozen: (Ŵ, V̂)_{k+1} = (Ŵ, V̂)_k + Δt (eq. 3.6, 3.7 evaluated at e_k, x̄_k, ‖x̃_k‖),
   and z_{k+1} = z_k + Δt (−λ z_k + x̃_k);
6. x̂_{k+1} = x̂_k + Δt (f_k + ĝ_k − A_d x̃_k) (runs also when frozen);
7. ``x_hat`` = x̂_{k+1} and ``x_tilde`` = x_{k+1} − x̂_{k+1}: the estimate of, and the error
   at, the state the env returns with this transition; ``z`` = z_{k+1}.

``x_next`` is used only for step 7 (reporting); the next ``step`` takes its own ``x``.
To re-evaluate a frozen network over a recorded run, record ``x_bar`` after every step and
call ``predict`` on the stacked (K, p) array: the result equals the recorded ``g_hat``
bit for bit (tested). A fresh identifier starts with x̂_0 = x_0, z_0 = 0, weights from the
seed; one "transition" is one ``step`` call (Δt = ``dt``).

Minibatch (baseline 2): ``x_bar`` = x̄_k = [x_k; u_k] (eq. 4.2 evaluates ĝ(x_k, u_k));
``g_hat`` = ĝ_k with the weights before the step; unless frozen, (x̄_k, x_k, x_{k+1}, f_k) is
pushed into the ring buffer and, every ``P_upd``-th pushed transition, one SGD step (eq. 4.4)
on M indices drawn uniformly with replacement from the filled buffer by the identifier's seeded
``numpy.random.Generator``. ``x_hat`` = x̂^pred_{k+1} = x_k + Δt (f_k + ĝ_k) (eq. 4.2) and
``x_tilde`` = x_{k+1} − x̂^pred_{k+1}; ``e`` = ``x_tilde``; ``z`` stays zero.

Learning-rate conventions (documented in :mod:`~simgap.identifiers.config`): the observer
laws use η, ρ exactly as printed; baseline 2 applies the printed η to the exact gradient of
J_mb as printed (eq. 4.3), so in terms of the residual error it acts as η·Δt².

Errors: :class:`IdentifierError` (a ``ValueError``) for bad input (wrong shapes, non-finite
x/u/f); :class:`IdentifierDivergedError` (subclass) when a weight matrix or x̂ becomes
non-finite or a weight norm exceeds ``config.max_weight_norm``; the identifier then keeps the
last good state (nothing half-written).

Batched use (vector envs): :class:`BatchIdentifier` holds N identifiers of one kind in arrays
of shape (N, …) and advances them with the same numba row code (``N = 1`` for one env); its
``step(x, u, f, x_next, learn=None)`` takes (N, ·) arrays and a boolean mask of the rows that
are real transitions (rows with ``learn[i] == False`` change nothing at all). From
``PARALLEL_MIN_ROWS`` = 256 rows up, the observer laws split the rows over numba's threads
(``numba.set_num_threads`` limits them); rows are independent, so the result is the same bit
for bit.

The numba kernels compile on first use, not at import: on a fresh machine the first
identifier of a kind takes ≈ 7-10 s (the threaded batch kernel ≈ 10 s); numba's cache serves
them afterwards. ``Identifier.step`` of the observer laws goes through a small optional C
extension that calls the kernel without numba's dispatcher (:mod:`~simgap.identifiers.fastcall`,
built at install time when a C compiler is present; without it, the same results ≈ 0.5 µs
slower per step).
"""

from simgap.identifiers.batch import BatchIdentifier
from simgap.identifiers.config import KINDS, SYSTEMS, IdentifierConfig, preset
from simgap.identifiers.errors import IdentifierDivergedError, IdentifierError
from simgap.identifiers.identifier import Identifier, load_identifier, make_identifier
from simgap.identifiers.network import init_weights, network_forward

__all__ = [
    "KINDS",
    "SYSTEMS",
    "BatchIdentifier",
    "Identifier",
    "IdentifierConfig",
    "IdentifierDivergedError",
    "IdentifierError",
    "init_weights",
    "load_identifier",
    "make_identifier",
    "network_forward",
    "preset",
]
