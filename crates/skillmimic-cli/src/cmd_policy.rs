//! `skillmimic export`, `skillmimic infer` and `skillmimic eval`: working with trained policies.

use std::collections::BTreeMap;
use std::path::PathBuf;

use anyhow::{Context, bail};
use serde::Serialize;
use skillmimic_core::tensorfile::{OwnedTensor, TensorFile, write_atomic};
use skillmimic_learn::checkpoint;
use skillmimic_learn::eval::{EvalReport, evaluate};
use skillmimic_learn::policy::InferenceBuffers;

use crate::common::{ConfigFlags, init_learner_threads, load_checkpoint};

/// File format of `skillmimic export`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum ExportFormat {
    /// The policy part of the checkpoint (actor, critic, log_std, normalisers).
    Safetensors,
    /// An ONNX graph (normaliser folded in) plus a `<out>.json` sidecar with the deployment
    /// metadata.
    Onnx,
}

#[derive(clap::Args)]
pub struct ExportArgs {
    /// Training (or policy) checkpoint.
    #[arg(long)]
    pub checkpoint: PathBuf,
    /// Output file.
    #[arg(long)]
    pub out: PathBuf,
    /// Output format; default: `onnx` when `--out` ends in `.onnx`, else `safetensors`.
    #[arg(long, value_enum)]
    pub format: Option<ExportFormat>,
    /// ONNX of a high-level policy: one graph with its frozen skill policy (high-level argmax →
    /// skill label → one-hot → skill policy → actions).
    #[arg(long)]
    pub fused: bool,
    /// The skill policy of `--fused` (default: `env.hlc.llc` of the high-level checkpoint's
    /// configuration).
    #[arg(long)]
    pub llc: Option<PathBuf>,
}

/// Write the policy part of a checkpoint (no optimizer state), or its ONNX graph.
pub fn export(a: ExportArgs) -> anyhow::Result<()> {
    let onnx_ext = a.out.extension().is_some_and(|e| e.eq_ignore_ascii_case("onnx"));
    let format =
        a.format.unwrap_or(if onnx_ext { ExportFormat::Onnx } else { ExportFormat::Safetensors });
    if format == ExportFormat::Safetensors && (a.fused || a.llc.is_some()) {
        bail!("--fused and --llc build an ONNX graph: add --format onnx");
    }
    if a.llc.is_some() && !a.fused {
        bail!("--llc names the skill policy of a fused graph: add --fused");
    }
    if format == ExportFormat::Onnx {
        return crate::cmd_onnx::export(&a.checkpoint, &a.out, a.fused, a.llc.as_deref());
    }
    let c = checkpoint::load(&a.checkpoint, None).map_err(anyhow::Error::msg)?;
    checkpoint::save(&a.out, &c.policy, None, &c.progress, &c.config)
        .with_context(|| format!("cannot write {}", a.out.display()))?;
    println!(
        "exported {} -> {} (obs {}, actions {})",
        a.checkpoint.display(),
        a.out.display(),
        c.policy.obs_dim(),
        c.policy.act_dim()
    );
    Ok(())
}

#[derive(clap::Args)]
pub struct InferArgs {
    /// Policy checkpoint.
    #[arg(long)]
    pub checkpoint: PathBuf,
    /// safetensors file with a float32 tensor `obs` of shape (N, obs_dim).
    #[arg(long)]
    pub obs: PathBuf,
    /// Output safetensors with `mu` (N, act_dim) and `value` (N,).
    #[arg(long)]
    pub out: PathBuf,
}

/// Batched deterministic inference of a checkpoint on given observations.
pub fn infer(a: InferArgs) -> anyhow::Result<()> {
    let c = checkpoint::load(&a.checkpoint, None).map_err(anyhow::Error::msg)?;
    let f = TensorFile::open(&a.obs)?;
    let (shape, obs) = f.f32("obs", &[None, Some(c.policy.obs_dim())])?;
    let n = shape[0];
    let (mut mu, mut value) = (vec![0.0f32; n * c.policy.act_dim()], vec![0.0f32; n]);
    c.policy.infer(&obs, n, &mut InferenceBuffers::default(), &mut mu, &mut value, 0);
    let tensors = [
        OwnedTensor::f32("mu", &[n, c.policy.act_dim()], &mu),
        OwnedTensor::f32("value", &[n], &value),
    ];
    write_atomic(&a.out, &tensors, &BTreeMap::new())
        .with_context(|| format!("cannot write {}", a.out.display()))?;
    Ok(())
}

