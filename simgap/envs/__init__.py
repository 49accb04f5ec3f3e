"""Gymnasium environments with a known ground truth, scenarios and a rollout helper.

Env classes and scenarios are imported lazily (PEP 562) so that ``import simgap`` (which
registers the env ids) stays light. ``rollout`` is imported eagerly: the function shares its
name with its module, and the function must win.
"""

from __future__ import annotations

from simgap._lazy import lazy_exports
from simgap.envs.rollout import Rollout as Rollout
from simgap.envs.rollout import rollout as rollout

_LAZY = {
    "ManipulatorFrictionEnv": "simgap.envs.manipulator",
    "BicycleTireEnv": "simgap.envs.bicycle",
    "QuinticReference": "simgap.envs.scenarios",
    "RandomWaypointReference": "simgap.envs.scenarios",
    "FeedbackLinearizationController": "simgap.envs.scenarios",
    "SteeringProgram": "simgap.envs.scenarios",
    "YawRateReference": "simgap.envs.scenarios",
    "step_steer": "simgap.envs.scenarios",
    "slalom": "simgap.envs.scenarios",
    "chirp": "simgap.envs.scenarios",
    "open_loop": "simgap.envs.scenarios",
}

__all__, __getattr__, __dir__ = lazy_exports("simgap.envs", _LAZY, ["Rollout", "rollout"])
