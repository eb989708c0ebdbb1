//! Motion data of skillmimic-rs.
//!
//! * [`pickle`], [`torch_zip`]: a bounded, restricted pickle interpreter and `torch.save`
//!   archive reader (sizes checked before allocating, no code runs);
//! * [`pt`]: a restricted reader (and a writer) for `torch.save` archives holding one float32
//!   matrix (BallPlay-M clips) — no pickle code is executed;
//! * [`layout`]: the BallPlay-M 337-column row layout (widths, frame rate, column names);
//! * [`amass`]: SMPL-family sequences in the AMASS `.npz` layout as a source skeleton motion;
//!   [`amass_smpl`]: the same sequences straight onto the SMPL humanoid (no retargeting);
//! * [`bvh`]: BVH motion files (bounded parser, forward kinematics) for retargeting users' motions;
//! * [`clip`]: the project's clip representation and its decoding from the 337-column layout;
//! * [`mod@format`]: the project's clip file format (safetensors, documented field by field);
//! * [`mod@reference`]: reference quantities derived once per clip (velocities, key bodies);
//! * [`character_clip`]: clips of any character (file format, validation);
//! * [`retarget_hsi`], [`retarget_smpl`]: SkillMimic-skeleton clips onto the TokenHSI character
//!   and onto the SMPL humanoid; [`retarget_onto`]: which character has which retarget;
//! * [`retarget_bvh`]: retargeting BVH motions onto the SkillMimic humanoid (rest-pose alignment of
//!   mapped bones, scaling, resampling, ground alignment);
//! * [`retarget_clip`]: a retargeted motion as a project clip (ball track, contact label) with
//!   its diagnostics (foot penetration and sliding, joint-speed spikes);
//! * [`validate`]: the one validation of clips (bounds, minimum length, fps) every loader runs;
//! * [`library`]: many clips, class-balanced clip sampling and random start frames;
//! * [`synth_walk`], [`synth_sit`], [`synth_carry`], [`synth_climb`]: procedural walks, stand-to-sit,
//!   box-carrying and step-up clips of the TokenHSI character (kinematics only; clips the project
//!   can ship);
//! * [`testing`]: synthetic clip rows for tests and the fuzzer's seeds.

pub mod amass;
pub mod amass_smpl;
pub mod bvh;
pub mod character_clip;
pub mod clip;
pub mod error;
pub mod format;
pub mod generate;
pub mod layout;
pub mod library;
pub mod limb_ik;
pub mod pickle;
pub mod pt;
pub mod reference;
pub mod retarget_bvh;
pub mod retarget_clip;
pub mod retarget_hsi;
pub mod retarget_onto;
pub mod retarget_positions;
pub mod retarget_smpl;
pub mod synth_carry;
pub mod synth_climb;
pub mod synth_sit;
pub mod synth_walk;
pub mod testing;
pub mod torch_zip;
pub mod validate;

pub use clip::{Clip, SKILL_WIDTH};
pub use error::ClipError;
pub use layout::{BALLPLAY_FPS, PT_WIDTH};
pub use library::{MotionClip, MotionLibrary};
pub use reference::{ClipReference, NUM_KEY};
