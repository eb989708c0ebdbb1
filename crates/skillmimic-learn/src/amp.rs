//! The adversarial motion prior's discriminator (AMP, Peng et al. 2021; ModSkill and TokenHSI
//! use it with an MLP [1024, 512] over 10-frame windows and task/style weights 0.5 / 0.5 —
//! modskill-tokenhsi-facts §1.5, §2.4) as a reusable reward component.
//!
//! * Input: a window of frame features (`skillmimic_env::amp`), normalised by a running
//!   mean/std updated with reference and simulated windows alike, clamped to ±5: one per window
//!   entry (`ppo.amp.normalizer = "per_entry"`, default), or one per frame entry shared by the
//!   window's frames ([`FrameLayout`], `"per_frame"`: TokenHSI's released rule, from CALM).
//! * Network: an MLP `in → hidden… → 1` (ReLU), the logit D(x).
//! * Loss ([`DiscLoss`]), `loss = "logistic"` (default, the released AMP/ASE code):
//!   ½[BCE(D(x_ref), 1) + BCE(D(x_sim), 0)] + w_gp · mean‖∇ₓD(x_ref)‖² + w_logit · ‖w_out‖²;
//!   `"least_squares"` (the AMP paper): mean (D(x_ref) − 1)² + mean (D(x_sim) + 1)² +
//!   (w_gp / 2) · mean‖∇ₓD(x_ref)‖² + w_logit · ‖w_out‖². The gradient is taken with respect to
//!   the normalised input. Either loss adds w_decay · Σ_layers ‖W‖² (every layer's weights,
//!   biases excluded: the AMP/ASE code's `disc_weight_decay`, `weight_decay`).
//! * Style reward ([`Discriminator::style_reward`]): logistic −ln(max(1 − σ(D), 1e-4)) · scale;
//!   least squares max(0, 1 − ¼(D − 1)²) · scale.
//!
//! The gradient penalty needs ∇ₓD inside the loss. For a ReLU MLP it is the product
//! W₁ᵀ diag(m₁) W₂ᵀ diag(m₂) … w_outᵀ with the activation masks m_k, which are constant almost
//! everywhere; [`Discriminator::loss_and_grads`] builds that product as a candle graph (masks
//! detached), so first-order autograd gives the penalty's exact parameter gradients.

use candle_core::{DType, Device, Tensor};
use rand::Rng;
use skillmimic_nn::mlp::{Mlp, Workspace};
use skillmimic_nn::normalizer::RunningMeanStd;

use crate::adam::Adam;
pub use crate::config::{AmpConfig as DiscConfig, AmpLoss};
use crate::error::LearnError;

/// Loss parts of one discriminator step.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct DiscLoss {
    /// The adversarial part (BCE or least squares).
    pub adversarial: f64,
    /// mean‖∇ₓD(x_ref)‖² (unweighted).
    pub grad_penalty: f64,
    /// ‖w_out‖² (unweighted).
    pub logit_reg: f64,
    pub total: f64,
    /// Mean logits on reference and simulated windows.
    pub mean_ref: f64,
    pub mean_sim: f64,
}

impl DiscLoss {
    /// Adds every part of `l` divided by `u` (running means over `u` steps).
    pub fn add_divided(&mut self, l: &DiscLoss, u: f64) {
        self.adversarial += l.adversarial / u;
        self.grad_penalty += l.grad_penalty / u;
        self.logit_reg += l.logit_reg / u;
        self.total += l.total / u;
        self.mean_ref += l.mean_ref / u;
        self.mean_sim += l.mean_sim / u;
    }
}

/// A window's layout for the per-frame normaliser: `window` frames of `fdim` entries, then
/// `cond` condition entries (a task one-hot). The normaliser sees every window as `window` rows
/// of (frame, condition) — the released layout, which repeats the one-hot in every frame — so
/// its statistics are `fdim + cond` wide and count frames.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FrameLayout {
    pub window: usize,
    pub fdim: usize,
    pub cond: usize,
}

impl FrameLayout {
    /// Entries of one window.
    pub fn width(&self) -> usize {
        self.window * self.fdim + self.cond
    }

    /// Entries of one (frame, condition) row.
    pub fn row(&self) -> usize {
        self.fdim + self.cond
    }

