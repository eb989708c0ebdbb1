//! The motion prior's checkpoint tensors: every discriminator's parameters, normaliser and Adam
//! state under `amp.*` (the run's one prior) or `amp.<task>.*` (one per task).

use skillmimic_core::tensorfile::{OwnedTensor, TensorFile};

use super::AmpReward;

impl AmpReward {
    /// Every discriminator, its normaliser and its Adam state as checkpoint tensors (`amp.*` for
    /// the run's one prior, `amp.<task>.*` per task of a multi-task run).
    pub fn tensors(&self) -> Vec<OwnedTensor> {
        let mut out = Vec::new();
        for p in &self.priors {
            let (d, pre) = (&p.disc, p.prefix());
            let names = d.mlp.param_names(&format!("{pre}.disc"));
            for ((name, shape), x) in names.iter().zip(d.mlp.params()) {
                out.push(OwnedTensor::f32(name, shape, x));
            }
            let n = d.norm.dim();
            out.push(OwnedTensor::f64(&format!("{pre}.norm.mean"), &[n], &d.norm.mean));
            out.push(OwnedTensor::f64(&format!("{pre}.norm.var"), &[n], &d.norm.var));
            out.push(OwnedTensor::f64(&format!("{pre}.norm.count"), &[], &[d.norm.count]));
            out.push(OwnedTensor::i64(&format!("{pre}.optim.step"), &[], &[d.adam.step as i64]));
            for (k, (name, shape)) in names.iter().enumerate() {
                let tail = &name[pre.len() + 1..];
                out.push(OwnedTensor::f32(&format!("{pre}.optim.m.{tail}"), shape, &d.adam.m[k]));
                out.push(OwnedTensor::f32(&format!("{pre}.optim.v.{tail}"), shape, &d.adam.v[k]));
            }
        }
        out
    }

    /// Restore the discriminators from a checkpoint written with [`AmpReward::tensors`];
    /// `Ok(false)` when the file has none of them (training then starts fresh discriminators).
    pub fn load_from(&mut self, f: &TensorFile) -> Result<bool, String> {
        let e = |x: skillmimic_core::tensorfile::TensorFileError| x.to_string();
        let want = |shape: &[usize]| shape.iter().map(|&s| Some(s)).collect::<Vec<_>>();
        let mut any = false;
        for p in self.priors.iter_mut() {
            let pre = p.prefix();
            if !f.names().iter().any(|n| *n == format!("{pre}.norm.mean")) {
                continue;
            }
            any = true;
            let d = &mut p.disc;
            let names = d.mlp.param_names(&format!("{pre}.disc"));
            for ((name, shape), dst) in names.iter().zip(d.mlp.params_mut()) {
                *dst = f.f32(name, &want(shape)).map_err(e)?.1;
            }
            let n = d.norm.dim();
            d.norm.mean = f.f64(&format!("{pre}.norm.mean"), &[Some(n)]).map_err(e)?.1;
            d.norm.var = f.f64(&format!("{pre}.norm.var"), &[Some(n)]).map_err(e)?.1;
            d.norm.count = f.f64(&format!("{pre}.norm.count"), &[]).map_err(e)?.1[0];
            d.adam.step = f.i64(&format!("{pre}.optim.step"), &[]).map_err(e)?.1[0] as u64;
            for (k, (name, shape)) in names.iter().enumerate() {
                let tail = &name[pre.len() + 1..];
                d.adam.m[k] = f.f32(&format!("{pre}.optim.m.{tail}"), &want(shape)).map_err(e)?.1;
                d.adam.v[k] = f.f32(&format!("{pre}.optim.v.{tail}"), &want(shape)).map_err(e)?.1;
            }
        }
        Ok(any)
    }
}
