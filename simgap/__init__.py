"""simgap: the gap between a simulator and the real system it stands for.

Importing the package registers the Gymnasium envs ``simgap/ManipulatorFriction-v0`` and
``simgap/BicycleTire-v0`` (safe to repeat, e.g. after ``importlib.reload``), and
``simgap/PacejkaLaneKeeping-v0`` when highway-env (extra ``highway``) is installed; that
registration does not import highway-env.
"""

from importlib.metadata import PackageNotFoundError
from importlib.metadata import version as _dist_version

from simgap.envs.registration import BICYCLE_ID, MANIPULATOR_ID, register_envs
from simgap.highway.registration import HIGHWAY_LANE_KEEPING_ID, register_highway_envs

try:
    __version__: str = _dist_version("simgap")
except PackageNotFoundError:  # pragma: no cover - a source tree that is not installed
    __version__ = "0+unknown"

register_envs()
register_highway_envs()

__all__ = ["BICYCLE_ID", "HIGHWAY_LANE_KEEPING_ID", "MANIPULATOR_ID", "__version__",
           "register_envs", "register_highway_envs"]
