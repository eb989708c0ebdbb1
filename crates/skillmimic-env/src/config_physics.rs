//! Physics solver options (`[env.physics]`): MuJoCo's constraint solver and its iteration
//! budget. The defaults are MuJoCo's (Newton, 100 iterations, tolerance 1e-8), which the shipped
//! scenes and every fidelity measurement use; the others are speed options (issue 21,
//! `skillmimic bench solver` measures their speed and divergence from Newton).

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};
use skillmimic_sim::{Solver, SolverOptions};

/// MuJoCo's constraint solver.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum PhysicsSolver {
    /// Newton (MuJoCo's default).
    #[default]
    Newton,
    /// Projected Gauss–Seidel.
    Pgs,
    /// Conjugate gradient.
    Cg,
}

/// Constraint-solver settings of the scene.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct PhysicsConfig {
    /// Constraint solver.
    pub solver: PhysicsSolver,
    /// Maximum solver iterations per physics step.
    #[schemars(range(min = 1, max = 10000))]
    pub iterations: usize,
    /// Solver tolerance (early termination).
    #[schemars(range(min = 0, max = 1))]
    pub tolerance: f64,
}

impl Default for PhysicsConfig {
    fn default() -> Self {
        let d = SolverOptions::default();
        Self { solver: PhysicsSolver::Newton, iterations: d.iterations, tolerance: d.tolerance }
    }
}

impl PhysicsConfig {
    /// The scene's solver options.
    pub fn solver_options(&self) -> SolverOptions {
        let solver = match self.solver {
            PhysicsSolver::Newton => Solver::Newton,
            PhysicsSolver::Pgs => Solver::Pgs,
            PhysicsSolver::Cg => Solver::Cg,
        };
        SolverOptions { solver, iterations: self.iterations, tolerance: self.tolerance }
    }
}
