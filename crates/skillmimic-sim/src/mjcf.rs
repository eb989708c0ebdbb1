//! MJCF generator of every scene: a character ([`skillmimic_core::characters`]) plus the things a
//! task puts in the world — the SkillMimic ball, movable or static box objects, markers and
//! static boxes.
//!
//! One function, [`scene_xml`], writes every variant from the character's [`CharacterSpec`];
//! the files in `mjcf/` are its output for each character's plain scene (`skillmimic mjcf`
//! regenerates them, a test keeps them in sync).
//!
//! Modelling choices common to the characters (per-character numbers are in their modules):
//! * PD drive of each joint split in two MuJoCo elements:
//!   - P term: one force-limited `position` actuator per dof. A ball joint gets three with gears
//!     (1,0,0), (0,1,0), (0,0,1): the actuator length is then the matching rotation-vector
//!     component, so `ctrl` is the exp-map PD target; a hinge gets one;
//!   - D term: the joint's passive `damping = kd` (target velocity 0), integrated implicitly by
//!     `implicitfast`. The damping stays outside the force limit on purpose: with `kv` on a
//!     force-limited actuator the clamp makes the damper explicit and the drive chatters and
//!     diverges within 10 steps under random actions at 1/120 s (measured on the SkillMimic
//!     humanoid), whereas the split drive runs 10 s of random actions without a warning;
//! * character geoms `condim = 1` (frictionless self-contact as in the references), MuJoCo's
//!   default `solref`/`solimp`; the character's excluded body pairs;
//! * floor: plane, friction 1.0, `condim = 3`; contacts take the larger friction of the pair;
//! * the ball ([`crate::ball`]): sphere r = 0.12 m, density 1000 kg/m³ (7.24 kg), friction 1.0,
//!   `condim = 3`.
//!   - Restitution as PhysX combines materials (average of the two shapes' coefficients): the
//!     floor contact (an explicit `<pair>`) gets (e_ball + 0.8)/2 = 0.805, contacts with the
//!     humanoid (Isaac Gym's default shape restitution 0) (e_ball + 0)/2 = 0.405. Both use a
//!     direct (−stiffness, −damping) `solref` calibrated for the coefficient
//!     ([`crate::ball::ball_floor_solref`]); the ball geom has `priority = 1` so that its
//!     `solref` (and its friction) decides every ball–humanoid contact.
//!     [`BodyContact::Soft`] keeps MuJoCo's default, non-bouncy
//!     ball–humanoid contact instead.
//!   - PhysX's linear and angular damping 0.01 s⁻¹ (dv/dt = −0.01·v, independent of the mass):
//!     MuJoCo's free joint takes one damping for its six dofs, so the ball is attached by three
//!     world-axis `slide` joints (`ball_x`, `ball_y`, `ball_z`, damping 0.01·m N·s/m; their
//!     `ref` makes `qpos` the absolute position) and a `ball` joint (`ball_rot`, damping
//!     0.01·I N·m·s/rad). `qpos`/`qvel` keep the free joint's layout: position (world),
//!     quaternion (wxyz), linear velocity (world), angular velocity (ball frame).
//!   - PhysX's bounce threshold (0.2 m/s: slower impacts do not bounce) has no MuJoCo element;
//!     [`crate::BatchSim`] applies it to the floor contact after every sub-step
//!     ([`crate::bounce`]).
//! * box objects ([`BoxObject`]): a static one (a seat, a platform) is a **mocap** body, so a
//!   task moves it per episode through `mocap_pos`/`mocap_quat`; a movable one (a carried box)
//!   is a free body with the given mass. Object geoms `condim = 3`, friction 1.
//!
//! Body order (the order of the state read-out): static props (world geoms), the character's
//! bodies, then the objects — the ball first where there is one, then the box objects.

use std::fmt::Write as _;

use skillmimic_core::characters::{CharacterSpec, GeomSpec, JointDef};
use skillmimic_core::math::Quat;

use crate::ball::{BallParams, BodyContact, ball_floor_solref};
pub use crate::scene_options::{
    BoxObject, ObjectBox, Prop, PropKind, RootJoint, SceneOptions, Solver, SolverOptions,
    default_scene, default_scene_file,
};

fn v3(v: [f64; 3]) -> String {
    format!("{} {} {}", v[0], v[1], v[2])
}

fn rgba(c: [f32; 4]) -> String {
    format!("{} {} {} {}", c[0], c[1], c[2], c[3])
}