#[derive(clap::Args)]
pub struct EvalArgs {
    /// Policy checkpoint (the environment configuration stored in it is used, then the flags).
    /// Optional with `--baselines` (then the `small` preset and the flags configure the task).
    #[arg(long, required_unless_present = "baselines")]
    pub checkpoint: Option<PathBuf>,
    #[command(flatten)]
    pub flags: ConfigFlags,
    /// Tasks with discrete choices (the high-level tasks): also evaluate a uniformly random
    /// choice and every fixed choice (one skill all the time) on the same episode starts.
    #[arg(long)]
    pub baselines: bool,
    /// Finished episodes to evaluate.
    #[arg(long, default_value_t = 64)]
    pub episodes: usize,
    /// Seed of clip/frame sampling.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Fixed episode length in steps (e.g. 600 = 10 s for SkillMimic-V2 success rates);
    /// default: episodes end with the reference clip as in training.
    #[arg(long)]
    pub horizon: Option<usize>,
    /// Start every episode at this reference frame (imitation; V2 evaluation uses 2; for the
    /// tracking task only 0 = whole clips); default random.
    #[arg(long)]
    pub start_frame: Option<usize>,
    /// Sample actions instead of using the mean.
    #[arg(long)]
    pub stochastic: bool,
    /// Imitation: start every episode from the reference state perturbed by the State Transition
    /// Field's noise with every half-width ε = this value (m, rad, m/s, rad/s by component;
    /// heights upward only), so that deterministic episodes from one start frame differ (the
    /// physics is deterministic). 0.1 is SkillMimic-V2's BallPlay setting (εNSR); with
    /// `env.compat = "code"` the noise has the released code's shape. It switches the State
    /// Transition Field on for the evaluation, so V2's rules apply (the get-up skill, label 0, is
    /// exempt from the fall rule). Applies to the nominal evaluation and `--sweep`, not to `--v2`,
    /// whose εNSR uses the run's own ε.
    #[arg(long, value_name = "EPS")]
    pub init_noise: Option<f64>,
    /// Also evaluate with the ball's radius, density and restitution scaled (robustness sweep).
    #[arg(long)]
    pub sweep: bool,
    /// Also run the SkillMimic-V2 metrics per skill: SR, TSR, εNSR, NR (`--episodes` trials per
    /// case, `--horizon` default 600, `--start-frame` default 2; SR and TSR sample their actions
    /// so that the trials from the one start frame are distinct, εNSR's differ by their starts).
    #[arg(long)]
    pub v2: bool,
    /// Also run SkillMimic's success rates as the paper measures them (§6.2.4): per skill,
    /// `--episodes` 10-s trials from distinct reference start states drawn with `--seed` (all of
    /// them when a skill has fewer), deterministic actions unless `--stochastic`; the rate with
    /// its 95 % interval.
    #[arg(long)]
    pub skillmimic: bool,
    /// Motion tracking (PHC's and ModSkill's evaluation): play every motion of `env.motion` once
    /// from its frame 0 with the deterministic policy, success = the mean body distance never
    /// beyond `env.tracking.success_distance` (0.5 m); reports the success rate over motions and
    /// the metrics over all motions and over the successful ones. Replaces `--episodes`.
    #[arg(long, conflicts_with_all = ["baselines", "horizon", "stochastic", "start_frame"])]
    pub each_motion: bool,
    /// Output JSON.
    #[arg(long, default_value = "metrics.json")]
    pub out: PathBuf,
}

#[derive(Serialize)]
struct SweepEntry {
    radius_scale: f64,
    density_scale: f64,
    restitution_scale: f64,
    report: EvalReport,
}

#[derive(Serialize)]
struct EvalOutput {
    checkpoint: PathBuf,
    /// `--init-noise`: the start-state half-width ε of the nominal and sweep evaluations.
    init_noise: Option<f64>,
    nominal: EvalReport,
    sweep: Vec<SweepEntry>,
    v2: Option<skillmimic_learn::eval::V2Report>,
    /// `--skillmimic`: SkillMimic's success rates (paper §6.2.4).
    skillmimic: Option<skillmimic_learn::eval_skillmimic::SkillMimicReport>,
}

/// Ball factors of the robustness sweep: (radius, density, restitution) scale factors.
pub const SWEEP: [(f64, f64, f64); 6] = [
    (0.8, 1.0, 1.0),
    (1.2, 1.0, 1.0),
    (1.0, 0.5, 1.0),
    (1.0, 2.0, 1.0),
    (1.0, 1.0, 0.8),
    (1.0, 1.0, 1.2),
];

