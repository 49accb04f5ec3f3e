"""``PacejkaBicycleVehicle``: highway-env's dynamical bicycle with Magic Formula tires.

highway-env's :class:`highway_env.vehicle.dynamics.BicycleVehicle` (Rajamani ch. 2) uses
linear axle forces F = 2·FRICTION·α (its ``FRICTION_*`` constants are per-tire cornering
stiffnesses in N/rad despite the name, so the axle stiffness is C = 2·FRICTION). This subclass
keeps everything else (state, slip angles via ``arctan2``, low-speed branch, RK4) and replaces
the forces by the Magic Formula axle law of :func:`simgap.models.tires.magic_formula`:

    F_y = D sin(C atan(B α − E (B α − atan(B α)))),  D = μ F_z,  B = C_axle / (C D),

so the slope at zero slip equals highway-env's linear tire and the force saturates at μ F_z
with static axle loads F_z,f = m g l_r / L, F_z,r = m g l_f / L. Units are highway-env's
(SI; note its default ``MASS`` = 1 kg, so forces are small but accelerations realistic).
Any highway-env scenario whose action type builds ``BicycleVehicle`` can use this class by
setting ``env.action_type.vehicle_class`` or creating the ego vehicle with it.
"""

from __future__ import annotations

import numpy as np
from highway_env.vehicle.dynamics import BicycleVehicle

from simgap.models.tires import MagicFormulaTire, magic_formula

GRAVITY = 9.81  # m/s²


class PacejkaBicycleVehicle(BicycleVehicle):
    """Bicycle vehicle whose axle lateral forces follow the Magic Formula.

    Class attributes ``MU`` (road friction, -) and ``TIRE`` (shape C, E) are the defaults;
    per-instance values may be given to the constructor.

    Args:
        road: the highway-env road.
        position: (x, y) of the centre (m).
        heading: heading (rad).
        speed: longitudinal speed (m/s).
        mu: road friction coefficient (-), > 0; ``None`` keeps ``MU``.
        tire: Magic Formula shape; ``None`` keeps ``TIRE``.
    """

    MU: float = 1.0
    TIRE: MagicFormulaTire = MagicFormulaTire()

    def __init__(self, road, position, heading: float = 0, speed: float = 0, *,
                 mu: float | None = None, tire: MagicFormulaTire | None = None) -> None:
        super().__init__(road, position, heading, speed)
        if mu is not None:
            if not (np.isfinite(mu) and mu > 0):
                raise ValueError(f"mu must be a positive friction coefficient, got {mu!r}")
            self.MU = float(mu)
        if tire is not None:
            if not isinstance(tire, MagicFormulaTire):
                raise ValueError(f"tire must be a MagicFormulaTire, got {tire!r}")
            self.TIRE = tire

    @classmethod
    def create_from(cls, vehicle) -> PacejkaBicycleVehicle:
        """Copy position, heading and speed of another vehicle (friction: class default)."""
        return cls(vehicle.road, vehicle.position, vehicle.heading, vehicle.speed)

    @property
    def axle_stiffness(self) -> tuple[float, float]:
        """(C_f, C_r) = 2·FRICTION_FRONT, 2·FRICTION_REAR (N/rad), highway-env's axle slopes."""
        return 2.0 * self.FRICTION_FRONT, 2.0 * self.FRICTION_REAR

    @property
    def axle_loads(self) -> tuple[float, float]:
        """Static (F_z,f, F_z,r) = m g (l_r, l_f) / L (N)."""
        big_l = self.LENGTH_A + self.LENGTH_B
        return (self.MASS * GRAVITY * self.LENGTH_B / big_l,
                self.MASS * GRAVITY * self.LENGTH_A / big_l)

    def slip_angles(self, speed: float, lateral_speed: float, yaw_rate: float,
                    delta_f: float, delta_r: float = 0.0) -> tuple[float, float]:
        """Axle slip angles (rad) as highway-env defines them (``arctan2`` of the velocities)."""
        theta_vf = np.arctan2(lateral_speed + self.LENGTH_A * yaw_rate, speed)
        theta_vr = np.arctan2(lateral_speed - self.LENGTH_B * yaw_rate, speed)
        return float(delta_f - theta_vf), float(delta_r - theta_vr)

    def tire_forces(self, alpha_f: float, alpha_r: float) -> tuple[float, float]:
        """Magic Formula axle forces (N) at slip angles (rad)."""
        c_f, c_r = self.axle_stiffness
        fz_f, fz_r = self.axle_loads
        t = self.TIRE
        return (float(magic_formula(alpha_f, c_f, fz_f, self.MU, t.C, t.E)),
                float(magic_formula(alpha_r, c_r, fz_r, self.MU, t.C, t.E)))

    def derivative_func(self, time: float, state: np.ndarray, **kwargs) -> np.ndarray:
        """highway-env's state derivative with Magic Formula axle forces (same layout)."""
        del time
        heading, speed, lateral_speed, yaw_rate = state[2:, 0]
        alpha_f, alpha_r = self.slip_angles(speed, lateral_speed, yaw_rate,
                                            self.action["steering"], 0.0)
        f_yf, f_yr = self.tire_forces(alpha_f, alpha_r)
        if abs(speed) < 1:  # highway-env's low-speed damping, unchanged
            f_yf = -self.MASS * lateral_speed - self.INERTIA_Z / self.LENGTH_A * yaw_rate
            f_yr = -self.MASS * lateral_speed + self.INERTIA_Z / self.LENGTH_A * yaw_rate
        d_lateral_speed = (f_yf + f_yr) / self.MASS - yaw_rate * speed
        d_yaw_rate = (self.LENGTH_A * f_yf - self.LENGTH_B * f_yr) / self.INERTIA_Z
        c, s = np.cos(heading), np.sin(heading)
        vel = np.array(((c, -s), (s, c))) @ np.array([speed, lateral_speed])
        return np.array([[vel[0]], [vel[1]], [yaw_rate], [self.action["acceleration"]],
                         [d_lateral_speed], [d_yaw_rate]])
