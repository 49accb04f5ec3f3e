"""The proof's ranges come from the vocabulary's injection ranges and equal the former table."""

from simgap.diagnosis.proof import RANGES

# The hand-written table the proof used before the ranges moved into the vocabulary; the
# proof's draws (hence its table) depend on these values and on this order.
FORMER = {
    "coulomb_friction": ("manipulator2dof", ("joint1", "joint2"), {"Fc": (0.05, 0.3, False)}),
    "viscous_friction": ("manipulator2dof", ("joint1", "joint2"), {"b": (0.05, 0.5, False)}),
    "stribeck_friction": ("manipulator2dof", ("joint1", "joint2"),
                          {"Fs": (0.2, 0.4, False), "vs": (0.07, 0.3, False)}),
    "torque_bias": ("manipulator2dof", ("joint1", "joint2"), {"tau0": (0.05, 0.3, True)}),
    "spring": ("manipulator2dof", ("joint1", "joint2"),
               {"k": (0.5, 3.0, False), "q0": (-0.5, 0.5, False)}),
    "payload_mass": ("manipulator2dof", None, {"mp": (0.1, 0.5, False)}),
    "gravity_mismatch": ("manipulator2dof", None, {"dG": (0.02, 0.1, True)}),
    "inertia_mismatch": ("manipulator2dof", ("joint1", "joint2"), {"dI": (0.015, 0.04, False)}),
    "tire_saturation": ("bicycle", None, {"mu": (0.5, 0.8, False)}),
    "cornering_stiffness": ("bicycle", ("front_axle", "rear_axle"),
                            {"ratio": (0.7, 0.85, False)}),
    "lateral_bias": ("bicycle", None, {"ay0": (0.2, 0.5, True)}),
    "yaw_bias": ("bicycle", None, {"dr0": (0.08, 0.2, True)}),
    "mass_mismatch": ("bicycle", None, {"ratio": (1.1, 1.25, False)}),
    "yaw_inertia_mismatch": ("bicycle", None, {"ratio": (1.15, 1.3, False)}),
    "steering_lag": ("bicycle", None, {"tau": (0.04, 0.15, False)}),
}


def test_ranges_read_from_the_vocabulary_equal_the_former_table_in_order():
    # each case draws from its own generator (seeded by the case), so the former effects'
    # draws depend only on their own ranges; their relative order fixes the table's rows
    former = {k: v for k, v in RANGES.items() if k in FORMER}
    assert former == FORMER
    assert list(former) == list(FORMER)
    assert [list(v[2]) for v in former.values()] == [list(v[2]) for v in FORMER.values()]
    # the effects added since (issue 13's vocabulary) and nothing else
    assert set(RANGES) - set(FORMER) == {"quadratic_drag", "cubic_stiffness", "input_delay",
                                         "dead_zone"}
