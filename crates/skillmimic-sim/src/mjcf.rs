//! MJCF generator for the SkillMimic humanoid + ball scene.
//!
//! One function, [`scene_xml`], writes every variant from the skeleton table of
//! [`skillmimic_core::skeleton`]; the files in `mjcf/` are its output for the shipped defaults
//! (`skillmimic mjcf` regenerates them, a test keeps them in sync).
//!
//! Modelling choices (facts from the reference, choices documented here):
//! * every non-root body has one `ball` joint (the clips store exp-map joint rotations; three
//!   hinges would read them as Euler angles, ≈12 cm of FK error) with armature 0.02;
//! * the PD drive of each joint is split in two MuJoCo elements:
//!   - P term: three `position` actuators per ball joint with gears (1,0,0), (0,1,0), (0,0,1).
//!     The actuator length is then the matching rotation-vector component, so `ctrl` is the
//!     exp-map PD target (`π·action`, clamped to ±π) and the force is `kp·(target − length)`;
//!   - D term: the joint's passive `damping = kd` (torque −kd·ω on the local angular velocity,
//!     target velocity 0 as in the reference), integrated implicitly by `implicitfast`;
//! * force limit ±500 N·m on each P actuator: the original code sets no explicit limit, but the
//!   reference model's motors have `gear = 500` with `ctrlrange ±1`, the effort limit the Isaac Gym
//!   MJCF importer derives for each dof — our choice for a careful port. The damping stays outside
//!   the limit on purpose: with `kv` on a force-limited actuator the clamp makes the damper explicit
//!   and the drive chatters and diverges within 10 steps under random actions at 1/120 s
//!   (measured), whereas the split drive runs 10 s of random actions without a warning;
//! * timestep 1/120 s (two sub-steps per 60 Hz policy step), `implicitfast` integrator;
//! * humanoid geoms `condim = 1` (frictionless self-contact as in the reference), MuJoCo's
//!   default `solref`/`solimp` (the reference values are not PhysX parameters); the two
//!   permanently overlapping Thumb1–Thumb3 pairs are excluded;
//! * floor: plane, friction 1.0, `condim = 3`; contacts take the larger friction of the pair;
//! * ball: sphere r = 0.12 m, density 1000 kg/m³ (7.24 kg), friction 1.0, `condim = 3`.
//!   - Restitution as PhysX combines materials (average of the two shapes' coefficients): the
//!     floor contact (an explicit `<pair>`) gets (e_ball + 0.8)/2 = 0.805, contacts with the
//!     humanoid (Isaac Gym's default shape restitution 0) (e_ball + 0)/2 = 0.405. Both use a
//!     direct (−stiffness, −damping) `solref` calibrated for the coefficient
//!     ([`ball_floor_solref`]); the ball geom has `priority = 1` so that its `solref` (and its
//!     friction) decides every ball–humanoid contact. [`BodyContact::Soft`] keeps MuJoCo's
//!     default, non-bouncy ball–humanoid contact instead.
//!   - PhysX's linear and angular damping 0.01 s⁻¹ (dv/dt = −0.01·v, independent of the mass):
//!     MuJoCo's free joint takes one damping for its six dofs, so the ball is attached by three
//!     world-axis `slide` joints (`ball_x`, `ball_y`, `ball_z`, damping 0.01·m N·s/m; their
//!     `ref` makes `qpos` the absolute position) and a `ball` joint (`ball_rot`, damping
//!     0.01·I N·m·s/rad). `qpos`/`qvel` keep the free joint's layout: position (world),
//!     quaternion (wxyz), linear velocity (world), angular velocity (ball frame).
//!   - PhysX's bounce threshold (0.2 m/s: slower impacts do not bounce) has no MuJoCo element;
//!     [`crate::BatchSim`] applies it to the floor contact after every sub-step
//!     ([`crate::bounce`]).
//! * box hands ([`HandModel::Box`]): the 30 finger bodies keep their geoms and frames but have no
//!   joint, so they are welded to the wrist in the rest pose (nv 168 → 78, nu 156 → 66).

use std::fmt::Write as _;

use skillmimic_core::math::Quat;
use skillmimic_core::skeleton::{self, BODIES, GeomSpec, JOINT_ARMATURE};

/// Which hand model the humanoid uses.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum HandModel {
    /// 15 articulated finger bodies per hand (156 actuated dofs).
    #[default]
    Full,
    /// Fingers welded to the wrist in the rest pose (66 actuated dofs, ≈45 % faster).
    Box,
}

