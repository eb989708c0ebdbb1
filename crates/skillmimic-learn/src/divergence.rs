//! Divergence detection: training stops with [`LearnError::Diverged`] as soon as it produces
//! values that make the run meaningless, before any of them reaches a checkpoint.
//!
//! The rules, checked by every rank on the same (reduced) values, so all ranks stop together:
//! * every minibatch: the loss terms (actor, critic, bounds, entropy, total) and the global L2
//!   norm of the gradients (before clipping) are finite ([`check_minibatch`]);
//! * after every iteration's update: every trained parameter is finite and at most
//!   [`MAX_ABS_PARAM`] in magnitude, and `log_std`, the Adam moments and the observation / value
//!   normaliser statistics are finite ([`check_state`]).
//!
//! The magnitude bound catches a run that explodes without (yet) overflowing: Adam moves each
//! weight by about `lr` per step whatever the gradient's scale, so a network initialised with
//! weights of order 1 reaches 1e6 only with a learning rate that makes training meaningless
//! (`ppo.lr` = 1e3 gets there within a few iterations; the paper's 2e-5 would need ~5e10 steps).
//!
//! The checkpoint writer refuses non-finite tensors as a last line of defence
//! ([`crate::checkpoint::save_with`]).

use crate::adam::Adam;
use crate::error::LearnError;
use crate::policy::Policy;
use crate::ppo::LossStats;

/// Largest magnitude a trained parameter may reach (see the module documentation).
pub const MAX_ABS_PARAM: f32 = 1e6;

/// The minibatch's loss terms and the global gradient norm (before clipping) are finite;
/// otherwise [`LearnError::Diverged`] saying which.
pub fn check_minibatch(l: &LossStats, grad_norm: f64) -> Result<(), LearnError> {
    let terms = [
        ("actor loss", l.actor),
        ("critic loss", l.critic),
        ("bounds loss", l.bounds),
        ("entropy", l.entropy),
        ("total loss", l.total),
    ];
    if let Some((name, v)) = terms.iter().find(|(_, v)| !v.is_finite()) {
        return Err(LearnError::Diverged(format!("the {name} is {v}")));
    }
    if !grad_norm.is_finite() {
        return Err(LearnError::Diverged(format!("the gradient norm is {grad_norm}")));
    }
    Ok(())
}

/// Index and value of the first entry of `xs` that is non-finite or larger than `max` in
/// magnitude.
fn first_bad<T: Copy + Into<f64>>(xs: &[T], max: f64) -> Option<(usize, f64)> {
    xs.iter().map(|&x| x.into()).enumerate().find(|&(_, x)| !(x.is_finite() && x.abs() <= max))
}

/// The state an iteration's update left: trained parameters finite and within
/// [`MAX_ABS_PARAM`]; `log_std`, the Adam moments and the normalisers finite. The error names
/// the tensor (checkpoint names), the index and the value.
pub fn check_state(policy: &Policy, adam: &Adam) -> Result<(), LearnError> {
    let params: Vec<&[f32]> =
        policy.actor.params().into_iter().chain(policy.critic.params()).collect();
    let names = || -> Vec<String> {
        let mut v: Vec<String> =
            policy.actor.param_names("actor").into_iter().map(|p| p.0).collect();
        v.extend(policy.critic.param_names("critic").into_iter().map(|p| p.0));
        v
    };
    let bad =
        |what: String, (i, v): (usize, f64)| LearnError::Diverged(format!("{what}[{i}] is {v:e}"));
    for (k, p) in params.iter().enumerate() {
        if let Some(b) = first_bad(p, MAX_ABS_PARAM as f64) {
            let what = format!("parameter '{}'", names()[k]);
            return Err(if b.1.is_finite() {
                LearnError::Diverged(format!(
                    "{what}[{}] is {:e}, beyond the bound of {MAX_ABS_PARAM:e} for trained \
                        parameters",
                    b.0, b.1
                ))
            } else {
                bad(what, b)
            });
        }
    }
    for (k, (m, v)) in adam.m.iter().zip(&adam.v).enumerate() {
        for (kind, xs) in [("m", m), ("v", v)] {
            if let Some(b) = first_bad(xs.as_slice(), f64::MAX) {
                return Err(bad(format!("Adam moment 'optim.{kind}.{}'", names()[k]), b));
            }
        }
    }
    if let Some(b) = first_bad(policy.log_std.as_slice(), f64::MAX) {
        return Err(bad("'log_std'".into(), b));
    }
    for (prefix, n) in [("obs_norm", &policy.obs_norm), ("value_norm", &policy.value_norm)] {
        for (field, xs) in [
            ("mean", n.mean.as_slice()),
            ("var", n.var.as_slice()),
            ("count", std::slice::from_ref(&n.count)),
        ] {
            if let Some(b) = first_bad(xs, f64::MAX) {
                return Err(bad(format!("normaliser statistic '{prefix}.{field}'"), b));
            }
        }
    }
    Ok(())
}

