//! Build script shared (through `package.build`) by every crate whose binaries, tests or Python
//! extension load libmujoco at run time.
//!
//! mujoco-rs links `libmujoco.so` found in `MUJOCO_DYNAMIC_LINK_DIR` (set by `.cargo/config.toml`
//! to the `.mujoco/lib` folder that `scripts/setup.sh` fills) but emits no run-time search path,
//! and a dependency's link arguments do not reach the final artefact. So each such crate adds:
//! * `$ORIGIN/../mujoco`: the Python extension lives in `site-packages/skillmimic_rs/`, next to the
//!   `mujoco` package whose `libmujoco.so.3.17.0` it must share with `import mujoco`;
//! * the absolute development folder, for `cargo run` / `cargo test` binaries.
fn main() {
    println!("cargo::rerun-if-env-changed=MUJOCO_DYNAMIC_LINK_DIR");
    println!("cargo::rustc-link-arg=-Wl,-rpath,$ORIGIN/../mujoco");
    if let Ok(dir) = std::env::var("MUJOCO_DYNAMIC_LINK_DIR") {
        println!("cargo::rustc-link-arg=-Wl,-rpath,{dir}");
    }
}