impl HandModel {
    /// Short name used in file names and configs.
    pub fn name(self) -> &'static str {
        match self {
            HandModel::Full => "full",
            HandModel::Box => "boxhand",
        }
    }
}

/// How the root (Pelvis) is attached.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum RootJoint {
    /// Free joint (the normal case).
    Free,
    /// Pelvis welded to the world at a pose (PD tests).
    Fixed { pos: [f64; 3], quat: Quat },
}

/// Restitution of the floor material (the reference's ground plane).
pub const FLOOR_RESTITUTION: f64 = 0.8;
/// Restitution of the humanoid's shapes (Isaac Gym's default; the reference sets none).
pub const BODY_RESTITUTION: f64 = 0.0;

/// How the ball's contacts with the humanoid behave.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum BodyContact {
    /// PhysX's combined restitution (ball 0.81 and body 0 average to 0.405).
    #[default]
    Combined,
    /// MuJoCo's default soft, non-bouncy contact (the behaviour before the ball physics followed
    /// the reference's materials).
    Soft,
}

/// Ball parameters.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BallParams {
    /// Radius (m).
    pub radius: f64,
    /// Density (kg/m³).
    pub density: f64,
    /// Restitution of the ball's material; a contact uses the average with the other material
    /// ([`FLOOR_RESTITUTION`], [`BODY_RESTITUTION`]).
    pub restitution: f64,
    /// Sliding friction coefficient.
    pub friction: f64,
    /// Linear and angular velocity damping (1/s): dv/dt = −damping·v (PhysX's rigid-body damping).
    pub damping: f64,
    /// Floor impacts slower than this (m/s, normal speed) do not bounce (PhysX's bounce
    /// threshold); 0 switches the rule off.
    pub bounce_threshold: f64,
    /// Ball–humanoid contact model.
    pub body_contact: BodyContact,
}

impl BallParams {
    /// Restitution of a ball–floor impact.
    pub fn floor_restitution(&self) -> f64 {
        0.5 * (self.restitution + FLOOR_RESTITUTION)
    }
    /// Restitution of a ball–humanoid impact ([`BodyContact::Combined`]).
    pub fn body_restitution(&self) -> f64 {
        0.5 * (self.restitution + BODY_RESTITUTION)
    }
    /// Mass (kg) of the solid sphere.
    pub fn mass(&self) -> f64 {
        self.density * 4.0 / 3.0 * std::f64::consts::PI * self.radius.powi(3)
    }
}

