//! A compiled scene and the index tables that map skeleton quantities onto MuJoCo arrays.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use mujoco_rs::prelude::*;
use mujoco_rs::wrappers::mj_model::MjtObjBase;
use skillmimic_core::skeleton::{self, BODIES, BodyPart, NUM_BODIES, NUM_DOFS, NUM_JOINTS};

use crate::error::SimError;
use crate::mjcf::{self, HandModel, RootJoint, SceneOptions};

/// Number of rigid bodies in the per-env state arrays: the 53 humanoid bodies, then the ball.
pub const NUM_STATE_BODIES: usize = NUM_BODIES + 1;
/// Index of the ball in the per-env body arrays.
pub const BALL: usize = NUM_BODIES;

/// What a geom belongs to, for contact classification.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GeomOwner {
    /// The floor plane (world body).
    Floor,
    /// The ball.
    Ball,
    /// Humanoid body with this skeleton index.
    Body(usize),
}

/// A compiled scene: the MuJoCo model plus index tables.
pub struct Scene {
    model: Arc<MjModel>,
    options: SceneOptions,
    xml: String,
    /// MuJoCo body id of skeleton body `b` (`b < 53`) and of the ball (`b = 53`).
    pub body_ids: [usize; NUM_STATE_BODIES],
    /// MuJoCo id of the root body of each state body's kinematic tree (whose subtree centre of
    /// mass is the reference point of `cvel`).
    pub tree_root: [usize; NUM_STATE_BODIES],
    /// `qpos` address of the quaternion of skeleton joint `j` (body `j + 1`); `None` if welded.
    pub joint_qpos: [Option<usize>; NUM_JOINTS],
    /// `qvel` address of the angular velocity of skeleton joint `j`; `None` if welded.
    pub joint_dof: [Option<usize>; NUM_JOINTS],
    /// `qpos` / `qvel` address of the root free joint (`None` when the root is fixed).
    pub root_qpos: Option<usize>,
    pub root_dof: Option<usize>,
    /// `qpos` / `qvel` address of the ball free joint.
    pub ball_qpos: usize,
    pub ball_dof: usize,
    /// For each MuJoCo actuator, its index in the 156-wide action vector.
    pub actuator_action: Vec<usize>,
    /// Owner of every MuJoCo geom.
    pub geom_owner: Vec<GeomOwner>,
}

impl Scene {
    /// Generate and compile the scene for `options`.
    pub fn new(options: SceneOptions) -> Result<Self, SimError> {
        let xml = mjcf::scene_xml(&options);
        let model = MjModel::from_xml_string(&xml).map_err(|e| SimError::Model {
            source_name: "<generated scene>".into(),
            message: e.to_string(),
        })?;
        Self::from_model(model, options, xml)
    }

    /// Compile a scene from MJCF text that follows the generator's naming (skeleton body names,
    /// `Ball`, actuators `<Body>_<axis>`), e.g. a generated scene edited for an experiment.
    /// `options` describes the variant (hand model, root joint) for the index tables.
    pub fn from_xml(xml: String, options: SceneOptions) -> Result<Self, SimError> {
        let model = MjModel::from_xml_string(&xml).map_err(|e| SimError::Model {
            source_name: "<custom scene>".into(),
            message: e.to_string(),
        })?;
        Self::from_model(model, options, xml)
    }

    /// The shipped default scene for a hand model.
    pub fn default_for(hands: HandModel) -> Result<Self, SimError> {
        Self::new(SceneOptions { hands, ..Default::default() })
    }

