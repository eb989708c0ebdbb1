//! The trainer exposed to Python: the same arguments and runner as `skillmimic train`, with the
//! collective operations of a data-parallel run supplied by a Python object (the package's
//! torch.distributed group, `skillmimic_rs.distributed.TorchCollective`).
//!
//! The Rust work runs with the GIL released; a collective operation takes the GIL, copies the
//! buffer into a numpy array cached per length, calls the object's `all_reduce(array)` (in-place
//! sum) or `broadcast(array)` (in place, from rank 0) and copies the result back. A Python
//! exception there (a dead peer, a timeout) becomes an error of the training call.

use std::collections::HashMap;

use clap::Parser;
use numpy::{PyArray1, PyArrayMethods};
use pyo3::exceptions::{PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use skillmimic_learn::LearnError;
use skillmimic_learn::args::{TrainArgs, init_learner_threads};
use skillmimic_learn::collective::{Collective, Single};
use skillmimic_learn::runner::Runner;
use skillmimic_learn::trainer::Trainer;

use crate::convert::detach_guarded;

/// A Python object with `rank`, `world_size`, `all_reduce(np.ndarray)`, `broadcast(np.ndarray)`.
struct PyCollective {
    obj: Py<PyAny>,
    rank: usize,
    world: usize,
    f32s: HashMap<usize, Py<PyArray1<f32>>>,
    f64s: HashMap<usize, Py<PyArray1<f64>>>,
}

/// One operation through a cached numpy array of `T`.
fn call<T: numpy::Element + Copy>(
    obj: &Py<PyAny>,
    cache: &mut HashMap<usize, Py<PyArray1<T>>>,
    buf: &mut [T],
    op: &str,
    rank: usize,
) -> Result<(), LearnError> {
    Python::attach(|py| -> PyResult<()> {
        let arr = match cache.get(&buf.len()) {
            Some(a) => a.bind(py).clone(),
            None => {
                let a = PyArray1::<T>::from_slice(py, buf);
                cache.insert(buf.len(), a.clone().unbind());
                a
            }
        };
        // SAFETY: the array is owned by this cache, contiguous, and not shared with Python code
        // outside this call
        unsafe { arr.as_slice_mut()? }.copy_from_slice(buf);
        obj.call_method1(py, op, (arr.clone(),))?;
        buf.copy_from_slice(unsafe { arr.as_slice()? });
        Ok(())
    })
    .map_err(|e| LearnError::Distributed(format!("{op} failed on rank {rank}: {e}")))
}

impl Collective for PyCollective {
    fn rank(&self) -> usize {
        self.rank
    }
    fn world_size(&self) -> usize {
        self.world
    }
    fn all_reduce_f32(&mut self, buf: &mut [f32]) -> Result<(), LearnError> {
        call(&self.obj, &mut self.f32s, buf, "all_reduce", self.rank)
    }
    fn all_reduce_f64(&mut self, buf: &mut [f64]) -> Result<(), LearnError> {
        call(&self.obj, &mut self.f64s, buf, "all_reduce", self.rank)
    }
    fn broadcast_f32(&mut self, buf: &mut [f32]) -> Result<(), LearnError> {
        call(&self.obj, &mut self.f32s, buf, "broadcast", self.rank)
    }
    fn broadcast_f64(&mut self, buf: &mut [f64]) -> Result<(), LearnError> {
        call(&self.obj, &mut self.f64s, buf, "broadcast", self.rank)
    }
}

#[derive(Parser)]
#[command(
    name = "python -m skillmimic_rs.train",
    about = "Train a policy with PPO (the arguments of `skillmimic train`)"
)]
struct Cli {
    #[command(flatten)]
    args: TrainArgs,
}

fn err(e: impl std::fmt::Display) -> PyErr {
    PyRuntimeError::new_err(e.to_string())
}

/// The trainer of `skillmimic train` for one rank (or one process).
#[pyclass(module = "skillmimic_rs._core", name = "Trainer")]
pub struct PyTrainer {
    trainer: Option<Trainer>,
    resumed_from: Option<std::path::PathBuf>,
}

impl PyTrainer {
    fn t(&mut self) -> PyResult<&mut Trainer> {
        self.trainer.as_mut().ok_or_else(|| {
            PyRuntimeError::new_err("the trainer is in use, or was closed after an internal error")
        })
    }
}

fn stats_json(s: &impl serde::Serialize) -> PyResult<String> {
    serde_json::to_string(s).map_err(err)
}

