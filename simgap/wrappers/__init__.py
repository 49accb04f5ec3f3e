"""Gymnasium wrappers that run the online identifiers inside any env with a nominal model.

* :class:`IdentifierWrapper`: one env, one :class:`~simgap.identifiers.Identifier`; adds
  ``residual_estimate``, ``state_estimate``, ``estimation_error``, ``identifier_frozen`` and
  ``physical_residual_estimate`` to ``info`` (details and reset semantics in
  :mod:`simgap.wrappers.identifier_wrapper`).
* :class:`ResidualObservation`: appends ĝ (and optionally x̃) to a Box observation.
* :class:`VectorIdentifierWrapper`: ``gym.make_vec(..., vectorization_mode="sync")`` with one
  batched kernel call per step; autoreset steps are not learned from.

Example::

    import gymnasium as gym
    import simgap
    from simgap.wrappers import IdentifierWrapper

    env = IdentifierWrapper(gym.make("simgap/ManipulatorFriction-v0"), "integral")
    obs, info = env.reset(seed=0)
    obs, r, term, trunc, info = env.step(env.action_space.sample())
    info["residual_estimate"], info["physical_residual_estimate"]   # ĝ and tau_d estimate
    env.freeze()                                                     # hold the weights
"""

from simgap.wrappers.identifier_wrapper import IdentifierWrapper, nominal_model_of
from simgap.wrappers.residual_observation import ResidualObservation
from simgap.wrappers.vector import VectorIdentifierWrapper

__all__ = ["IdentifierWrapper", "ResidualObservation", "VectorIdentifierWrapper",
           "nominal_model_of"]
