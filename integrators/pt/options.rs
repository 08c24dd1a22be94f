//! pt's options, declared once (`integrators/options.rs`); `guiding.rs` and `batch.rs` declare
//! theirs beside the code that reads them.

use super::{batch, guiding};
use crate::integrators::options::{DefaultValue, Kind, SAMPLER, Spec};

/// pt's default roulette start (Mitsuba's).
pub(super) const RR_DEPTH: i64 = 5;

/// Option `rr_depth` of pt (and of pssmlt).
pub const RR_DEPTH_OPTION: Spec = Spec {
    name: "rr_depth",
    kind: Kind::Int { min: 1 },
    default: DefaultValue::Int(RR_DEPTH),
    doc: "Russian roulette starts on paths of this many segments (Mitsuba's default)",
};

/// Option `strategy` of pt (and of pssmlt).
pub const STRATEGY_OPTION: Spec = Spec {
    name: "strategy",
    kind: Kind::Choice(&["mis", "bsdf", "nee"]),
    default: DefaultValue::Word("mis"),
    doc: "`bsdf`: emitters only found by BSDF sampling; `nee`: only by next-event estimation \
          (except after delta bounces and for the camera ray)",
};

/// pt's options.
pub const OPTIONS: &[Spec] = &[
    RR_DEPTH_OPTION,
    STRATEGY_OPTION,
    batch::BATCH_OPTION,
    SAMPLER,
    guiding::GUIDING_OPTION,
    guiding::GUIDE_FRACTION_OPTION,
    guiding::LEARN_FRACTION_OPTION,
];
