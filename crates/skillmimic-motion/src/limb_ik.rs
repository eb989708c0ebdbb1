//! Light IK for retargeting (issue 23, `skillmimic retarget --ik`): after the rotations are
//! transferred, each leg (hip → knee → ankle) and arm (shoulder → elbow → wrist) is bent so that
//! its end body reaches a target, the source's ankle or wrist position × scale.
//!
//! Frame: the humanoid skeleton's Y-up frame (metres, no rest rotations; the same frame as the
//! global rotations `G(b)` of [`crate::retarget_bvh`]). Why the target is the source position ×
//! scale: the root is placed at the source root × scale, so a foot the source plants stays planted
//! and a hand on the ball (whose track is scaled the same way) stays on it, whatever the limb
//! proportions; rotations alone move an end body by the difference of the bone lengths.
//!
//! Per limb, analytic two-bone IK:
//! 1. the middle joint turns about the limb's plane normal (or, for a straight limb, about its
//!    flexion axis: knee +x, left elbow −y, right elbow +y in the middle body's frame) until the
//!    root-to-end distance equals the clamped target distance (law of cosines; clamped to
//!    [|l₁ − l₂| + 1 mm, l₁ + l₂ − 1 mm] so the chain never locks straight);
//! 2. the upper body turns by the smallest rotation taking the root-to-end direction onto the
//!    root-to-target direction.
//!
//! The end body keeps its global rotation (a foot keeps the source's foot orientation) and so do
//! its descendants (toes, fingers). Only limbs whose three bodies are all mapped take part.
//!
//! Before the limbs, the root moves so that the midpoint of the humanoid's hips lands on the
//! midpoint of the source's hips × scale (when both hips are mapped): skeletons place their hips
//! differently below the pelvis (the humanoid's sit 3.7 cm below its pelvis, SMPL's 9.1 cm ×
//! scale), and without the shift a standing source's ankles would lie beyond the humanoid's
//! straight legs. The body's shape is unchanged by the shift; only its position is.

use skillmimic_core::characters::skillmimic::{self as skeleton, BODIES, NUM_BODIES};
use skillmimic_core::math::{Quat, Vec3, add, cross, dot, norm, scale, sub};

/// The IK chains: upper, middle and end body, and the middle body's flexion axis (body frame).
pub const LIMBS: [([&str; 3], Vec3); 4] = [
    (["L_Hip", "L_Knee", "L_Ankle"], [1.0, 0.0, 0.0]),
    (["R_Hip", "R_Knee", "R_Ankle"], [1.0, 0.0, 0.0]),
    (["L_Shoulder", "L_Elbow", "L_Wrist"], [0.0, -1.0, 0.0]),
    (["R_Shoulder", "R_Elbow", "R_Wrist"], [0.0, 1.0, 0.0]),
];

/// Position of body `b` (Y-up skeleton frame) from the root position and global rotations: the
/// walk up its chain (the IK needs a handful of bodies, not the whole skeleton).
pub fn position_of(root: Vec3, g: &[Quat; NUM_BODIES], b: usize) -> Vec3 {
    // root first, as forward kinematics sums (the chains are at most 8 deep)
    match BODIES[b].parent {
        Some(pa) => add(position_of(root, g, pa), g[pa].rotate(BODIES[b].offset)),
        None => root,
    }
}

/// Bend one chain `[a, b, c]` so that body `c` reaches `target` (see the module docs); returns the
/// distance left (m, > 0 when the target is out of reach). A limb that is straight, nearly straight
/// (interior angle within 11.5° of 180°) or bent the wrong way first turns about its flexion axis;
/// the pass repeats (at most 4 times) until the target is met to 1 nm or no longer approached.
pub fn two_bone(
    g: &mut [Quat; NUM_BODIES],
    root: Vec3,
    chain: [usize; 3],
    flex_axis: Vec3,
    target: Vec3,
) -> f64 {
    let mut r = f64::INFINITY;
    for _ in 0..4 {
        let next = two_bone_pass(g, root, chain, flex_axis, target);
        let done = next < 1e-9 || next > r - 1e-9;
        r = next;
        if done {
            break;
        }
    }
    r
}