    /// Windows `x` (`n × width`) as `n · window` rows of (frame, condition) into `out`.
    pub fn to_rows(&self, x: &[f32], out: &mut Vec<f32>) {
        let (w, r, f, wf) = (self.width(), self.row(), self.fdim, self.window * self.fdim);
        out.resize(x.len() / w * self.window * r, 0.0);
        for (win, rows) in x.chunks_exact(w).zip(out.chunks_exact_mut(self.window * r)) {
            for (k, row) in rows.chunks_exact_mut(r).enumerate() {
                row[..f].copy_from_slice(&win[k * f..(k + 1) * f]);
                row[f..].copy_from_slice(&win[wf..]);
            }
        }
    }

    /// The inverse of [`FrameLayout::to_rows`]: each frame from its row, the condition from the
    /// first frame's row, into `out` (`n × width`).
    pub fn from_rows(&self, rows: &[f32], out: &mut [f32]) {
        let (w, r, f, wf) = (self.width(), self.row(), self.fdim, self.window * self.fdim);
        for (win, rs) in out.chunks_exact_mut(w).zip(rows.chunks_exact(self.window * r)) {
            for (k, row) in rs.chunks_exact(r).enumerate() {
                win[k * f..(k + 1) * f].copy_from_slice(&row[..f]);
            }
            win[wf..].copy_from_slice(&rs[f..r]);
        }
    }
}

/// The discriminator with its input normaliser and optimiser.
#[derive(Clone, Debug)]
pub struct Discriminator {
    pub cfg: DiscConfig,
    pub mlp: Mlp,
    /// Input statistics: per window entry, or per frame entry ([`Discriminator::frames`]).
    pub norm: RunningMeanStd,
    /// `Some`: the normaliser is per frame ([`Discriminator::per_frame`]).
    pub frames: Option<FrameLayout>,
    pub adam: Adam,
    ws: Workspace,
    /// Normalised inputs of the last [`Discriminator::logits`] call (reused).
    xn: Vec<f32>,
    /// Per-frame normaliser: rows of the windows, raw and normalised (reused).
    rows: Vec<f32>,
    rows_n: Vec<f32>,
}

impl Discriminator {
    /// A new discriminator over inputs of `dim` values.
    pub fn new<R: Rng>(dim: usize, cfg: DiscConfig, rng: &mut R) -> Self {
        let mut dims = vec![dim];
        dims.extend(&cfg.hidden);
        dims.push(1);
        let mlp = Mlp::new(&dims, rng);
        let sizes: Vec<usize> = mlp.params().iter().map(|p| p.len()).collect();
        let adam = Adam::new(&sizes, cfg.lr, 1e-8);
        Self {
            norm: RunningMeanStd::new(dim, 1e-5, 5.0),
            adam,
            mlp,
            cfg,
            frames: None,
            ws: Workspace::default(),
            xn: Vec::new(),
            rows: Vec::new(),
            rows_n: Vec::new(),
        }
    }

    /// The same discriminator with a per-frame normaliser over windows of `layout` (fresh
    /// statistics `layout.row()` wide). Errors when the layout's width is not the input width.
    pub fn per_frame(mut self, layout: FrameLayout) -> Result<Self, LearnError> {
        if layout.width() != self.input_dim() || layout.window == 0 {
            return Err(LearnError::Config(format!(
                "ppo.amp.normalizer = \"per_frame\": windows of {} frames of {} entries and {} \
                    condition entries do not make the discriminator's {} inputs",
                layout.window,
                layout.fdim,
                layout.cond,
                self.input_dim()
            )));
        }
        self.norm = RunningMeanStd::new(layout.row(), self.norm.eps, self.norm.clip);
        self.frames = Some(layout);
        Ok(self)
    }

    /// Normalise raw windows `x` into `out` (same shape) with the current statistics.
    pub fn normalize_into(&mut self, x: &[f32], out: &mut [f32]) {
        match self.frames {
            None => self.norm.normalize_into(x, out),
            Some(l) => {
                l.to_rows(x, &mut self.rows);
                self.rows_n.resize(self.rows.len(), 0.0);
                self.norm.normalize_into(&self.rows, &mut self.rows_n);
                l.from_rows(&self.rows_n, out);
            }
        }
    }

