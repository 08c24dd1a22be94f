//! lodestar: a research renderer for selective guided sampling with complete light transport
//! paths (Reibold et al. 2018) and the unbiased estimators it is measured against.
//!
//! The framework lives in `src/` (scene, geometry, BSDFs, lights, camera, film, the pass
//! driver); integrators live in `integrators/`, one module each, registered by name in
//! `integrators/mod.rs`. See `DESIGN.md` in the project's shared notes for the map.

pub mod bench;
pub mod bsdf;
pub mod camera;
pub mod check;
pub mod clock;
pub mod dbor;
pub mod error;
pub mod film;
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

#[path = "../integrators/mod.rs"]
pub mod integrators;

pub use error::{Error, Result};
