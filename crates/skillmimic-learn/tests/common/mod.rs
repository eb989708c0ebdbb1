//! Helpers shared by the learner's integration tests.

use skillmimic_learn::checkpoint::{self, Progress};
use skillmimic_learn::config::PpoConfig;
use skillmimic_learn::policy::Policy;

/// The checkout (the shipped demo clips live in `motions/`).
pub fn workspace_root() -> std::path::PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// A small skill policy checkpoint (observation 902, 156 actions, hidden [32]) for the high-level
/// tasks, written into a temporary folder named by `tag`.
pub fn skill_policy(tag: &str) -> std::path::PathBuf {
    let mut rng = <rand_chacha::ChaCha8Rng as rand::SeedableRng>::seed_from_u64(4);
    let p = Policy::new(902, 156, &PpoConfig { hidden: vec![32], ..Default::default() }, &mut rng);
    let dir = std::env::temp_dir().join(format!("skillmimic-{tag}-llc-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("llc.safetensors");
    checkpoint::save(&path, &p, None, &Progress::default(), "").unwrap();
    path
}

/// The token transformer at test sizes (tokenizer [32], embedding 16, one layer, feed-forward 32,
/// head [32]).
#[allow(dead_code)] // not every test binary builds a token policy
pub fn tiny_token(ppo: &mut PpoConfig) {
    ppo.token.tokenizer = vec![32];
    ppo.token.embed = 16;
    ppo.token.layers = 1;
    ppo.token.feedforward = 32;
    ppo.token.head = vec![32];
}