    /// Merge raw windows `x` into the statistics over the ranks of `comm`.
    fn update_norm(
        &mut self,
        x: &[f32],
        comm: &mut dyn crate::collective::Collective,
        scratch: &mut Vec<f64>,
    ) -> Result<(), LearnError> {
        match self.frames {
            None => crate::collective::update_normalizer(&mut self.norm, x, comm, scratch),
            Some(l) => {
                l.to_rows(x, &mut self.rows);
                crate::collective::update_normalizer(&mut self.norm, &self.rows, comm, scratch)
            }
        }
    }

    /// Input width.
    pub fn input_dim(&self) -> usize {
        self.mlp.input_dim()
    }

    /// Logits of `n` raw windows.
    pub fn logits(&mut self, x: &[f32], n: usize) -> &[f32] {
        let mut xn = std::mem::take(&mut self.xn);
        xn.resize(x.len(), 0.0);
        self.normalize_into(x, &mut xn);
        self.xn = xn;
        self.mlp.forward_into(&self.xn, n, &mut self.ws, 1)
    }

    /// Style rewards of `n` raw windows (see the module doc).
    pub fn style_reward(&mut self, x: &[f32], n: usize) -> Vec<f32> {
        let mut out = vec![0.0; n];
        self.style_reward_into(x, n, &mut out);
        out
    }

    /// [`Discriminator::style_reward`] into `out` (`n`), without allocating after the first call.
    pub fn style_reward_into(&mut self, x: &[f32], n: usize, out: &mut [f32]) {
        let (scale, loss) = (self.cfg.reward_scale, self.cfg.loss);
        for (o, &d) in out.iter_mut().zip(self.logits(x, n)) {
            let d = d as f64;
            let r = match loss {
                AmpLoss::Logistic => -(1.0 - 1.0 / (1.0 + (-d).exp())).max(1e-4).ln(),
                AmpLoss::LeastSquares => (1.0 - 0.25 * (d - 1.0) * (d - 1.0)).max(0.0),
            };
            *o = (r * scale) as f32;
        }
    }

    /// Loss and parameter gradients (in `mlp.params()` order) on *normalised* reference and
    /// simulated windows (`n_ref` and `n_sim` rows).
    pub fn loss_and_grads(
        &self,
        x_ref: &[f32],
        n_ref: usize,
        x_sim: &[f32],
        n_sim: usize,
    ) -> Result<(DiscLoss, Vec<Vec<f32>>), LearnError> {
        let dev = Device::Cpu;
        let d = self.input_dim();
        let vars = self.mlp.candle_vars(&dev)?;
        let run = || -> candle_core::Result<(DiscLoss, Vec<Vec<f32>>)> {
            let layers = vars.len() / 2;
            let xr = Tensor::from_slice(x_ref, (n_ref, d), &dev)?;
            let xs = Tensor::from_slice(x_sim, (n_sim, d), &dev)?;
            // reference forward, keeping the activation masks for ∇ₓD
            let mut h = xr.clone();
            let mut masks = Vec::new();
            for k in 0..layers {
                let z = h
                    .matmul(&vars[2 * k].as_tensor().t()?)?
                    .broadcast_add(vars[2 * k + 1].as_tensor())?;
                if k + 1 < layers {
                    masks.push(z.gt(0.0)?.to_dtype(DType::F32)?.detach());
                    h = z.relu()?;
                } else {
                    h = z;
                }
            }
            let d_ref = h.squeeze(1)?;
            let d_sim = Mlp::candle_forward(&vars, &xs)?.squeeze(1)?;
            // ∇ₓD(x_ref): back through the layers with the masks held fixed
            let mut g = Tensor::ones((n_ref, 1), DType::F32, &dev)?;
            for k in (0..layers).rev() {
                g = g.matmul(vars[2 * k].as_tensor())?;
                if k > 0 {
                    g = (g * &masks[k - 1])?;
                }
            }
            let gp = g.sqr()?.sum(1)?.mean_all()?;
            let w_out = vars[2 * (layers - 1)].as_tensor();
            let reg = w_out.sqr()?.sum_all()?;
            let (adv, gp_w) = match self.cfg.loss {
                AmpLoss::Logistic => {
                    // BCE with logits: softplus(−D) for label 1, softplus(D) for label 0
                    let softplus = |t: &Tensor| -> candle_core::Result<Tensor> {
                        // log(1 + e^t) = max(t, 0) + log(1 + e^(−|t|))
                        t.relu()? + (t.abs()?.neg()?.exp()? + 1.0)?.log()?
                    };
                    (
                        ((softplus(&d_ref.neg()?)?.mean_all()?
                            + softplus(&d_sim)?.mean_all()?)?
                            * 0.5)?,
                        self.cfg.grad_penalty,
                    )
                }
                AmpLoss::LeastSquares => (
                    ((d_ref.clone() - 1.0)?.sqr()?.mean_all()?
                        + (d_sim.clone() + 1.0)?.sqr()?.mean_all()?)?,
                    0.5 * self.cfg.grad_penalty,
                ),
            };
            let mut total = ((&adv + (&gp * gp_w)?)? + (&reg * self.cfg.logit_reg)?)?;
            if self.cfg.weight_decay > 0.0 {
                let mut decay = Tensor::zeros((), DType::F32, &dev)?;
                for k in 0..layers {
                    decay = (decay + vars[2 * k].as_tensor().sqr()?.sum_all()?)?;
                }
                total = (total + (decay * self.cfg.weight_decay)?)?;
            }
            let gs = total.backward()?;
            let mut grads = Vec::with_capacity(vars.len());
            for v in &vars {
                let gr = gs
                    .get(v)
                    .map(|t| t.flatten_all()?.to_vec1::<f32>())
                    .transpose()?
                    .unwrap_or_else(|| vec![0.0; v.elem_count()]);
                grads.push(gr);
            }
            let s = |t: &Tensor| -> candle_core::Result<f64> {
                t.to_dtype(DType::F64)?.to_scalar::<f64>()
            };
            let loss = DiscLoss {
                adversarial: s(&adv)?,
                grad_penalty: s(&gp)?,
                logit_reg: s(&reg)?,
                total: s(&total)?,
                mean_ref: s(&d_ref.mean_all()?)?,
                mean_sim: s(&d_sim.mean_all()?)?,
            };
            Ok((loss, grads))
        };
        Ok(run()?)
    }

