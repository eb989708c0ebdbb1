//! A compiled scene and the index tables that map a character's quantities (and the scene's
//! objects) onto MuJoCo's arrays.
//!
//! State bodies (the rows of the read-out): the character's bodies in their order, then the
//! objects — the ball first where there is one ([`Scene::ball`]), then the box objects.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use mujoco_rs::prelude::*;
use mujoco_rs::wrappers::mj_model::MjtObjBase;
use skillmimic_core::characters::{ActionMap, BodyPart, CharacterSpec, JointDef};

use crate::error::SimError;
use crate::mjcf::{self, RootJoint, SceneOptions};

/// Index of the ball in the state bodies of a SkillMimic scene (53 humanoid bodies, then the
/// ball).
pub const BALL: usize = skillmimic_core::characters::skillmimic::NUM_BODIES;
/// State bodies of a SkillMimic scene: the 53 humanoid bodies and the ball.
pub const NUM_STATE_BODIES: usize = BALL + 1;

/// What a geom belongs to, for contact classification.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GeomOwner {
    /// The floor plane or another world geom (static props).
    Floor,
    /// The ball.
    Ball,
    /// Box object `k` (in [`SceneOptions::objects`] order).
    Object(usize),
    /// Character body `b`.
    Body(usize),
}

/// Where one joint of the character lives in MuJoCo's arrays.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct JointAddr {
    /// Its first slot in the dof (action) vector.
    pub dof: usize,
    /// `true`: a ball joint (3 slots: rotation vector ↔ quaternion `qpos`); `false`: a hinge
    /// (1 slot).
    pub ball: bool,
    pub qpos: usize,
    pub qvel: usize,
}

/// Where an object's state lives.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ObjectAddr {
    /// A static (mocap) object: its index in `mocap_pos`/`mocap_quat`.
    Mocap(usize),
    /// A free body (or the ball's free-joint-like chain): the addresses of its position (3),
    /// quaternion (4), linear velocity (3, world) and angular velocity (3, body frame).
    Free { qpos: usize, qvel: usize },
}

/// The floor bounce-threshold rule's addresses ([`crate::bounce`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BounceAddr {
    /// `qpos` index of the ball's height and `qvel` index of its vertical velocity.
    pub z: usize,
    pub vz: usize,
    pub radius: f64,
    pub threshold: f64,
}

/// A compiled scene: the MuJoCo model plus index tables.
pub struct Scene {
    model: Arc<MjModel>,
    options: SceneOptions,
    spec: CharacterSpec,
    xml: String,
    /// MuJoCo body id of each state body.
    pub body_ids: Vec<usize>,
    /// MuJoCo id of the root body of each state body's kinematic tree (whose subtree centre of
    /// mass is the reference point of `cvel`).
    pub tree_root: Vec<usize>,
    /// Driven joints of the character, in body order.
    pub joints: Vec<JointAddr>,
    /// `qpos` / `qvel` address of the root free joint (`None` when the root is fixed).
    pub root_qpos: Option<usize>,
    pub root_dof: Option<usize>,
    /// Every object (the ball first), in state-body order after the character.
    pub objects: Vec<ObjectAddr>,
    /// Per MuJoCo actuator: its slot in the dof (action) vector and the action map.
    pub actuators: Vec<(usize, ActionMap)>,
    /// Owner of every MuJoCo geom.
    pub geom_owner: Vec<GeomOwner>,
    /// Anatomical part of each character body (contact classification).
    pub body_part: Vec<BodyPart>,
    /// The ball's floor rule, when the scene has a ball.
    pub bounce: Option<BounceAddr>,
}

impl Scene {
    /// Generate and compile the scene for `options`.
    pub fn new(options: SceneOptions) -> Result<Self, SimError> {
        let spec = options.character.spec();
        let xml = mjcf::scene_xml_of(&spec, &options);
        Self::compile(xml, options, spec, "<generated scene>")
    }

    /// Compile a scene from MJCF text that follows the generator's naming (the character's body,
    /// joint and actuator names, `Ball`, the objects' names), e.g. a generated scene edited for
    /// an experiment. `options` describes what it holds, for the index tables.
    pub fn from_xml(xml: String, options: SceneOptions) -> Result<Self, SimError> {
        let spec = options.character.spec();
        Self::compile(xml, options, spec, "<custom scene>")
    }

