//! The MJCF files shipped in `mjcf/` are exactly the generator's output for every character's
//! plain scene (regenerate with `skillmimic mjcf`), and they compile to the expected model sizes
//! and masses.

use skillmimic_core::shared_data::workspace_root;
use skillmimic_sim::mjcf::{default_scene, default_scene_file, scene_xml};
use skillmimic_sim::{BALL, Character, HandModel, Scene};

#[test]
fn shipped_files_equal_the_generator_output() {
    for c in Character::variants() {
        let path = workspace_root().join("mjcf").join(default_scene_file(c));
        let shipped =
            std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        let generated = scene_xml(&default_scene(c));
        assert!(shipped == generated, "{} is stale: run `skillmimic mjcf`", path.display());
    }
}

#[test]
fn compiled_model_has_the_reference_sizes_and_masses() {
    let full = Scene::default_for(HandModel::Full).unwrap();
    assert_eq!(full.sizes(), (7 + 52 * 4 + 7, 6 + 52 * 3 + 6, 156));
    let m = full.model();
    let total: f64 = full.body_ids[..53].iter().map(|&id| m.body_mass()[id]).sum();
    let ball = m.body_mass()[full.body_ids[BALL]];
    println!("humanoid mass {total:.3} kg, ball mass {ball:.3} kg");
    assert!((total - 66.59).abs() < 0.01, "humanoid mass {total}");
    assert!((ball - 1000.0 * 4.0 / 3.0 * std::f64::consts::PI * 0.12f64.powi(3)).abs() < 1e-9);
    assert!((m.opt().timestep - 1.0 / 120.0).abs() < 1e-18);
    let boxed = Scene::default_for(HandModel::Box).unwrap();
    assert_eq!(boxed.sizes(), (7 + 22 * 4 + 7, 6 + 22 * 3 + 6, 66));
    // every actuated skeleton dof maps to one actuator
    assert_eq!((0..156).filter(|&k| boxed.action_is_actuated(k)).count(), 66);
}
