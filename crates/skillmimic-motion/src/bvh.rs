//! BVH (Biovision Hierarchy) motion files: a bounded parser and forward kinematics, the first stage
//! of retargeting users' own motions (issue 23).
//!
//! Accepted: any hierarchy (`ROOT`, `JOINT`, `End Site`), any number of roots' children, 0, 3 or 6
//! channels per joint in any order (`Xposition`…`Zrotation`), position channels on any joint, any
//! units and up axis (the file's own; conversion to the project's metres and Z-up happens later in
//! retargeting). Values are in degrees, as every BVH exporter writes them.
//!
//! Conventions (documented because exporters disagree where the format is silent):
//! * rotation channels compose in file order as intrinsic rotations: channels `Z X Y` give
//!   R = R_z(θ_z) · R_x(θ_x) · R_y(θ_y), mapping child-frame vectors into the parent frame;
//! * a joint's local translation is its `OFFSET` plus its position channels (as Blender's importer
//!   does; for the usual root with a zero offset both readings agree);
//! * global positions are the joint origins in the file's frame and units; `End Site` offsets are
//!   kept (they are the ends of the leaf bones) but carry no channels.
//!
//! Hostile input: sizes are bounded ([`MAX_JOINTS`], [`MAX_VALUES`]) before allocating, every
//! number must be finite, and every error names the file, the line and what was expected.

use std::path::{Path, PathBuf};

use skillmimic_core::math::{Quat, Vec3, add};

use crate::error::ClipError;

/// Most joints a file may declare.
pub const MAX_JOINTS: usize = 1024;
/// Most channel values (frames × channels) a file may hold.
pub const MAX_VALUES: usize = 50_000_000;
/// Largest file read (bytes), checked before reading.
pub const MAX_BYTES: u64 = 512 << 20;

/// One channel of a joint.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Channel {
    Xposition,
    Yposition,
    Zposition,
    Xrotation,
    Yrotation,
    Zrotation,
}

impl Channel {
    fn parse(s: &str) -> Option<Self> {
        Some(match s.to_ascii_lowercase().as_str() {
            "xposition" => Self::Xposition,
            "yposition" => Self::Yposition,
            "zposition" => Self::Zposition,
            "xrotation" => Self::Xrotation,
            "yrotation" => Self::Yrotation,
            "zrotation" => Self::Zrotation,
            _ => return None,
        })
    }
    /// Axis index 0..3 of the channel.
    fn axis(self) -> usize {
        match self {
            Self::Xposition | Self::Xrotation => 0,
            Self::Yposition | Self::Yrotation => 1,
            Self::Zposition | Self::Zrotation => 2,
        }
    }
    fn is_rotation(self) -> bool {
        matches!(self, Self::Xrotation | Self::Yrotation | Self::Zrotation)
    }
}

/// One joint of the hierarchy.
#[derive(Clone, Debug, PartialEq)]
pub struct BvhJoint {
    pub name: String,
    /// Index of the parent joint (`None` for a root).
    pub parent: Option<usize>,
    /// Offset from the parent's origin, in the parent's frame (file units).
    pub offset: Vec3,
    pub channels: Vec<Channel>,
    /// Index of this joint's first value in a frame's row.
    pub first_value: usize,
    /// `End Site` offset below this joint, if it has one (file units).
    pub end_site: Option<Vec3>,
}

/// A parsed BVH file.
#[derive(Clone, Debug)]
pub struct Bvh {
    pub path: PathBuf,
    /// Joints in file order (every parent before its children).
    pub joints: Vec<BvhJoint>,
    /// Seconds per frame.
    pub frame_time: f64,
    pub frames: usize,
    /// Values per frame (the sum of the joints' channels).
    pub width: usize,
    /// `frames × width` channel values, row-major (degrees and file units).
    pub values: Vec<f64>,
}

/// Global pose of every joint at one frame (file frame and units).
#[derive(Clone, Debug)]
pub struct Pose {
    pub positions: Vec<Vec3>,
    pub rotations: Vec<Quat>,
}

struct Tokens<'a> {
    path: &'a Path,
    items: Vec<(usize, &'a str)>,
    at: usize,
}

