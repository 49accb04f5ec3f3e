"""Nominal bicycle model of the Stanford race-car recording for ``simgap diagnose --model``.

Usage (from the repository root)::

    simgap diagnose ../shared/data/real/racecar_sideslip_100hz/racecar_sideslip_100hz.csv \
        --model examples/racecar_model.py:RACECAR --out racecar-report

Parameters are the ones the dataset's estimators use (``MBDS/sideslip-angle-vehicle-
estimation``, ``CarParameters`` in ``main.cpp``; Leanza, Reina and Blanco-Claraco, Sensors
21(16):5409, 2021): m = 982 kg, lf = 1.33 m, lr = 1.07 m, Iz = m/12·(1.7² + 4.09²) =
1605.4 kg·m², C_af = 0.7e5 N/rad, C_ar = 1.2e5 N/rad, linear tires.

Column map: ``t_s`` → t (s), ``vx_mps`` → vx (m/s, measured, used per sample), ``vy_mps`` →
vy (m/s), ``r_radps`` → r (rad/s), ``delta_rad`` → delta_f (rad, road-wheel angle) and
delta_r = 0 (no rear steering).

Steering glitches. The README names two isolated spikes in ``delta_rad`` above 0.2 rad
(rows 37486 and 52168: 0.237 and 0.478 rad between neighbours at 0.017 and −0.048 rad).
There are two more of the same kind below 0.2 rad (rows 5728 and 35350: 0.136 and 0.150 rad
between neighbours near 0; ``deltaFL_rad`` has them too). All four are single-sample logging
glitches: the steering was cut from 1 kHz to 100 Hz without a filter, and no road wheel turns
0.1–0.5 rad and back within 20 ms. ``despike=0.05`` rad removes them: a sample more than
0.05 rad from the median of itself and its two neighbours is replaced by linear
interpolation in time. After that, the largest sample-to-sample change of the steering is
0.005 rad, ten times below the threshold, so nothing real is touched. The report's notes
list the replaced rows. (Clipping to ±0.2 rad, as the dataset README did, would leave the
two smaller glitches and half of the big ones in.)
"""

from simgap.diagnosis import Column, with_columns
from simgap.models.bicycle import BicycleNominal, BicycleParams

#: Vehicle parameters published with the dataset's estimators.
PARAMS = BicycleParams(m=982.0, Iz=982.0 / 12.0 * (1.7**2 + 4.09**2), lf=1.33, lr=1.07,
                       C_af=0.7e5, C_ar=1.2e5)
#: Largest plausible single-sample jump of the road-wheel angle (rad) before it counts as a
#: logging glitch.
DELTA_SPIKE = 0.05

RACECAR = with_columns(
    BicycleNominal(PARAMS, vx=30.0, dt=0.01),
    t="t_s",
    vx="vx_mps",
    vy="vy_mps",
    r="r_radps",
    delta_f=Column(source="delta_rad", despike=DELTA_SPIKE),
    delta_r=0.0,
)