fn geom_xml(g: &GeomSpec) -> String {
    match *g {
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
        GeomSpec::Box { half_extents, center, quat, density } => {
            let turn = if quat == skillmimic_core::characters::IDENTITY_WXYZ {
                String::new()
            } else {
                format!(" quat=\"{} {} {} {}\"", quat[0], quat[1], quat[2], quat[3])
            };
            format!(
                "type=\"box\" size=\"{}\" pos=\"{}\"{turn} density=\"{density}\"",
                v3(half_extents),
                v3(center)
            )
        }
    }
}

/// The MJCF text of the scene (deterministic: same options → same bytes).
pub fn scene_xml(opts: &SceneOptions) -> String {
    scene_xml_of(&opts.character.spec(), opts)
}

/// [`scene_xml`] for an already built character description.
pub fn scene_xml_of(ch: &CharacterSpec, opts: &SceneOptions) -> String {
    let mut x = String::with_capacity(32 * 1024);
    let ball = if opts.ball.is_some() { " + ball" } else { "" };
    let objects = if opts.objects.is_empty() { "" } else { " + task objects" };
    let _ = writeln!(
        x,
        "<!-- {}{ball}{objects}, generated by skillmimic-rs (skillmimic mjcf). Do not edit by \
            hand. -->",
        ch.title
    );
    let _ = writeln!(x, "<mujoco model=\"{}\">", ch.model_name);
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
    let _ =
        writeln!(x, "  <option timestep=\"{}\" integrator=\"implicitfast\"{solver}/>", ch.timestep);
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
        "    <texture name=\"sky\" type=\"skybox\" builtin=\"gradient\" rgb1=\"0.45 0.55 0.65\" \
            rgb2=\"0.05 0.05 0.1\" width=\"256\" height=\"256\"/>\n",
        "    <texture name=\"grid\" type=\"2d\" builtin=\"checker\" rgb1=\"0.22 0.24 0.26\" \
            rgb2=\"0.3 0.32 0.34\" width=\"512\" height=\"512\"/>\n",
        "    <material name=\"grid\" texture=\"grid\" texrepeat=\"8 8\" texuniform=\"true\" \
            reflectance=\"0\"/>\n",
    ));
    let _ = writeln!(x, "    <material name=\"body\" rgba=\"{}\"/>", rgba(ch.rgba));
    if let Some(h) = ch.hand_rgba {
        let _ = writeln!(x, "    <material name=\"hand\" rgba=\"{}\"/>", rgba(h));
    }
    if opts.ball.is_some() {
        let _ = writeln!(x, "    <material name=\"ball\" rgba=\"0.9 0.45 0.1 1\"/>");
    }
    x.push_str(concat!(
        "  </asset>\n",
        "  <worldbody>\n",
        "    <light name=\"sun\" directional=\"true\" pos=\"0 0 5\" dir=\"-0.3 0.2 -1\" \
            diffuse=\"0.35 0.35 0.35\" castshadow=\"false\"/>\n",
        "    <light name=\"key\" mode=\"trackcom\" pos=\"1.8 -1.2 6\" dir=\"-0.3 0.2 -1\" \
            cutoff=\"70\" exponent=\"1\" diffuse=\"0.4 0.4 0.4\" castshadow=\"true\" \
            bulbradius=\"0\"/>\n",
        "    <geom name=\"floor\" type=\"plane\" size=\"0 0 0.05\" condim=\"3\" friction=\"1 \
            0.005 0.0001\" material=\"grid\"/>\n",
        "    <camera name=\"side\" mode=\"trackcom\" pos=\"0 -5.5 1.7\" xyaxes=\"1 0 0 0 0.09 \
            0.996\"/>\n",
    ));
    write_props(&mut x, opts);
    write_character(&mut x, ch, opts.root);
    if let Some(b) = &opts.ball {
        write_ball(&mut x, b);
    }
    write_objects(&mut x, &opts.objects);
    let _ = writeln!(x, "  </worldbody>");
    if !ch.excludes.is_empty() || opts.ball.is_some() {
        let _ = writeln!(x, "  <contact>");
        for (a, b) in &ch.excludes {
            let _ = writeln!(x, "    <exclude body1=\"{a}\" body2=\"{b}\"/>");
        }
        if let Some(ball) = &opts.ball {
            let [k, b] = ball_floor_solref(ball.floor_restitution());
            let _ = writeln!(x, "    <exclude body1=\"world\" body2=\"Ball\"/>");
            let _ = writeln!(
                x,
                "    <pair name=\"ball_floor\" geom1=\"floor\" geom2=\"ball\" condim=\"3\" \
                    friction=\"{f} {f} 0.005 0.0001 0.0001\" solref=\"{k} {b}\"/>",
                f = ball.friction
            );
        }
        let _ = writeln!(x, "  </contact>");
    }
    write_actuators(&mut x, ch);
    let _ = writeln!(x, "</mujoco>");
    x
}

