//! Headless rendering (mujoco-rs renderer over EGL) and video files.
//!
//! * `.gif`: written natively (the `gif` crate), no external program;
//! * `.mp4`: raw RGB frames piped into ffmpeg (H.264, yuv420p). ffmpeg is looked up in
//!   `$SKILLMIMIC_FFMPEG`, then on `PATH`, then in the `imageio-ffmpeg` Python package (which
//!   bundles a static ffmpeg) of `.venv` or of the first `python3` on `PATH`.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::Arc;

use anyhow::{Context, bail};
use mujoco_rs::prelude::*;
use mujoco_rs::renderer::MjRenderer;
use mujoco_rs::wrappers::mj_model::{MjtGeomBase, MjtObjBase};

use skillmimic_env::markers::{MAX_MARKERS, Marker};

/// RGB frames of one size.
pub struct Frames {
    pub width: usize,
    pub height: usize,
    pub fps: u32,
    pub rgb: Vec<Vec<u8>>,
}

/// Colour of the reference ghost (translucent grey-blue).
pub const GHOST_RGBA: [f32; 4] = [0.55, 0.7, 0.95, 0.35];

/// Offscreen renderer of a scene through its `side` camera (it tracks the centre of mass of the
/// whole scene, the character and its objects together).
pub struct SceneRenderer {
    renderer: MjRenderer,
    data: MjData<Arc<MjModel>>,
    /// Kinematics of the reference ghost (a second copy of the scene's state).
    ghost: MjData<Arc<MjModel>>,
    model: Arc<MjModel>,
}

/// A second, translucent copy of the scene's bodies drawn into a frame: the reference motion's
/// state `qpos` shifted by `offset` (world, m; zero = drawn over the policy's character).
#[derive(Clone, Copy, Debug)]
pub struct Ghost<'a> {
    pub qpos: &'a [f64],
    pub offset: [f64; 3],
}

impl SceneRenderer {
    /// A renderer of `width × height` pixels for `model`.
    pub fn new(model: &Arc<MjModel>, width: usize, height: usize) -> anyhow::Result<Self> {
        let camera = model
            .name_to_id(MjtObjBase::mjOBJ_CAMERA, "side")
            .map(MjvCamera::new_fixed)
            .unwrap_or_else(|| MjvCamera::new_free(model));
        let renderer = MjRenderer::builder()
            .width(width as u32)
            .height(height as u32)
            .rgb(true)
            .num_visual_user_geom((MAX_MARKERS + model.ffi().ngeom as usize) as u32)
            .camera(camera)
            .build(model)
            .map_err(|e| {
                anyhow::anyhow!(
                    "cannot start headless rendering (EGL through Mesa's libEGL is needed): {e}"
                )
            })?;
        Ok(Self {
            renderer,
            data: MjData::new(Arc::clone(model)),
            ghost: MjData::new(Arc::clone(model)),
            model: Arc::clone(model),
        })
    }

    /// Add the ghost's geoms (every geom of a body other than the world: the character and its
    /// objects) to the user scene, translucent, at the ghost state's kinematics.
    fn add_ghost(&mut self, g: Ghost<'_>) {
        self.ghost.qpos_mut().copy_from_slice(g.qpos);
        self.ghost.forward();
        let m = &self.model;
        let scene = self.renderer.user_scene_mut();
        let (types, sizes, bodies) = (m.geom_type(), m.geom_size(), m.geom_bodyid());
        for k in 0..types.len() {
            if bodies[k] == 0 {
                continue;
            }
            let s = sizes[k];
            // the abstract visual geom's size: radii and half-lengths per axis
            let size = match types[k] {
                MjtGeomBase::mjGEOM_SPHERE => [s[0]; 3],
                MjtGeomBase::mjGEOM_CAPSULE | MjtGeomBase::mjGEOM_CYLINDER => [s[0], s[0], s[1]],
                _ => s,
            };
            let p = self.ghost.geom_xpos()[k];
            let pos = [p[0] + g.offset[0], p[1] + g.offset[1], p[2] + g.offset[2]];
            // SAFETY: the created geom keeps the "none" material, texture and object ids.
            let _ = unsafe {
                scene.try_create_geom(
                    MjtGeom::from(types[k]),
                    Some(size),
                    Some(pos),
                    Some(self.ghost.geom_xmat()[k]),
                    Some(GHOST_RGBA),
                )
            };
        }
    }