impl<'a> Tokens<'a> {
    fn new(path: &'a Path, text: &'a str) -> Self {
        let items = text
            .lines()
            .enumerate()
            .flat_map(|(i, l)| l.split_whitespace().map(move |w| (i + 1, w)))
            .collect();
        Self { path, items, at: 0 }
    }
    fn line(&self) -> usize {
        self.items.get(self.at).or(self.items.last()).map_or(0, |t| t.0)
    }
    fn err(&self, what: impl Into<String>) -> ClipError {
        ClipError::Format {
            path: self.path.to_path_buf(),
            detail: format!("BVH line {}: {}", self.line(), what.into()),
        }
    }
    fn next(&mut self, expected: &str) -> Result<&'a str, ClipError> {
        let t = self
            .items
            .get(self.at)
            .ok_or_else(|| self.err(format!("unexpected end of file, expected {expected}")))?;
        self.at += 1;
        Ok(t.1)
    }
    fn peek(&self) -> Option<&'a str> {
        self.items.get(self.at).map(|t| t.1)
    }
    fn expect(&mut self, word: &str) -> Result<(), ClipError> {
        let t = self.next(&format!("'{word}'"))?;
        if t.eq_ignore_ascii_case(word) {
            Ok(())
        } else {
            Err(self.err(format!("expected '{word}', found '{t}'")))
        }
    }
    fn number(&mut self, what: &str) -> Result<f64, ClipError> {
        let t = self.next(what)?;
        match t.parse::<f64>() {
            Ok(v) if v.is_finite() => Ok(v),
            _ => Err(self.err(format!("{what}: expected a finite number, found '{t}'"))),
        }
    }
    fn vec3(&mut self, what: &str) -> Result<Vec3, ClipError> {
        Ok([self.number(what)?, self.number(what)?, self.number(what)?])
    }
}

/// Read and parse a BVH file.
pub fn read(path: &Path) -> Result<Bvh, ClipError> {
    let len = std::fs::metadata(path)
        .map_err(|error| ClipError::Io { path: path.to_path_buf(), error })?
        .len();
    if len > MAX_BYTES {
        return Err(ClipError::Format {
            path: path.to_path_buf(),
            detail: format!("BVH: file of {len} bytes exceeds the limit of {MAX_BYTES}"),
        });
    }
    let bytes =
        std::fs::read(path).map_err(|error| ClipError::Io { path: path.to_path_buf(), error })?;
    let text = String::from_utf8(bytes).map_err(|e| ClipError::Format {
        path: path.to_path_buf(),
        detail: format!("BVH: not UTF-8 text ({e})"),
    })?;
    parse(path, &text)
}

