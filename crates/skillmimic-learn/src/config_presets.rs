//! The named presets of [`TrainConfig`] (`--preset NAME`): the papers' settings at several
//! machine sizes and the released settings of ModSkill and TokenHSI.

use crate::config::{AmpNormalizer, AmpSchedule, TrainConfig};
use crate::error::LearnError;

/// Named presets.
pub const PRESETS: [&str; 6] = ["paper", "small", "cpu", "tiny", "modskill", "tokenhsi"];

impl TrainConfig {
    /// A named preset:
    /// * `paper`: the paper's network and PPO settings with 2048 environments
    ///   (65 536 samples per iteration, minibatch 16 384) — for large machines;
    /// * `small`: the paper's network and PPO settings at workstation scale: 256 environments,
    ///   horizon 32 (8192 samples per iteration), minibatch 4096, 6 mini-epochs;
    /// * `cpu`: time to skill on a CPU (issue 41, docs/throughput.md "Time to skill"), a
    ///   deviation from the paper's PPO settings chosen by measured learning curves on real
    ///   clips: 128 environments × horizon 32 (4096 samples per iteration: twice the updates per
    ///   sample of `small`), minibatch 2048, 2 mini-epochs, networks [512, 256, 256] and lr 1e-4
    ///   (the fewer, cheaper Adam steps move the policy about as far per update as `small`'s:
    ///   median approx-KL 0.046 against 0.069). Reward, observations, σ, horizon, γ, λ
    ///   and clip are the paper's. More cores do not call for more environments: the samples
    ///   per update are what the measured curves chose;
    /// * `modskill`: ModSkill's released sizes on the `paper` scale: `modular_attention` with
    ///   controllers and critic [2048, 1536, 1024, 512] (modskill-tokenhsi-facts §1.4), and the
    ///   motion prior on with the released settings (10-frame windows, discriminator [1024, 512],
    ///   gradient penalty 5, logit regularisation 0.01, weight decay 1e-4, reward scale 2, task
    ///   and style weights 0.5 / 0.5; on the SMPL humanoid's tracking task it reads the released
    ///   features, `skillmimic_env::tasks::tracking::prior`);
    /// * `tokenhsi`: TokenHSI's released single-skill settings (`amp_imitation_task.yaml`,
    ///   `basic_interaction_skills/*.yaml`) for the `hsi_*` tasks: 4 096 environments, actor and
    ///   critic [1024, 512], the PPO settings of the defaults (which the released file shares),
    ///   and the motion prior on as the released agent trains it: logit regularisation 0.01,
    ///   weight decay 1e-4, one discriminator step in every PPO minibatch on 4 096 current and
    ///   4 096 replay windows against 4 096 reference windows, a replay buffer of 200 000 windows
    ///   with keep probability 0.01 (`ppo.amp.schedule = "per_minibatch"`), its input normalised
    ///   per frame (`ppo.amp.normalizer = "per_frame"`). On `hsi_multi` each episode's task is
    ///   drawn from the mix at its reset (`env.multi.assign = "per_episode"`, the released
    ///   multi-task rule); the multi-task network is `--set ppo.policy="token_transformer"`;
    /// * `tiny`: a small network ([256, 128]) for smoke tests and CI: 16 environments, horizon 16,
    ///   minibatch 128, 2 mini-epochs, learning rate 3e-5. Measured on the demo clips (400
    ///   iterations, 32 environments): 1e-4 and 3e-5 reach the same reward (≈ 3.4× the first 25
    ///   iterations), but 1e-4 moves the policy by an approx-KL of 0.4–0.9 per update against
    ///   0.06–0.09 for 3e-5, and with a worse clip it made the reward fall.
    pub fn preset(name: &str) -> Result<Self, LearnError> {
        let mut c = TrainConfig::default();
        match name {
            "paper" => {
                c.env.num_envs = 2048;
            }
            "small" => {
                c.env.num_envs = 256;
                c.ppo.minibatch = 4096;
            }
            "cpu" => {
                c.env.num_envs = 128;
                c.ppo.minibatch = 2048;
                c.ppo.mini_epochs = 2;
                c.ppo.hidden = vec![512, 256, 256];
                c.ppo.lr = 1e-4;
            }
            "tiny" => {
                c.env.num_envs = 16;
                c.ppo.hidden = vec![256, 128];
                c.ppo.horizon = 16;
                c.ppo.minibatch = 128;
                c.ppo.mini_epochs = 2;
                c.ppo.lr = 3e-5;
                c.run.iterations = 5;
                c.run.save_every = 5;
                c.run.eval_episodes = 4;
            }
            "modskill" => {
                c.env.num_envs = 2048;
                c.ppo.policy = "modular_attention".into();
                c.ppo.hidden = vec![2048, 1536, 1024, 512];
                c.ppo.modular.controller = vec![2048, 1536, 1024, 512];
                c.ppo.amp.enabled = true;
                c.ppo.amp.logit_reg = 0.01;
                c.ppo.amp.weight_decay = 1e-4;
            }
            "tokenhsi" => {
                c.env.num_envs = 4096;
                c.ppo.hidden = vec![1024, 512];
                let a = &mut c.ppo.amp;
                a.enabled = true;
                a.logit_reg = 0.01;
                a.weight_decay = 1e-4;
                a.schedule = AmpSchedule::PerMinibatch;
                a.batch = 4096;
                a.buffer = 200_000;
                a.replay_keep = 0.01;
                a.normalizer = AmpNormalizer::PerFrame;
                c.env.table_mut::<skillmimic_env::tasks::multi::config::MultiConfig>().assign =
                    skillmimic_env::tasks::multi::Assign::PerEpisode;
            }
            other => {
                return Err(LearnError::Config(format!(
                    "unknown preset '{other}', expected one of {PRESETS:?}"
                )));
            }
        }
        Ok(c)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_are_the_papers() {
        let c = TrainConfig::preset("paper").unwrap();
        assert_eq!(c.ppo.hidden, vec![1024, 512, 512]);
        assert_eq!((c.ppo.horizon, c.ppo.minibatch, c.ppo.mini_epochs), (32, 16384, 6));
        assert_eq!(c.batch_size(), 65536);
        assert_eq!((c.ppo.lr, c.ppo.gamma, c.ppo.lam, c.ppo.clip), (2e-5, 0.99, 0.95, 0.2));
        assert_eq!((c.ppo.critic_coef, c.ppo.bounds_coef, c.ppo.log_std), (5.0, 10.0, -2.9));
        assert!(!c.ppo.truncate_grads);
    }

    /// Preset `tokenhsi` against TokenHSI's released amp_imitation_task.yaml (and numEnvs 4096
    /// of basic_interaction_skills/amp_humanoid_traj.yaml): the numbers as read there.
    #[test]
    fn tokenhsi_preset_has_the_released_single_skill_settings() {
        let c = TrainConfig::preset("tokenhsi").unwrap();
        assert_eq!((c.env.num_envs, c.ppo.hidden.clone()), (4096, vec![1024, 512]));
        assert_eq!((c.ppo.horizon, c.ppo.minibatch, c.ppo.mini_epochs), (32, 16384, 6));
        assert_eq!((c.ppo.lr, c.ppo.gamma, c.ppo.lam, c.ppo.clip), (2e-5, 0.99, 0.95, 0.2));
        assert_eq!((c.ppo.critic_coef, c.ppo.bounds_coef, c.ppo.log_std), (5.0, 10.0, -2.9));
        assert_eq!((c.ppo.grad_norm, c.ppo.entropy_coef, c.ppo.truncate_grads), (1.0, 0.0, false));
        let a = &c.ppo.amp;
        assert!(a.enabled && a.window == 10 && a.hidden == vec![1024, 512]);
        assert_eq!(
            (a.schedule, a.batch, a.buffer, a.replay_keep),
            (AmpSchedule::PerMinibatch, 4096, 200_000, 0.01)
        );
        assert_eq!((a.logit_reg, a.grad_penalty, a.weight_decay, a.lr), (0.01, 5.0, 1e-4, 2e-5));
        assert_eq!((a.reward_scale, a.task_weight, a.style_weight), (2.0, 0.5, 0.5));
        assert_eq!(a.normalizer, AmpNormalizer::PerFrame);
        // multi_task/amp_humanoid_traj_sit_carry_climb.yaml: taskInitProb drawn at every reset
        let m = c.env.table::<skillmimic_env::tasks::multi::config::MultiConfig>();
        assert_eq!(m.assign, skillmimic_env::tasks::multi::Assign::PerEpisode);
    }
}