/// `e` with the iteration (1-based) it happened in, when it is a divergence.
pub fn in_iteration(e: LearnError, iteration: u64) -> LearnError {
    match e {
        LearnError::Diverged(m) => {
            LearnError::Diverged(format!("training diverged in iteration {iteration}: {m}"))
        }
        other => other,
    }
}

/// `e` with the last good checkpoint of the run (or the absence of one) and what to do, when it
/// is a divergence.
pub fn with_last_good(e: LearnError, last_good: Option<&std::path::Path>) -> LearnError {
    match e {
        LearnError::Diverged(m) => LearnError::Diverged(match last_good {
            Some(p) => format!(
                "{m}; last good checkpoint: {} (lower ppo.lr and resume from it)",
                p.display()
            ),
            None => format!("{m}; no checkpoint of this run was written before it (lower ppo.lr)"),
        }),
        other => other,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::PpoConfig;
    use rand::SeedableRng;

    #[test]
    fn rules_name_what_failed() {
        let mut l = LossStats { critic: f64::NAN, ..Default::default() };
        let e = check_minibatch(&l, 1.0).unwrap_err().to_string();
        assert_eq!(e, "the critic loss is NaN");
        l.critic = 0.5;
        assert!(check_minibatch(&l, 1.0).is_ok());
        assert_eq!(
            check_minibatch(&l, f64::INFINITY).unwrap_err().to_string(),
            "the gradient norm is inf"
        );

        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(0);
        let mut p =
            Policy::new(6, 2, &PpoConfig { hidden: vec![4], ..Default::default() }, &mut rng);
        let sizes: Vec<usize> =
            p.actor.params().iter().chain(p.critic.params().iter()).map(|x| x.len()).collect();
        let mut adam = Adam::new(&sizes, 1e-3, 1e-8);
        assert!(check_state(&p, &adam).is_ok());
        p.critic.params_mut()[1][0] = 2e6;
        let e = check_state(&p, &adam).unwrap_err().to_string();
        assert!(e.contains("'critic.0.bias'[0]") && e.contains("beyond the bound"), "{e}");
        p.critic.params_mut()[1][0] = 0.0;
        adam.v[0][3] = f32::INFINITY;
        let e = check_state(&p, &adam).unwrap_err().to_string();
        assert_eq!(e, "Adam moment 'optim.v.actor.0.weight'[3] is inf");
        adam.v[0][3] = 0.0;
        p.value_norm.var[0] = f64::NAN;
        assert!(
            check_state(&p, &adam).unwrap_err().to_string().contains("'value_norm.var'[0] is NaN")
        );
        let e = in_iteration(LearnError::Diverged("x".into()), 7);
        let e = with_last_good(
            e,
            Some(std::path::Path::new("run/checkpoints/iter_000006.safetensors")),
        );
        assert_eq!(
            e.to_string(),
            "training diverged in iteration 7: x; last good checkpoint: \
                run/checkpoints/iter_000006.safetensors (lower ppo.lr and resume from it)"
        );
    }
}
