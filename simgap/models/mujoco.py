"""MuJoCo models (MJCF) as nominal simulators: ``from_mjcf(path_or_MjModel, joints=...)``.

A MuJoCo model is a mechanical system

    M(q) ddq + qfrc_bias(q, dq) = qfrc_passive(q, dq) + qfrc_constraint + tau

(MuJoCo's equation of motion; thesis eq. 2.2 with C dq + G = ``qfrc_bias``). The nominal
model built here takes everything from MuJoCo itself:

* M(q) from ``mj_fullM`` (it includes the joint ``armature``);
* bias(q, dq) = ``qfrc_bias`` − ``qfrc_passive`` (joint ``damping``, ``stiffness`` about
  ``springref``, gravity compensation, fluid forces: whatever the XML declares) + the joint
  ``frictionloss`` term below;
* ``frictionloss`` is not a force law in MuJoCo but a dry-friction *constraint*: while a
  joint slides it pushes back with exactly ``frictionloss`` (N·m or N) against the
  velocity; while it sticks it holds the joint with any force up to that level. The smooth
  nominal written here uses ``frictionloss · tanh(dq / friction_velocity)``, equal to
  MuJoCo's force while sliding faster than a few ``friction_velocity`` and undefined (as in
  MuJoCo: any value up to the level) while stuck. The diagnosis scores only the samples where
  a joint moves (its stick mask), where the two agree.

Joints: hinge (q in rad, effort in N·m, inertia in kg·m²) and slide (m, N, kg) joints, all of
them or those named in ``joints``; joints not named are held at their reference pose
``qpos0`` and at rest. Free and ball joints are refused (:class:`~simgap.errors.ModelError`).

State and columns: the identifier state is x = (q, dq) (rad or m, rad/s or m/s), the input
u the joint efforts tau (N·m or N). Recording columns: ``t``, ``q_<joint>``, ``dq_<joint>``
(derivable: differentiated from q when absent), ``tau_<joint>``. With ``inputs="ctrl"`` the
inputs are the actuators' controls, mapped to joint efforts through the actuator model
(``tau = gear · gain · clip(ctrl, ctrlrange)``: motor-type actuators on one joint each).
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np

from simgap.errors import ModelError
from simgap.models.base import MechanicalNominalModel, validate_positive

#: Joint type → (position unit, velocity unit, effort unit, inertia unit).
JOINT_UNITS = {"hinge": ("rad", "rad/s", "N·m", "kg·m²"), "slide": ("m", "m/s", "N", "kg")}
#: Default velocity scale (rad/s or m/s) of the smooth frictionloss law.
FRICTION_VELOCITY = 1e-3


def _mujoco():
    try:
        import mujoco
    except ImportError as exc:  # pragma: no cover - the extra is installed by make install
        raise ModelError("MuJoCo models need the 'mujoco' package: pip install "
                         "'simgap[mujoco]'") from exc
    return mujoco


def load_model(source: object) -> tuple[object, str]:
    """Return (compiled ``MjModel``, label) for an MJCF path or an ``MjModel``.

    Raises:
        ModelError: the file does not exist, is not an MJCF/URDF MuJoCo compiles, or
            ``source`` is neither a path nor an ``MjModel``.
    """
    mujoco = _mujoco()
    if isinstance(source, mujoco.MjModel):
        return source, "MjModel"
    if not isinstance(source, str | Path):
        raise ModelError(f"from_mjcf needs an MJCF path or a mujoco.MjModel, got "
                         f"{type(source).__name__}")
    path = Path(source)
    if not path.is_file():
        raise ModelError(f"{path}: MJCF file not found")
    try:
        return mujoco.MjModel.from_xml_path(str(path)), str(path)
    except ValueError as exc:
        first = " ".join(str(exc).split())
        raise ModelError(f"{path}: MuJoCo cannot compile it: {first}") from exc


def _name(mujoco, model, obj, i: int) -> str:
    """Name of object ``i`` of kind ``obj``, or ``<kind><i>`` when it has none."""
    kind = "joint" if obj == mujoco.mjtObj.mjOBJ_JOINT else "actuator"
    return mujoco.mj_id2name(model, obj, i) or f"{kind}{i}"


class MujocoNominal(MechanicalNominalModel):
    """Nominal model of the hinge/slide joints of a compiled MuJoCo model (module docstring).

    Build it with :func:`from_mjcf`. Evaluations go through one private ``MjData``: an
    instance is not thread-safe.

    Attributes:
        mj_model: the compiled ``MjModel`` (never changed by simgap).
        joint_names: modelled joints, in order (the channels of the diagnosis).
        joint_types: ``"hinge"`` or ``"slide"`` per joint.
        ctrl_to_tau: (n_joints, n_actuators) map from controls to joint efforts (only when
            ``inputs="ctrl"``; ``None`` otherwise).
        friction_velocity: velocity scale of the smooth frictionloss law (rad/s or m/s).
        source: the MJCF path when built from a file (``None`` for an ``MjModel``).
    """

    derivable_columns: tuple[str, ...] = ()

    def __init__(self, mj_model: object, *, joints: Sequence[str] | None = None,
                 inputs: str = "torque", dt: float | None = None, name: str | None = None,
                 source: Path | None = None,
                 friction_velocity: float = FRICTION_VELOCITY) -> None:
        mujoco = _mujoco()
        self._mj = mujoco
        self.mj_model = mj_model
        self.source = source
        self.name = name or (Path(source).stem if source else "mujoco")
        self.dt = validate_positive("dt", dt if dt is not None else mj_model.opt.timestep, "s")
        self.friction_velocity = validate_positive("friction_velocity", friction_velocity)
        self._data = mujoco.MjData(mj_model)
        ids = self._select_joints(joints)
        kinds = {int(mujoco.mjtJoint.mjJNT_HINGE): "hinge",
                 int(mujoco.mjtJoint.mjJNT_SLIDE): "slide"}
        self.joint_ids = np.array(ids, dtype=np.int64)
        self.joint_names = tuple(_name(mujoco, mj_model, mujoco.mjtObj.mjOBJ_JOINT, i)
                                 for i in ids)
        self.joint_types = tuple(kinds[int(mj_model.jnt_type[i])] for i in ids)
        self.dof = np.array([mj_model.jnt_dofadr[i] for i in ids], dtype=np.int64)
        self.qadr = np.array([mj_model.jnt_qposadr[i] for i in ids], dtype=np.int64)
        self.frictionloss = np.array(mj_model.dof_frictionloss[self.dof], dtype=np.float64)
        units = [JOINT_UNITS[k] for k in self.joint_types]
        n = len(ids)
        self.channel_names = self.joint_names
        self.obs_names = tuple(f"q_{j}" for j in self.joint_names) + \
            tuple(f"dq_{j}" for j in self.joint_names)
        self.obs_units = tuple(u[0] for u in units) + tuple(u[1] for u in units)
        self.state_names = self.obs_names
        self.state_units = self.obs_units
        self.input_names = tuple(f"tau_{j}" for j in self.joint_names)
        self.input_units = tuple(u[2] for u in units)
        self.recording_columns = ("t",) + self.obs_names + self.input_names
        self.derivable_columns = self.obs_names[n:]
        if inputs not in ("torque", "ctrl"):
            raise ModelError(f"inputs must be 'torque' or 'ctrl', got {inputs!r}")
        self.inputs = inputs
        self.ctrl_to_tau = self._actuator_map() if inputs == "ctrl" else None
        self.actuator_names = tuple(_name(mujoco, mj_model, mujoco.mjtObj.mjOBJ_ACTUATOR, a)
                                    for a in range(mj_model.nu))

    # -- construction ------------------------------------------------------------------
    def _select_joints(self, joints: Sequence[str] | None) -> list[int]:
        mj, m = self._mj, self.mj_model
        ok = (int(mj.mjtJoint.mjJNT_HINGE), int(mj.mjtJoint.mjJNT_SLIDE))
        kind_name = {int(mj.mjtJoint.mjJNT_FREE): "free", int(mj.mjtJoint.mjJNT_BALL): "ball"}
        if joints is None:
            ids = list(range(m.njnt))
        else:
            if isinstance(joints, str) or not len(joints):
                raise ModelError(f"joints must be a non-empty list of joint names, got "
                                 f"{joints!r}")
            ids = []
            for j in joints:
                i = mj.mj_name2id(m, mj.mjtObj.mjOBJ_JOINT, j)
                if i < 0:
                    names = [_name(mj, m, mj.mjtObj.mjOBJ_JOINT, k) for k in range(m.njnt)]
                    raise ModelError(f"{self.name}: no joint named {j!r} (it has {names})")
                ids.append(i)
        if not ids:
            raise ModelError(f"{self.name}: the model has no joints")
        for i in ids:
            if int(m.jnt_type[i]) not in ok:
                jn = _name(mj, m, mj.mjtObj.mjOBJ_JOINT, i)
                raise ModelError(f"{self.name}: joint {jn!r} is a "
                                 f"{kind_name[int(m.jnt_type[i])]} joint; simgap models hinge "
                                 "and slide joints only (name the others with joints=[...] to "
                                 "hold it fixed)")
        return ids

    def _actuator_map(self) -> np.ndarray:
        """(n_joints, n_actuators) efforts per unit control of motor-type actuators."""
        mj, m = self._mj, self.mj_model
        out = np.zeros((len(self.joint_ids), m.nu))
        for a in range(m.nu):
            aname = _name(mj, m, mj.mjtObj.mjOBJ_ACTUATOR, a)
            linear = (int(m.actuator_gaintype[a]) == int(mj.mjtGain.mjGAIN_FIXED)
                      and int(m.actuator_biastype[a]) == int(mj.mjtBias.mjBIAS_NONE)
                      and int(m.actuator_dyntype[a]) == int(mj.mjtDyn.mjDYN_NONE)
                      and int(m.actuator_trntype[a]) == int(mj.mjtTrn.mjTRN_JOINT))
            if not linear:
                raise ModelError(f"{self.name}: actuator {aname!r} is not a motor on one joint "
                                 "(gain, bias or dynamics); use inputs='torque' and record "
                                 "joint efforts")
            jid = int(m.actuator_trnid[a, 0])
            hit = np.flatnonzero(self.joint_ids == jid)
            if hit.size:
                out[hit[0], a] = m.actuator_gear[a, 0] * m.actuator_gainprm[a, 0]
        return out

    def nominal_coefficients(self) -> dict[str, tuple[float, ...]]:
        """The model's own per-joint passive terms, which a diagnosis may correct either way.

        ``damping`` (N·m·s/rad or N·s/m), ``frictionloss`` (N·m or N), ``stiffness`` (N·m/rad
        or N/m) of each modelled joint.
        """
        m = self.mj_model
        return {"damping": tuple(float(v) for v in m.dof_damping[self.dof]),
                "frictionloss": tuple(float(v) for v in self.frictionloss),
                "stiffness": tuple(float(v) for v in m.jnt_stiffness[self.joint_ids])}

    def __repr__(self) -> str:
        return (f"MujocoNominal(name={self.name!r}, joints={self.joint_names}, "
                f"inputs={self.inputs!r}, dt={self.dt})")

    # -- protocol ----------------------------------------------------------------------
    @property
    def residual_names(self) -> tuple[str, ...]:
        """Left-out effort per joint."""
        return tuple(f"tau_d_{j}" for j in self.joint_names)

    @property
    def residual_units(self) -> tuple[str, ...]:
        """N·m (hinge) or N (slide) per joint."""
        return self.input_units

    def input(self, action: np.ndarray) -> np.ndarray:
        """Env action → joint efforts: identity for torques, actuator model for controls."""
        a = np.asarray(action, dtype=np.float64)
        if self.ctrl_to_tau is None:
            return a
        m = self.mj_model
        lim = m.actuator_ctrllimited.astype(bool)
        a = np.where(lim, np.clip(a, m.actuator_ctrlrange[:, 0], m.actuator_ctrlrange[:, 1]), a)
        return self.ctrl_to_tau @ a

    def _set(self, q: np.ndarray, dq: np.ndarray | None) -> object:
        d = self._data
        d.qpos[:] = self.mj_model.qpos0
        d.qvel[:] = 0.0
        d.qpos[self.qadr] = q
        if dq is not None:
            d.qvel[self.dof] = dq
        self._mj.mj_fwdPosition(self.mj_model, d)
        return d

    def _full_mass(self, d: object) -> np.ndarray:
        nv = self.mj_model.nv
        full = np.zeros((nv, nv))
        self._mj.mj_fullM(self.mj_model, d, full)
        return full[np.ix_(self.dof, self.dof)]

    def _bias_now(self, d: object, dq: np.ndarray) -> np.ndarray:
        self._mj.mj_fwdVelocity(self.mj_model, d)
        out = d.qfrc_bias[self.dof] - d.qfrc_passive[self.dof]
        return out + self.frictionloss * np.tanh(np.asarray(dq) / self.friction_velocity)

    def M(self, q: np.ndarray) -> np.ndarray:  # noqa: N802 - the physics name
        """Mass matrix M(q) from ``mj_fullM`` (kg·m² / kg; armature included)."""
        return self._full_mass(self._set(np.asarray(q, dtype=np.float64), None))

    def bias(self, q: np.ndarray, dq: np.ndarray) -> np.ndarray:
        """``qfrc_bias − qfrc_passive`` + smooth frictionloss (N·m or N)."""
        dq = np.asarray(dq, dtype=np.float64)
        return self._bias_now(self._set(np.asarray(q, dtype=np.float64), dq), dq)

    def inverse_dynamics(self, q: np.ndarray, dq: np.ndarray, ddq: np.ndarray) -> np.ndarray:
        """Efforts the nominal needs for the motion, M(q) ddq + bias(q, dq); rows allowed."""
        q, dq, ddq = (np.asarray(v, dtype=np.float64) for v in (q, dq, ddq))
        if q.ndim == 2:
            return np.array([self.inverse_dynamics(q[k], dq[k], ddq[k])
                             for k in range(q.shape[0])])
        d = self._set(q, dq)
        return self._full_mass(d) @ ddq + self._bias_now(d, dq)

    def mass_rows(self, q: np.ndarray) -> np.ndarray:
        """M(q) per row of q (N, n) → (N, n, n)."""
        return np.array([self.M(row) for row in np.asarray(q, dtype=np.float64)])

    def state(self, obs: np.ndarray) -> np.ndarray:
        """Observation (q, dq) is the state."""
        return np.asarray(obs, dtype=np.float64)

    def f(self, x: np.ndarray, u: np.ndarray) -> np.ndarray:
        """Nominal derivative (dq, M(q)⁻¹ (u − bias(q, dq))) (thesis eq. 2.2 solved for ddq)."""
        x = np.asarray(x, dtype=np.float64)
        n = len(self.joint_ids)
        q, dq = x[:n], x[n:]
        d = self._set(q, dq)
        mass = self._full_mass(d)
        rhs = np.asarray(u, dtype=np.float64) - self._bias_now(d, dq)
        return np.concatenate([dq, np.linalg.solve(mass, rhs)])

    def physical_residual(self, x: np.ndarray, g: np.ndarray) -> np.ndarray:
        """State residual g → left-out effort tau_d = −M(q) g_dq (N·m or N)."""
        x = np.asarray(x, dtype=np.float64)
        g = np.asarray(g, dtype=np.float64)
        n = len(self.joint_ids)
        return -self.M(x[:n]) @ g[n:]

    # -- geometry for payload candidates -----------------------------------------------
    def point_regressor(self, body: int, point: np.ndarray, q: np.ndarray, dq: np.ndarray,
                        ddq: np.ndarray) -> np.ndarray:
        """Joint efforts per kg of a point mass at ``point`` (body frame) of ``body`` (N·m/kg).

        tau = Jᵀ (J ddq + J̇ dq − g) for the point's translational Jacobian J (Newton's law
        for a point mass, mapped to the joints); rows of (q, dq, ddq) allowed.
        """
        q, dq, ddq = (np.atleast_2d(np.asarray(v, dtype=np.float64)) for v in (q, dq, ddq))
        mj, m = self._mj, self.mj_model
        nv = m.nv
        jac = np.zeros((3, nv))
        jdot = np.zeros((3, nv))
        grav = np.asarray(m.opt.gravity, dtype=np.float64)
        out = np.empty_like(q)
        for k in range(q.shape[0]):
            d = self._set(q[k], dq[k])
            mj.mj_fwdVelocity(m, d)
            world = d.xpos[body] + d.xmat[body].reshape(3, 3) @ point
            mj.mj_jac(m, d, jac, None, world, body)
            mj.mj_jacDot(m, d, jdot, None, world, body)
            js, jds = jac[:, self.dof], jdot[:, self.dof]
            out[k] = js.T @ (js @ ddq[k] + jds @ dq[k] - grav)
        return out

    def tip_points(self) -> list[tuple[str, int, np.ndarray]]:
        """Candidate payload points: sites of leaf bodies, else leaf body origins.

        Returns:
            (name, body id, position in the body frame (m)) per candidate point.
        """
        mj, m = self._mj, self.mj_model
        moved = {int(m.jnt_bodyid[i]) for i in self.joint_ids}
        parents = set(int(p) for p in m.body_parentid[1:])
        out = []
        for b in range(1, m.nbody):
            if b in parents:
                continue
            # a leaf that the modelled joints move
            chain, x = False, b
            while x > 0:
                chain |= x in moved
                x = int(m.body_parentid[x])
            if not chain:
                continue
            sites = [s for s in range(m.nsite) if int(m.site_bodyid[s]) == b]
            if sites:
                out += [(mj.mj_id2name(m, mj.mjtObj.mjOBJ_SITE, s) or f"site{s}", b,
                         np.array(m.site_pos[s])) for s in sites]
            else:
                out.append((mj.mj_id2name(m, mj.mjtObj.mjOBJ_BODY, b) or f"body{b}", b,
                            np.zeros(3)))
        return out


def from_mjcf(source: object, joints: Sequence[str] | None = None, *, inputs: str = "torque",
              dt: float | None = None, name: str | None = None,
              friction_velocity: float = FRICTION_VELOCITY) -> MujocoNominal:
    """Build a mechanical nominal model from an MJCF file or a compiled ``MjModel``.

    Args:
        source: path to an MJCF (``.xml``) file, or a ``mujoco.MjModel``.
        joints: names of the hinge/slide joints to model (default: all joints; free or ball
            joints are refused); the others are held at ``qpos0``.
        inputs: ``"torque"`` (inputs are joint efforts, N·m or N) or ``"ctrl"`` (actuator
            controls through the actuator model; motor-type actuators only).
        dt: step period (s); default the model's ``opt.timestep``.
        name: model name in reports (default the file stem).
        friction_velocity: velocity scale (rad/s or m/s) of the smooth frictionloss law.

    Returns:
        A :class:`MujocoNominal`.

    Raises:
        ModelError: file missing or not compilable, unknown joint name, a free/ball joint,
            a non-motor actuator with ``inputs="ctrl"``.
    """
    model, label = load_model(source)
    path = Path(label) if label != "MjModel" else None
    if path is not None and name is None:
        name = path.stem
    return MujocoNominal(model, joints=joints, inputs=inputs, dt=dt, name=name, source=path,
                         friction_velocity=friction_velocity)


class MujocoEnvNominal(MujocoNominal):
    """Nominal model of a Gymnasium MuJoCo env: its own ``MjModel``, state from its ``MjData``.

    The state x = (q, dq) is read from ``env.unwrapped.data`` (``qpos``, ``qvel``) whatever the
    observation holds (Reacher's observation has cosines and the target, InvertedPendulum's
    is (qpos, qvel)); inputs are the env's actions (actuator controls) through the actuator
    model; ``dt`` is the env's step period (``timestep · frame_skip``).
    """

    def __init__(self, env: object) -> None:
        base = getattr(env, "unwrapped", env)
        super().__init__(base.model, inputs="ctrl", dt=float(base.dt),
                         name=f"mujoco:{type(base).__name__}")
        self._env_data = base.data

    def state(self, obs: np.ndarray) -> np.ndarray:
        """Joint positions and velocities of the env's current ``MjData`` (obs unused)."""
        d = self._env_data
        return np.concatenate([d.qpos[self.qadr], d.qvel[self.dof]]).astype(np.float64)


def from_mujoco_env(env: object) -> MujocoEnvNominal:
    """Nominal model of a Gymnasium MuJoCo env (``env.unwrapped.model`` / ``.data``).

    Raises:
        ModelError: the env is not a MuJoCo env, has free/ball joints, or non-motor
            actuators.
    """
    base = getattr(env, "unwrapped", env)
    mujoco = _mujoco()
    if not (isinstance(getattr(base, "model", None), mujoco.MjModel)
            and isinstance(getattr(base, "data", None), mujoco.MjData)):
        raise ModelError(f"{type(base).__name__} is not a MuJoCo env (no MjModel in "
                         "env.unwrapped.model and MjData in env.unwrapped.data)")
    return MujocoEnvNominal(base)


__all__ = ["FRICTION_VELOCITY", "JOINT_UNITS", "MujocoEnvNominal", "MujocoNominal", "from_mjcf",
           "from_mujoco_env", "load_model"]