    fn from_model(model: MjModel, options: SceneOptions, xml: String) -> Result<Self, SimError> {
        let bad =
            |message: String| SimError::Model { source_name: "<generated scene>".into(), message };
        let id_of = |name: &str| {
            model
                .name_to_id(MjtObjBase::mjOBJ_BODY, name)
                .ok_or_else(|| bad(format!("body '{name}' missing")))
        };
        let mut body_ids = [0usize; NUM_STATE_BODIES];
        for (b, spec) in BODIES.iter().enumerate() {
            body_ids[b] = id_of(spec.name)?;
        }
        body_ids[BALL] = id_of("Ball")?;

        let jntadr = model.body_jntadr();
        let qposadr = model.jnt_qposadr();
        let dofadr = model.jnt_dofadr();
        let joint_of = |b: usize| -> Option<usize> {
            let j = jntadr[body_ids[b]];
            (j >= 0).then_some(j as usize)
        };
        let mut joint_qpos = [None; NUM_JOINTS];
        let mut joint_dof = [None; NUM_JOINTS];
        for j in 0..NUM_JOINTS {
            if let Some(jid) = joint_of(j + 1) {
                joint_qpos[j] = Some(qposadr[jid] as usize);
                joint_dof[j] = Some(dofadr[jid] as usize);
            }
        }
        let (root_qpos, root_dof) = match joint_of(0) {
            Some(jid) => (Some(qposadr[jid] as usize), Some(dofadr[jid] as usize)),
            None => (None, None),
        };
        let ball_joint = joint_of(BALL).ok_or_else(|| bad("ball has no free joint".into()))?;

        // actuators: "<Body>_<axis>" -> action index 3 (b - 1) + axis
        let nu = model.ffi().nu as usize;
        let mut actuator_action = Vec::with_capacity(nu);
        for a in 0..nu {
            let name = model.id_to_name(MjtObjBase::mjOBJ_ACTUATOR, a).unwrap_or_default();
            let (body, axis) =
                name.rsplit_once('_').ok_or_else(|| bad(format!("actuator '{name}'")))?;
            let b = skeleton::body_index(body)
                .filter(|&b| b > 0)
                .ok_or_else(|| bad(format!("actuator '{name}'")))?;
            let k = match axis {
                "x" => 0,
                "y" => 1,
                "z" => 2,
                _ => return Err(bad(format!("actuator '{name}'"))),
            };
            actuator_action.push(skeleton::dof_range(b).start + k);
        }

        let mut skeleton_of_body = vec![None; model.ffi().nbody as usize];
        for (b, &id) in body_ids.iter().enumerate() {
            skeleton_of_body[id] = Some(b);
        }
        let geom_owner = model
            .geom_bodyid()
            .iter()
            .map(|&body| match skeleton_of_body[body as usize] {
                Some(BALL) => GeomOwner::Ball,
                Some(b) => GeomOwner::Body(b),
                None => GeomOwner::Floor,
            })
            .collect();

        let (ball_qpos, ball_dof) = (qposadr[ball_joint] as usize, dofadr[ball_joint] as usize);
        let rootid = model.body_rootid();
        let tree_root = std::array::from_fn(|b| rootid[body_ids[b]] as usize);
        Ok(Self {
            model: Arc::new(model),
            options,
            xml,
            body_ids,
            tree_root,
            joint_qpos,
            joint_dof,
            root_qpos,
            root_dof,
            ball_qpos,
            ball_dof,
            actuator_action,
            geom_owner,
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
    /// The MJCF text the model was compiled from.
    pub fn xml(&self) -> &str {
        &self.xml
    }
    /// Hand model of this scene.
    pub fn hands(&self) -> HandModel {
        self.options.hands
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
    /// True if action entry `k` (0…155) drives an actuator in this scene.
    pub fn action_is_actuated(&self, k: usize) -> bool {
        k < NUM_DOFS && self.actuator_action.contains(&k)
    }
    /// Part of the humanoid a skeleton body belongs to.
    pub fn body_part(b: usize) -> BodyPart {
        skeleton::body_part(b)
    }
}

/// Path of the shipped MJCF file for a hand model inside the repository's `mjcf/` folder.
pub fn shipped_scene_path(repo_root: &Path, hands: HandModel) -> PathBuf {
    repo_root.join("mjcf").join(mjcf::default_scene_file(hands))
}