fn write_props(x: &mut String, opts: &SceneOptions) {
    for p in &opts.props {
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
            "    <geom name=\"{}\" {shape} pos=\"{px} {py} {pz}\" rgba=\"{}\"/>",
            p.name,
            rgba(p.rgba)
        );
    }
}

/// The character's bodies, depth first, with joints and geoms.
fn write_character(x: &mut String, ch: &CharacterSpec, root: RootJoint) {
    let (root_pos, root_quat) = match root {
        RootJoint::Free => (ch.root_pos, ch.root_quat),
        RootJoint::Fixed { pos, quat } => (pos, quat),
    };
    let mut open: Vec<usize> = Vec::new();
    for (i, b) in ch.bodies.iter().enumerate() {
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
            let quat = if root_quat == Quat::IDENTITY {
                String::new()
            } else {
                let q = root_quat.to_wxyz();
                format!(" quat=\"{} {} {} {}\"", q[0], q[1], q[2], q[3])
            };
            let _ = writeln!(x, "{ind}<body name=\"{}\" pos=\"{}\"{quat}>", b.name, v3(root_pos));
            if root == RootJoint::Free {
                let _ = writeln!(x, "{ind}  <freejoint name=\"root\"/>");
            }
        } else {
            let _ = writeln!(x, "{ind}<body name=\"{}\" pos=\"{}\">", b.name, v3(b.offset));
        }
        match &b.joint {
            JointDef::Ball { name, drive, .. } => {
                let _ = writeln!(
                    x,
                    "{ind}  <joint name=\"{name}\" type=\"ball\" armature=\"{}\" damping=\"{}\"/>",
                    drive.armature, drive.kd
                );
            }
            JointDef::Hinges { hinges, drive } => {
                for h in hinges {
                    let range =
                        h.range.map_or(String::new(), |[lo, hi]| format!(" range=\"{lo} {hi}\""));
                    let _ = writeln!(
                        x,
                        "{ind}  <joint name=\"{}\" type=\"hinge\" axis=\"{}\"{range} \
                            armature=\"{}\" damping=\"{}\"/>",
                        h.name,
                        v3(h.axis),
                        drive.armature,
                        drive.kd
                    );
                }
            }
            JointDef::Free | JointDef::Welded => {}
        }
        for g in &b.geoms {
            let material = g.material.map_or(String::new(), |m| format!(" material=\"{m}\""));
            let _ =
                writeln!(x, "{ind}  <geom name=\"{}\" {}{material}/>", g.name, geom_xml(&g.spec));
        }
        open.push(i);
    }
    while open.pop().is_some() {
        let _ = writeln!(x, "{}</body>", "  ".repeat(open.len() + 2));
    }
}