#[pymethods]
impl PyTrainer {
    /// Build from the arguments of `skillmimic train` (`argv` without the program name) and an
    /// optional collective (None: one process). Bad arguments raise ValueError with the usage.
    #[new]
    #[pyo3(signature = (argv, collective = None))]
    fn new(py: Python<'_>, argv: Vec<String>, collective: Option<Py<PyAny>>) -> PyResult<Self> {
        let cli = Cli::try_parse_from(
            std::iter::once("python -m skillmimic_rs.train".to_string()).chain(argv),
        )
        .map_err(|e| PyValueError::new_err(e.render().to_string()))?;
        let cfg = cli.args.config().map_err(|e| PyValueError::new_err(format!("{e:#}")))?;
        let resume = cli.args.resume_path(&cfg.run.out_dir);
        let comm: Box<dyn Collective> = match collective {
            None => Box::new(Single),
            Some(obj) => {
                let rank: usize = obj.getattr(py, "rank")?.extract(py)?;
                let world: usize = obj.getattr(py, "world_size")?.extract(py)?;
                Box::new(PyCollective {
                    obj,
                    rank,
                    world,
                    f32s: HashMap::new(),
                    f64s: HashMap::new(),
                })
            }
        };
        init_learner_threads(cfg.run.learner_threads);
        let r = resume.clone();
        let mut trainer = detach_guarded(py, "Trainer()", move || {
            Trainer::with_collective(cfg, r.as_deref(), comm)
        })?
        .map_err(|e| PyValueError::new_err(e.to_string()))?;
        trainer.finish_if_complete = cli.args.resume_is_latest();
        Ok(Self { trainer: Some(trainer), resumed_from: resume })
    }

    /// The usage text of the arguments.
    #[staticmethod]
    fn usage() -> String {
        use clap::CommandFactory;
        Cli::command().render_help().to_string()
    }

    /// Train to `run.iterations` with the runner (rank 0 writes logs, checkpoints, the
    /// evaluation and `summary.json`); `on_iteration(stats_json)` is called after every
    /// iteration. Returns the summary as JSON on rank 0, None on the other ranks. An exception
    /// of the callback or a pending signal (Ctrl-C) stops training after the current iteration,
    /// saves a checkpoint of it and is raised.
    #[pyo3(signature = (on_iteration = None))]
    fn run(&mut self, py: Python<'_>, on_iteration: Option<Py<PyAny>>) -> PyResult<Option<String>> {
        let trainer =
            self.trainer.take().ok_or_else(|| PyRuntimeError::new_err("the trainer is in use"))?;
        if trainer.cfg.run.final_video {
            // the end-of-training video starts EGL in this process: keep a later `import triton`
            // safe (skillmimic_rs/_gl.py); failing to do so must not stop training
            let _ = py.import("skillmimic_rs._gl").and_then(|m| m.call_method0("before_rendering"));
        }
        // the artefacts of `skillmimic train` (curve, video) besides checkpoint, log and summary
        let mut runner = skillmimic_cli::with_artefact_hooks(Runner::new(trainer));
        let mut stop: Option<PyErr> = None;
        let result = detach_guarded(py, "Trainer.run", || {
            runner.run_until(|s| {
                let r = Python::attach(|py| -> PyResult<()> {
                    py.check_signals()?;
                    if let Some(cb) = &on_iteration {
                        cb.call1(py, (serde_json::to_string(s).unwrap_or_default(),))?;
                    }
                    Ok(())
                });
                stop = r.err();
                stop.is_none()
            })
        });
        // after an internal error the trainer's state is unknown: it stays closed
        let result = result?;
        self.trainer = Some(runner.trainer);
        if let Some(e) = stop {
            return Err(e);
        }
        let summary = result.map_err(|e| PyRuntimeError::new_err(format!("{e:#}")))?;
        summary.map(|s| stats_json(&s)).transpose()
    }

    /// One iteration (rollout + update); its statistics as JSON.
    fn iteration(&mut self, py: Python<'_>) -> PyResult<String> {
        let t = self.t()?;
        let s = detach_guarded(py, "Trainer.iteration", || t.iteration())?.map_err(err)?;
        stats_json(&s)
    }

    /// Collect a rollout only; its statistics as JSON (pass them to `update_from_rollout`).
    fn collect_rollout(&mut self, py: Python<'_>) -> PyResult<String> {
        let t = self.t()?;
        let s =
            detach_guarded(py, "Trainer.collect_rollout", || t.collect_rollout())?.map_err(err)?;
        stats_json(&s)
    }

