"""Nominal model of the EMPS positioning axis for ``simgap diagnose --model``.

Usage (from the repository root)::

    simgap diagnose ../shared/data/real/emps/emps_estimation.csv \
        --model examples/emps_model.py:EMPS --out emps-report

The "textbook" nominal: a rigid mass M = 95.1089 kg (the benchmark's IDIM-LS value) driven
by the force gtau·vir, with no friction at all. The diagnosis then has to find what the
benchmark's published model adds (Janot, Gautier and Brunot, *Data Set and Reference Models
of EMPS*, 2019): viscous friction Fv ≈ 203.5 N·s/m, Coulomb friction Fc ≈ 20.39 N and a force
offset ≈ −3.16 N.

Column map: ``t_s`` → t (s), ``qm_m`` → q (m, motor position on the load side), ``vir_V``
× gtau → u (N). The velocity is not recorded: the diagnosis differentiates the position.
``qg_m`` (the reference) and ``pulses_N`` (validation set) are not used.
"""

from simgap.diagnosis import Column, with_columns
from simgap.models.prismatic import RigidAxisNominal, RigidAxisParams

#: Drive gain (N/V) stored in DATA_EMPS.mat: force on the load = GTAU · vir.
GTAU = 35.15065188248547
#: Moved mass (kg), IDIM-LS value printed in the benchmark description.
MASS = 95.1089

EMPS = with_columns(
    RigidAxisNominal(RigidAxisParams(mass=MASS, joint="prismatic"), dt=0.001, name="emps"),
    t="t_s",
    q="qm_m",
    u=Column(source="vir_V", scale=GTAU),
)
