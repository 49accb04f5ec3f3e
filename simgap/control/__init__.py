"""Controllers that use the learned residual ĝ downstream (issue 6).

* :mod:`~simgap.control.compensation`: feed-forward compensation of ĝ on scripted
  controllers: :class:`CompensatedFeedbackLinearization` (manipulator) and
  :class:`YawRateController` (bicycle, nominal inversion with or without the axle-force
  residual).
* :mod:`~simgap.control.mpc`: :class:`SamplingMPC`, a sampling (MPPI) yaw-rate MPC whose
  prediction model is the nominal bicycle, optionally plus a frozen residual network.
* :mod:`~simgap.control.experiments`: the closed-loop runs behind the benchmarks and notebooks
  (pre-training an identifier, tracking runs with and without compensation, the exact
  residual as an upper bound).
* :mod:`~simgap.control.rl`: residual RL with stable-baselines3 (extra ``rl``), plain
  observation vs :class:`~simgap.wrappers.ResidualObservation`.
* :mod:`~simgap.control.figures`: the PNG figures of these studies.
"""

from simgap.control.compensation import (
    CompensatedFeedbackLinearization,
    ResidualNetwork,
    YawRateController,
)
from simgap.control.mpc import MPCConfig, SamplingMPC

__all__ = [
    "CompensatedFeedbackLinearization",
    "MPCConfig",
    "ResidualNetwork",
    "SamplingMPC",
    "YawRateController",
]
