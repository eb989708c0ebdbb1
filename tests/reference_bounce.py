"""The floor bounce threshold of the Rust core, written independently from its definition
(docs/fidelity.md row 18) for the PyPI-mujoco shadows of the parity tests."""

from __future__ import annotations

from reference_env import ball_body_id, free_joint_of_body


class FloorBounce:
    """The floor bounce threshold the Rust core applies after every physics sub-step (PhysX's 0.2
    m/s: a floor contact that starts slower than this does not rebound), written from its
    definition: a contact starts on the first sub-step ending with the ball centre below its
    radius, its impact speed is −v_z then; while such a slow contact lasts (centre below the
    radius) an upward v_z is set to 0. Use one instance per ``MjData``; ``reset()`` after setting
    a state."""

    def __init__(self, m, threshold=0.2):
        ball = ball_body_id(m)
        jid = free_joint_of_body(m, ball)
        self.qa, self.va = int(m.jnt_qposadr[jid]), int(m.jnt_dofadr[jid])
        geom = int(m.body_geomadr[ball])
        self.radius = float(m.geom_size[geom][0])
        self.threshold = threshold
        self.reset()

    def reset(self):
        self.touching = False
        self.inelastic = False

    def after_substep(self, d):
        if self.threshold <= 0.0:
            return
        z, vz = d.qpos[self.qa + 2], d.qvel[self.va + 2]
        touching = z < self.radius
        if touching and not self.touching:
            self.inelastic = -vz < self.threshold
        if not touching:
            self.inelastic = False
        if touching and self.inelastic and vz > 0.0:
            d.qvel[self.va + 2] = 0.0
        self.touching = touching