    /// Render the state `qpos` (kinematics only) with visual-only task markers and, when given,
    /// the reference ghost; return the RGB image (row 0 at the top).
    pub fn render_frame(
        &mut self,
        qpos: &[f64],
        markers: &[Marker],
        ghost: Option<Ghost<'_>>,
    ) -> anyhow::Result<Vec<u8>> {
        self.renderer.user_scene_mut().clear_geom();
        if let Some(g) = ghost {
            self.add_ghost(g);
        }
        let scene = self.renderer.user_scene_mut();
        for m in markers.iter().take(MAX_MARKERS) {
            // SAFETY: the created geoms keep the "none" material, texture and object ids.
            match *m {
                Marker::Sphere { pos, radius, rgba } => unsafe {
                    scene.create_geom(
                        MjtGeom::mjGEOM_SPHERE,
                        Some([radius; 3]),
                        Some(pos),
                        None,
                        Some(rgba),
                    );
                },
                Marker::Segment { from, to, radius, rgba } => unsafe {
                    scene.create_geom(MjtGeom::mjGEOM_CAPSULE, None, None, None, Some(rgba))
                }
                .connect(radius, from, to),
                Marker::Box { pos, half, rgba } => unsafe {
                    scene.create_geom(
                        MjtGeom::mjGEOM_BOX,
                        Some(half),
                        Some(pos),
                        Some([1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0]),
                        Some(rgba),
                    );
                },
            }
        }
        self.data.qpos_mut().copy_from_slice(qpos);
        self.data.forward();
        self.renderer.sync_data(&mut self.data).map_err(|e| anyhow::anyhow!("render: {e}"))?;
        self.renderer.render().map_err(|e| anyhow::anyhow!("render: {e}"))?;
        let rgb = self.renderer.rgb_flat().context("renderer produced no RGB image")?;
        Ok(rgb.to_vec())
    }
}

/// Write frames to `path` (`.gif` or `.mp4`).
pub fn write_video(path: &Path, f: &Frames) -> anyhow::Result<()> {
    if f.rgb.is_empty() {
        bail!("no frames to write to {}", path.display());
    }
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
    }
    match path.extension().and_then(|e| e.to_str()) {
        Some("gif") => write_gif(path, f),
        Some("mp4") => write_mp4(path, f),
        _ => bail!("{}: unsupported video extension, use .mp4 or .gif", path.display()),
    }
}

fn write_gif(path: &Path, f: &Frames) -> anyhow::Result<()> {
    let tmp = path.with_extension("gif.tmp");
    {
        let file = std::fs::File::create(&tmp)
            .with_context(|| format!("cannot create {}", tmp.display()))?;
        let mut enc =
            gif::Encoder::new(std::io::BufWriter::new(file), f.width as u16, f.height as u16, &[])?;
        enc.set_repeat(gif::Repeat::Infinite)?;
        let delay = (100.0 / f.fps as f64).round() as u16;
        for rgb in &f.rgb {
            let mut frame = gif::Frame::from_rgb_speed(f.width as u16, f.height as u16, rgb, 20);
            frame.delay = delay;
            enc.write_frame(&frame)?;
        }
    }
    std::fs::rename(&tmp, path).with_context(|| format!("cannot write {}", path.display()))
}

/// Python interpreters to try, in order: `.venv` of the working directory, of the checkout,
/// then `python3` on `PATH`.
pub fn python_candidates() -> [PathBuf; 3] {
    [
        PathBuf::from(".venv/bin/python"),
        skillmimic_core::shared_data::workspace_root().join(".venv/bin/python"),
        PathBuf::from("python3"),
    ]
}

/// The ffmpeg executable, if one can be found.
pub fn find_ffmpeg() -> Option<PathBuf> {
    if let Some(p) = std::env::var_os("SKILLMIMIC_FFMPEG") {
        return Some(PathBuf::from(p));
    }
    if Command::new("ffmpeg")
        .arg("-version")
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
        .is_ok_and(|s| s.success())
    {
        return Some(PathBuf::from("ffmpeg"));
    }
    for py in python_candidates() {
        let out = Command::new(&py)
            .args(["-c", "import imageio_ffmpeg; print(imageio_ffmpeg.get_ffmpeg_exe())"])
            .output();
        if let Ok(o) = out
            && o.status.success()
        {
            let p = PathBuf::from(String::from_utf8_lossy(&o.stdout).trim());
            if p.exists() {
                return Some(p);
            }
        }
    }
    None
}

fn write_mp4(path: &Path, f: &Frames) -> anyhow::Result<()> {
    let ffmpeg = find_ffmpeg().context(
        "MP4 output needs ffmpeg: install it, `pip install imageio-ffmpeg`, or set \
            SKILLMIMIC_FFMPEG; or write a .gif instead",
    )?;
    let tmp = path.with_extension("tmp.mp4");
    let mut child = Command::new(&ffmpeg)
        .args(["-y", "-loglevel", "error", "-f", "rawvideo", "-pix_fmt", "rgb24", "-s"])
        .arg(format!("{}x{}", f.width, f.height))
        .args([
            "-r",
            &f.fps.to_string(),
            "-i",
            "-",
            "-pix_fmt",
            "yuv420p",
            "-vcodec",
            "libx264",
            "-crf",
            "23",
        ])
        .arg(&tmp)
        .stdin(Stdio::piped())
        .spawn()
        .with_context(|| format!("cannot start {}", ffmpeg.display()))?;
    {
        let stdin = child.stdin.as_mut().context("ffmpeg stdin")?;
        for rgb in &f.rgb {
            stdin.write_all(rgb).context("writing frames to ffmpeg")?;
        }
    }
    let status = child.wait()?;
    if !status.success() {
        bail!("{} failed with {status} while writing {}", ffmpeg.display(), path.display());
    }
    std::fs::rename(&tmp, path).with_context(|| format!("cannot write {}", path.display()))
}
