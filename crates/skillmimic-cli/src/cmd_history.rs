//! `skillmimic history pretrain`: pre-train the SkillMimic-V2 history encoder on clips by
//! next-state prediction and save it (safetensors, PyTorch tensor names) with a JSON report.

use std::collections::BTreeMap;
use std::io::IsTerminal;
use std::path::PathBuf;
use std::sync::Arc;

use anyhow::Context;
use indicatif::{ProgressBar, ProgressStyle};
use skillmimic_env::v2::history::reference_features;
use skillmimic_env::{EnvConfig, load_motion_library};
use skillmimic_learn::history_pretrain::{PretrainConfig, PretrainData, pretrain};
use skillmimic_sim::Scene;

use crate::common::init_learner_threads;

#[derive(clap::Subcommand)]
pub enum HistoryCommand {
    /// Pre-train the history encoder (3 conv1d + linear) with a next-state predictor.
    Pretrain(PretrainArgs),
}

#[derive(clap::Args)]
pub struct PretrainArgs {
    /// Clip files or folders (repeatable; `builtin:demo` = the shipped demo clips).
    #[arg(long = "motion", required = true)]
    pub motion: Vec<PathBuf>,
    /// Output encoder file (.safetensors); the report goes next to it as .json.
    #[arg(long)]
    pub out: PathBuf,
    /// Epochs (paper: 1000; stops early once the plateau schedule has cut the learning rate
    /// below 1e-6 of its start).
    #[arg(long, default_value_t = 1000)]
    pub epochs: usize,
    /// Minibatch size.
    #[arg(long, default_value_t = 256)]
    pub batch: usize,
    /// Adam learning rate (reduced ×0.1 after 5 epochs without improvement).
    #[arg(long, default_value_t = 1e-3)]
    pub lr: f64,
    /// History length k (frames).
    #[arg(long, default_value_t = 60)]
    pub length: usize,
    /// Embedding width μ.
    #[arg(long, default_value_t = 3)]
    pub embed: usize,
    /// Weight λb of the embedding-norm penalty.
    #[arg(long, default_value_t = 1e-5)]
    pub lambda_b: f64,
    /// Hand model of the scene whose kinematics produce the features (as in training).
    #[arg(long, default_value = "full")]
    pub hands: String,
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Learner threads (0 = all cores).
    #[arg(long, default_value_t = 0)]
    pub threads: usize,
}

pub fn run(cmd: HistoryCommand) -> anyhow::Result<()> {
    match cmd {
        HistoryCommand::Pretrain(a) => run_pretrain(a),
    }
}

fn run_pretrain(a: PretrainArgs) -> anyhow::Result<()> {
    init_learner_threads(a.threads);
    let lib = load_motion_library(&a.motion)?;
    let env_cfg = EnvConfig { hands: a.hands.clone(), ..Default::default() };
    let scene = Arc::new(Scene::new(skillmimic_env::registry::scene_options(&env_cfg)?)?);
    let features = reference_features(scene, &lib)?;
    let labels = (0..lib.len()).map(|c| lib.get(c).clip.skill).collect();
    let data = PretrainData::new(features, labels);
    let cfg = PretrainConfig {
        history_length: a.length,
        embed_dim: a.embed,
        epochs: a.epochs,
        batch: a.batch,
        lr: a.lr,
        lambda_b: a.lambda_b,
        seed: a.seed,
        ..Default::default()
    };
    tracing::info!(
        "history pre-training: {} clips, {} samples, {} epochs, batch {}",
        lib.len(),
        data.samples.len(),
        cfg.epochs,
        cfg.batch
    );
    let pb = std::io::stderr().is_terminal().then(|| {
        let pb = ProgressBar::new(cfg.epochs as u64);
        pb.set_style(
            ProgressStyle::with_template(
                "{spinner} [{elapsed_precise}] {bar:30} {pos}/{len} epochs  {msg}",
            )
            .expect("valid template"),
        );
        pb
    });
    let every = (cfg.epochs / 10).max(1);
    let (enc, rep) = pretrain(&data, &cfg, |epoch, loss, lr| match &pb {
        Some(pb) => {
            pb.set_position(epoch as u64);
            pb.set_message(format!("loss {loss:.5}  lr {lr:.1e}"));
        }
        None if epoch % every == 0 || epoch == 1 => {
            tracing::info!("epoch {epoch}: loss {loss:.5}, lr {lr:.1e}")
        }
        None => {}
    })
    .map_err(anyhow::Error::msg)?;
    if let Some(pb) = pb {
        pb.finish();
    }
    let mut meta = BTreeMap::new();
    meta.insert(
        "clips".into(),
        (0..lib.len()).map(|c| lib.get(c).clip.name.clone()).collect::<Vec<_>>().join(","),
    );
    meta.insert("epochs".into(), rep.epochs.to_string());
    meta.insert("initial_prediction_mse".into(), rep.initial_prediction_mse.to_string());
    meta.insert("final_prediction_mse".into(), rep.final_prediction_mse.to_string());
    meta.insert("hands".into(), a.hands.clone());
    if let Some(dir) = a.out.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
    }
    enc.save(&a.out, &meta).with_context(|| format!("cannot write {}", a.out.display()))?;
    let report_path = a.out.with_extension("json");
    #[derive(serde::Serialize)]
    struct Out<'a> {
        config: &'a PretrainConfig,
        report: &'a skillmimic_learn::history_pretrain::PretrainReport,
    }
    skillmimic_core::tensorfile::write_bytes_atomic(
        &report_path,
        serde_json::to_string_pretty(&Out { config: &cfg, report: &rep })?.as_bytes(),
    )
    .with_context(|| format!("cannot write {}", report_path.display()))?;
    println!(
        "pre-trained on {} samples, {} epochs in {:.1} s: next-state MSE {:.6} -> {:.6} ({:.1}x \
            lower); epoch loss {:.6} -> {:.6}",
        rep.samples,
        rep.epochs,
        rep.seconds,
        rep.initial_prediction_mse,
        rep.final_prediction_mse,
        rep.initial_prediction_mse / rep.final_prediction_mse,
        rep.first_epoch_loss,
        rep.last_epoch_loss
    );
    println!("encoder {}\nreport  {}", a.out.display(), report_path.display());
    Ok(())
}