pub fn eval(a: EvalArgs) -> anyhow::Result<()> {
    init_learner_threads(0);
    let (c, mut cfg) = match &a.checkpoint {
        Some(p) => {
            let (c, cfg) = load_checkpoint(p)?;
            (Some(c), cfg)
        }
        None => (
            None,
            skillmimic_learn::config::TrainConfig::preset("small").map_err(anyhow::Error::msg)?,
        ),
    };
    a.flags.apply(&mut cfg)?;
    let entry = skillmimic_env::registry::entry(&cfg.env.task).ok_or_else(|| {
        anyhow::anyhow!(
            "task '{}' is not registered; registered: {}",
            cfg.env.task,
            skillmimic_env::registry::names().join(", ")
        )
    })?;
    let starts =
        skillmimic_env::task::EpisodeStarts { horizon: a.horizon, start_frame: a.start_frame };
    (entry.episode_starts)(&mut cfg.env, starts).map_err(anyhow::Error::msg)?;
    if a.episodes == 0 {
        bail!("--episodes must be at least 1");
    }
    if let Some(e) = a.init_noise.filter(|e| !(e.is_finite() && *e >= 0.0)) {
        bail!("--init-noise {e}: expected a finite half-width ≥ 0 (m, rad, m/s, rad/s)");
    }
    // more environments than episodes would only burn time (each env contributes its first ones)
    cfg.env.num_envs = cfg.env.num_envs.min(a.episodes);
    if a.each_motion {
        if a.sweep || a.v2 || a.skillmimic || a.init_noise.is_some() {
            bail!(
                "--each-motion is an evaluation of its own: without --sweep, --v2, --skillmimic, --init-noise"
            );
        }
        let c = c.context("--each-motion evaluates a policy: give --checkpoint")?;
        return crate::cmd_eval_tasks::each_motion(&c.policy, &cfg, &a.out);
    }
    let skillmimic = entry.evaluation == skillmimic_env::registry::Evaluation::SkillMimic;
    if !skillmimic || a.baselines {
        // tasks other than imitation: the task-independent episode report (and baselines)
        if a.sweep || a.v2 || a.skillmimic || a.init_noise.is_some() {
            bail!(
                "--sweep, --v2, --skillmimic and --init-noise are SkillMimic evaluations of the \
                    imitation task; \
                    this run's task is '{}'",
                cfg.env.task
            );
        }
        let opts = crate::cmd_eval_tasks::Options {
            episodes: a.episodes,
            seed: a.seed,
            stochastic: a.stochastic,
            baselines: a.baselines,
            out: a.out.clone(),
        };
        return crate::cmd_eval_tasks::run(&opts, c.as_ref().map(|c| &c.policy), &cfg);
    }
    let (c, checkpoint) = (
        c.expect("imitation evaluation has a checkpoint"),
        a.checkpoint.clone().unwrap_or_default(),
    );
    let run_one = |env_cfg: skillmimic_env::EnvConfig| -> anyhow::Result<EvalReport> {
        let mut env = skillmimic_env::registry::make(&env_cfg)?;
        if (env.obs_dim(), env.act_dim()) != (c.policy.obs_dim(), c.policy.act_dim()) {
            bail!(
                "{}: the policy expects observations of {} and actions of {}",
                checkpoint.display(),
                c.policy.obs_dim(),
                c.policy.act_dim()
            );
        }
        Ok(evaluate(&c.policy, env.as_mut(), a.episodes, a.seed, a.stochastic, 0))
    };
    let mut eval_env = cfg.env.clone();
    if let Some(e) = a.init_noise {
        eval_env.v2.stf.enabled = true;
        eval_env.v2.stf.prob = 1.0;
        eval_env.v2.stf.eps = skillmimic_env::config_v2::NoiseEps::uniform(e);
    }
    let mut nominal = run_one(eval_env.clone())?;
    let lib = std::sync::Arc::new(skillmimic_env::load_motion_library(&cfg.env.motion)?);
    nominal.acc_ceiling_percent = Some(skillmimic_env::replay::acc_ceiling(&eval_env, &lib)?);
    let mut sweep = Vec::new();
    if a.sweep {
        for (r, d, e) in SWEEP {
            let mut ec = eval_env.clone();
            ec.ball.radius_scale = r;
            ec.ball.density_scale = d;
            ec.ball.restitution_scale = e;
            sweep.push(SweepEntry {
                radius_scale: r,
                density_scale: d,
                restitution_scale: e,
                report: run_one(ec)?,
            });
        }
    }
    println!(
        "{} episodes: NR {:.4}, Acc {:.1} % (replay ceiling {:.1} %), E_b {:.1} mm, E_o {:.1} mm, \
            E_cg {:.4}, falls {:.1} %",
        nominal.episodes,
        nominal.nr,
        nominal.acc_percent,
        nominal.acc_ceiling_percent.unwrap_or(f64::NAN),
        nominal.e_b_mpjpe_mm,
        nominal.e_o_mpjpe_mm,
        nominal.e_cg,
        100.0 * nominal.fall_rate
    );
    for s in &sweep {
        println!(
            "  ball radius x{} density x{} restitution x{}: NR {:.4}, Acc {:.1} %",
            s.radius_scale, s.density_scale, s.restitution_scale, s.report.nr, s.report.acc_percent
        );
    }
    let mut v2 = None;
    if a.v2 {
        let vcfg = skillmimic_learn::eval::V2EvalConfig {
            episodes: a.episodes,
            horizon: a.horizon.unwrap_or(600),
            start_frame: a.start_frame.unwrap_or(2),
            seed: a.seed,
            ..Default::default()
        };
        let r = skillmimic_learn::eval::evaluate_v2(&c.policy, &cfg.env, &lib, &vcfg, 0)?;
        // a mean over no skill with a rule is NaN in the report (null in the JSON): say so
        let rate = |x: f64| if x.is_finite() { format!("{x:.3}") } else { "n/a".into() };
        println!(
            "SkillMimic-V2 ({} episodes per case, {} steps from frame {}): SR {}, TSR {}, \
                eps-NSR {}, NR {:.4}",
            vcfg.episodes,
            vcfg.horizon,
            vcfg.start_frame,
            rate(r.sr_mean),
            rate(r.tsr_mean),
            rate(r.eps_nsr_mean),
            r.nr_mean
        );
        println!(
            "  {} trials per case (SR and TSR with sampled actions); fewest distinct trajectories \
                in a case: {}",
            vcfg.episodes,
            r.distinct.values().min().copied().unwrap_or(0)
        );
        for (k, v) in &r.sr {
            println!("  skill {k}: SR {v:.3}  eps-NSR {:.3}  NR {:.4}", r.eps_nsr[k], r.nr[k]);
        }
        for (k, v) in &r.tsr {
            println!("  transition {k}: TSR {v:.3}");
        }
        for s in &r.skills_without_rule {
            println!("  skill {s:03}: no success rule (NR {:.4})", r.nr[&format!("{s:03}")]);
        }
        v2 = Some(r);
    }
    let mut success = None;
    if a.skillmimic {
        use skillmimic_learn::eval_skillmimic::{SkillMimicEvalConfig, evaluate_skillmimic};
        let scfg =
            SkillMimicEvalConfig { trials: a.episodes, seed: a.seed, stochastic: a.stochastic };
        let r = evaluate_skillmimic(&c.policy, &cfg.env, &lib, &scfg)?;
        if r.per_skill.is_empty() {
            println!("SkillMimic success rates (paper 6.2.4, 10-s trials): no skill with a rule");
        } else {
            println!("SkillMimic success rates (paper 6.2.4, 10-s trials): mean {:.3}", r.mean);
        }
        for (k, v) in &r.per_skill {
            println!(
                "  skill {k}: {:.3} (95 % interval {:.3} to {:.3}) over {} trials of {} start \
                    states, falls {:.1} %",
                v.success_rate,
                v.ci95[0],
                v.ci95[1],
                v.trials,
                v.start_states,
                100.0 * v.fall_rate
            );
        }
        for s in &r.skills_without_rule {
            println!("  skill {s:03}: no success rule in the paper");
        }
        success = Some(r);
    }
    let out = EvalOutput {
        checkpoint,
        init_noise: a.init_noise,
        nominal,
        sweep,
        v2,
        skillmimic: success,
    };
    skillmimic_core::tensorfile::write_bytes_atomic(
        &a.out,
        serde_json::to_string_pretty(&out)?.as_bytes(),
    )
    .with_context(|| format!("cannot write {}", a.out.display()))?;
    println!("wrote {}", a.out.display());
    Ok(())
}
