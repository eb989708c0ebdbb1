//! Reading the golden fixtures of the released TokenHSI code (`tests/fixtures/tokenhsi_*_golden.json`)
//! into this project's state types.

#![allow(dead_code)]

use serde_json::Value;
use skillmimic_core::shared_data::workspace_root;
use skillmimic_sim::EnvState;

pub const TOL: f64 = 1e-5;

pub fn fixture(name: &str) -> Value {
    let path = workspace_root().join("tests/fixtures").join(name);
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    serde_json::from_str(&text).expect("fixture JSON")
}

pub fn floats(v: &Value) -> Vec<f64> {
    match v {
        Value::Array(a) => a.iter().flat_map(floats).collect(),
        Value::Number(n) => vec![n.as_f64().expect("a number")],
        Value::Bool(b) => vec![f64::from(u8::from(*b))],
        other => panic!("not a number: {other}"),
    }
}

pub fn vec3(v: &Value) -> [f64; 3] {
    let f = floats(v);
    assert_eq!(f.len(), 3, "a 3-vector: {v}");
    [f[0], f[1], f[2]]
}

pub fn flag(v: &Value) -> bool {
    match v {
        Value::Bool(b) => *b,
        other => other.as_u64().expect("a 0/1 flag") != 0,
    }
}

/// Compare float64 values to [`TOL`], recording the largest difference.
pub fn check(what: &str, state: usize, ours: &[f64], theirs: &[f64], worst: &mut f64) {
    assert_eq!(ours.len(), theirs.len(), "{what} width, state {state}");
    for (k, (a, b)) in ours.iter().zip(theirs).enumerate() {
        let d = (a - b).abs();
        assert!(d <= TOL, "{what}[{k}] of state {state}: ours {a} vs released {b}");
        *worst = worst.max(d);
    }
}

/// Compare a float32 observation: to [`TOL`] or float32 resolution of the value's magnitude.
pub fn check_f32(what: &str, state: usize, ours: &[f32], theirs: &[f64]) {
    assert_eq!(ours.len(), theirs.len(), "{what} width, state {state}");
    for (k, (a, b)) in ours.iter().zip(theirs).enumerate() {
        let (a, tol) = (f64::from(*a), TOL.max(2e-7 * b.abs()));
        assert!((a - b).abs() <= tol, "{what}[{k}] state {state}: ours {a} vs released {b}");
    }
}

/// The arrays one state's [`EnvState`] borrows: the character's 15 bodies, then any extra bodies
/// (objects).
pub struct Arrays {
    pub pos: Vec<f64>,
    pub quat: Vec<f64>,
    pub vel: Vec<f64>,
    pub angvel: Vec<f64>,
    pub force: Vec<f64>,
    pub dof_pos: Vec<f64>,
    pub dof_vel: Vec<f64>,
    pub dof_force: Vec<f64>,
    pairs: Vec<u8>,
    touch: Vec<u8>,
}

/// Isaac Gym's x, y, z, w → w, x, y, z.
pub fn wxyz(xyzw: &[f64]) -> Vec<f64> {
    xyzw.chunks(4).flat_map(|q| [q[3], q[0], q[1], q[2]]).collect()
}

impl Arrays {
    /// The character of a fixture state (`body_pos`, `body_rot` x y z w, …).
    pub fn of(s: &Value) -> Self {
        Self {
            pos: floats(&s["body_pos"]),
            quat: wxyz(&floats(&s["body_rot"])),
            vel: floats(&s["body_vel"]),
            angvel: floats(&s["body_ang_vel"]),
            force: floats(&s["contact_force"]),
            dof_pos: floats(&s["dof_pos"]),
            dof_vel: floats(&s["dof_vel"]),
            dof_force: floats(&s["dof_force"]),
            pairs: vec![0; 7],
            touch: vec![0; 16],
        }
    }
    /// Append a body (an object) at `pos` (world), `quat_xyzw`, with velocities, no contact.
    pub fn push_body(&mut self, pos: [f64; 3], quat_xyzw: &[f64], vel: [f64; 3], angvel: [f64; 3]) {
        self.pos.extend(pos);
        self.quat.extend(wxyz(quat_xyzw));
        self.vel.extend(vel);
        self.angvel.extend(angvel);
        self.force.extend([0.0; 3]);
    }
    pub fn state(&self) -> EnvState<'_> {
        EnvState {
            body_pos: &self.pos,
            body_quat: &self.quat,
            body_linvel: &self.vel,
            body_angvel: &self.angvel,
            dof_pos: &self.dof_pos,
            dof_vel: &self.dof_vel,
            dof_force: &self.dof_force,
            contact_force: &self.force,
            contact_pairs: &self.pairs,
            touch: &self.touch,
            unstable: false,
        }
    }
}