    /// One optimisation step on raw reference and simulated windows: update the normaliser with
    /// both, normalise, take the loss and gradients, Adam step. Returns the loss before the step.
    pub fn update(
        &mut self,
        x_ref: &[f32],
        n_ref: usize,
        x_sim: &[f32],
        n_sim: usize,
    ) -> Result<DiscLoss, LearnError> {
        self.update_with(x_ref, n_ref, x_sim, n_sim, &mut crate::collective::Single)
    }

    /// [`Discriminator::update`] of a data-parallel run: every rank brings its share of the
    /// windows (the same count on every rank); the normaliser merges the windows of all ranks
    /// (reference windows, then simulated ones, as one process does), the gradients and the
    /// reported losses are averaged over the ranks — with equal shares, the step one process
    /// takes on the union of the windows. Replicas equal before the call stay equal.
    pub fn update_with(
        &mut self,
        x_ref: &[f32],
        n_ref: usize,
        x_sim: &[f32],
        n_sim: usize,
        comm: &mut dyn crate::collective::Collective,
    ) -> Result<DiscLoss, LearnError> {
        let mut scratch = Vec::new();
        self.update_norm(x_ref, comm, &mut scratch)?;
        self.update_norm(x_sim, comm, &mut scratch)?;
        let (mut nr, mut ns) = (vec![0.0f32; x_ref.len()], vec![0.0f32; x_sim.len()]);
        self.normalize_into(x_ref, &mut nr);
        self.normalize_into(x_sim, &mut ns);
        let (mut loss, mut grads) = self.loss_and_grads(&nr, n_ref, &ns, n_sim)?;
        let world = comm.world_size();
        if world > 1 {
            let inv = 1.0 / world as f32;
            let mut flat: Vec<f32> = grads.iter().flatten().copied().collect();
            comm.all_reduce_f32(&mut flat)?;
            let mut at = 0;
            for g in grads.iter_mut() {
                for (d, s) in g.iter_mut().zip(&flat[at..]) {
                    *d = s * inv;
                }
                at += g.len();
            }
            let mut l = [
                loss.adversarial,
                loss.grad_penalty,
                loss.logit_reg,
                loss.total,
                loss.mean_ref,
                loss.mean_sim,
            ];
            comm.all_reduce_f64(&mut l)?;
            let w = world as f64;
            loss = DiscLoss {
                adversarial: l[0] / w,
                grad_penalty: l[1] / w,
                logit_reg: l[2] / w,
                total: l[3] / w,
                mean_ref: l[4] / w,
                mean_sim: l[5] / w,
            };
        }
        let mut params = self.mlp.params_mut();
        self.adam.update(&mut params, &grads);
        Ok(loss)
    }

