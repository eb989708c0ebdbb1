//! `skillmimic demo`: a short run of the batched simulation core.
//!
//! The humanoid starts upright in its zero pose with the ball in front and holds that pose with
//! small random PD targets; the demo reports throughput, how many environments are still upright
//! and the contact pairs seen. It exercises the scene, the PD drives, sub-stepping, resets and the
//! state read-out without any learned policy.

use std::sync::Arc;
use std::time::Instant;

use rand::{Rng, SeedableRng};
use skillmimic_core::characters::skillmimic::NUM_DOFS;
use skillmimic_sim::{BatchSim, ContactPair, HandModel, ResetState, Scene};

#[derive(clap::Args)]
pub struct Args {
    /// Environments.
    #[arg(long, default_value_t = 16)]
    pub envs: usize,
    /// Policy steps (60 Hz).
    #[arg(long, default_value_t = 300)]
    pub steps: usize,
    /// Worker threads (0 = one per core).
    #[arg(long, default_value_t = 0)]
    pub threads: usize,
    /// Hand model: full or box.
    #[arg(long, default_value = "full")]
    pub hands: String,
}

pub fn run(a: Args) -> anyhow::Result<()> {
    let hands: HandModel = crate::cmd_trace::parse_hands(&a.hands)?;
    let scene = Arc::new(Scene::default_for(hands)?);
    let mut sim = BatchSim::new(scene, a.envs, a.threads)?;
    tracing::info!(
        "{} environments, {} threads, {} hands",
        a.envs,
        sim.num_threads(),
        hands.name()
    );
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(0);
    let mut actions = vec![0.0f32; a.envs * NUM_DOFS];
    let mut seen = [0usize; 7];
    let (mut falls, init) = (0usize, vec![ResetState::default(); a.envs]);
    let t = Instant::now();
    for _ in 0..a.steps {
        actions.iter_mut().for_each(|x| *x = 0.05 * rng.random_range(-1.0f32..=1.0));
        sim.step(&actions)?;
        let mut mask = vec![false; a.envs];
        for (i, m) in mask.iter_mut().enumerate() {
            let st = sim.state().env(i);
            for (k, s) in seen.iter_mut().enumerate() {
                *s += st.contact_pairs[k] as usize;
            }
            if st.pos(0)[2] < 0.3 || st.unstable {
                *m = true;
                falls += 1;
            }
        }
        sim.reset(&mask, &init)?;
    }
    let secs = t.elapsed().as_secs_f64();
    println!(
        "simulated {} env-steps ({:.1} s of motion each) in {secs:.2} s: {:.0} policy steps/s; \
            {falls} falls (pelvis below 0.3 m) reset",
        a.envs * a.steps,
        a.steps as f64 / 60.0,
        (a.envs * a.steps) as f64 / secs
    );
    for (k, p) in ContactPair::ALL.iter().enumerate() {
        println!("  contact {:<11} in {:>6} env-steps", p.name(), seen[k]);
    }
    Ok(())
}