    /// The update on the rollout storage (after `collect_rollout` or `load_rollout_part`).
    #[pyo3(signature = (stats_json = None))]
    fn update_from_rollout(
        &mut self,
        py: Python<'_>,
        stats_json: Option<&str>,
    ) -> PyResult<String> {
        let stats = match stats_json {
            Some(j) => serde_json::from_str(j)
                .map_err(|e| PyValueError::new_err(format!("stats_json: {e}")))?,
            None => Default::default(),
        };
        let t = self.t()?;
        let s = detach_guarded(py, "Trainer.update_from_rollout", || t.update_from_rollout(stats))?
            .map_err(err)?;
        self::stats_json(&s)
    }

    /// Take this rank's environments of `other`'s rollout (a one-process trainer over all
    /// `env.num_envs` environments): equivalence checks.
    fn load_rollout_part(&mut self, other: PyRef<'_, PyTrainer>) -> PyResult<()> {
        let src = other
            .trainer
            .as_ref()
            .ok_or_else(|| PyRuntimeError::new_err("the other trainer is in use"))?;
        if src.shard.world != 1 || src.shard.total_envs != self.t()?.shard.total_envs {
            return Err(PyValueError::new_err(
                "load_rollout_part: the source must be a one-process trainer over the same \
                    env.num_envs",
            ));
        }
        let full = src.rollout_storage().clone();
        self.t()?.load_rollout_part(&full);
        Ok(())
    }

    /// Everything an update changes, as float64 arrays: `params` (actor then critic, PyTorch
    /// order, flattened), `log_std`, `adam_m`, `adam_v`, `obs_mean`, `obs_var`, `obs_count`,
    /// `value_mean`, `value_var`, `value_count`, `adam_step`, `iteration`, `samples`.
    fn state<'py>(&mut self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let t = self.t()?;
        let d = PyDict::new(py);
        let f = |xs: &mut dyn Iterator<Item = f32>| xs.map(|x| x as f64).collect::<Vec<f64>>();
        let p = &t.policy;
        d.set_item(
            "params",
            PyArray1::from_vec(
                py,
                f(&mut p.actor.params().into_iter().chain(p.critic.params()).flatten().copied()),
            ),
        )?;
        d.set_item("log_std", PyArray1::from_vec(py, f(&mut p.log_std.iter().copied())))?;
        d.set_item("adam_m", PyArray1::from_vec(py, f(&mut t.adam.m.iter().flatten().copied())))?;
        d.set_item("adam_v", PyArray1::from_vec(py, f(&mut t.adam.v.iter().flatten().copied())))?;
        d.set_item("obs_mean", PyArray1::from_slice(py, &p.obs_norm.mean))?;
        d.set_item("obs_var", PyArray1::from_slice(py, &p.obs_norm.var))?;
        d.set_item("obs_count", PyArray1::from_slice(py, &[p.obs_norm.count]))?;
        d.set_item("value_mean", PyArray1::from_slice(py, &p.value_norm.mean))?;
        d.set_item("value_var", PyArray1::from_slice(py, &p.value_norm.var))?;
        d.set_item("value_count", PyArray1::from_slice(py, &[p.value_norm.count]))?;
        d.set_item("adam_step", t.adam.step)?;
        d.set_item("iteration", t.progress.iteration)?;
        d.set_item("samples", t.progress.samples)?;
        Ok(d)
    }

    /// Write a training checkpoint (and its config) to `path`.
    fn save(&mut self, path: std::path::PathBuf) -> PyResult<()> {
        self.t()?.save(&path).map_err(err)
    }

    #[getter]
    fn rank(&mut self) -> PyResult<usize> {
        Ok(self.t()?.shard.rank)
    }
    #[getter]
    fn world_size(&mut self) -> PyResult<usize> {
        Ok(self.t()?.shard.world)
    }
    /// Environments this rank steps.
    #[getter]
    fn local_envs(&mut self) -> PyResult<usize> {
        Ok(self.t()?.shard.local)
    }
    /// Iterations the run trains to (`run.iterations`).
    #[getter]
    fn iterations(&mut self) -> PyResult<u64> {
        Ok(self.t()?.cfg.run.iterations as u64)
    }
    /// Iterations done (after resuming: the checkpoint's count).
    #[getter]
    fn iterations_done(&mut self) -> PyResult<u64> {
        Ok(self.t()?.progress.iteration)
    }
    /// The checkpoint this trainer resumed from (`--resume`), if any.
    #[getter]
    fn resumed_from(&self) -> Option<std::path::PathBuf> {
        self.resumed_from.clone()
    }
    /// The effective configuration (TOML).
    #[getter]
    fn config_toml(&mut self) -> PyResult<String> {
        Ok(self.t()?.config_toml().to_string())
    }
}