fn two_bone_pass(
    g: &mut [Quat; NUM_BODIES],
    root: Vec3,
    chain: [usize; 3],
    flex_axis: Vec3,
    target: Vec3,
) -> f64 {
    let [a, b, c] = chain;
    let pa = position_of(root, g, a);
    let pb = add(pa, g[a].rotate(BODIES[b].offset));
    let pc = add(pb, g[b].rotate(BODIES[c].offset));
    let (l1, l2) = (norm(BODIES[b].offset), norm(BODIES[c].offset));
    let d = norm(sub(target, pa)).clamp((l1 - l2).abs() + 1e-3, l1 + l2 - 1e-3);
    // 1. the middle joint: interior angle at b from the law of cosines, turned about the plane
    //    normal u1 × u2 (turning u2 about it by a positive angle opens the limb)
    let (u1, u2) = (sub(pa, pb), sub(pc, pb));
    let theta = (dot(u1, u2) / (norm(u1) * norm(u2))).clamp(-1.0, 1.0).acos();
    let want = ((l1 * l1 + l2 * l2 - d * d) / (2.0 * l1 * l2)).clamp(-1.0, 1.0).acos();
    let n = cross(u1, u2);
    let flex = g[b].rotate(flex_axis); // turning about it flexes the limb
    let bend = if norm(n) > 0.2 * norm(u1) * norm(u2) && dot(n, flex) < 0.0 {
        Quat::from_axis_angle(scale(n, 1.0 / norm(n)), want - theta)
    } else {
        // signed flexion now (negative: bent the wrong way) → the flexion wanted, about the axis
        let now = if dot(n, flex) < 0.0 {
            std::f64::consts::PI - theta
        } else {
            theta - std::f64::consts::PI
        };
        Quat::from_axis_angle(scale(flex, 1.0 / norm(flex)), (std::f64::consts::PI - want) - now)
    };
    g[b] = bend.mul(g[b]).normalized();
    // 2. the upper joint: swing the chain onto the target direction
    let pc = add(pb, g[b].rotate(BODIES[c].offset));
    let r = Quat::between(sub(pc, pa), sub(target, pa));
    g[a] = r.mul(g[a]).normalized();
    g[b] = r.mul(g[b]).normalized();
    let end = add(pa, r.rotate(sub(pc, pa)));
    norm(sub(end, target))
}

/// The chains of one retargeting run (those whose bodies are all mapped) and the residual
/// statistics over the frames solved.
#[derive(Clone, Debug, Default)]
pub struct Limbs {
    /// (chain bodies, flexion axis, the end body's source joint).
    chains: Vec<([usize; 3], Vec3, usize)>,
    /// Hip bodies and their source joints, when both are mapped (root placement).
    hips: Option<([usize; 2], [usize; 2])>,
    /// Per kind (0 legs, 1 arms): largest residual, residual sum, chains solved.
    stats: [(f64, f64, usize); 2],
}

/// Distances (m) left between the IK end bodies and their targets over the source frames: non-zero
/// only where a target lies beyond the straight limb (zeros without IK).
#[derive(Clone, Copy, Debug, Default, serde::Serialize)]
pub struct IkResiduals {
    pub feet_mean_m: f64,
    pub feet_max_m: f64,
    pub hands_mean_m: f64,
    pub hands_max_m: f64,
}

impl Limbs {
    /// The limbs whose three bodies are mapped (`src`: body → source joint).
    pub fn new(src: &[Option<usize>; NUM_BODIES]) -> Self {
        let chains = LIMBS
            .iter()
            .filter_map(|(names, axis)| {
                let chain = names.map(|n| skeleton::body_index(n).expect("limb bodies exist"));
                chain
                    .iter()
                    .all(|&b| src[b].is_some())
                    .then(|| (chain, *axis, src[chain[2]].expect("mapped")))
            })
            .collect();
        let hip = |n: &str| skeleton::body_index(n).expect("hip bodies exist");
        let (l, r) = (hip("L_Hip"), hip("R_Hip"));
        let hips = src[l].zip(src[r]).map(|(jl, jr)| ([l, r], [jl, jr]));
        Self { chains, hips, ..Self::default() }
    }