/// The ball, resting on the floor in front of the character.
fn write_ball(x: &mut String, ball: &BallParams) {
    let start = [0.0, 0.6, ball.radius];
    let _ = writeln!(x, "    <body name=\"Ball\" pos=\"{}\">", v3(start));
    // three world-axis slides + a ball joint = a free joint with separate linear and angular
    // damping; `ref` = the body position makes each slide's qpos the absolute coordinate
    let lin = ball.damping * ball.mass();
    let ang = ball.damping * 0.4 * ball.mass() * ball.radius * ball.radius;
    for (k, (axis, dir)) in [("x", "1 0 0"), ("y", "0 1 0"), ("z", "0 0 1")].iter().enumerate() {
        let _ = writeln!(
            x,
            "      <joint name=\"ball_{axis}\" type=\"slide\" axis=\"{dir}\" ref=\"{}\" \
                damping=\"{lin}\"/>",
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
        "      <geom name=\"ball\" type=\"sphere\" size=\"{}\" density=\"{}\" condim=\"3\" \
            friction=\"{} 0.005 0.0001\"{contact} material=\"ball\"/>",
        ball.radius, ball.density, ball.friction
    );
    let _ = writeln!(x, "    </body>");
}

fn write_objects(x: &mut String, objects: &[BoxObject]) {
    for (k, o) in objects.iter().enumerate() {
        // objects start parked away from the character; tasks place them per episode
        let park = [5.0 + 3.0 * k as f64, 5.0, 1.0];
        match o.mass {
            None => {
                let _ = writeln!(
                    x,
                    "    <body name=\"{}\" mocap=\"true\" pos=\"{}\">",
                    o.name,
                    v3(park)
                );
            }
            Some(_) => {
                let _ = writeln!(x, "    <body name=\"{}\" pos=\"{}\">", o.name, v3(park));
                let _ = writeln!(x, "      <freejoint name=\"{}\"/>", o.name);
            }
        }
        let volume: f64 = o.boxes.iter().map(|bx| 8.0 * bx.half[0] * bx.half[1] * bx.half[2]).sum();
        for (j, bx) in o.boxes.iter().enumerate() {
            let mass = o
                .mass
                .map(|m| {
                    format!(" mass=\"{}\"", m * 8.0 * bx.half[0] * bx.half[1] * bx.half[2] / volume)
                })
                .unwrap_or_default();
            let _ = writeln!(
                x,
                "      <geom name=\"{}_{j}\" type=\"box\" size=\"{}\" pos=\"{}\" condim=\"3\" \
                    friction=\"1 0.005 0.0001\" rgba=\"{}\"{mass}/>",
                o.name,
                v3(bx.half),
                v3(bx.center),
                rgba(o.rgba)
            );
        }
        let _ = writeln!(x, "    </body>");
    }
}

/// One force-limited position actuator per driven dof, in body order (ball joints x, y, z).
fn write_actuators(x: &mut String, ch: &CharacterSpec) {
    let _ = writeln!(x, "  <actuator>");
    for b in &ch.bodies {
        let (names, drive): (Vec<(String, &str, Option<&str>)>, _) = match &b.joint {
            JointDef::Ball { name, drive, .. } => (
                [("x", "1 0 0"), ("y", "0 1 0"), ("z", "0 0 1")]
                    .iter()
                    .map(|(axis, gear)| (format!("{name}_{axis}"), name.as_str(), Some(*gear)))
                    .collect(),
                drive,
            ),
            JointDef::Hinges { hinges, drive } => {
                (hinges.iter().map(|h| (h.name.clone(), h.name.as_str(), None)).collect(), drive)
            }
            JointDef::Free | JointDef::Welded => continue,
        };
        for (name, joint, gear) in names {
            let gear = gear.map_or(String::new(), |g| format!(" gear=\"{g}\""));
            let _ = writeln!(
                x,
                "    <position name=\"{name}\" joint=\"{joint}\"{gear} kp=\"{}\" ctrlrange=\"{} \
                    {}\" forcerange=\"{} {}\"/>",
                drive.kp, drive.ctrlrange[0], drive.ctrlrange[1], -drive.effort, drive.effort
            );
        }
    }
    let _ = writeln!(x, "  </actuator>");
}

#[cfg(test)]
mod tests {
    use super::*;
    use skillmimic_core::characters::{HandModel, skillmimic, smpl, tokenhsi};

    #[test]
    fn xml_is_deterministic_and_counts_actuators() {
        let a = scene_xml(&SceneOptions::default());
        assert_eq!(a, scene_xml(&SceneOptions::default()));
        assert_eq!(a.matches("<position ").count(), 156);
        // 52 skeleton joints + the ball's rotation joint (plus its three slides)
        assert_eq!(a.matches("type=\"ball\"").count(), 53);
        assert_eq!(a.matches("type=\"slide\"").count(), 3);
        let boxed = scene_xml(&SceneOptions {
            character: skillmimic::humanoid(HandModel::Box),
            ..Default::default()
        });
        assert_eq!(boxed.matches("<position ").count(), 66);
        assert_eq!(boxed.matches("type=\"ball\"").count(), 23);
        let hsi = scene_xml(&SceneOptions::bare(tokenhsi::CHARACTER));
        // ten 3-DoF joints as three limited hinges each, plus the elbows
        assert_eq!(hsi.matches("type=\"ball\"").count(), 0);
        assert_eq!(hsi.matches("type=\"hinge\"").count(), 32);
        assert_eq!(hsi.matches(" range=\"").count(), 32);
        assert_eq!(hsi.matches("<position ").count(), 32);
        let smpl = scene_xml(&SceneOptions::bare(smpl::CHARACTER));
        assert_eq!(smpl.matches("type=\"hinge\"").count(), 69);
        assert_eq!(smpl.matches("<position ").count(), 69);
        assert_eq!(smpl.matches("<exclude ").count(), 10);
    }
}
