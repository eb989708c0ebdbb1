//! Generalised advantage estimation over a rollout (reference-facts §7.4).
//!
//! Per environment, backwards over the horizon:
//! δ_t = r_t + γ·V_next,t − V_t, with V_next,t the value of the observation returned by step t
//! (the terminal observation for finished episodes) already multiplied by (1 − terminated_t), so
//! timeouts bootstrap; A_t = δ_t + γλ(1 − done_t)·A_{t+1}; returns R_t = A_t + V_t.

/// Compute advantages and returns. Arrays are `[t][env]` (time-major), length `horizon × n`.
#[allow(clippy::too_many_arguments)]
pub fn gae(
    rewards: &[f32],
    values: &[f32],
    next_values: &[f32],
    dones: &[u8],
    n: usize,
    gamma: f32,
    lam: f32,
    advantages: &mut [f32],
    returns: &mut [f32],
) {
    let horizon = rewards.len() / n;
    for i in 0..n {
        let mut last = 0.0f32;
        for t in (0..horizon).rev() {
            let k = t * n + i;
            let not_done = if dones[k] != 0 { 0.0 } else { 1.0 };
            let delta = rewards[k] + gamma * next_values[k] - values[k];
            last = delta + gamma * lam * not_done * last;
            advantages[k] = last;
            returns[k] = last + values[k];
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hand_computed_two_env_example() {
        // horizon 3, 2 envs (time-major), gamma 0.5, lambda 0.5 env 0: rewards 1,1,1; values 0,0,0;
        // next values 2 (bootstrap), none done env 1: rewards 0,1,0; values 1,1,1; next values 0
        // (terminated at t=1 -> next value 0), done at t=1
        let rewards = [1.0, 0.0, 1.0, 1.0, 1.0, 0.0];
        let values = [0.0, 1.0, 0.0, 1.0, 0.0, 1.0];
        let next = [2.0, 1.0, 2.0, 0.0, 2.0, 1.0];
        let dones = [0, 0, 0, 1, 0, 0];
        let (mut a, mut r) = ([0.0f32; 6], [0.0f32; 6]);
        gae(&rewards, &values, &next, &dones, 2, 0.5, 0.5, &mut a, &mut r);
        // env 0: d = 1 + 0.5*2 = 2 each; A2 = 2, A1 = 2 + 0.25*2 = 2.5, A0 = 2 + 0.25*2.5 = 2.625
        assert_eq!([a[0], a[2], a[4]], [2.625, 2.5, 2.0]);
        // env 1: d0 = 0 + 0.5*1 - 1 = -0.5, d1 = 1 + 0 - 1 = 0 (done), d2 = 0 + 0.5*1 - 1 = -0.5
        // A2 = -0.5, A1 = 0 (chain cut), A0 = -0.5 + 0.25*0 = -0.5
        assert_eq!([a[1], a[3], a[5]], [-0.5, 0.0, -0.5]);
        assert_eq!(r[1], 0.5);
    }

    #[test]
    fn an_episode_end_mid_rollout_cuts_the_chain() {
        // γ 0.99, λ 0.95 (γλ = 0.9405); horizon 5, 2 envs with the same rewards and values; the
        // episode ends at t = 2 in both: env 0 terminated (next value 0), env 1 truncated (next
        // value V(terminal obs) = 0.7). A new episode with a large advantage follows (t = 3), so
        // an uncut chain would raise every advantage before the end by γλ·A₃ ≈ 3.73.
        //    r = 1, 0, 2, 2, 0.5; V = 0.5, 1.0, 0.2, 0.0, 2.0; V_next = 1.0, 0.2, {0 | 0.7}, 2.0,
        // 1.5
        //   δ = r + γ·V_next − V = 1.49, −0.802, {1.8 | 2.493}, 3.98, −0.015
        //   A₄ = −0.015
        //   A₃ = 3.98 + 0.9405·(−0.015) = 3.9658925
        //   A₂ = δ₂ (done: the chain is cut) = {1.8 | 2.493}
        //   A₁ = −0.802 + 0.9405·A₂ = {0.8909 | 1.5426665}
        //   A₀ = 1.49 + 0.9405·A₁ = {2.32789145 | 2.94087784}
        // (uncut, env 0 would be A₂ = 5.5299, A₁ = 4.3989, A₀ = 5.6272)
        let r = [1.0, 1.0, 0.0, 0.0, 2.0, 2.0, 2.0, 2.0, 0.5, 0.5];
        let v = [0.5, 0.5, 1.0, 1.0, 0.2, 0.2, 0.0, 0.0, 2.0, 2.0];
        let next = [1.0, 1.0, 0.2, 0.2, 0.0, 0.7, 2.0, 2.0, 1.5, 1.5];
        let dones = [0, 0, 0, 0, 1, 1, 0, 0, 0, 0];
        let (mut a, mut ret) = ([0.0f32; 10], [0.0f32; 10]);
        gae(&r, &v, &next, &dones, 2, 0.99, 0.95, &mut a, &mut ret);
        let want = [
            [2.32789145, 0.8909, 1.8, 3.9658925, -0.015],
            [2.940_877_8, 1.5426665, 2.493, 3.9658925, -0.015],
        ];
        for (i, w) in want.iter().enumerate() {
            for (t, &x) in w.iter().enumerate() {
                let k = t * 2 + i;
                assert!((a[k] - x).abs() < 1e-5, "env {i} t {t}: advantage {} vs {x}", a[k]);
                assert!(
                    (ret[k] - (x + v[k])).abs() < 1e-5,
                    "env {i} t {t}: return {} vs {}",
                    ret[k],
                    x + v[k]
                );
            }
        }
    }
}
