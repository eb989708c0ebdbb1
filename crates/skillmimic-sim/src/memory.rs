//! Memory check before a batch of MuJoCo environments is allocated.
//!
//! MuJoCo ends the whole process (`exit(1)`, no unwinding, no Python exception) when `mj_makeData`
//! cannot allocate. A batch therefore measures one environment's `MjData` first and refuses a
//! batch that cannot fit in the memory this process may still take, with an error naming
//! `env.num_envs`, before the allocation that would fail.

use mujoco_rs::mujoco_c::mjData;

use crate::error::SimError;

/// Share of an environment's `MjData` added for the task's own per-environment buffers
/// (observations, reward terms, history windows; measured at 10-20 % of the `MjData` of the
/// SkillMimic scene), so the estimate errs on the safe side.
const TASK_OVERHEAD: f64 = 0.25;

/// Bytes one environment's `MjData` takes: its main buffer and arena (both allocated by
/// `mj_makeData`) plus the struct itself.
pub fn data_bytes(d: &mjData) -> u64 {
    d.nbuffer as u64 + d.narena as u64 + std::mem::size_of::<mjData>() as u64
}

fn read_kb_field(text: &str, key: &str) -> Option<u64> {
    let line = text.lines().find(|l| l.starts_with(key))?;
    let kb: u64 = line[key.len()..].split_whitespace().next()?.parse().ok()?;
    Some(kb.saturating_mul(1024))
}

/// Bytes this process may still allocate: the smallest of the system's `MemAvailable`, the
/// cgroup (v2) limit minus its usage, and the address-space limit (`RLIMIT_AS`, read from
/// `/proc/self/limits`) minus the current virtual size. `None` where none of them can be read
/// (not Linux), in which case nothing is refused.
pub fn available_bytes() -> Option<u64> {
    let mut limits = Vec::new();
    if let Ok(m) = std::fs::read_to_string("/proc/meminfo") {
        limits.extend(read_kb_field(&m, "MemAvailable:"));
    }
    let cg = |f: &str| {
        std::fs::read_to_string(format!("/sys/fs/cgroup/{f}"))
            .ok()
            .and_then(|s| s.trim().parse::<u64>().ok())
    };
    if let (Some(max), Some(cur)) = (cg("memory.max"), cg("memory.current")) {
        limits.push(max.saturating_sub(cur));
    }
    if let Ok(l) = std::fs::read_to_string("/proc/self/limits") {
        let soft = l.lines().find(|x| x.starts_with("Max address space")).and_then(|x| {
            x["Max address space".len()..]
                .split_whitespace()
                .next()
                .and_then(|v| v.parse::<u64>().ok())
        });
        if let Some(soft) = soft {
            let vm = std::fs::read_to_string("/proc/self/status")
                .ok()
                .and_then(|s| read_kb_field(&s, "VmSize:"))
                .unwrap_or(0);
            limits.push(soft.saturating_sub(vm));
        }
    }
    limits.into_iter().min()
}

/// Estimated bytes of `num_envs` environments whose `MjData` takes `per_env` bytes each.
pub fn batch_bytes(num_envs: usize, per_env: u64) -> u64 {
    (num_envs as f64 * per_env as f64 * (1.0 + TASK_OVERHEAD)) as u64
}

/// Refuse `num_envs` environments of `per_env` `MjData` bytes each when their estimate
/// ([`batch_bytes`]) exceeds [`available_bytes`]. `what` names the scene in the message.
pub fn check_batch(num_envs: usize, per_env: u64, what: &str) -> Result<(), SimError> {
    let need = batch_bytes(num_envs, per_env);
    match available_bytes() {
        Some(avail) if need > avail => {
            let fit = (avail as f64 / (per_env as f64 * (1.0 + TASK_OVERHEAD))) as u64;
            Err(SimError::Config(format!(
                "env.num_envs = {num_envs}: {what} needs about {:.1} GB ({:.0} KB per \
                    environment), but this process can allocate about {:.1} GB; use at most about \
                    {fit} environments",
                need as f64 / 1e9,
                per_env as f64 * (1.0 + TASK_OVERHEAD) / 1e3,
                avail as f64 / 1e9
            )))
        }
        _ => Ok(()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn available_memory_is_read_and_huge_batches_are_refused() {
        let avail = available_bytes().expect("Linux exposes /proc/meminfo");
        assert!(avail > 1 << 20, "{avail}");
        let e = check_batch(usize::MAX / 4096, 1 << 20, "the test scene").unwrap_err().to_string();
        assert!(
            e.contains("env.num_envs")
                && e.contains("the test scene")
                && e.contains("at most about"),
            "{e}"
        );
        check_batch(1, 1024, "the test scene").unwrap();
    }
}
