"""simgap: the gap between a simulator and the real system it stands for.

Importing the package registers the Gymnasium envs ``simgap/ManipulatorFriction-v0`` and
``simgap/BicycleTire-v0`` (safe to repeat, e.g. after ``importlib.reload``), and
``simgap/PacejkaLaneKeeping-v0`` when highway-env (extra ``highway``) is installed; that
registration does not import highway-env.
"""

from typing import Any

from simgap.envs.registration import BICYCLE_ID, MANIPULATOR_ID, register_envs
from simgap.highway.registration import HIGHWAY_LANE_KEEPING_ID, register_highway_envs


def __getattr__(name: str) -> Any:
    """``__version__`` on first use (importlib.metadata costs ≈ 20 ms of ``import simgap``)."""
    if name != "__version__":
        raise AttributeError(f"module 'simgap' has no attribute {name!r}")
    from importlib.metadata import PackageNotFoundError, version

    try:
        value = version("simgap")
    except PackageNotFoundError:  # pragma: no cover - a source tree that is not installed
        value = "0+unknown"
    globals()["__version__"] = value
    return value


register_envs()
register_highway_envs()

__all__ = ["BICYCLE_ID", "HIGHWAY_LANE_KEEPING_ID", "MANIPULATOR_ID", "__version__",
           "register_envs", "register_highway_envs"]