impl Default for BallParams {
    fn default() -> Self {
        Self {
            radius: 0.12,
            density: 1000.0,
            restitution: 0.81,
            friction: 1.0,
            damping: 0.01,
            bounce_threshold: 0.2,
            body_contact: BodyContact::Combined,
        }
    }
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
    /// A static box with these half-sizes (m) that collides with the humanoid and the ball.
    /// Contacts with it are not classified by the contact graph (they count as no known pair).
    Box { half: [f64; 3] },
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

/// Everything that selects a scene variant.
#[derive(Clone, Debug, PartialEq)]
pub struct SceneOptions {
    pub hands: HandModel,
    pub root: RootJoint,
    pub ball: BallParams,
    /// Physics time step (s).
    pub timestep: f64,
    /// Symmetric actuator force limit (N·m).
    pub force_limit: f64,
    /// Constraint solver (issue 21's speed option; Newton by default).
    pub solver: SolverOptions,
    /// Static task props, written after the floor in this order (none: the plain scene, byte for
    /// byte as before props existed).
    pub props: Vec<Prop>,
}

impl Default for SceneOptions {
    fn default() -> Self {
        Self {
            hands: HandModel::Full,
            root: RootJoint::Free,
            ball: BallParams::default(),
            timestep: 1.0 / 120.0,
            force_limit: 500.0,
            solver: SolverOptions::default(),
            props: Vec::new(),
        }
    }
}

/// Stiffness of the ball–floor contact (1/s², direct `solref` form, independent of the ball mass).
///
/// At 1/120 s a floor contact lasts only a few steps, and how much energy the soft contact adds or
/// removes depends on where the impact falls within a step. Measured over drops from 0.3 to 3 m,
/// 8000 s⁻² is where the restitution depends least on the impact speed (σ_e = 0.01, against 0.06
/// at 10⁴ and 0.02–0.04 at 5000–7000); the ball then sinks at most ≈ v/√k into the floor
/// (6 cm at 5.4 m/s).
pub const BALL_FLOOR_STIFFNESS: f64 = 8_000.0;

/// Ball–floor `solref` (−stiffness, −damping) for a restitution coefficient `e` in (0, 1].
///
/// A linear spring–damper of natural frequency ω = √k and damping ratio ζ bounces with
/// e = exp(−ζπ/√(1−ζ²)), i.e. ζ = −ln e / √(π² + ln² e) and damping b = 2ζ√k. Measured at
/// 1/120 s with e = 0.81 (apex-height restitution of drops from 0.3 to 3 m): mean 0.813, σ 0.02,
/// 0.823 for the 1.5 m drop of the ball-drop test; targets 0.65 and 0.9 measure 0.65 and 0.90.
/// Known limit: a ball left resting on the floor keeps a ±1 mm micro-bounce (the contact switches
/// on and off around zero distance at this time step); PhysX hides the same effect with its
/// 0.2 m/s bounce threshold, which MuJoCo lacks.
pub fn ball_floor_solref(e: f64) -> [f64; 2] {
    let e = e.clamp(1e-3, 1.0);
    let l = e.ln();
    let zeta = -l / (std::f64::consts::PI.powi(2) + l * l).sqrt();
    let b = 2.0 * zeta * BALL_FLOOR_STIFFNESS.sqrt();
    [-BALL_FLOOR_STIFFNESS, -b]
}

fn v3(v: [f64; 3]) -> String {
    format!("{} {} {}", v[0], v[1], v[2])
}

/// The MJCF text of the scene (deterministic: same options → same bytes).
pub fn scene_xml(opts: &SceneOptions) -> String {
    let mut x = String::with_capacity(32 * 1024);
    let hands = opts.hands;
    let _ = writeln!(
        x,
        "<!-- SkillMimic humanoid + ball, generated by skillmimic-rs (skillmimic mjcf). Do not edit by hand. -->"
    );
    let _ = writeln!(x, "<mujoco model=\"skillmimic_humanoid_ball_{}\">", hands.name());
    let _ = writeln!(x, "  <compiler angle=\"radian\" autolimits=\"true\"/>");
    let sv = &opts.solver;
    let solver = if *sv == SolverOptions::default() {
        String::new()
    } else {
        format!(
            " solver=\"{}\" iterations=\"{}\" tolerance=\"{}\"",
            sv.solver.mjcf_name(),
            sv.iterations,
            sv.tolerance
        )
    };
    let _ = writeln!(
        x,
        "  <option timestep=\"{}\" integrator=\"implicitfast\"{solver}/>",
        opts.timestep
    );
    let _ = writeln!(x, "  <size memory=\"4M\"/>");
    // Rendering only (no effect on physics): the `side` camera tracks the centre of mass from 5.5 m
    // at 1.7 m, pitched 5 degrees down, so a ball up to ~3.4 m (a layup at the rim) stays in frame;
    // shadows come from a spot light that follows the character (`key`, crisp 4096² map over a
    // small area) instead of the directional `sun`, whose map spread over the whole scene
    // dithered the shadows; no floor reflection.
    x.push_str(concat!(
        "  <visual>\n",
        "    <global offwidth=\"1280\" offheight=\"720\"/>\n",
        "    <quality shadowsize=\"4096\"/>\n",
        "    <headlight ambient=\"0.35 0.35 0.35\" diffuse=\"0.5 0.5 0.5\"/>\n",
        "  </visual>\n",
        "  <default>\n",
        "    <geom condim=\"1\" friction=\"1 0.05 0.05\" material=\"body\"/>\n",
        "  </default>\n",
        "  <asset>\n",
        "    <texture name=\"sky\" type=\"skybox\" builtin=\"gradient\" rgb1=\"0.45 0.55 0.65\" rgb2=\"0.05 0.05 0.1\" width=\"256\" height=\"256\"/>\n",
        "    <texture name=\"grid\" type=\"2d\" builtin=\"checker\" rgb1=\"0.22 0.24 0.26\" rgb2=\"0.3 0.32 0.34\" width=\"512\" height=\"512\"/>\n",
        "    <material name=\"grid\" texture=\"grid\" texrepeat=\"8 8\" texuniform=\"true\" reflectance=\"0\"/>\n",
        "    <material name=\"body\" rgba=\"0.78 0.62 0.5 1\"/>\n",
        "    <material name=\"hand\" rgba=\"0.85 0.7 0.58 1\"/>\n",
        "    <material name=\"ball\" rgba=\"0.9 0.45 0.1 1\"/>\n",
        "  </asset>\n",
        "  <worldbody>\n",
        "    <light name=\"sun\" directional=\"true\" pos=\"0 0 5\" dir=\"-0.3 0.2 -1\" diffuse=\"0.35 0.35 0.35\" castshadow=\"false\"/>\n",
        "    <light name=\"key\" mode=\"trackcom\" pos=\"1.8 -1.2 6\" dir=\"-0.3 0.2 -1\" cutoff=\"70\" exponent=\"1\" diffuse=\"0.4 0.4 0.4\" castshadow=\"true\" bulbradius=\"0\"/>\n",
        "    <geom name=\"floor\" type=\"plane\" size=\"0 0 0.05\" condim=\"3\" friction=\"1 0.005 0.0001\" material=\"grid\"/>\n",
        "    <camera name=\"side\" mode=\"trackcom\" pos=\"0 -5.5 1.7\" xyaxes=\"1 0 0 0 0.09 0.996\"/>\n",
    ));
    for p in &opts.props {
        let [r, g, b, a] = p.rgba;
        let [px, py, pz] = p.pos;
        let shape = match p.kind {
            PropKind::Marker { radius } => {
                format!("type=\"sphere\" size=\"{radius}\" contype=\"0\" conaffinity=\"0\"")
            }
            PropKind::Box { half: [hx, hy, hz] } => {
                format!("type=\"box\" size=\"{hx} {hy} {hz}\" condim=\"3\"")
            }
        };
        let _ = writeln!(
            x,
            "    <geom name=\"{}\" {shape} pos=\"{px} {py} {pz}\" rgba=\"{r} {g} {b} {a}\"/>",
            p.name
        );
    }

    // humanoid, depth first
    let (root_pos, root_quat) = match opts.root {
        RootJoint::Free => {
            ([0.0, 0.0, 0.95], Quat::from_rotvec([std::f64::consts::FRAC_PI_2, 0.0, 0.0]))
        }
        RootJoint::Fixed { pos, quat } => (pos, quat),
    };
    let mut open: Vec<usize> = Vec::new();
    for (i, b) in BODIES.iter().enumerate() {
        // close bodies until the parent is on top of the stack
        while let Some(&top) = open.last() {
            if Some(top) == b.parent {
                break;
            }
            open.pop();
            let _ = writeln!(x, "{}</body>", "  ".repeat(open.len() + 2));
        }
        let ind = "  ".repeat(open.len() + 2);
        if i == 0 {
            let q = root_quat.to_wxyz();
            let _ = writeln!(
                x,
                "{ind}<body name=\"{}\" pos=\"{}\" quat=\"{} {} {} {}\">",
                b.name,
                v3(root_pos),
                q[0],
                q[1],
                q[2],
                q[3]
            );
            if opts.root == RootJoint::Free {
                let _ = writeln!(x, "{ind}  <freejoint name=\"root\"/>");
            }
        } else {
            let _ = writeln!(x, "{ind}<body name=\"{}\" pos=\"{}\">", b.name, v3(b.offset));
            let welded = hands == HandModel::Box && skeleton::is_finger(i);
            if !welded {
                let kd = b.group.gains().1;
                let _ = writeln!(
                    x,
                    "{ind}  <joint name=\"{}\" type=\"ball\" armature=\"{JOINT_ARMATURE}\" damping=\"{kd}\"/>",
                    b.name
                );
            }
        }
        let material = if skeleton::body_part(i) == skeleton::BodyPart::Hand {
            " material=\"hand\""
        } else {
            ""
        };
        let geom = match b.geom {
            GeomSpec::Sphere { radius, center, density } => {
                format!(
                    "type=\"sphere\" size=\"{radius}\" pos=\"{}\" density=\"{density}\"",
                    v3(center)
                )
            }
            GeomSpec::Capsule { radius, from, to, density } => format!(
                "type=\"capsule\" size=\"{radius}\" fromto=\"{} {}\" density=\"{density}\"",
                v3(from),
                v3(to)
            ),
            GeomSpec::Box { half_extents, center, density } => format!(
                "type=\"box\" size=\"{}\" pos=\"{}\" density=\"{density}\"",
                v3(half_extents),
                v3(center)
            ),
        };
        let _ = writeln!(x, "{ind}  <geom name=\"{}\" {geom}{material}/>", b.name);
        open.push(i);
    }
    while open.pop().is_some() {
        let _ = writeln!(x, "{}</body>", "  ".repeat(open.len() + 2));
    }

    // ball, resting on the floor in front of the character
    let ball = opts.ball;
    let start = [0.0, 0.6, ball.radius];
    let _ = writeln!(x, "    <body name=\"Ball\" pos=\"{}\">", v3(start));
    // three world-axis slides + a ball joint = a free joint with separate linear and angular
    // damping; `ref` = the body position makes each slide's qpos the absolute coordinate
    let lin = ball.damping * ball.mass();
    let ang = ball.damping * 0.4 * ball.mass() * ball.radius * ball.radius;
    for (k, (axis, dir)) in [("x", "1 0 0"), ("y", "0 1 0"), ("z", "0 0 1")].iter().enumerate() {
        let _ = writeln!(
            x,
            "      <joint name=\"ball_{axis}\" type=\"slide\" axis=\"{dir}\" ref=\"{}\" damping=\"{lin}\"/>",
            start[k]
        );
    }
    let _ = writeln!(x, "      <joint name=\"ball_rot\" type=\"ball\" damping=\"{ang}\"/>");
    let contact = match ball.body_contact {
        BodyContact::Combined => {
            let [k, b] = ball_floor_solref(ball.body_restitution());
            format!(" priority=\"1\" solref=\"{k} {b}\"")
        }
        BodyContact::Soft => String::new(),
    };
    let _ = writeln!(
        x,
        "      <geom name=\"ball\" type=\"sphere\" size=\"{}\" density=\"{}\" condim=\"3\" friction=\"{} 0.005 0.0001\"{contact} material=\"ball\"/>",
        ball.radius, ball.density, ball.friction
    );
    let _ = writeln!(x, "    </body>");
    let _ = writeln!(x, "  </worldbody>");

    let _ = writeln!(x, "  <contact>");
    if hands == HandModel::Full {
        for side in ["L", "R"] {
            let _ = writeln!(x, "    <exclude body1=\"{side}_Thumb1\" body2=\"{side}_Thumb3\"/>");
        }
    }
    let [k, b] = ball_floor_solref(ball.floor_restitution());
    let _ = writeln!(x, "    <exclude body1=\"world\" body2=\"Ball\"/>");
    let _ = writeln!(
        x,
        "    <pair name=\"ball_floor\" geom1=\"floor\" geom2=\"ball\" condim=\"3\" friction=\"{f} {f} 0.005 0.0001 0.0001\" solref=\"{k} {b}\"/>",
        f = ball.friction
    );
    let _ = writeln!(x, "  </contact>");

    let _ = writeln!(x, "  <actuator>");
    let pi = std::f64::consts::PI;
    for (i, b) in BODIES.iter().enumerate().skip(1) {
        if hands == HandModel::Box && skeleton::is_finger(i) {
            continue;
        }
        let kp = b.group.gains().0;
        for (axis, gear) in [("x", "1 0 0"), ("y", "0 1 0"), ("z", "0 0 1")] {
            let _ = writeln!(
                x,
                "    <position name=\"{n}_{axis}\" joint=\"{n}\" gear=\"{gear}\" kp=\"{kp}\" ctrlrange=\"{} {pi}\" forcerange=\"{} {}\"/>",
                -pi,
                -opts.force_limit,
                opts.force_limit,
                n = b.name,
            );
        }
    }
    let _ = writeln!(x, "  </actuator>");
    let _ = writeln!(x, "</mujoco>");
    x
}

/// File name of the shipped scene for a hand model (inside `mjcf/`).
pub fn default_scene_file(hands: HandModel) -> String {
    format!("skillmimic_{}.xml", hands.name())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn restitution_formula_is_monotone_and_matches_the_measured_point() {
        let [k, b] = ball_floor_solref(0.81);
        assert_eq!(k, -8_000.0);
        // hand-computed: ln 0.81 = -0.21072, zeta = 0.066920, b = 2 zeta sqrt(8000) = 11.972
        assert!((b + 11.972).abs() < 1e-3, "{b}");
        assert!(ball_floor_solref(0.5)[1] < ball_floor_solref(0.9)[1]);
    }

    #[test]
    fn xml_is_deterministic_and_counts_actuators() {
        let a = scene_xml(&SceneOptions::default());
        assert_eq!(a, scene_xml(&SceneOptions::default()));
        assert_eq!(a.matches("<position ").count(), 156);
        // 52 skeleton joints + the ball's rotation joint (plus its three slides)
        assert_eq!(a.matches("type=\"ball\"").count(), 53);
        assert_eq!(a.matches("type=\"slide\"").count(), 3);
        let boxed = scene_xml(&SceneOptions { hands: HandModel::Box, ..Default::default() });
        assert_eq!(boxed.matches("<position ").count(), 66);
        assert_eq!(boxed.matches("type=\"ball\"").count(), 23);
    }
}
