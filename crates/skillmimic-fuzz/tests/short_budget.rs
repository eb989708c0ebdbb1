//! CI: every fuzz target runs for a short fixed budget and must produce no finding (panic, slow
//! input, huge allocation; a hang ends the test process).

use std::time::Duration;

use skillmimic_fuzz::{Options, Target, run};

fn fuzz(target: Target) {
    let opts = Options {
        target,
        duration: Duration::from_secs(3),
        seed: 19,
        time_limit: Duration::from_secs(2),
        findings_dir: std::env::temp_dir().join("skillmimic-fuzz-findings"),
        progress_every: 0,
    };
    let r = run(&opts);
    println!(
        "{}: {} executions, {} accepted, {} error kinds, corpus {}",
        target.name(),
        r.executions,
        r.accepted,
        r.error_kinds,
        r.corpus
    );
    assert!(r.findings.is_empty(), "findings: {:#?}", r.findings);
    assert!(r.executions > 50, "only {} executions", r.executions);
    assert!(r.error_kinds >= 3, "the mutations reach only {} kinds of error", r.error_kinds);
}

#[test]
fn pt_reader() {
    fuzz(Target::Pt);
}

#[test]
fn project_clip_reader() {
    fuzz(Target::Clip);
}

#[test]
fn checkpoint_loader() {
    fuzz(Target::Checkpoint);
}

#[test]
fn config_parser() {
    fuzz(Target::Config);
}

#[test]
fn bvh_reader_and_retargeting() {
    fuzz(Target::Bvh);
}

#[test]
fn positions_reader_and_retargeting() {
    fuzz(Target::Positions);
}
