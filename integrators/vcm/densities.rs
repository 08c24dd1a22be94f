//! vcm's technique densities of a path from its vertices alone: what guided-vcm's `p_u` is
//! (`Unguided::pdf_unguided`), and the densities a path vcm's tracer hands to a sink carries.
//!
//! A path y_0 .. y_k (camera first) has bdpt's k + 1 connection techniques (s light
//! vertices, t = k + 1 − s camera vertices; `paths::PathTerms`) and, at each mergeable y_j,
//! merging: the density `eta prod_{l <= j} pc[l] prod_{l >= j} pl[l]` with
//! `eta = pi r^2 N` (`PathTerms::merge_densities`). With these explicit densities a further
//! technique (the guider) joins the balance heuristic by adding its own density to their sum;
//! vcm's own tracer weighs by the same heuristic recursively, O(1) per path (`vertex.rs`).

use crate::integrators::bdpt::BdptSettings;
use crate::integrators::paths::{Kind, PathTerms, Vertex, path_terms_into};
use crate::path::MAX_VERTICES;
use crate::scene::Scene;

/// Whether a vertex can be merged at: a non-delta, non-black surface (not in media).
pub fn mergeable(scene: &Scene, v: &Vertex) -> bool {
    matches!(v.kind, Kind::Surface { .. }) && v.connectible(scene)
}

/// Every technique's density for the path `y` (camera first, an emitter last) from its
/// vertices alone: bdpt's techniques by s in `vc[..=k]` and, with `eta = pi r^2 N > 0`,
/// merging at each mergeable y_j in `vm[j]`; returns their sum, or `None` for a path of no
/// segment or of more than `max_depth`. `settings` gives the depth limit, the roulette and
/// whether emitters seen directly are splatted; `terms` is scratch (no allocation once grown).
pub fn densities_from_vertices(
    scene: &Scene,
    y: &[Vertex],
    settings: &BdptSettings,
    eta: f64,
    terms: &mut PathTerms,
    vc: &mut [f64; MAX_VERTICES],
    vm: &mut [f64; MAX_VERTICES],
) -> Option<f64> {
    let k = y.len().saturating_sub(1);
    if k == 0 || k > settings.max_depth as usize {
        return None;
    }
    path_terms_into(scene, y, settings.rr_depth, terms);
    terms.direct_by_camera &= !settings.direct_splats;
    terms.eta = eta;
    vc.fill(0.0);
    vm.fill(0.0);
    terms.technique_densities(vc);
    let merge = terms.merge_densities(|j| mergeable(scene, &y[j]), vm);
    Some(vc[..=k].iter().sum::<f64>() + merge)
}
