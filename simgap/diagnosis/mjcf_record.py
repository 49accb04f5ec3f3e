"""Recordings made by MuJoCo itself: a closed-loop run of an MJCF ("the real robot").

Used to prove the MJCF diagnosis with an independent truth: the recording comes from
MuJoCo's own simulation of a "real" MJCF (its soft constraints, frictionloss, actuator
delay, integrator), not from simgap's models. A PD controller tracks a smooth random
multisine per joint; its command is held for one control period (zero-order hold) and
logged as the joint effort, as a robot's log would hold the commanded torque.

Columns: ``t`` (s), ``q_<joint>`` (rad or m), ``dq_<joint>`` (rad/s or m/s) with Gaussian
sensor noise, and ``tau_<joint>`` (N·m or N), the commanded effort.
"""

from __future__ import annotations

import numpy as np

from simgap.errors import GeneratorError
from simgap.models.mujoco import MujocoNominal, load_model


def record_mjcf(source: object, *, joints: list[str] | None = None, duration: float = 20.0,
                control_dt: float = 0.002,
                seed: int = 0, bandwidth: float = 3.0, amplitude: float = 0.6,
                q_noise: float = 1e-5, dq_noise: float = 1e-4) -> dict[str, np.ndarray]:
    """Simulate an MJCF under PD tracking of random multisines and log it.

    Args:
        source: MJCF path or ``MjModel`` of the "real" robot. A joint driven by a motor
            actuator gets ctrl = effort / (gear · gain); others get the effort in
            ``qfrc_applied``.
        joints: the joints to drive and log (default all hinge/slide joints).
        duration: length (s).
        control_dt: control and logging period (s), a multiple of the model timestep.
        seed: seed of the references and the noise.
        bandwidth: closed-loop natural frequency of the PD law (Hz).
        amplitude: reference amplitude (rad for hinges; a fifth of it in m for slides).
        q_noise: position noise std (rad or m).
        dq_noise: velocity noise std (rad/s or m/s).

    Returns:
        Columns name → array.
    """
    import mujoco

    model, _ = load_model(source)
    nominal = MujocoNominal(model, joints=joints)
    n_sub = int(round(control_dt / model.opt.timestep))
    if n_sub < 1 or abs(n_sub * model.opt.timestep - control_dt) > 1e-12:
        raise GeneratorError(f"control_dt {control_dt} s is not a multiple of the model "
                             f"timestep {model.opt.timestep} s")
    rng = np.random.default_rng(seed)
    n = len(nominal.joint_names)
    freqs = rng.uniform(0.1, 0.7, (n, 3))
    phases = rng.uniform(0, 2 * np.pi, (n, 3))
    amp = np.array([amplitude if k == "hinge" else amplitude / 5 for k in nominal.joint_types])
    q0 = np.array(model.qpos0)[nominal.qadr]

    def reference(t: float) -> tuple[np.ndarray, np.ndarray]:
        w = 2 * np.pi * freqs
        q = q0 + amp / 3 * np.sum(np.sin(w * t + phases), axis=1)
        dq = amp / 3 * np.sum(w * np.cos(w * t + phases), axis=1)
        return q, dq

    data = mujoco.MjData(model)
    data.qpos[nominal.qadr], data.qvel[nominal.dof] = reference(0.0)
    mujoco.mj_forward(model, data)
    m_diag = np.diag(nominal.M(data.qpos[nominal.qadr]))
    w0 = 2 * np.pi * bandwidth
    kp, kd = m_diag * w0**2, m_diag * 2 * w0
    act = {int(model.actuator_trnid[a, 0]): a for a in range(model.nu)}
    gain = model.actuator_gear[:, 0] * model.actuator_gainprm[:, 0]
    steps = int(round(duration / control_dt))
    out = {k: np.empty(steps) for k in ("t",) + nominal.recording_columns[1:]}
    for k in range(steps):
        t = data.time
        qr, dqr = reference(t)
        q, dq = data.qpos[nominal.qadr].copy(), data.qvel[nominal.dof].copy()
        tau = kp * (qr - q) + kd * (dqr - dq) + nominal.bias(q, np.zeros(n))
        out["t"][k] = t
        for j, name in enumerate(nominal.joint_names):
            out[f"q_{name}"][k] = q[j] + q_noise * rng.standard_normal()
            out[f"dq_{name}"][k] = dq[j] + dq_noise * rng.standard_normal()
            out[f"tau_{name}"][k] = tau[j]
            jid = int(nominal.joint_ids[j])
            if jid in act:
                data.ctrl[act[jid]] = tau[j] / gain[act[jid]]
            else:
                data.qfrc_applied[nominal.dof[j]] = tau[j]
        for _ in range(n_sub):
            mujoco.mj_step(model, data)
        if not np.all(np.isfinite(data.qpos)):
            raise GeneratorError(f"MuJoCo simulation diverged at t = {t:.3f} s")
    return out
