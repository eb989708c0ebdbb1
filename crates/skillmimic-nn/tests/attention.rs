//! The attention blocks against a plain-loop reference written from the formulas of PyTorch's
//! documentation (softmax(QKᵀ/√d)V per head, post-norm encoder layer), not from the candle code.

use candle_core::{Device, Tensor};
use rand::SeedableRng;
use skillmimic_nn::Network;
use skillmimic_nn::attention::{Dense, MultiHeadAttention, TransformerEncoderLayer};

fn dense(d: &Dense, x: &[f64]) -> Vec<f64> {
    (0..d.out)
        .map(|o| {
            d.bias[o] as f64
                + (0..d.inp).map(|i| d.weight[o * d.inp + i] as f64 * x[i]).sum::<f64>()
        })
        .collect()
}

/// Reference attention of one batch element: x (S × E), mask[s] = true → ignored key.
fn ref_mha(m: &MultiHeadAttention, x: &[Vec<f64>], mask: &[bool]) -> Vec<Vec<f64>> {
    let (e, h) = (m.embed_dim, m.num_heads);
    let hd = e / h;
    let proj: Vec<Vec<f64>> = x.iter().map(|r| dense(&m.in_proj, r)).collect(); // 3E per token
    let mut out = vec![vec![0.0; e]; x.len()];
    for head in 0..h {
        for (l, o) in out.iter_mut().enumerate() {
            let q = &proj[l][head * hd..(head + 1) * hd];
            let scores: Vec<f64> = (0..x.len())
                .map(|s| {
                    let k = &proj[s][e + head * hd..e + (head + 1) * hd];
                    if mask[s] {
                        f64::NEG_INFINITY
                    } else {
                        q.iter().zip(k).map(|(a, b)| a * b).sum::<f64>() / (hd as f64).sqrt()
                    }
                })
                .collect();
            let mx = scores.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
            let w: Vec<f64> = scores.iter().map(|s| (s - mx).exp()).collect();
            let z: f64 = w.iter().sum();
            for s in 0..x.len() {
                let v = &proj[s][2 * e + head * hd..2 * e + (head + 1) * hd];
                for j in 0..hd {
                    o[head * hd + j] += w[s] / z * v[j];
                }
            }
        }
    }
    out.iter().map(|r| dense(&m.out_proj, r)).collect()
}

fn ref_ln(x: &[f64], p: &(Vec<f32>, Vec<f32>)) -> Vec<f64> {
    let n = x.len() as f64;
    let mean = x.iter().sum::<f64>() / n;
    let var = x.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / n;
    x.iter()
        .enumerate()
        .map(|(i, v)| (v - mean) / (var + 1e-5).sqrt() * p.0[i] as f64 + p.1[i] as f64)
        .collect()
}

fn ref_layer(t: &TransformerEncoderLayer, x: &[Vec<f64>], mask: &[bool]) -> Vec<Vec<f64>> {
    let sa = ref_mha(&t.self_attn, x, mask);
    x.iter()
        .zip(&sa)
        .map(|(a, b)| {
            let h1 = ref_ln(&a.iter().zip(b).map(|(u, v)| u + v).collect::<Vec<_>>(), &t.norm1);
            let f = dense(
                &t.linear2,
                &dense(&t.linear1, &h1).into_iter().map(|v| v.max(0.0)).collect::<Vec<_>>(),
            );
            ref_ln(&h1.iter().zip(&f).map(|(u, v)| u + v).collect::<Vec<_>>(), &t.norm2)
        })
        .collect()
}

#[test]
fn transformer_layer_matches_the_loop_reference_with_and_without_mask() {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
    let (b, s, e, h, f) = (2, 5, 8, 2, 16);
    let mut layer = TransformerEncoderLayer::new(e, h, f, &mut rng);
    // non-trivial biases and norms
    use rand::Rng;
    for v in layer
        .self_attn
        .in_proj
        .bias
        .iter_mut()
        .chain(layer.norm1.1.iter_mut())
        .chain(layer.norm2.0.iter_mut())
    {
        *v += rng.random_range(-0.5..0.5);
    }
    let x: Vec<f32> = (0..b * s * e).map(|_| rng.random_range(-1.0..1.0)).collect();
    let mask_rows = [[false, false, true, false, true], [false; 5]];
    let dev = Device::Cpu;
    let xt = Tensor::from_slice(&x, (b, s, e), &dev).unwrap();
    let mt = Tensor::from_vec(
        mask_rows.iter().flatten().map(|&m| u8::from(m)).collect::<Vec<u8>>(),
        (b, s),
        &dev,
    )
    .unwrap();
    for masked in [false, true] {
        let y: Vec<f32> = layer
            .forward_masked(&xt, masked.then_some(&mt))
            .unwrap()
            .flatten_all()
            .unwrap()
            .to_vec1()
            .unwrap();
        for bi in 0..b {
            let rows: Vec<Vec<f64>> = (0..s)
                .map(|si| {
                    x[(bi * s + si) * e..(bi * s + si + 1) * e].iter().map(|&v| v as f64).collect()
                })
                .collect();
            let mask = if masked { mask_rows[bi] } else { [false; 5] };
            let r = ref_layer(&layer, &rows, &mask);
            for si in 0..s {
                for j in 0..e {
                    let d = (r[si][j] - y[(bi * s + si) * e + j] as f64).abs();
                    assert!(d < 1e-4, "masked {masked} b {bi} s {si} e {j}: {d}");
                }
            }
        }
    }
    // a masked key changes nothing when its value changes
    let mut x2 = x.clone();
    for v in &mut x2[2 * e..3 * e] {
        *v += 3.0;
    }
    let attn = |x: &[f32]| -> Vec<f32> {
        let t = Tensor::from_slice(x, (b, s, e), &dev).unwrap();
        layer.self_attn.attend(&t, &t, Some(&mt)).unwrap().flatten_all().unwrap().to_vec1().unwrap()
    };
    let (a1, a2) = (attn(&x), attn(&x2));
    for si in [0, 1, 3, 4] {
        for j in 0..e {
            assert!((a1[si * e + j] - a2[si * e + j]).abs() < 1e-5);
        }
    }
    let names: Vec<String> = layer.state_dict().into_iter().map(|t| t.name).collect();
    assert_eq!(
        names[..4],
        [
            "self_attn.in_proj_weight",
            "self_attn.in_proj_bias",
            "self_attn.out_proj.weight",
            "self_attn.out_proj.bias"
        ]
    );
    assert!(
        names.contains(&"norm2.bias".to_string()) && names.contains(&"linear1.weight".to_string())
    );
    assert_eq!(
        layer.num_parameters(),
        3 * e * e + 3 * e + e * e + e + f * e + f + e * f + e + 4 * e
    );
}
