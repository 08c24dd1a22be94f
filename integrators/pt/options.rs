//! pt's options, declared once (`integrators/options.rs`); `guiding.rs` and `batch.rs` declare
//! theirs beside the code that reads them. And what the options allow of the registry's
//! capabilities (`--part`, `--film splatted`).

use super::{batch, guiding};
use crate::error::{Error, Result};
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

/// `--part` (`Entry::parts`): pt's passes are independent, except with `guiding=sdtree`,
/// whose tree each part would learn from its own passes.
pub fn check_parts(_: &str, o: &crate::integrators::Options) -> Result<()> {
    if o.declared(&[OPTIONS]).word("guiding")? == "sdtree" {
        return Err(Error::new(
            "--part with pt -O guiding=sdtree: each part would learn its own tree from its \
             own passes, so the parts would not be slices of one render",
        ));
    }
    Ok(())
}

/// `Entry::splat_film` of pt: every pass through the pass driver, but SD-tree guiding's
/// learning passes, which keep their own film.
pub fn check_splat_film(_: &str, o: &crate::integrators::Options) -> Result<()> {
    if o.declared(&[OPTIONS]).word("guiding")? == "sdtree" {
        return Err(Error::new(
            "--film splatted with pt -O guiding=sdtree: the learning passes count each camera \
             sample for one pixel",
        ));
    }
    Ok(())
}
