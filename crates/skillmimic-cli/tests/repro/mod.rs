//! What the results-reproduction tests share: the machine class a reference was written on and
//! the log rows without their wall-clock fields.

use serde_json::Value;

/// Wall-clock fields of a log line: the only ones allowed to differ.
pub const TIMING: [&str; 6] =
    ["rollout_s", "update_s", "env_s", "inference_s", "samples_per_s", "allreduce_s"];

/// The class of machine whose float results a reference holds: the matrix kernels the CPU
/// selects (AVX-512 or not) and the thread count.
pub fn machine_class() -> Value {
    #[cfg(target_arch = "x86_64")]
    let avx512 = std::arch::is_x86_feature_detected!("avx512f");
    #[cfg(not(target_arch = "x86_64"))]
    let avx512 = false;
    serde_json::json!({
        "arch": std::env::consts::ARCH,
        "avx512f": avx512,
        "threads": std::thread::available_parallelism().map_or(1, |c| c.get()),
    })
}

/// The rows of a `log.jsonl` text without the [`TIMING`] fields.
pub fn rows(text: &str) -> Vec<Value> {
    text.lines()
        .filter(|l| !l.trim().is_empty())
        .map(|l| {
            let mut v: Value = serde_json::from_str(l).unwrap();
            for k in TIMING {
                v.as_object_mut().unwrap().remove(k);
            }
            v
        })
        .collect()
}
