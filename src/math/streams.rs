//! The random-stream layout: which numbers every sample of every integrator reads.
//!
//! Every random number in a render comes from a stream keyed by three integers
//! `(seed, pass, index)` ([`super::stream_seed`], a SplitMix64 hash of the three; a
//! [`super::IndependentSampler`] or [`super::sobol::SobolSampler`] draws from it). A sample
//! therefore depends on the seed and on where it sits, never on which thread drew it or in
//! which order: images are bit-identical for any thread count, and a part of a render
//! (`--part`) draws exactly what the same passes of the whole render draw.
//!
//! | who | seed | pass | index |
//! |---|---|---|---|
//! | a pixel's sample (pt, bdpt, vcm; U's sample of a guided pass) | seed | the pass (`first_pass` + its ordinal) | the pixel, row-major |
//! | guided sample j of a pass | seed | the pass | N_pix + j |
//! | light subpath k of a vcm / guided-vcm pass | seed | the pass | [`LIGHT_STREAMS`] + k |
//! | guided render passes | seed | [`GUIDED_RENDER_PASSES`] + the render pass | as above |
//! | pt's SD-tree learning passes | seed ^ [`SDTREE_LEARNING`] | the learning pass | the pixel |
//! | the chain seeder's chain j in learning iteration i | seed | [`SEEDER_CHAINS`] + i | j |
//! | mcmc bootstrap sample i of group g | seed | [`MCMC_BOOTSTRAP`] + g | i |
//! | mcmc chain start choice of chain j | seed | [`MCMC_START`] | j |
//! | mcmc chain j's mutations | seed | [`MCMC_CHAINS`] | j |
//! | mcmc per-pixel estimate (`mmlt`'s split) in pass p | seed | [`MCMC_DIRECT`] + p | the pixel |
//!
//! The offsets keep the families apart: pass numbers of ordinary passes stay far below
//! 2^40, pixel and sample indices below 2^48, and the Markov-chain keys sit in their own
//! ranges of the pass argument. A Markov chain's primary samples, once keyed, are drawn from
//! PCG streams [`PCG_INITIAL`] (its first state) and [`PCG_CHAIN`] (its mutations).

/// Index offset of the light subpaths of a vcm pass (pixels use 0 .. N_pix, guided samples
/// N_pix ..).
pub const LIGHT_STREAMS: u64 = 1 << 48;

/// Pass offset of a guided render's render passes, apart from its learning passes (which use
/// the pass numbers 0, 1, ... themselves): a render from a saved cache repeats the render
/// passes of the run that saved it.
pub const GUIDED_RENDER_PASSES: u64 = 1 << 40;

/// Seed mask of pt's SD-tree learning passes (apart from its render passes).
pub const SDTREE_LEARNING: u64 = 0x5344_5452_4545_0000;

/// Pass key of the chain seeder's chains (`guided/chains.rs`), plus the learning iteration.
pub const SEEDER_CHAINS: u64 = 0x5345_4544_0000_0000;

/// Pass key of the Markov-chain bootstrap, plus the chain group.
pub const MCMC_BOOTSTRAP: u64 = 0x4d43_4d43_0000_0000;

/// Pass key of the draws that pick each chain's starting bootstrap sample.
pub const MCMC_START: u64 = 0x4d43_4d43_1000_0000;

/// Pass key of the chains' own streams.
pub const MCMC_CHAINS: u64 = 0x4d43_4d43_2000_0000;

/// Pass key of the per-pixel estimate beside the chains, plus the pass.
pub const MCMC_DIRECT: u64 = 0x4d43_4d43_3000_0000;

/// PCG stream selector of a Markov chain's initial state.
pub const PCG_INITIAL: u64 = 0x0a02_bdbf_7bb3_c0a7;

/// PCG stream selector of a Markov chain's continuation (`PrimarySampler::reseed`).
pub const PCG_CHAIN: u64 = 0x5851_f42d_4c95_7f2d;
