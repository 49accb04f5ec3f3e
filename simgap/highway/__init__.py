"""highway-env integration (optional extra ``highway``): saturating tires in driving scenarios.

* :class:`~simgap.highway.vehicle.PacejkaBicycleVehicle`: highway-env's ``BicycleVehicle``
  with its linear tire forces replaced by the Magic Formula of :mod:`simgap.models.tires`.
* :class:`~simgap.highway.lane_keeping.PacejkaLaneKeepingEnv`, registered as
  ``simgap/PacejkaLaneKeeping-v0``: highway-env's lane-keeping task with that vehicle, the
  observation taken *after* the step, a ``nominal_model`` for the
  :class:`~simgap.wrappers.IdentifierWrapper`, and the true residual in ``info``.

Nothing here imports highway-env until a class is used: :func:`register_highway_envs` (called
by ``import simgap``) registers the id only when highway-env is installed, by string entry
point.
"""

from __future__ import annotations

from simgap._lazy import lazy_exports
from simgap.highway.registration import (  # noqa: F401 - re-exported via __all__
    HIGHWAY_LANE_KEEPING_ID,
    register_highway_envs,
)

_LAZY = {
    "PacejkaBicycleVehicle": "simgap.highway.vehicle",
    "PacejkaLaneKeepingEnv": "simgap.highway.lane_keeping",
    "HighwayBicycleNominal": "simgap.highway.lane_keeping",
}

__all__, __getattr__, __dir__ = lazy_exports(
    "simgap.highway", _LAZY, ["HIGHWAY_LANE_KEEPING_ID", "register_highway_envs"])