    /// Solve one frame: move the root so the hips' midpoint meets the source's (module docs), then
    /// bend every chain; `target(j)`: the target position of source joint `j` (Y-up skeleton frame,
    /// metres). Returns the root position used.
    pub fn solve(
        &mut self,
        g: &mut [Quat; NUM_BODIES],
        root: Vec3,
        target: impl Fn(usize) -> Vec3,
    ) -> Vec3 {
        let root = match self.hips {
            Some(([l, r], [jl, jr])) => {
                let mid = scale(add(position_of(root, g, l), position_of(root, g, r)), 0.5);
                let want = scale(add(target(jl), target(jr)), 0.5);
                add(root, sub(want, mid))
            }
            None => root,
        };
        for &(chain, axis, j) in &self.chains {
            let r = two_bone(g, root, chain, axis, target(j));
            let kind = &mut self.stats[(BODIES[chain[2]].name.ends_with("Wrist")) as usize];
            *kind = (kind.0.max(r), kind.1 + r, kind.2 + 1);
        }
        root
    }

    /// Mean and largest distance left (m) per kind over the chains solved; zeros where none was.
    pub fn residuals(&self) -> IkResiduals {
        let mean = |(_, sum, n): (f64, f64, usize)| if n == 0 { 0.0 } else { sum / n as f64 };
        IkResiduals {
            feet_mean_m: mean(self.stats[0]),
            feet_max_m: self.stats[0].0,
            hands_mean_m: mean(self.stats[1]),
            hands_max_m: self.stats[1].0,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A reachable target is met to 1e-9 m with the end body's rotation and the rest of the
    /// skeleton untouched; an unreachable one leaves the straight-limb distance.
    #[test]
    fn reaches_targets_and_keeps_the_end_rotation() {
        let mut g = [Quat::IDENTITY; NUM_BODIES];
        let idx = |n: &str| skeleton::body_index(n).unwrap();
        let (hip, knee, ankle) = (idx("L_Hip"), idx("L_Knee"), idx("L_Ankle"));
        g[idx("L_Toe")] = Quat::from_axis_angle([0.0, 1.0, 0.0], 0.3);
        g[ankle] = Quat::from_axis_angle([1.0, 0.0, 0.0], 0.2);
        let before = g;
        let root = [0.1, 0.9, -0.2];
        let positions = |g: &[Quat; NUM_BODIES]| -> [Vec3; NUM_BODIES] {
            std::array::from_fn(|b| position_of(root, g, b))
        };
        let p0 = positions(&g);
        // a target 10 cm up and 5 cm forward of the straight rest leg's ankle: the knee must bend
        let target = add(p0[ankle], [0.0, 0.1, 0.05]);
        let r = two_bone(&mut g, root, [hip, knee, ankle], [1.0, 0.0, 0.0], target);
        let p = positions(&g);
        assert!(r < 1e-9 && norm(sub(p[ankle], target)) < 1e-9, "residual {r}");
        assert_eq!(g[ankle], before[ankle]);
        assert_eq!(g[idx("L_Toe")], before[idx("L_Toe")]);
        assert_eq!(g[idx("R_Knee")], before[idx("R_Knee")]);
        assert!(norm(sub(p[hip], p0[hip])) == 0.0);
        // the straight leg bent forward at the knee's flexion axis, i.e. the shin turned backwards
        let shin = sub(p[ankle], p[knee]);
        let thigh = sub(p[knee], p[hip]);
        assert!(
            cross(thigh, shin)[0] > 0.0,
            "knee bent the wrong way: thigh {thigh:?}, shin {shin:?}"
        );
        // out of reach: 2 m below the hip
        let far = add(p0[hip], [0.0, -2.0, 0.0]);
        let r = two_bone(&mut g, root, [hip, knee, ankle], [1.0, 0.0, 0.0], far);
        let reach = norm(BODIES[knee].offset) + norm(BODIES[ankle].offset);
        assert!((r - (2.0 - reach + 1e-3)).abs() < 1e-6, "residual {r}, reach {reach}");
    }
}
