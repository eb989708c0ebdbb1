//! What selects a scene ([`SceneOptions`]: the character, how its root is attached, the ball, box
//! objects, static props, the constraint solver) and each character's shipped plain scene. The
//! MJCF text is written from these by [`crate::mjcf`].

use skillmimic_core::characters::Character;
use skillmimic_core::math::Quat;

use crate::ball::BallParams;

/// How the root (body 0) is attached.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum RootJoint {
    /// Free joint (the normal case).
    Free,
    /// Root welded to the world at a pose (PD tests).
    Fixed { pos: [f64; 3], quat: Quat },
}

/// A static prop a task adds to the world (fixed in the world frame, world coordinates in metres).
#[derive(Clone, Debug, PartialEq)]
pub struct Prop {
    /// Geom name (unique in the scene).
    pub name: String,
    pub kind: PropKind,
    /// Centre position (m, world frame).
    pub pos: [f64; 3],
    /// RGBA colour.
    pub rgba: [f32; 4],
}

/// What a prop is.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PropKind {
    /// A visual sphere of this radius (m): no collisions, no mass (target markers, a hoop marker).
    Marker { radius: f64 },
    /// A static box with these half-sizes (m) that collides with the character and the ball.
    /// It is a world geom: its contacts count as floor contacts of the contact read-out.
    Box { half: [f64; 3] },
}

/// One box of an object, in the object's frame (m).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ObjectBox {
    pub center: [f64; 3],
    pub half: [f64; 3],
}

/// A task object made of boxes (TokenHSI's chairs, platforms, carried boxes).
#[derive(Clone, Debug, PartialEq)]
pub struct BoxObject {
    /// Body name (unique; geoms are `<name>_<k>`).
    pub name: String,
    /// `None`: static (mocap) object; `Some(kg)`: a free rigid body of this mass.
    pub mass: Option<f64>,
    pub boxes: Vec<ObjectBox>,
    pub rgba: [f32; 4],
}

impl BoxObject {
    /// Axis-aligned bounds (min, max) of the object's boxes in its own frame (m).
    pub fn bounds(&self) -> ([f64; 3], [f64; 3]) {
        let mut lo = [f64::INFINITY; 3];
        let mut hi = [f64::NEG_INFINITY; 3];
        for b in &self.boxes {
            for k in 0..3 {
                lo[k] = lo[k].min(b.center[k] - b.half[k]);
                hi[k] = hi[k].max(b.center[k] + b.half[k]);
            }
        }
        (lo, hi)
    }
}

/// MuJoCo's constraint solver (`<option solver>`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Solver {
    /// Newton (MuJoCo's default; the shipped scenes).
    #[default]
    Newton,
    /// Projected Gauss–Seidel.
    Pgs,
    /// Conjugate gradient.
    Cg,
}

impl Solver {
    /// The MJCF attribute value.
    pub fn mjcf_name(self) -> &'static str {
        match self {
            Solver::Newton => "Newton",
            Solver::Pgs => "PGS",
            Solver::Cg => "CG",
        }
    }
}

/// Constraint-solver settings (`<option solver iterations tolerance>`); the defaults are
/// MuJoCo's and leave the MJCF text unchanged.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SolverOptions {
    pub solver: Solver,
    /// Maximum solver iterations per step.
    pub iterations: usize,
    /// Early-termination tolerance of the solver.
    pub tolerance: f64,
}

impl Default for SolverOptions {
    fn default() -> Self {
        Self { solver: Solver::Newton, iterations: 100, tolerance: 1e-8 }
    }
}

/// Everything that selects a scene.
#[derive(Clone, Debug, PartialEq)]
pub struct SceneOptions {
    /// The character (and its variant, e.g. the SkillMimic humanoid's hands).
    pub character: Character,
    pub root: RootJoint,
    /// The ball (SkillMimic's scenes); `None`: no ball.
    pub ball: Option<BallParams>,
    /// Box objects, after the ball in body order.
    pub objects: Vec<BoxObject>,
    /// Constraint solver (issue 21's speed option; Newton by default).
    pub solver: SolverOptions,
    /// Static task props, written after the floor in this order.
    pub props: Vec<Prop>,
}

impl Default for SceneOptions {
    /// The SkillMimic humanoid with articulated hands and the ball.
    fn default() -> Self {
        Self {
            character: Character::default(),
            root: RootJoint::Free,
            ball: Some(BallParams::default()),
            objects: Vec::new(),
            solver: SolverOptions::default(),
            props: Vec::new(),
        }
    }
}

impl SceneOptions {
    /// The plain scene of `character`: free root, no ball, no objects, no props.
    pub fn bare(character: Character) -> Self {
        Self { character, ball: None, ..Self::default() }
    }
}

/// File name of a character's shipped plain scene inside `mjcf/` (`skillmimic_full.xml`,
/// `skillmimic_boxhand.xml` with the ball; `tokenhsi.xml`, `smpl.xml` bare).
pub fn default_scene_file(character: Character) -> String {
    match character.hands() {
        Some(hands) => format!("{}_{}.xml", character.name(), hands.name()),
        None => format!("{}.xml", character.name()),
    }
}

/// The shipped plain scene of a character: the SkillMimic humanoid with its ball, the others
/// bare.
pub fn default_scene(character: Character) -> SceneOptions {
    if character.plays_ballplay() {
        SceneOptions { character, ..SceneOptions::default() }
    } else {
        SceneOptions::bare(character)
    }
}
