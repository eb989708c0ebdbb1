//! Every registered task on every character it declares × every policy family that can act in
//! its action space, each its own named case (`task/character/family`; MuJoCo Playground style):
//! build, reset, 30 steps with the policy's sampled actions (checking shapes against the declared
//! spaces and that nothing is NaN), then one PPO iteration through the trainer. High-level tasks
//! drive a small skill policy written for the test. Also: an unknown task, and a character a
//! task does not run on, are clear errors listing the registered ones.
//!
//! Per task and character, `…/resume`: an environment's saved state ([`Env::save_state`])
//! restored into a fresh environment built with other episode starts continues bit for bit
//! (the same buffers after every step and reset, and the same saved state at the end); a state
//! restored into an environment of another size is refused naming the difference.
//!
//! A custom harness (libtest-mimic) so that `cargo test` lists and filters the cases by name.

mod common;
use common::{skill_policy, workspace_root};
use libtest_mimic::{Arguments, Failed, Trial};
use skillmimic_env::Env;
use skillmimic_env::registry::{self, TASKS};
use skillmimic_env::tasks::hlc::config::HlcConfig;
use skillmimic_learn::config::TrainConfig;
use skillmimic_learn::policies::{FAMILIES, ObsInfo};
use skillmimic_learn::policy::{InferenceBuffers, Policy};
use skillmimic_learn::trainer::Trainer;

fn config(task: &str, character: &str, out: &str, llc: &std::path::Path) -> TrainConfig {
    let mut c = TrainConfig::preset("tiny").unwrap();
    c.env.task = task.to_string();
    c.env.character = character.to_string();
    c.env.motion = vec![workspace_root().join("motions")];
    c.env.num_envs = 4;
    c.env.threads = 1;
    c.ppo.horizon = 8;
    c.ppo.minibatch = 16;
    c.ppo.mini_epochs = 1;
    c.run.out_dir =
        std::env::temp_dir().join(format!("skillmimic-every-task-{out}-{}", std::process::id()));
    if registry::is_high_level(task) {
        c.env.table_mut::<HlcConfig>().llc = llc.to_path_buf();
    }
    common::tiny_token(&mut c.ppo);
    c
}

/// Build, step and train one task × character × family.
fn run_case(mut c: TrainConfig, family: &str) -> Result<(), Failed> {
    let name = format!("{}/{}/{family}", c.env.task, c.env.character);
    c.ppo.policy = family.to_string();
    let mut env = registry::make(&c.env).map_err(|e| format!("{name}: {e}"))?;
    let spec = env.spec().clone();
    if spec.name != c.env.task {
        return Err(format!("{name}: the environment says it is '{}'", spec.name).into());
    }
    let (n, d, a) = (env.num_envs(), spec.obs_dim, spec.act_dim());
    declarations_agree(&name, &c, env.as_ref())?;
    let mut rng = <rand_chacha::ChaCha8Rng as rand::SeedableRng>::seed_from_u64(1);
    let ppo = skillmimic_learn::policies::token_transformer::with_task_groups(&c.ppo, &spec);
    let obs = ObsInfo::of_env(
        env.as_ref(),
        skillmimic_env::registry::character(&c.env).map_err(|e| e.to_string())?,
    );
    let policy = Policy::build_for(&obs, spec.action_space, &ppo, &mut rng)?;
    let mut buf = InferenceBuffers::default();
    let o = policy.actor_outputs();
    let (mut mu, mut values, mut actions, mut neglogp) =
        (vec![0.0; n * o], vec![0.0; n], vec![0.0; n * a], vec![0.0; n]);
    env.reset_all(Some(3));
    let mut reward_sum = 0.0f64;
    for step in 0..30 {
        let b = env.buffers();
        let shapes = [
            ("observation", b.obs.len(), n * d),
            ("terms", b.terms.len(), n * spec.term_names.len()),
            ("metrics", b.metrics.len(), n * spec.metric_names.len()),
            ("info", b.info.len(), n * spec.info_names.len()),
        ];
        for (what, got, want) in shapes {
            if got != want {
                return Err(
                    format!("{name}: {what} buffer of {got}, the spec declares {want}").into()
                );
            }
        }
        if !b.obs.iter().all(|v| v.is_finite()) {
            return Err(format!("{name} step {step}: non-finite observation").into());
        }
        let obs = b.obs.clone();
        policy.infer(&obs, n, &mut buf, &mut mu, &mut values, 1);
        policy.sample(&mu, n, &mut rng, &mut actions, &mut neglogp);
        env.step(&actions).map_err(|e| format!("{name} step {step}: {e}"))?;
        let b = env.buffers();
        for (what, xs) in
            [("reward", &b.reward), ("terms", &b.terms), ("metrics", &b.metrics), ("info", &b.info)]
        {
            if !xs.iter().all(|v| v.is_finite()) {
                return Err(format!("{name} step {step}: non-finite {what}").into());
            }
        }
        reward_sum += b.reward.iter().map(|&r| r.abs() as f64).sum::<f64>();
        env.reset_done();
    }
    // every environment was stepped by its task (a zero-width buffer once stopped them all)
    if reward_sum <= 0.0 {
        return Err(format!("{name}: no reward in 30 steps").into());
    }
    // one PPO iteration through the trainer on the same task
    let mut t = Trainer::new(c.clone(), None).map_err(|e| format!("{name}: {e}"))?;
    if (t.env.obs_dim(), t.env.act_dim()) != (d, a) {
        return Err(format!("{name}: the trainer's environment differs from the registry's").into());
    }
    let s = t.iteration().map_err(|e| format!("{name}: {e}"))?;
    let _ = std::fs::remove_dir_all(&c.run.out_dir);
    if !(s.mean_reward.is_finite() && s.actor_loss.is_finite() && s.critic_loss.is_finite()) {
        return Err(format!("{name}: {s:?}").into());
    }
    if s.reward_terms.len() != spec.term_names.len()
        || s.low_level_samples != s.samples * spec.steps_per_action as u64
    {
        return Err(format!("{name}: iteration statistics do not follow the spec: {s:?}").into());
    }
    Ok(())
}