/// Parse BVH text (`path` names it in errors).
pub fn parse(path: &Path, text: &str) -> Result<Bvh, ClipError> {
    let mut t = Tokens::new(path, text);
    t.expect("HIERARCHY")?;
    let mut joints: Vec<BvhJoint> = Vec::new();
    let mut width = 0usize;
    // stack of open joints (index, or None for an End Site block)
    let mut stack: Vec<Option<usize>> = Vec::new();
    loop {
        let word = t.next("ROOT, JOINT, End Site, '}' or MOTION")?;
        match word.to_ascii_uppercase().as_str() {
            "ROOT" | "JOINT" => {
                let is_root = word.eq_ignore_ascii_case("ROOT");
                if is_root != stack.is_empty() {
                    return Err(t.err(if is_root {
                        "ROOT inside another joint"
                    } else {
                        "JOINT outside a ROOT"
                    }));
                }
                if joints.len() >= MAX_JOINTS {
                    return Err(t.err(format!("more than {MAX_JOINTS} joints")));
                }
                let name = t.next("a joint name")?.to_string();
                if joints.iter().any(|j| j.name == name) {
                    return Err(t.err(format!("joint name '{name}' appears twice")));
                }
                let parent = match stack.last() {
                    Some(Some(p)) => Some(*p),
                    Some(None) => return Err(t.err("JOINT inside an End Site")),
                    None => None,
                };
                t.expect("{")?;
                t.expect("OFFSET")?;
                let offset = t.vec3("OFFSET")?;
                let mut channels = Vec::new();
                if t.peek().is_some_and(|w| w.eq_ignore_ascii_case("CHANNELS")) {
                    t.next("CHANNELS")?;
                    let n = t.next("the channel count")?;
                    let n: usize = n.parse().ok().filter(|&n| n <= 6).ok_or_else(|| {
                        t.err(format!("CHANNELS: expected a count of 0 to 6, found '{n}'"))
                    })?;
                    for _ in 0..n {
                        let c = t.next("a channel name")?;
                        let ch = Channel::parse(c).ok_or_else(|| {
                            t.err(format!(
                                "unknown channel \
                            '{c}' (expected Xposition, Yposition, Zposition, Xrotation, Yrotation \
                            or Zrotation)"
                            ))
                        })?;
                        if channels.contains(&ch) {
                            return Err(
                                t.err(format!("channel '{c}' given twice for joint '{name}'"))
                            );
                        }
                        channels.push(ch);
                    }
                }
                joints.push(BvhJoint {
                    name,
                    parent,
                    offset,
                    first_value: width,
                    channels: channels.clone(),
                    end_site: None,
                });
                width += channels.len();
                stack.push(Some(joints.len() - 1));
            }
            "END" => {
                t.expect("Site")?;
                let owner = match stack.last() {
                    Some(Some(j)) => *j,
                    _ => return Err(t.err("End Site outside a joint")),
                };
                t.expect("{")?;
                t.expect("OFFSET")?;
                let off = t.vec3("End Site OFFSET")?;
                t.expect("}")?;
                if joints[owner].end_site.replace(off).is_some() {
                    return Err(t.err(format!("joint '{}' has two End Sites", joints[owner].name)));
                }
            }
            "}" => {
                if stack.pop().is_none() {
                    return Err(t.err("'}' without an open joint"));
                }
            }
            "MOTION" => {
                if !stack.is_empty() {
                    return Err(t.err("MOTION before the hierarchy's braces are closed"));
                }
                break;
            }
            other => {
                return Err(t.err(format!(
                    "expected ROOT, JOINT, End Site, '}}' or MOTION, found '{other}'"
                )));
            }
        }
    }
    if joints.is_empty() {
        return Err(t.err("no joints in the HIERARCHY"));
    }
    t.expect("Frames:")?;
    let n = t.next("the frame count")?;
    let frames: usize =
        n.parse().map_err(|_| t.err(format!("Frames: expected a whole number, found '{n}'")))?;
    t.expect("Frame")?;
    t.expect("Time:")?;
    let frame_time = t.number("Frame Time")?;
    if frame_time <= 0.0 {
        return Err(t.err(format!("Frame Time must be positive, found {frame_time}")));
    }
    let total = frames.checked_mul(width).filter(|&v| v <= MAX_VALUES).ok_or_else(|| {
        t.err(format!("{frames} frames × {width} channels exceeds {MAX_VALUES} values"))
    })?;
    let available = t.items.len() - t.at;
    if available != total {
        return Err(t.err(format!(
            "MOTION holds {available} values, expected Frames ({frames}) × \
            channels ({width}) = {total}"
        )));
    }
    let mut values = Vec::with_capacity(total);
    for i in 0..total {
        values.push(t.number(&format!("frame {} value {}", i / width.max(1), i % width.max(1)))?);
    }
    Ok(Bvh { path: path.to_path_buf(), joints, frame_time, frames, width, values })
}

impl Bvh {
    /// Frames per second.
    pub fn fps(&self) -> f64 {
        1.0 / self.frame_time
    }

    /// Index of the joint called `name`.
    pub fn joint(&self, name: &str) -> Option<usize> {
        self.joints.iter().position(|j| j.name == name)
    }

    /// Local rotation and translation of joint `j` at `frame` (parent frame, file units).
    pub fn local(&self, frame: usize, j: usize) -> (Quat, Vec3) {
        let joint = &self.joints[j];
        let row = &self.values[frame * self.width + joint.first_value..][..joint.channels.len()];
        let mut rot = Quat::IDENTITY;
        let mut pos = joint.offset;
        for (c, &v) in joint.channels.iter().zip(row) {
            if c.is_rotation() {
                let mut axis = [0.0; 3];
                axis[c.axis()] = 1.0;
                rot = rot.mul(Quat::from_axis_angle(axis, v.to_radians()));
            } else {
                pos[c.axis()] += v;
            }
        }
        (rot, pos)
    }

    /// Global pose of every joint at `frame` (file frame and units).
    pub fn pose(&self, frame: usize) -> Pose {
        let n = self.joints.len();
        let (mut positions, mut rotations) = (vec![[0.0; 3]; n], vec![Quat::IDENTITY; n]);
        for j in 0..n {
            let (r, p) = self.local(frame, j);
            match self.joints[j].parent {
                Some(pa) => {
                    positions[j] = add(positions[pa], rotations[pa].rotate(p));
                    rotations[j] = rotations[pa].mul(r).normalized();
                }
                None => {
                    positions[j] = p;
                    rotations[j] = r.normalized();
                }
            }
        }
        Pose { positions, rotations }
    }
}
