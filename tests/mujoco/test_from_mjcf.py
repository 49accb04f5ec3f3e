"""MJCF nominal models: parity with the built-in arm, passive forces, units, refusals."""

from pathlib import Path

import numpy as np
import pytest

mujoco = pytest.importorskip("mujoco")

from simgap.errors import ModelError, SimgapError  # noqa: E402
from simgap.models.manipulator import ManipulatorNominal  # noqa: E402
from simgap.models.mujoco import from_mjcf  # noqa: E402

ARM = Path(__file__).resolve().parents[2] / "examples" / "mujoco" / "arm2dof.xml"


def _with(xml: str, old: str, new: str) -> str:
    assert old in xml
    return xml.replace(old, new, 1)


def test_arm_mjcf_matches_builtin_mass_and_bias():
    nom = from_mjcf(ARM)
    ref = ManipulatorNominal()
    assert nom.joint_names == ("shoulder", "elbow")
    assert nom.input_units == ("N·m", "N·m")
    rng = np.random.default_rng(0)
    for _ in range(200):
        q = rng.uniform(-np.pi, np.pi, 2)
        dq = rng.uniform(-5.0, 5.0, 2)
        np.testing.assert_allclose(nom.M(q), ref.M(q), rtol=0, atol=1e-9)
        np.testing.assert_allclose(nom.bias(q, dq), ref.bias(q, dq), rtol=0, atol=1e-9)


def test_recording_columns_and_units():
    nom = from_mjcf(ARM)
    assert nom.recording_columns == ("t", "q_shoulder", "q_elbow", "dq_shoulder", "dq_elbow",
                                     "tau_shoulder", "tau_elbow")
    assert nom.derivable_columns == ("dq_shoulder", "dq_elbow")
    assert nom.dt == pytest.approx(0.001)


def test_passive_forces_follow_the_xml():
    xml = ARM.read_text()
    xml = _with(xml, 'name="elbow" type="hinge" axis="0 0 1" armature="0.008118"',
                'name="elbow" type="hinge" axis="0 0 1" armature="0.018118" damping="0.3" '
                'stiffness="2.0" springref="0.1" frictionloss="0.4"')
    nom = from_mjcf(mujoco.MjModel.from_xml_string(xml))
    base = from_mjcf(ARM)
    q, dq = np.array([0.3, -0.4]), np.array([0.5, 1.5])
    extra = nom.bias(q, dq) - base.bias(q, dq)
    want = 0.3 * 1.5 + 2.0 * (-0.4 - 0.1) + 0.4 * np.tanh(1.5 / nom.friction_velocity)
    np.testing.assert_allclose(extra, [0.0, want], atol=1e-12)
    np.testing.assert_allclose(nom.M(q) - base.M(q), [[0, 0], [0, 0.01]], atol=1e-12)


def test_slide_joint_units_and_nominal_derivative():
    xml = """<mujoco><worldbody><body name="cart"><joint name="x" type="slide" axis="1 0 0"/>
    <inertial pos="0 0 0" mass="3.0" diaginertia="0.1 0.1 0.1"/></body></worldbody></mujoco>"""
    nom = from_mjcf(mujoco.MjModel.from_xml_string(xml))
    assert nom.obs_units == ("m", "m/s") and nom.input_units == ("N",)
    np.testing.assert_allclose(nom.f(np.array([0.0, 1.0]), np.array([6.0])), [1.0, 2.0])


def test_free_and_ball_joints_are_refused():
    xml = """<mujoco><worldbody><body name="b"><freejoint name="root"/>
    <inertial pos="0 0 0" mass="1" diaginertia="1 1 1"/></body></worldbody></mujoco>"""
    with pytest.raises(ModelError, match="'root' is a free joint"):
        from_mjcf(mujoco.MjModel.from_xml_string(xml))


def test_bad_sources_are_one_line_errors(tmp_path):
    with pytest.raises(ModelError, match="not found"):
        from_mjcf(tmp_path / "missing.xml")
    bad = tmp_path / "bad.xml"
    bad.write_text("<mujoco><worldbody><body></mujoco>")
    with pytest.raises(SimgapError, match="bad.xml: MuJoCo cannot compile it"):
        from_mjcf(bad)
    with pytest.raises(ModelError, match="no joint named 'wrist'"):
        from_mjcf(ARM, joints=["wrist"])


def test_ctrl_inputs_through_the_actuator_model():
    xml = _with(ARM.read_text(), '<motor name="elbow_motor" joint="elbow" gear="1"/>',
                '<motor name="elbow_motor" joint="elbow" gear="5" ctrlrange="-1 1"/>')
    nom = from_mjcf(mujoco.MjModel.from_xml_string(xml), inputs="ctrl")
    np.testing.assert_allclose(nom.input(np.array([2.0, 3.0])), [2.0, 5.0])


def test_inverse_dynamics_matches_mujoco_forward_step():
    """MuJoCo's own forward dynamics agrees with the nominal's f (damping included)."""
    xml = _with(ARM.read_text(), 'name="shoulder" type="hinge" axis="0 0 1"',
                'name="shoulder" type="hinge" axis="0 0 1" damping="0.2"')
    m = mujoco.MjModel.from_xml_string(xml)
    d = mujoco.MjData(m)
    nom = from_mjcf(m)
    d.qpos[:] = [0.4, -0.2]
    d.qvel[:] = [1.0, -2.0]
    d.ctrl[:] = [3.0, -1.0]
    mujoco.mj_forward(m, d)
    np.testing.assert_allclose(nom.f(np.r_[d.qpos, d.qvel], d.ctrl)[2:], d.qacc, atol=1e-9)