/// What the registry declares about the task (observation layout, episode fields) agrees with
/// the built environment: the layout's blocks are the spec's, except that a multi-task
/// environment's task part is one block of the layout; both tile the observation.
fn declarations_agree(name: &str, c: &TrainConfig, env: &dyn Env) -> Result<(), Failed> {
    let spec = env.spec();
    let declared =
        registry::obs_blocks(&c.env, spec.obs_dim).map_err(|e| format!("{name}: {e}"))?;
    let tiles = |b: &[skillmimic_env::obs_blocks::ObsBlock]| {
        b.first().is_some_and(|f| f.range.start == 0)
            && b.windows(2).all(|w| w[0].range.end == w[1].range.start)
            && b.last().is_some_and(|l| l.range.end == spec.obs_dim)
    };
    if !tiles(&declared) || !tiles(&spec.obs_blocks) {
        return Err(format!("{name}: observation blocks do not tile 0..{}", spec.obs_dim).into());
    }
    let k = declared.len() - 1;
    // a multi-task environment details its task part (groups, mask) where its layout has one block
    let same = declared == spec.obs_blocks
        || (declared[k].name == spec.name
            && spec.obs_blocks.len() > k
            && declared[..k] == spec.obs_blocks[..k]);
    if !same {
        return Err(format!(
            "{name}: the registry's layout {declared:?} differs from the environment's {:?}",
            spec.obs_blocks
        )
        .into());
    }
    let info = env.episode_info(0);
    if info.len() != spec.episode_names.len() {
        return Err(
            format!("{name}: {} episode fields for {:?}", info.len(), spec.episode_names).into()
        );
    }
    Ok(())
}

/// The buffers a caller reads, as bit patterns.
fn snapshot(env: &dyn Env) -> Vec<u32> {
    let b = env.buffers();
    let f = [&b.obs, &b.reward, &b.terms, &b.info, &b.metrics, &b.final_obs];
    let u = [&b.terminated, &b.truncated, &b.unstable, &b.final_mask];
    f.iter()
        .flat_map(|v| v.iter().map(|x| x.to_bits()))
        .chain(u.iter().flat_map(|v| v.iter().map(|&x| x as u32)))
        .collect()
}

