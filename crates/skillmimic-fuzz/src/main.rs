//! `skillmimic-fuzz --target NAME|all --seconds N --seed S [--time-limit-ms MS] [--findings DIR]`:
//! fuzz one reader (or all four, N seconds each) and print executions per target; exit code 1
//! when there are findings (their inputs are saved in the findings folder).

use std::time::Duration;

use skillmimic_fuzz::{Options, Target, run, targets::ALL};

fn usage() -> ! {
    eprintln!(
        "usage: skillmimic-fuzz --target pt|clip|checkpoint|config|all [--seconds N (60)] [--seed \
            S (0)] [--time-limit-ms MS (1000)] [--findings DIR (fuzz-findings)]"
    );
    std::process::exit(2)
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let (mut target, mut seconds, mut seed, mut limit_ms, mut findings) =
        (None, 60.0, 0u64, 1000u64, "fuzz-findings".to_string());
    let mut k = 0;
    while k < args.len() {
        let value = args.get(k + 1).cloned().unwrap_or_else(|| usage());
        match args[k].as_str() {
            "--target" => target = Some(value),
            "--seconds" => seconds = value.parse().unwrap_or_else(|_| usage()),
            "--seed" => seed = value.parse().unwrap_or_else(|_| usage()),
            "--time-limit-ms" => limit_ms = value.parse().unwrap_or_else(|_| usage()),
            "--findings" => findings = value,
            _ => usage(),
        }
        k += 2;
    }
    let targets: Vec<Target> = match target.as_deref() {
        Some("all") => ALL.to_vec(),
        Some(name) => vec![Target::from_name(name).unwrap_or_else(|| usage())],
        None => usage(),
    };
    if !(seconds > 0.0 && seconds < 1e7) {
        usage();
    }
    let (mut total, mut found) = (0, 0);
    for (i, t) in targets.into_iter().enumerate() {
        let opts = Options {
            target: t,
            duration: Duration::from_secs_f64(seconds),
            seed: seed.wrapping_add(i as u64),
            time_limit: Duration::from_millis(limit_ms),
            findings_dir: findings.clone().into(),
            progress_every: 30,
        };
        let r = run(&opts);
        println!(
            "target {:<10} {:>9} executions in {:.0} s ({:.0}/s), {} accepted, {} error kinds, \
                corpus {}, {} findings",
            t.name(),
            r.executions,
            r.seconds,
            r.executions as f64 / r.seconds,
            r.accepted,
            r.error_kinds,
            r.corpus,
            r.findings.len()
        );
        for f in &r.findings {
            println!("  {f}");
        }
        total += r.executions;
        found += r.findings.len();
    }
    println!("total {total} executions, {found} findings");
    if found > 0 {
        std::process::exit(1);
    }
}