    /// The shipped default scene of the SkillMimic humanoid with a hand model.
    pub fn default_for(hands: skillmimic_core::characters::HandModel) -> Result<Self, SimError> {
        Self::new(SceneOptions {
            character: skillmimic_core::characters::skillmimic::humanoid(hands),
            ..Default::default()
        })
    }

    fn compile(
        xml: String,
        options: SceneOptions,
        spec: CharacterSpec,
        source: &str,
    ) -> Result<Self, SimError> {
        let bad = |message: String| SimError::Model { source_name: source.into(), message };
        let model = MjModel::from_xml_string(&xml).map_err(|e| bad(e.to_string()))?;
        let body_id = |name: &str| {
            model
                .name_to_id(MjtObjBase::mjOBJ_BODY, name)
                .ok_or_else(|| bad(format!("body '{name}' missing")))
        };
        let joint_id = |name: &str| {
            model
                .name_to_id(MjtObjBase::mjOBJ_JOINT, name)
                .ok_or_else(|| bad(format!("joint '{name}' missing")))
        };
        let (qposadr, dofadr) = (model.jnt_qposadr(), model.jnt_dofadr());
        let mut body_ids = Vec::new();
        for b in &spec.bodies {
            body_ids.push(body_id(b.name)?);
        }
        let (root_qpos, root_dof) = match options.root {
            RootJoint::Free => {
                let j = joint_id("root")?;
                (Some(qposadr[j] as usize), Some(dofadr[j] as usize))
            }
            RootJoint::Fixed { .. } => (None, None),
        };
        let mut joints = Vec::new();
        let mut actuator_of = std::collections::HashMap::new();
        for b in &spec.bodies {
            match &b.joint {
                JointDef::Ball { name, action, .. } => {
                    let j = joint_id(name)?;
                    joints.push(JointAddr {
                        dof: b.dofs.start,
                        ball: true,
                        qpos: qposadr[j] as usize,
                        qvel: dofadr[j] as usize,
                    });
                    for (k, axis) in ["x", "y", "z"].iter().enumerate() {
                        actuator_of.insert(format!("{name}_{axis}"), (b.dofs.start + k, *action));
                    }
                }
                JointDef::Hinges { hinges, .. } => {
                    for (k, h) in hinges.iter().enumerate() {
                        let j = joint_id(&h.name)?;
                        let dof = b.dofs.start + k;
                        joints.push(JointAddr {
                            dof,
                            ball: false,
                            qpos: qposadr[j] as usize,
                            qvel: dofadr[j] as usize,
                        });
                        actuator_of.insert(h.name.clone(), (dof, h.action));
                    }
                }
                JointDef::Free | JointDef::Welded => {}
            }
        }
        let mut objects = Vec::new();
        let mut bounce = None;
        if let Some(ball) = &options.ball {
            body_ids.push(body_id("Ball")?);
            let j = joint_id("ball_x")?;
            let (q, v) = (qposadr[j] as usize, dofadr[j] as usize);
            objects.push(ObjectAddr::Free { qpos: q, qvel: v });
            bounce = Some(BounceAddr {
                z: q + 2,
                vz: v + 2,
                radius: ball.radius,
                threshold: ball.bounce_threshold,
            });
        }
        let mocapid = model.body_mocapid();
        for o in &options.objects {
            let body = body_id(&o.name)?;
            body_ids.push(body);
            objects.push(match o.mass {
                None => ObjectAddr::Mocap(
                    usize::try_from(mocapid[body])
                        .map_err(|_| bad(format!("object '{}' is not a mocap body", o.name)))?,
                ),
                Some(_) => {
                    let j = joint_id(&o.name)?;
                    ObjectAddr::Free { qpos: qposadr[j] as usize, qvel: dofadr[j] as usize }
                }
            });
        }
        let nu = model.ffi().nu as usize;
        let mut actuators = Vec::with_capacity(nu);
        for a in 0..nu {
            let name =
                model.id_to_name(MjtObjBase::mjOBJ_ACTUATOR, a).unwrap_or_default().to_string();
            let m = actuator_of.get(&name).ok_or_else(|| {
                bad(format!("actuator '{name}' drives no joint of the character"))
            })?;
            actuators.push(*m);
        }
        let nchar = spec.bodies.len();
        let mut state_of_body = vec![None; model.ffi().nbody as usize];
        for (b, &id) in body_ids.iter().enumerate() {
            state_of_body[id] = Some(b);
        }
        let has_ball = options.ball.is_some();
        let geom_owner = model
            .geom_bodyid()
            .iter()
            .map(|&body| match state_of_body[body as usize] {
                Some(b) if b < nchar => GeomOwner::Body(b),
                Some(b) if has_ball && b == nchar => GeomOwner::Ball,
                Some(b) => GeomOwner::Object(b - nchar - usize::from(has_ball)),
                None => GeomOwner::Floor,
            })
            .collect();
        let rootid = model.body_rootid();
        let tree_root = body_ids.iter().map(|&id| rootid[id] as usize).collect();
        let body_part = spec.bodies.iter().map(|b| b.part).collect();
        Ok(Self {
            model: Arc::new(model),
            options,
            spec,
            xml,
            body_ids,
            tree_root,
            joints,
            root_qpos,
            root_dof,
            objects,
            actuators,
            geom_owner,
            body_part,
            bounce,
        })
    }