/// Save mid-run, restore into a fresh environment with other starts, replay: bit for bit.
fn resume_case(c: TrainConfig) -> Result<(), Failed> {
    let name = format!("{}/{}/resume", c.env.task, c.env.character);
    let err = |e: skillmimic_env::EnvError| format!("{name}: {e}");
    let mut a = registry::make(&c.env).map_err(err)?;
    let spec = a.spec().clone();
    let obs = ObsInfo::of_env(
        a.as_ref(),
        skillmimic_env::registry::character(&c.env).map_err(|e| e.to_string())?,
    );
    let family = FAMILIES
        .iter()
        .find(|f| f.acts_on(&spec.action_space, &obs))
        .ok_or(format!("{name}: no policy family acts here"))?;
    let mut ppo = c.ppo.clone();
    ppo.policy = family.name().to_string();
    let ppo = skillmimic_learn::policies::token_transformer::with_task_groups(&ppo, &spec);
    let mut rng = <rand_chacha::ChaCha8Rng as rand::SeedableRng>::seed_from_u64(5);
    let policy = Policy::build_for(&obs, spec.action_space, &ppo, &mut rng)?;
    let (n, o, act) = (a.num_envs(), policy.actor_outputs(), spec.act_dim());
    let mut buf = InferenceBuffers::default();
    let (mut mu, mut values, mut neglogp) = (vec![0.0; n * o], vec![0.0; n], vec![0.0; n]);
    let mut act_step = |env: &mut dyn Env, actions: &mut Vec<f32>| {
        actions.resize(n * act, 0.0);
        let obs = env.buffers().obs.clone();
        policy.infer(&obs, n, &mut buf, &mut mu, &mut values, 1);
        policy.sample(&mu, n, &mut rng, actions, &mut neglogp);
    };
    a.reset_all(Some(3));
    let mut actions = Vec::new();
    for _ in 0..12 {
        act_step(a.as_mut(), &mut actions);
        a.step(&actions).map_err(err)?;
        a.reset_done();
    }
    let saved = a.save_state().map_err(err)?;
    let at_save = snapshot(a.as_ref());
    let (mut played, mut seen) = (Vec::new(), Vec::new());
    for _ in 0..12 {
        act_step(a.as_mut(), &mut actions);
        a.step(&actions).map_err(err)?;
        seen.push(snapshot(a.as_ref()));
        a.reset_done();
        seen.push(snapshot(a.as_ref()));
        played.push(actions.clone());
    }
    let mut b = registry::make(&c.env).map_err(err)?;
    b.reset_all(Some(99));
    b.restore_state(&saved).map_err(err)?;
    if snapshot(b.as_ref()) != at_save {
        return Err(format!("{name}: the restored buffers differ from the saved ones").into());
    }
    for (k, acts) in played.iter().enumerate() {
        b.step(acts).map_err(err)?;
        if snapshot(b.as_ref()) != seen[2 * k] {
            return Err(format!("{name}: step {k} after the restore differs").into());
        }
        b.reset_done();
        if snapshot(b.as_ref()) != seen[2 * k + 1] {
            return Err(format!("{name}: the resets after step {k} differ").into());
        }
    }
    if b.save_state().map_err(err)? != a.save_state().map_err(err)? {
        return Err(format!("{name}: the states differ after the replay").into());
    }
    // another number of environments: refused, naming it
    let mut other = c.env.clone();
    other.num_envs = c.env.num_envs + 1;
    let mut wrong = registry::make(&other).map_err(err)?;
    let e = wrong.restore_state(&saved).err().ok_or(format!("{name}: a 5-env state fit 4"))?;
    if !e.to_string().contains("environments") {
        return Err(format!("{name}: the refusal does not name the difference: {e}").into());
    }
    Ok(())
}

fn errors_are_clear(llc: &std::path::Path) -> Result<(), Failed> {
    let c = config("juggle", "", "unknown", llc);
    let e = registry::make(&c.env).err().ok_or("an unknown task was accepted")?.to_string();
    if !(e.contains("env.task")
        && e.contains("juggle")
        && e.contains("imitation")
        && e.contains("stand")
        && e.contains("heading"))
    {
        return Err(format!("unknown task: {e}").into());
    }
    let c = config("imitation", "smpl", "character", llc);
    let e = registry::make(&c.env)
        .err()
        .ok_or("imitation on the SMPL humanoid was accepted")?
        .to_string();
    if !(e.contains("env.character")
        && e.contains("imitation")
        && e.contains("skillmimic")
        && e.contains("tokenhsi"))
    {
        return Err(format!("unsupported character: {e}").into());
    }
    let c = config("stand", "robot", "character", llc);
    let e = registry::make(&c.env).err().ok_or("an unknown character was accepted")?.to_string();
    if !(e.contains("env.character") && e.contains("robot") && e.contains("smpl")) {
        return Err(format!("unknown character: {e}").into());
    }
    Ok(())
}

fn main() {
    let args = Arguments::from_args();
    let llc = skill_policy("every-task");
    let mut trials = Vec::new();
    for entry in TASKS {
        for &character in entry.characters {
            // the action space (and the character) decides the compatible families
            let probe = config(entry.name, character, "probe", &llc);
            let (space, obs) = match registry::make(&probe.env) {
                Ok(env) => {
                    let ch = registry::character(&probe.env).expect("a built task's character");
                    (env.spec().action_space, ObsInfo::of_env(env.as_ref(), ch))
                }
                Err(e) => {
                    let name = format!("{}/{character}/build", entry.name);
                    let msg = e.to_string();
                    trials.push(Trial::test(name, move || Err(msg.into())));
                    continue;
                }
            };
            let c =
                config(entry.name, character, &format!("{}-{character}-resume", entry.name), &llc);
            trials.push(Trial::test(format!("{}/{character}/resume", entry.name), move || {
                resume_case(c)
            }));
            for family in FAMILIES.iter().filter(|f| f.acts_on(&space, &obs)) {
                let c = config(
                    entry.name,
                    character,
                    &format!("{}-{character}-{}", entry.name, family.name()),
                    &llc,
                );
                let fam = family.name();
                trials.push(Trial::test(format!("{}/{character}/{fam}", entry.name), move || {
                    run_case(c, fam)
                }));
            }
        }
    }
    let llc2 = llc.clone();
    trials.push(Trial::test("errors/unknown_task_and_character", move || errors_are_clear(&llc2)));
    let covered: std::collections::BTreeSet<&str> =
        trials.iter().filter_map(|t| t.name().split('/').next()).collect();
    let missing: Vec<&str> =
        TASKS.iter().map(|e| e.name).filter(|n| !covered.contains(n)).collect();
    assert!(missing.is_empty(), "tasks without a compatible policy family: {missing:?}");
    libtest_mimic::run(&args, trials).exit();
}
