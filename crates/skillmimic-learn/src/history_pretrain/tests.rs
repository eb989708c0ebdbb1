//! Tests of the history encoder's pre-training (the parent module).

use super::*;

#[test]
fn candle_encoder_forward_equals_the_environment_encoder() {
    // the training graph (pad + unfold + matmul) and the environment's per-position
    // convolution compute the same function
    let cfg = PretrainConfig { history_length: 6, ..Default::default() };
    let mut rng = ChaCha8Rng::seed_from_u64(4);
    let params = init_params(&cfg, &mut rng);
    let enc_t: [Vec<f32>; 8] = std::array::from_fn(|i| params.values[i].clone());
    let enc = HistoryEncoder::from_torch(6, 3, &enc_t);
    let dev = Device::Cpu;
    let b = 3;
    let win: Vec<f32> = (0..b * 6 * FEATURE_DIM).map(|_| rng.random_range(-1.0f32..1.0)).collect();
    let p: Vec<Tensor> = params
        .values
        .iter()
        .zip(&params.shapes)
        .map(|(v, s)| Tensor::from_slice(v, s.as_slice(), &dev).unwrap())
        .collect();
    let h: Vec<f32> = encode(&p, &Tensor::from_slice(&win, (b, 6, FEATURE_DIM), &dev).unwrap())
        .unwrap()
        .flatten_all()
        .unwrap()
        .to_vec1()
        .unwrap();
    for r in 0..b {
        let mut out = [0.0f32; 3];
        enc.embed(&win[r * 6 * FEATURE_DIM..(r + 1) * 6 * FEATURE_DIM], &mut out);
        for j in 0..3 {
            assert!(
                (out[j] - h[r * 3 + j]).abs() <= 1e-5 * (1.0 + out[j].abs()),
                "{out:?} vs {:?}",
                &h[r * 3..r * 3 + 3]
            );
        }
    }
}

#[test]
fn shared_first_convolution_equals_the_plain_path() {
    let cfg = PretrainConfig { history_length: 8, ..Default::default() };
    let mut rng = ChaCha8Rng::seed_from_u64(9);
    let params = init_params(&cfg, &mut rng);
    // two clips of 12 and 5 frames; samples near the start (zero rows) and inside
    let feats: Vec<Vec<f32>> = [12usize, 5]
        .iter()
        .map(|&t| (0..t * FEATURE_DIM).map(|_| rng.random_range(-1.0f32..1.0)).collect())
        .collect();
    let data = PretrainData::new(feats, vec![3, 7]);
    let idx = [(0, 0), (0, 3), (0, 10), (1, 2), (0, 9), (1, 3)];
    let dev = Device::Cpu;
    let p: Vec<Tensor> = params
        .values
        .iter()
        .zip(&params.shapes)
        .map(|(v, s)| Tensor::from_slice(v, s.as_slice(), &dev).unwrap())
        .collect();
    let host = data.batch(&idx, 8);
    let plain: Vec<f32> =
        encode(&p, &Tensor::from_slice(&host[0], (6, 8, FEATURE_DIM), &dev).unwrap())
            .unwrap()
            .flatten_all()
            .unwrap()
            .to_vec1()
            .unwrap();
    let sb = data.shared_batch(&idx, 8);
    assert!(sb.rows < 6 * 8, "frames are shared between windows");
    assert_eq!(sb.current, host[1]);
    assert_eq!(sb.target, host[3]);
    let shared: Vec<f32> =
        encode_shared(&p, &sb, 6, 8, &dev).unwrap().flatten_all().unwrap().to_vec1().unwrap();
    for (a, b) in plain.iter().zip(&shared) {
        assert!((a - b).abs() <= 1e-5 * (1.0 + a.abs()), "{plain:?} vs {shared:?}");
    }
}

#[test]
fn plateau_reduces_after_patience_epochs_without_improvement() {
    let mut p = Plateau { best: f64::INFINITY, bad: 0, patience: 2, factor: 0.1 };
    let mut lr = 1.0;
    for loss in [1.0, 0.5, 0.5, 0.5] {
        p.step(loss, &mut lr);
    }
    assert_eq!(lr, 1.0); // two bad epochs = patience
    p.step(0.49999, &mut lr); // below the relative threshold: still bad
    assert!((lr - 0.1).abs() < 1e-12);
    p.step(0.4, &mut lr);
    assert_eq!(p.bad, 0);
}