    /// Copy rank 0's parameters, normaliser and Adam state into every rank.
    pub fn broadcast(
        &mut self,
        comm: &mut dyn crate::collective::Collective,
    ) -> Result<(), LearnError> {
        for p in self.mlp.params_mut() {
            comm.broadcast_f32(p)?;
        }
        for (m, v) in self.adam.m.iter_mut().zip(self.adam.v.iter_mut()) {
            comm.broadcast_f32(m)?;
            comm.broadcast_f32(v)?;
        }
        let mut step = [self.adam.step as f64, self.norm.count];
        comm.broadcast_f64(&mut step)?;
        (self.adam.step, self.norm.count) = (step[0] as u64, step[1]);
        comm.broadcast_f64(&mut self.norm.mean)?;
        comm.broadcast_f64(&mut self.norm.var)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;

    /// Window `i` of 3 frames of 2 entries, frame k = (10 i + k, −(i + k)), then the one-hot of
    /// task i mod 2.
    fn window(i: usize) -> Vec<f32> {
        let mut w: Vec<f32> =
            (0..3).flat_map(|k| [(10 * i + k) as f32, -((i + k) as f32)]).collect();
        w.extend(if i.is_multiple_of(2) { [1.0, 0.0] } else { [0.0, 1.0] });
        w
    }

    #[test]
    fn the_per_frame_normaliser_pools_the_frames_of_every_window() {
        let l = FrameLayout { window: 3, fdim: 2, cond: 2 };
        let cfg = DiscConfig { hidden: vec![4], ..Default::default() };
        let mut d = Discriminator::new(8, cfg.clone(), &mut ChaCha8Rng::seed_from_u64(1))
            .per_frame(l)
            .unwrap();
        assert_eq!(d.norm.dim(), 4);
        assert!(
            Discriminator::new(9, cfg, &mut ChaCha8Rng::seed_from_u64(1)).per_frame(l).is_err()
        );
        let xr: Vec<f32> = (0..4).flat_map(window).collect();
        let xs: Vec<f32> = (4..10).flat_map(window).collect();
        let mut rows = Vec::new();
        l.to_rows(&xr, &mut rows);
        assert_eq!(&rows[..8], &[0.0, 0.0, 1.0, 0.0, 1.0, -1.0, 1.0, 0.0]);
        let mut back = vec![0.0; xr.len()];
        l.from_rows(&rows, &mut back);
        assert_eq!(back, xr, "windows round-trip through the row layout");
        d.update(&xr, 4, &xs, 6).unwrap();
        // 30 frames merged into the fresh statistics (mean 0, variance 1, count 1): the first
        // entry's values 10 i + k average 46, the one-hot's first entry is 1 in 15 of them
        let close = |a: f64, b: f64| (a - b).abs() < 1e-9 * (1.0 + b.abs());
        assert!(close(d.norm.count, 31.0), "{}", d.norm.count);
        assert!(close(d.norm.mean[0], 30.0 * 46.0 / 31.0), "{:?}", d.norm.mean);
        assert!(close(d.norm.mean[1], 30.0 * -5.5 / 31.0), "{:?}", d.norm.mean);
        assert!(close(d.norm.mean[2], 15.0 / 31.0) && close(d.norm.mean[3], 15.0 / 31.0));
        // a window's frames are normalised with the shared statistics, the one-hot with its own
        let x = window(7);
        let mut out = vec![0.0f32; 8];
        d.normalize_into(&x, &mut out);
        let z = |j: usize, v: f32| {
            ((v as f64 - d.norm.mean[j]) / (d.norm.var[j] + 1e-5).sqrt()).clamp(-5.0, 5.0) as f32
        };
        let want: Vec<f32> =
            (0..8).map(|e| if e < 6 { z(e % 2, x[e]) } else { z(e - 4, x[e]) }).collect();
        assert_eq!(out, want);
    }
}