    /// The compiled model (shared by all environments).
    pub fn model(&self) -> &Arc<MjModel> {
        &self.model
    }
    /// The options the scene was generated from.
    pub fn options(&self) -> &SceneOptions {
        &self.options
    }
    /// The (first) joint of character body `b`, if it is driven.
    pub fn joint_addr(&self, b: usize) -> Option<JointAddr> {
        let dofs = &self.spec.bodies.get(b)?.dofs;
        if dofs.is_empty() {
            return None;
        }
        self.joints.iter().copied().find(|j| j.dof == dofs.start)
    }
    /// The box objects (after the ball in state-body order).
    pub fn box_objects(&self) -> &[crate::mjcf::BoxObject] {
        &self.options.objects
    }
    /// The character's description.
    pub fn character(&self) -> &CharacterSpec {
        &self.spec
    }
    /// The MJCF text the model was compiled from.
    pub fn xml(&self) -> &str {
        &self.xml
    }
    /// Character bodies (the first rows of the state read-out).
    pub fn num_character_bodies(&self) -> usize {
        self.spec.bodies.len()
    }
    /// State bodies: the character's, then the objects.
    pub fn num_state_bodies(&self) -> usize {
        self.body_ids.len()
    }
    /// Width of the dof (action) vector.
    pub fn num_dofs(&self) -> usize {
        self.spec.num_dofs
    }
    /// The state body of the ball (`None` without a ball).
    pub fn ball(&self) -> Option<usize> {
        self.options.ball.map(|_| self.spec.bodies.len())
    }
    /// `qpos` address of the ball's position (`None` without a ball).
    pub fn ball_qpos(&self) -> Option<usize> {
        match (self.options.ball, self.objects.first()) {
            (Some(_), Some(ObjectAddr::Free { qpos, .. })) => Some(*qpos),
            _ => None,
        }
    }
    /// The state body of box object `k`.
    pub fn object_body(&self, k: usize) -> usize {
        self.spec.bodies.len() + usize::from(self.options.ball.is_some()) + k
    }
    /// Physics steps per policy step.
    pub fn substeps(&self) -> usize {
        self.spec.substeps
    }
    /// True when the root has a free joint.
    pub fn free_root(&self) -> bool {
        matches!(self.options.root, RootJoint::Free)
    }
    /// `nq`, `nv`, `nu` of the model.
    pub fn sizes(&self) -> (usize, usize, usize) {
        let m = self.model.ffi();
        (m.nq as usize, m.nv as usize, m.nu as usize)
    }
    /// True if action entry `k` drives an actuator in this scene.
    pub fn action_is_actuated(&self, k: usize) -> bool {
        self.actuators.iter().any(|&(a, _)| a == k)
    }
}

/// Path of a character's shipped plain scene inside the repository's `mjcf/` folder.
pub fn shipped_scene_path(
    repo_root: &Path,
    character: skillmimic_core::characters::Character,
) -> PathBuf {
    repo_root.join("mjcf").join(mjcf::default_scene_file(character))
}
