//! The discriminator loss against the released TokenHSI agent's own functions
//! (`tests/fixtures/tokenhsi_disc_loss_golden.json`, its note says how it was made): on the same
//! weights and normalised windows, the logistic loss, its logit-regularisation, gradient-penalty
//! and weight-decay parts, the mean logits and every parameter gradient equal the values of
//! `AMPAgent._disc_loss` with the released per-minibatch input (agent logits of the current and
//! the replay windows concatenated).

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use serde_json::Value;
use skillmimic_learn::amp::{AmpLoss, DiscConfig, Discriminator};

fn floats(v: &Value) -> Vec<f32> {
    v.as_array().unwrap().iter().map(|x| x.as_f64().unwrap() as f32).collect()
}

#[test]
fn the_loss_and_its_gradients_equal_the_released_disc_loss() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../tests/fixtures/tokenhsi_disc_loss_golden.json");
    let fx: Value = serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
    let cases = fx["cases"].as_array().unwrap();
    assert_eq!(cases.len(), 3);
    for (k, c) in cases.iter().enumerate() {
        let dims: Vec<usize> =
            c["dims"].as_array().unwrap().iter().map(|d| d.as_u64().unwrap() as usize).collect();
        let cfg = DiscConfig {
            hidden: dims[1..dims.len() - 1].to_vec(),
            loss: AmpLoss::Logistic,
            grad_penalty: c["grad_penalty"].as_f64().unwrap(),
            logit_reg: c["logit_reg"].as_f64().unwrap(),
            weight_decay: c["weight_decay"].as_f64().unwrap(),
            ..Default::default()
        };
        let mut disc = Discriminator::new(dims[0], cfg, &mut ChaCha8Rng::seed_from_u64(0));
        let (ws, bs) = (c["weights"].as_array().unwrap(), c["biases"].as_array().unwrap());
        for (l, p) in disc.mlp.params_mut().into_iter().enumerate() {
            let want = floats(if l % 2 == 0 { &ws[l / 2] } else { &bs[l / 2] });
            assert_eq!(p.len(), want.len(), "case {k}: parameter {l}");
            *p = want;
        }
        let (xr, xs) = (floats(&c["x_ref"]), floats(&c["x_sim"]));
        let (nr, ns) =
            (c["n_ref"].as_u64().unwrap() as usize, c["n_sim"].as_u64().unwrap() as usize);
        let (loss, grads) = disc.loss_and_grads(&xr, nr, &xs, ns).unwrap();
        let close = |got: f64, want: &Value, what: &str| {
            let want = want.as_f64().unwrap();
            assert!(
                (got - want).abs() <= 1e-5 * (1.0 + want.abs()),
                "case {k}: {what} {got} vs released {want}"
            );
        };
        close(loss.total, &c["disc_loss"], "loss");
        close(loss.grad_penalty, &c["disc_grad_penalty"], "gradient penalty");
        close(loss.logit_reg, &c["disc_logit_loss"], "logit regularisation");
        close(loss.mean_ref, &c["mean_demo_logit"], "mean reference logit");
        close(loss.mean_sim, &c["mean_agent_logit"], "mean simulated logit");
        let mut worst = 0.0f64;
        for (g, want) in grads.iter().zip(c["grads"].as_array().unwrap()) {
            let want = floats(want);
            assert_eq!(g.len(), want.len());
            for (a, b) in g.iter().zip(&want) {
                worst = worst.max(((a - b) as f64).abs() / (1.0 + (*b as f64).abs()));
            }
        }
        println!("case {k}: loss {:.6}, max relative gradient difference {worst:.2e}", loss.total);
        assert!(worst < 1e-5, "case {k}: gradients differ from the released loss's by {worst:.2e}");
    }
}
