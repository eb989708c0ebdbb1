//! The minibatch a PPO update reads and the loss statistics it returns (shared by the canonical
//! loss and its fast specialisation).

/// One minibatch (row-major arrays, `n` samples).
#[derive(Clone, Copy, Debug)]
pub struct Minibatch<'a> {
    pub n: usize,
    /// `n × obs_dim`, already normalised.
    pub obs_n: &'a [f32],
    /// `n × act_dim` sampled actions.
    pub actions: &'a [f32],
    pub old_neglogp: &'a [f32],
    /// Normalised advantages.
    pub advantages: &'a [f32],
    /// Returns in normalised value space.
    pub returns_n: &'a [f32],
}

/// Loss values and diagnostics of one minibatch.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct LossStats {
    pub actor: f64,
    pub critic: f64,
    /// Bounds loss (Gaussian family; 0 otherwise), unweighted.
    pub bounds: f64,
    /// Mean entropy (families that compute it; 0 otherwise).
    pub entropy: f64,
    pub total: f64,
    /// Fraction of samples whose ratio left [1−ε, 1+ε].
    pub clip_frac: f64,
    /// mean(neglogp_new − neglogp_old).
    pub approx_kl: f64,
}

/// A minibatch of raw (unnormalised) observations.
#[derive(Clone, Copy, Debug)]
pub struct RawMinibatch<'a> {
    pub n: usize,
    pub obs: &'a [f32],
    pub actions: &'a [f32],
    pub old_neglogp: &'a [f32],
    pub advantages: &'a [f32],
    pub returns_n: &'a [f32],
}
