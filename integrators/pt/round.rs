//! One round of a batch of paths (a segment each): the closest hits of their rays traced
//! together, then their next-event shadow rays together, then the paths that ended written
//! out. The buffers are kept per thread from row to row; the batched (`batch.rs`) and the
//! wavefront (`wavefront/`) tracers share them.

use super::{Deferred, PathState};
use crate::math::Spectrum;
use crate::scene::Scene;
use glam::Vec3;

thread_local! {
    /// The calling thread's round buffers, kept from row to row (also the wavefront's).
    pub(super) static ROUND: std::cell::RefCell<Round> = std::cell::RefCell::new(Round::default());
}

/// One round's buffers, kept across rounds.
#[derive(Default)]
pub(super) struct Round {
    pub(super) hits: Vec<Option<crate::geometry::Hit>>,
    /// Per path, whether it goes on after this round.
    pub(super) alive: Vec<bool>,
    /// Next-event samples of the round, and the path (index in the round) of each.
    pub(super) deferred: Vec<Deferred>,
    pub(super) owner: Vec<usize>,
    rays: Vec<crate::geometry::Ray>,
    queries: Vec<(Vec3, Vec3, f32)>,
    free: Vec<bool>,
}

impl Round {
    /// Start a round: the closest hits of the paths' rays into `hits`, the other buffers
    /// cleared.
    pub(super) fn trace(&mut self, scene: &Scene, paths: &[(usize, PathState)]) {
        self.rays.clear();
        self.rays.extend(paths.iter().map(|(_, p)| p.ray));
        scene.intersect_many(&self.rays, &mut self.hits);
        self.alive.clear();
        self.deferred.clear();
        self.owner.clear();
    }

    /// End a round once every path has pushed its `alive` flag and its next-event samples:
    /// the shadow rays traced together, each visible sample added to its path's radiance in
    /// the order they were pushed, and the paths that ended written to `out` (at their
    /// raster index) and dropped.
    pub(super) fn settle(
        &mut self,
        scene: &Scene,
        paths: &mut Vec<(usize, PathState)>,
        out: &mut [Spectrum],
    ) {
        self.queries.clear();
        self.queries
            .extend(self.deferred.iter().filter_map(|d| d.query));
        scene.unoccluded_many(&self.queries, &mut self.free);
        let mut free = self.free.iter();
        for (d, &k) in self.deferred.iter().zip(&self.owner) {
            let visible = d.query.is_none() || *free.next().expect("one answer per query");
            let value = if visible { d.value } else { Spectrum::ZERO };
            let path = &mut paths[k].1;
            path.l += d.beta * value;
        }
        let mut alive = self.alive.iter();
        paths.retain(|(i, path)| {
            let keep = *alive.next().expect("one flag per path");
            if !keep {
                out[*i] = path.l;
            }
            keep
        });
    }
}
