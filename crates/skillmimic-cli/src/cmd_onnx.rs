//! `skillmimic export --format onnx`: a checkpoint to an ONNX graph and its JSON sidecar.

use std::path::Path;

use skillmimic_learn::onnx::export::export_checkpoint;
use skillmimic_learn::onnx::meta::{Dim, Io};

/// Export `ckpt` to `out` and report what was written.
pub fn export(ckpt: &Path, out: &Path, fused: bool, llc: Option<&Path>) -> anyhow::Result<()> {
    let w = export_checkpoint(ckpt, out, fused, llc)?;
    let m = &w.exported.meta;
    let size = std::fs::metadata(&w.model).map(|x| x.len()).unwrap_or(0);
    println!(
        "exported {} -> {} ({}, {:.1} MB, opset {})",
        ckpt.display(),
        w.model.display(),
        m.graph,
        size as f64 / 1e6,
        skillmimic_learn::onnx::graph::OPSET
    );
    let dim = |d: &Dim| match d {
        Dim::Symbol(s) => s.clone(),
        Dim::Size(n) => n.to_string(),
    };
    let io = |v: &[Io]| {
        v.iter()
            .map(|p| {
                format!(
                    "{} {}[{}]",
                    p.name,
                    p.dtype,
                    p.shape.iter().map(dim).collect::<Vec<_>>().join(", ")
                )
            })
            .collect::<Vec<_>>()
            .join(", ")
    };
    println!("  inputs:  {}", io(&m.inputs));
    println!("  outputs: {}", io(&m.outputs));
    if !m.choices.is_empty() {
        let table: Vec<String> = m
            .choices
            .iter()
            .map(|c| format!("{} -> {} ({})", c.choice, c.label, c.skill))
            .collect();
        println!("  choices: {}", table.join(", "));
    }
    println!("  metadata: {}", w.sidecar.display());
    Ok(())
}
