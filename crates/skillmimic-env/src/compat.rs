//! The `env.compat` profile: one switch between the papers' behaviour (`paper`, the default) and
//! the released implementations' (`code`: wyhuai/SkillMimic, Ingrid789/SkillMimic-V2) where the
//! two differ (reference-facts §5.3, §9.5, §9.7, §12). `docs/fidelity.md` lists every difference
//! between paper, released code and this project with the key that selects it.
//!
//! * STF noise ([`crate::v2::transition::perturb`]) — `paper`: every component uniform in [−ε, ε]
//!   (P2 Tab. 7), heights upward only; `code`: root/ball height + U(0, w); root and ball orientation:
//!   roll/pitch/yaw each + U(−w, w); root velocities, joint rotations and velocities, ball
//!   velocities + w_g·(2·N(0,1) − 1) (a Gaussian of mean −w_g, std 2·w_g); no root or ball x/y
//!   noise; after a get-up episode (label 0) w = 1 and joint rotations 0.5·(2·N − 1)
//! * STF connection similarity ([`crate::v2::similarity`]) — `paper`: S = r_b·r_o·r_rel with the
//!   reward's weights, after forward kinematics; `code`: sim_pose·sim_obj·sim_rel with the code's
//!   weights (2, 0.1, 2, 2; 1, 0.1; 2) and forms (Euclidean key-body distance, squared root angle,
//!   mean squared joint angle)
//! * masked bridging steps — `paper`: N = min(−⌈log10 β⌉, N_max), inserted and excluded from the
//!   reward; `code`: N = 0 for β > 0.5, else min(−⌊log10 β⌋, N_max); the reward of those steps is
//!   replaced by the mean reward of the environments on the same clip (unless
//!   `env.v2.bridge.masked_reward` is set)
//! * history buffer at a reset — `paper`: rows before the physical start state's (clip, frame);
//!   `code`: rows before the imitated (clip, frame) after the STF/STG resampling
//! * velocity regulariser on the first step — `paper`: previous joint velocity = the reset state's;
//!   `code`: previous joint velocity = 0
//! * ATS distribution before its first update — `paper`: class-uniform clips, uniform frames;
//!   `code`: the library's class-balanced clip weights (pickup counted twice), uniform frames
//! * DeepMimic baseline reward — `paper`: mean of the four exp terms; `code`: their sum
//!
//! Not profile-dependent (papers silent, both codebases agree or the issue fixed one rule):
//! early termination exempts the get-up skill (label 0) only in SkillMimic-V2 runs (any
//! `env.v2` part on); a SkillMimic run never exempts it.

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

/// Which source the behaviours that paper and released code disagree on follow (module docs
/// list every behaviour it changes).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum Compat {
    /// The papers (SkillMimic, SkillMimic-V2) as written.
    #[default]
    Paper,
    /// The released implementations.
    Code,
}

impl Compat {
    /// True for the released implementations' behaviour.
    #[inline]
    pub fn is_code(self) -> bool {
        self == Compat::Code
    }
}
