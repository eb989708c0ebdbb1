//! Locating the reference data (`../shared` next to the checkout) for tests and benchmarks.
//!
//! Tests that need the real BallPlay-M clips call [`shared_dir_or_skip`]: when the folder is
//! missing the test prints a clear `SKIPPED` line and returns early, except when the `CI`
//! environment variable is set, where a missing folder is a failure.

use std::path::{Path, PathBuf};

/// Environment variable that overrides the location of the shared folder.
pub const SHARED_ENV: &str = "SKILLMIMIC_SHARED";

/// The workspace root (two levels above this crate's manifest).
pub fn workspace_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../..")
        .canonicalize()
        .unwrap_or_else(|_| Path::new(env!("CARGO_MANIFEST_DIR")).join("../.."))
}

/// `$SKILLMIMIC_SHARED` if set, else `<workspace>/../shared`; `None` when that folder has no
/// `data/`.
pub fn shared_dir() -> Option<PathBuf> {
    let dir = match std::env::var_os(SHARED_ENV) {
        Some(d) => PathBuf::from(d),
        None => workspace_root().join("../shared"),
    };
    dir.join("data").is_dir().then_some(dir)
}

/// The shared folder, or `None` after printing a skip notice.
///
/// # Panics
/// When the folder is missing and the `CI` environment variable is set: CI must run every test.
pub fn shared_dir_or_skip(test: &str) -> Option<PathBuf> {
    match shared_dir() {
        Some(d) => Some(d),
        None if std::env::var_os("CI").is_some() => panic!(
            "{test}: reference data not found (looked in ${SHARED_ENV} or <workspace>/../shared/data) \
             and CI is set, so this test may not be skipped"
        ),
        None => {
            eprintln!(
                "SKIPPED {test}: reference data not found (set ${SHARED_ENV} or place the shared folder \
                 next to the checkout)"
            );
            None
        }
    }
}

/// `rel` inside the sources of the crates.io package `crate_dir` (e.g. `bvh_anim-0.4.0`) in the
/// local cargo registry: test data shipped by a registry package, fetched by
/// `scripts/setup.sh --tests` (tests/data-crates/Cargo.toml). `None` after a skip notice when it is
/// missing.
///
/// # Panics
/// When the file is missing and the `CI` environment variable is set.
pub fn registry_file_or_skip(test: &str, crate_dir: &str, rel: &str) -> Option<PathBuf> {
    let home = std::env::var_os("CARGO_HOME")
        .map(PathBuf::from)
        .or_else(|| std::env::var_os("HOME").map(|h| Path::new(&h).join(".cargo")));
    let found = home.and_then(|h| std::fs::read_dir(h.join("registry/src")).ok()).and_then(|d| {
        d.flatten().map(|e| e.path().join(crate_dir).join(rel)).find(|p| p.is_file())
    });
    match found {
        Some(p) => Some(p),
        None if std::env::var_os("CI").is_some() => panic!(
            "{test}: {crate_dir}/{rel} is not in the cargo registry and CI is set \
                (scripts/setup.sh --tests fetches it)"
        ),
        None => {
            eprintln!(
                "SKIPPED {test}: {crate_dir}/{rel} is not in the cargo registry (run \
                    scripts/setup.sh --tests)"
            );
            None
        }
    }
}

/// All `.pt` clips under `<shared>/data/ballplay_m`, sorted by path.
pub fn ballplay_clips(shared: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    let mut stack = vec![shared.join("data/ballplay_m")];
    while let Some(dir) = stack.pop() {
        let Ok(rd) = std::fs::read_dir(&dir) else { continue };
        for entry in rd.flatten() {
            let p = entry.path();
            if p.is_dir() {
                stack.push(p);
            } else if p.extension().is_some_and(|e| e == "pt") {
                out.push(p);
            }
        }
    }
    out.sort();
    out
}
