//! Every character on the one stack: its plain scene compiles with the model sizes its table
//! gives, it stands in its rest pose under PD control (zero actions hold every joint at 0) for
//! two seconds, and the simulation read-out is the character's forward kinematics.

use std::sync::Arc;

use skillmimic_sim::mjcf::default_scene;
use skillmimic_sim::{BatchSim, Character, ResetState, Scene};

#[test]
fn every_character_stands_under_pd_control_in_its_rest_pose() {
    for c in Character::variants() {
        let scene = Arc::new(Scene::new(default_scene(c)).unwrap());
        let spec = scene.character().clone();
        let (_, nv, nu) = scene.sizes();
        let driven: usize = spec.bodies.iter().map(|b| b.joint.dofs()).sum();
        assert_eq!(nu, driven, "{}: one actuator per driven dof", c.name());
        assert_eq!(nv, 6 + driven + 6 * scene.objects.len(), "{}", c.name());
        let mut sim = BatchSim::new(scene.clone(), 2, 1).unwrap();
        let rest = ResetState::rest(&scene);
        sim.reset(&[true, true], &[rest.clone(), rest.clone()]).unwrap();
        // the read-out at rest is the character's forward kinematics
        let (pos, _) = spec.forward_kinematics(rest.root_pos, rest.root_quat, &rest.dof_pos);
        for (b, p) in pos.iter().enumerate() {
            let q = sim.state().env(0).pos(b);
            assert!(
                (0..3).all(|k| (p[k] - q[k]).abs() < 1e-12),
                "{} body {b}: {p:?} vs {q:?}",
                c.name()
            );
        }
        let zero = vec![0.0f32; 2 * spec.num_dofs];
        let steps = (2.0 / (spec.timestep * spec.substeps as f64)).round() as usize;
        let mut lowest = f64::INFINITY;
        for _ in 0..steps {
            sim.step(&zero).unwrap();
            let st = sim.state().env(0);
            assert!(!st.unstable, "{}", c.name());
            lowest = lowest.min(st.pos(0)[2]);
        }
        let z0 = rest.root_pos[2];
        println!(
            "{}: pelvis {z0:.3} m at rest, lowest {lowest:.3} m over 2 s of zero actions",
            c.name()
        );
        assert!(lowest > 0.9 * z0, "{} fell: pelvis down to {lowest} m from {z0} m", c.name());
    }
}
