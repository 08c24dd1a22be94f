//! The guided estimators' counters ([`Stats`]): guided samples and why they failed, p_g's
//! work, rays, and where U's second moment sits by what the cache offers it; summed over a
//! pass's rows and passes, and reported at the end of a render (`report.rs`).

/// Why a guided sample failed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Failure {
    /// The first direction leaves the image.
    OffImage,
    /// A ray towards a surface vertex hit nothing, or a surface of another kind (delta or
    /// not) than the guide's vertex.
    Miss,
    /// The path's structure (modes, delta flags) differs from the guide's.
    Structure,
    /// BSDF or phase sampling produced nothing, or a drawn distance was not positive.
    Scatter,
    /// A medium target is not visible or not in the guide's medium.
    Occluded,
    /// The step to the emitter does not reach it: a specular or BSDF direction outside a
    /// light's cone, or a ray towards the emitter that hits something else first.
    Light,
    /// The specular-chain step's Newton walk did not converge (`manifold/`).
    NoConvergence,
    /// The specular-chain step converged, but the walk from the path's own far end returns
    /// another chain (the basin indicator is 0 for the path drawn).
    OtherChain,
}

/// Names of [`Stats::reasons`], in order.
pub const FAILURE_REASONS: &str =
    "offimage_miss_structure_scatter_occluded_light_noconvergence_otherchain_zero_edge_nonfinite";
/// Index of the reasons that are not [`Failure`]s.
pub(super) const ZERO: usize = 8;
pub(super) const EDGE: usize = 9;
pub(super) const NON_FINITE: usize = 10;

/// Counters of one or more passes.
#[derive(Debug, Clone, Copy, Default)]
pub struct Stats {
    /// Guided samples drawn.
    pub guided: u64,
    /// Guided samples that failed (a sample of value zero that still counts).
    pub failed: u64,
    /// Failures by reason ([`FAILURE_REASONS`]): off the image, missed / wrong vertex,
    /// structure (mode), scatter, occluded medium target, emitter not reached by the step to
    /// it, the specular-chain step's walk did not converge, or the path's own walk returns
    /// another chain, zero contribution, own guide's term zero on re-evaluation (a truncation edge),
    /// non-finite value.
    pub reasons: [u64; 11],
    /// Failures of the walk ([`Failure`]) by the vertex it was drawing: x_1 ..
    /// x_6, then x_7 and later.
    pub failed_by_vertex: [u64; PG_ZERO_VERTICES],
    /// Evaluations of p_g (paths of a held structure).
    pub pg_evaluations: u64,
    /// Candidate guide paths whose terms those evaluations computed.
    pub pg_candidates: u64,
    /// Of `pg_evaluations` and `pg_candidates`, those of guided samples.
    pub pg_evaluations_guided: u64,
    /// Guided samples whose walk the specular-chain step completed (`manifold/`), before
    /// the basin check and the contribution.
    pub chain_steps: u64,
    /// Of `pg_candidates`, those of guided samples.
    pub pg_candidates_guided: u64,
    /// Unguided paths dropped for a non-finite or negative value.
    pub invalid: u64,
    /// Unguided paths U formed whose density recomputed from their vertices is 0 (see
    /// [`Estimator::densities`](super::estimator::Estimator::densities)); they keep U's own
    /// density.
    pub pu_disagreements: u64,
    /// Queries of the first-vertex BVH (one per distinct x_1 with `X1Candidates::reuse`).
    pub bvh_queries: u64,
    /// Rays traced by the unguided technique (the share's cost measure).
    pub rays_u: u64,
    /// Rays traced by the guided technique.
    pub rays_g: u64,
    /// U's paths by what the cache offers them (in [`Coverage`](super::estimator::Coverage)
    /// order): how many, and the sum of their contributions' squared luminance (the second
    /// moment each class adds to the image, `f / (p_u + (n_g / n_u) p_g)` squared): where
    /// U's error sits that guiding does or cannot reduce.
    pub coverage_paths: [u64; 3],
    /// Sum of squared luminance of U's paths by coverage class (see `coverage_paths`).
    pub coverage_m2: [f64; 3],
    /// The second moment of the `Zero` class by the vertex where p_g vanished
    /// ([`Densities::vanished_at`](super::estimator::Densities::vanished_at); index v - 1
    /// for x_v, the last bucket x_7 and later).
    pub pg_zero_m2_by_vertex: [f64; PG_ZERO_VERTICES],
}

