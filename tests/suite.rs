//! The test suite: one test binary, so that `cargo test --release` compiles and links the test
//! code once. Each module is one theme (its file says what it checks); `common`, `util` and
//! `fuzz_support` hold the helpers they share.
//!
//! Run one theme with `cargo test --release --test suite THEME::` (e.g. `furnace::`), one test
//! with its full path and `-- --exact`.

mod common;
mod fuzz_support;
mod util;

mod bdpt;
mod bench_harness;
mod bench_page_browser;
mod bench_parts;
mod bsdf_energy;
mod check;
mod chi2_anisotropic;
mod chi2_blend;
mod chi2_bsdf;
mod chi2_lights;
mod chi2_lights_spot;
mod chi2_mask;
mod chi2_microfacet;
mod chi2_phase;
mod chi2_plastic;
mod cli_errors;
mod cluster_scripts;
mod determinism;
mod envmap;
mod example_integrator;
mod exr_roundtrip;
mod features;
mod furnace;
mod fuzz_regressions;
mod guided;
mod guided_bdpt;
mod guided_exact;
mod guided_mcmc;
mod guided_pdfs;
mod guided_vcm;
mod guided_vcm_learning;
mod integrators_doc;
mod lights_render;
mod manifold;
mod manifold_render;
mod mcmc;
mod mcmc_tiles;
mod media;
mod media_lights;
mod mitsuba_tiles;
mod mitsuba_xml;
mod normal_maps;
mod parts;
mod pdf_unguided;
mod properties;
mod pt_agreement;
mod pt_batch;
mod pt_guiding;
mod references;
mod scene_errors;
mod scenes;
mod sobol_sampler;
mod stress_gaussian;
mod stress_scenes;
mod textures;
mod vcm;
