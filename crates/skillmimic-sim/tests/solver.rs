//! The constraint-solver option reaches the compiled model, and the default leaves the shipped
//! MJCF text unchanged.

use skillmimic_sim::mjcf::scene_xml;
use skillmimic_sim::{Scene, SceneOptions, Solver, SolverOptions};

#[test]
fn solver_options_reach_the_compiled_model() {
    let default = scene_xml(&SceneOptions::default());
    assert!(
        !default.contains("solver="),
        "the default scene keeps MuJoCo's default solver implicitly"
    );
    // MuJoCo's mjtSolver: PGS 0, CG 1, Newton 2
    for (solver, code, iterations, tolerance) in
        [(Solver::Pgs, 0, 20, 1e-6), (Solver::Cg, 1, 50, 1e-7), (Solver::Newton, 2, 7, 1e-5)]
    {
        let opts = SceneOptions {
            solver: SolverOptions { solver, iterations, tolerance },
            ..Default::default()
        };
        let scene = Scene::new(opts).unwrap();
        let o = &scene.model().ffi().opt;
        assert_eq!(
            (o.solver, o.iterations as usize, o.tolerance),
            (code, iterations, tolerance),
            "{solver:?}"
        );
    }
    let newton = Scene::new(SceneOptions::default()).unwrap();
    let o = &newton.model().ffi().opt;
    assert_eq!((o.solver, o.iterations, o.tolerance), (2, 100, 1e-8));
}
