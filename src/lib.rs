//! lodestar: a research renderer for selective guided sampling with complete light transport
//! paths (Reibold et al. 2018) and the unbiased estimators it is measured against.
//!
//! The framework lives in `src/` (scene, geometry, BSDFs, lights, camera, film, the pass
//! driver); integrators live in `integrators/`, one module each, registered by name in
//! `integrators/mod.rs`. docs/architecture.md is the map; docs/extending.md says how to add
//! an integrator, inside the crate or outside it.

// Every public item is documented; CI's clippy run (-D warnings) keeps it so.
#![warn(missing_docs)]

pub mod bench;
pub mod bsdf;
pub mod camera;
pub mod check;
pub mod clock;
pub mod control;
pub mod dbor;
pub mod error;
pub mod film;
pub mod filter;
pub mod geometry;
pub mod light;
pub mod math;
pub mod medium;
pub mod metrics;
pub mod parts;
pub mod path;
pub mod prefetch;
pub mod render;
pub mod scene;
pub mod snapshot;
pub mod texture;

#[path = "../integrators/mod.rs"]
pub mod integrators;

pub use error::{Error, Result};