/// Buckets of [`Stats::pg_zero_m2_by_vertex`]: x_1 .. x_6, then x_7 and later.
pub const PG_ZERO_VERTICES: usize = 7;

/// Names of [`Stats::coverage_paths`] and [`Stats::coverage_m2`], in order.
pub const COVERAGE_CLASSES: [&str; 3] = ["structure_not_held", "pg_zero", "covered"];

impl Stats {
    /// Add another's counters to these.
    pub fn add(&mut self, o: &Stats) {
        self.guided += o.guided;
        self.failed += o.failed;
        self.pg_evaluations += o.pg_evaluations;
        self.pg_candidates += o.pg_candidates;
        self.pg_candidates_guided += o.pg_candidates_guided;
        self.pg_evaluations_guided += o.pg_evaluations_guided;
        self.chain_steps += o.chain_steps;
        self.invalid += o.invalid;
        self.pu_disagreements += o.pu_disagreements;
        self.bvh_queries += o.bvh_queries;
        self.rays_u += o.rays_u;
        self.rays_g += o.rays_g;
        for c in 0..3 {
            self.coverage_paths[c] += o.coverage_paths[c];
            self.coverage_m2[c] += o.coverage_m2[c];
        }
        for (a, b) in self
            .pg_zero_m2_by_vertex
            .iter_mut()
            .zip(o.pg_zero_m2_by_vertex)
        {
            *a += b;
        }
        for (a, b) in self.failed_by_vertex.iter_mut().zip(o.failed_by_vertex) {
            *a += b;
        }
        for (a, b) in self.reasons.iter_mut().zip(o.reasons) {
            *a += b;
        }
    }

    pub(super) fn fail(&mut self, reason: usize) {
        self.failed += 1;
        self.reasons[reason] += 1;
    }

    /// A walk that failed while drawing vertex `v` (1 for x_1).
    pub(super) fn fail_at(&mut self, why: Failure, v: usize) {
        self.fail(why as usize);
        self.failed_by_vertex[v.clamp(1, PG_ZERO_VERTICES) - 1] += 1;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use Failure::{self, *};

    /// The report names `Stats::reasons` by [`FAILURE_REASONS`] while walks count at
    /// `Failure as usize`: the orders must agree. (The match names every `Failure`.)
    #[test]
    fn failure_reasons_are_named_in_the_order_they_are_counted() {
        let name = |f: Failure| match f {
            OffImage => "offimage",
            Miss => "miss",
            Structure => "structure",
            Scatter => "scatter",
            Occluded => "occluded",
            Light => "light",
            NoConvergence => "noconvergence",
            OtherChain => "otherchain",
        };
        let names: Vec<&str> = FAILURE_REASONS.split('_').collect();
        assert_eq!(names.len(), Stats::default().reasons.len());
        for f in [
            OffImage,
            Miss,
            Structure,
            Scatter,
            Occluded,
            Light,
            NoConvergence,
            OtherChain,
        ] {
            assert_eq!(names[f as usize], name(f), "{f:?}");
        }
        assert_eq!(
            [names[ZERO], names[EDGE], names[NON_FINITE]],
            ["zero", "edge", "nonfinite"]
        );
    }

    /// The estimator passes the length of the walk's path buffer, which holds x_0 .. x_{v-1}
    /// when drawing x_v fails: x_1 .. x_6 get a bucket each, x_7 and later share the last.
    #[test]
    fn a_failed_walk_counts_at_the_vertex_it_was_drawing() {
        let mut s = Stats::default();
        for (why, v) in [
            (OffImage, 1),
            (Light, 4),
            (Structure, 6),
            (Light, 7),
            (Miss, 12),
        ] {
            s.fail_at(why, v);
        }
        assert_eq!(s.failed, 5);
        assert_eq!(s.failed_by_vertex, [1, 0, 0, 1, 0, 1, 2]);
        assert_eq!(s.reasons, [1, 1, 1, 0, 0, 2, 0, 0, 0, 0, 0]);
    }
}
