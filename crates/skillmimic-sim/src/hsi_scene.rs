//! A compiled TokenHSI scene (character + task objects) and its index tables.

use std::sync::Arc;

use mujoco_rs::prelude::*;
use mujoco_rs::wrappers::mj_model::MjtObjBase;
use skillmimic_core::hsi_character::{
    BODIES, JointSpec, NUM_BODIES, NUM_DOFS, action_offset_scale,
};

use crate::error::SimError;
use crate::hsi_mjcf::{HsiObject, hsi_scene_xml};

/// Most objects a TokenHSI scene holds (carry: the box and two supports).
pub const MAX_OBJECTS: usize = 4;

/// Where one actuated joint lives in MuJoCo's arrays.
#[derive(Clone, Copy, Debug)]
pub struct JointAddr {
    /// First action index of the joint.
    pub action: usize,
    /// 3 for a ball joint, 1 for a hinge.
    pub dofs: usize,
    pub qpos: usize,
    pub qvel: usize,
}

/// Where one object lives.
#[derive(Clone, Copy, Debug)]
pub enum ObjectAddr {
    /// A static (mocap) object: its index in `mocap_pos`/`mocap_quat`.
    Mocap(usize),
    /// A free body: its `qpos`/`qvel` addresses.
    Free { qpos: usize, qvel: usize },
}

/// The character and objects compiled into one MuJoCo model.
pub struct HsiScene {
    model: Arc<MjModel>,
    xml: String,
    objects: Vec<HsiObject>,
    /// MuJoCo body id of character body `b` (0…14), then of each object.
    pub body_ids: Vec<usize>,
    /// MuJoCo id of the root body of each body's kinematic tree (reference point of `cvel`).
    pub tree_root: Vec<usize>,
    /// Actuated joints in action order.
    pub joints: Vec<JointAddr>,
    /// `qpos`/`qvel` address of the character's free joint.
    pub root_qpos: usize,
    pub root_qvel: usize,
    pub object_addr: Vec<ObjectAddr>,
    /// Per MuJoCo actuator: (action index, offset, scale) of `ctrl = offset + scale · a`.
    pub actuator_map: Vec<(usize, f64, f64)>,
    /// Per MuJoCo geom: the character body it belongs to (`None`: floor or an object).
    pub geom_character_body: Vec<Option<usize>>,
}

impl HsiScene {
    /// Generate and compile the scene with `objects` (at most [`MAX_OBJECTS`]).
    pub fn new(objects: Vec<HsiObject>) -> Result<Self, SimError> {
        if objects.len() > MAX_OBJECTS {
            return Err(SimError::Config(format!(
                "a TokenHSI scene holds at most {MAX_OBJECTS} objects, got {}",
                objects.len()
            )));
        }
        let xml = hsi_scene_xml(&objects);
        Self::from_xml(xml, objects)
    }

    /// Compile MJCF text that follows the generator's naming (e.g. a generated scene edited for
    /// an experiment); `objects` names the task objects it holds.
    pub fn from_xml(xml: String, objects: Vec<HsiObject>) -> Result<Self, SimError> {
        let bad =
            |message: String| SimError::Model { source_name: "<TokenHSI scene>".into(), message };
        let model = MjModel::from_xml_string(&xml).map_err(|e| bad(e.to_string()))?;
        let id_of = |name: &str| {
            model
                .name_to_id(MjtObjBase::mjOBJ_BODY, name)
                .ok_or_else(|| bad(format!("body '{name}' missing")))
        };
        let mut body_ids = Vec::with_capacity(NUM_BODIES + objects.len());
        for b in &BODIES {
            body_ids.push(id_of(b.name)?);
        }
        for o in &objects {
            body_ids.push(id_of(&o.name)?);
        }
        let jnt_id = |name: &str| {
            model
                .name_to_id(MjtObjBase::mjOBJ_JOINT, name)
                .ok_or_else(|| bad(format!("joint '{name}' missing")))
        };
        let (qposadr, dofadr) = (model.jnt_qposadr(), model.jnt_dofadr());
        let root = jnt_id("root")?;
        let mut joints = Vec::new();
        let mut action = 0;
        for b in &BODIES {
            let dofs = b.joint.dofs();
            if dofs > 0 {
                let j = jnt_id(b.joint_name)?;
                joints.push(JointAddr {
                    action,
                    dofs,
                    qpos: qposadr[j] as usize,
                    qvel: dofadr[j] as usize,
                });
                action += dofs;
            }
        }
        let mut object_addr = Vec::with_capacity(objects.len());
        let mocapid = model.body_mocapid();
        for (k, o) in objects.iter().enumerate() {
            let body = body_ids[NUM_BODIES + k];
            object_addr.push(match o.mass {
                None => ObjectAddr::Mocap(
                    usize::try_from(mocapid[body])
                        .map_err(|_| bad(format!("object '{}' is not a mocap body", o.name)))?,
                ),
                Some(_) => {
                    let j = jnt_id(&o.name)?;
                    ObjectAddr::Free { qpos: qposadr[j] as usize, qvel: dofadr[j] as usize }
                }
            });
        }
        // actuators "<joint>_<axis>" (ball) or "<joint>" (hinge)
        let maps = action_offset_scale();
        let nu = model.ffi().nu as usize;
        let mut actuator_map = Vec::with_capacity(nu);
        for a in 0..nu {
            let name = model.id_to_name(MjtObjBase::mjOBJ_ACTUATOR, a).unwrap_or_default();
            let found = joints.iter().zip(BODIES.iter().filter(|b| b.joint.dofs() > 0)).find_map(
                |(j, b)| match b.joint {
                    JointSpec::HingeY { .. } if name == b.joint_name => Some(j.action),
                    JointSpec::Ball { .. } => {
                        let (stem, axis) = name.rsplit_once('_')?;
                        let k = ["x", "y", "z"].iter().position(|&s| s == axis)?;
                        (stem == b.joint_name).then_some(j.action + k)
                    }
                    _ => None,
                },
            );
            let k = found.ok_or_else(|| {
                bad(format!("actuator '{name}' drives no joint of the character"))
            })?;
            actuator_map.push((k, maps[k].0, maps[k].1));
        }
        if action != NUM_DOFS {
            return Err(bad(format!("{action} actuated dofs, expected {NUM_DOFS}")));
        }
        let mut character_of_body = vec![None; model.ffi().nbody as usize];
        for (b, &id) in body_ids.iter().take(NUM_BODIES).enumerate() {
            character_of_body[id] = Some(b);
        }
        let geom_character_body =
            model.geom_bodyid().iter().map(|&b| character_of_body[b as usize]).collect();
        let rootid = model.body_rootid();
        let tree_root = body_ids.iter().map(|&id| rootid[id] as usize).collect();
        Ok(Self {
            xml,
            objects,
            body_ids,
            tree_root,
            joints,
            root_qpos: qposadr[root] as usize,
            root_qvel: dofadr[root] as usize,
            object_addr,
            actuator_map,
            geom_character_body,
            model: Arc::new(model),
        })
    }

    /// The compiled model.
    pub fn model(&self) -> &Arc<MjModel> {
        &self.model
    }
    /// The MJCF text the model was compiled from.
    pub fn xml(&self) -> &str {
        &self.xml
    }
    /// The task objects, in body order after the character.
    pub fn objects(&self) -> &[HsiObject] {
        &self.objects
    }
    /// `nq`, `nv`, `nu`.
    pub fn sizes(&self) -> (usize, usize, usize) {
        let m = self.model.ffi();
        (m.nq as usize, m.nv as usize, m.nu as usize)
    }
}
