//! The MIS weights of bdpt's techniques. Explicit: each connection assembles the densities
//! of every technique that could have made its path (`PathTerms`, from the subpaths' caches
//! and the densities across the connection edge), and the balance or power heuristic weighs
//! its own technique among them. Recursive (`weight_recursive`, used when roulette starts at
//! the first bounce and nothing inspects the densities): the same weight from one running sum
//! per subpath vertex, O(1) per connection.

use super::*;
use cache::heuristic;

/// The densities across the connection edge y_{t-1} - y_t of technique (s, t), each in the
/// measure of the vertex it generates, free flight included, roulette not.
#[derive(Default)]
pub(super) struct Bridge {
    /// `pc[t]`: y_t generated from y_{t-1} (having come from y_{t-2}).
    pub(super) cam_next: f32,
    /// `pl[t-1]`: y_{t-1} generated from y_t (having come from y_{t+1}).
    pub(super) light_next: f32,
    /// `pl[t-2]` (t >= 3): y_{t-2} generated from y_{t-1}, having come from y_t.
    pub(super) cam_back: f32,
    /// `pc[t+1]` (s >= 2): y_{t+1} generated from y_t, having come from y_{t-1}.
    pub(super) light_back: f32,
}

impl<'a> Tracer<'a> {
    /// MIS weight of technique (s, t) for the path camera prefix `c` + reversed light prefix
    /// `lp` (with their caches), given the densities across the connection and `nee_k`, the
    /// next-event density of the light vertex.
    pub(super) fn weight_connection(
        &mut self,
        c: &[Vertex<'a>],
        cc: &[Cached],
        lp: &[Vertex<'a>],
        lc: &[Cached],
        bridge: &Bridge,
        nee_k: f64,
    ) -> f64 {
        let scene = self.scene;
        let rr_depth = self.settings.rr_depth;
        let (t, s) = (c.len(), lp.len());
        let k = s + t - 1;
        let Kind::Light { light } = lp[0].kind else {
            return 0.0;
        };
        let recursive = self
            .recursive_mis()
            .then(|| weight_recursive(cc, lc, bridge, nee_k, self.settings.heuristic));
        if let Some(w) = recursive
            && !self.recording
        {
            return w;
        }
        // Roulette when leaving a vertex of local probability q after `segments` segments.
        let rr = |q: f32, segments: usize| roulette(q, segments, rr_depth) as f64;
        let terms = &mut self.terms;
        terms.reset(k);
        terms.hittable = hittable(scene, light);
        terms.nee_k = nee_k;
        // y_j is c[j] for j < t and lp[k - j] from t on; inside either subpath a vertex the
        // walk left through a delta lobe joins no connection (the two ends always can).
        for (j, v) in cc.iter().enumerate() {
            terms.connectible[j] = v.connectible && (j + 1 == t || !c[j].is_specular_surface());
        }
        for (i, v) in lc.iter().enumerate() {
            terms.connectible[k - i] =
                v.connectible && (i + 1 == s || !lp[i].is_specular_surface());
        }
        // Camera side: the camera walk's own densities, the two across the connection, then
        // the light walk's reverse densities with camera-side roulette.
        terms.pc[1..t]
            .iter_mut()
            .zip(&cc[1..t])
            .for_each(|(p, v)| *p = v.fwd);
        terms.pc[t] = bridge.cam_next as f64 * if t >= 2 { rr(cc[t - 1].q, t - 1) } else { 1.0 };
        if s >= 2 {
            terms.pc[t + 1] = bridge.light_back as f64 * rr(lc[s - 1].q, t);
        }
        for j in t + 2..=k {
            let i = k - j;
            terms.pc[j] = rr(lc[i + 1].q, j - 1) * lp[i].pdf_rev as f64;
        }
        // Light side, symmetrically.
        for j in t..=k {
            terms.pl[j] = lc[k - j].fwd;
        }
        if t >= 2 {
            terms.pl[t - 1] =
                bridge.light_next as f64 * if s >= 2 { rr(lc[s - 1].q, s - 1) } else { 1.0 };
        }
        if t >= 3 {
            terms.pl[t - 2] = bridge.cam_back as f64 * rr(cc[t - 1].q, s);
        }
        for j in 1..t.saturating_sub(2) {
            terms.pl[j] = rr(cc[j + 1].q, k - j - 1) * c[j].pdf_rev as f64;
        }
        let terms = &self.terms;
        self.inspect(
            || {
                let mut y = Vec::with_capacity(k + 1);
                join_subpaths(c, lp, true, &mut y);
                y
            },
            s,
            terms,
        );
        if let Some(w) = recursive {
            return self.hold_recursive(w, s);
        }
        if self.recording {
            return self.hold(s);
        }
        self.densities.resize(self.densities.len().max(k + 1), 0.0);
        self.terms
            .weight_with(s, self.settings.heuristic, &mut self.densities)
    }

    pub(super) fn inspect(
        &self,
        path: impl FnOnce() -> Vec<Vertex<'a>>,
        s: usize,
        terms: &PathTerms,
    ) {
        if let Some(f) = &self.inspector {
            (f.borrow_mut())(&path(), s, terms);
        }
    }

    /// MIS weight of s = 0 for the camera path `c` (with its cache) whose last vertex is
    /// `emitter` (on `light`).
    pub(super) fn weight_emitter_hit(
        &mut self,
        c: &[Vertex<'a>],
        cc: &[Cached],
        emitter: &Vertex<'a>,
        light: usize,
    ) -> f64 {
        let scene = self.scene;
        let rr_depth = self.settings.rr_depth;
        let rr = |q: f32, segments: usize| roulette(q, segments, rr_depth) as f64;
        let k = c.len() - 1;
        let recursive = self
            .recursive_mis()
            .then(|| self.weight_emitter_hit_recursive(c, cc, emitter, light));
        if let Some(w) = recursive
            && !self.recording
        {
            return w;
        }
        let direct_by_camera =
            k == 1 && emitter.edge.first.is_none() && self.left_to_camera(light, emitter.p);
        let terms = &mut self.terms;
        terms.reset(k);
        for (j, v) in cc[..k].iter().enumerate() {
            terms.connectible[j] = v.connectible && !c[j].is_specular_surface();
        }
        terms.connectible[k] = emitter.connectible(scene);
        terms.hittable = hittable(scene, light);
        terms.direct_by_camera = direct_by_camera;
        terms.pc[1..=k]
            .iter_mut()
            .zip(&cc[1..=k])
            .for_each(|(p, v)| *p = v.fwd);
        terms.pl[k] = origin_density(scene, emitter, light) as f64;
        if k >= 2 {
            terms.pl[k - 1] = emitter_back(scene, c, emitter);
        }
        for j in 1..k.saturating_sub(1) {
            terms.pl[j] = rr(cc[j + 1].q, k - j - 1) * c[j].pdf_rev as f64;
        }
        terms.nee_k = nee_density(scene, &c[k - 1], emitter, light);
        let terms = &self.terms;
        self.inspect(
            || {
                c[..k]
                    .iter()
                    .chain(std::iter::once(emitter))
                    .copied()
                    .collect()
            },
            0,
            terms,
        );
        if let Some(w) = recursive {
            return self.hold_recursive(w, 0);
        }
        if self.recording {
            return self.hold(0);
        }
        self.densities.resize(self.densities.len().max(k + 1), 0.0);
        self.terms
            .weight_with(0, self.settings.heuristic, &mut self.densities)
    }
}

/// `pl[k - 1]` of an emitter hit: the density of y_{k-1} from the emitter point y_k, free
/// flight included (the light walk's second vertex; no roulette at the light).
fn emitter_back(scene: &Scene, c: &[Vertex], emitter: &Vertex) -> f64 {
    let k = c.len() - 1;
    (pdf(scene, emitter, None, &c[k - 1]) * emitter.edge.factor(scene, c[k - 1].is_medium(), false))
        as f64
}

/// The weight `1 / sum` of a technique whose relative sum is `sum` (>= 1); 0 when the sum
/// overflowed or is NaN (a zero own density).
pub(super) fn inverse_or_zero(sum: f64) -> f64 {
    if sum.is_finite() { 1.0 / sum } else { 0.0 }
}

/// Recursive MIS weight of technique (s, t) = (`lc.len()`, `cc.len()`) with the cached
/// sums of both subpaths (see the module doc): the same number as the explicit weight, for
/// roulette from the first bounce.
fn weight_recursive(
    cc: &[Cached],
    lc: &[Cached],
    bridge: &Bridge,
    nee_k: f64,
    h: Heuristic,
) -> f64 {
    let (t, s) = (cc.len(), lc.len());
    let r = |num: f64, den: f64| heuristic(h, num / den);
    let nee = s == 1 && t >= 2;
    // Light side of the connection: the techniques with more camera vertices. `pc[t]`, then
    // `pc[t + 1]`, replace the light vertices' forward densities.
    let pc_t = bridge.cam_next as f64 * if t >= 2 { cc[t - 1].q as f64 } else { 1.0 };
    let l = if nee {
        // Next-event estimation chose the light point: only the emitter hit has more.
        lc[0].mis_valid * r(pc_t, nee_k)
    } else {
        let inner = if s >= 2 {
            let pc_t1 = bridge.light_back as f64 * lc[s - 1].q as f64;
            let before = if s >= 3 { lc[s - 3].mis_sum } else { 0.0 };
            r(pc_t1, lc[s - 2].fwd) * (lc[s - 2].mis_valid_inside + before)
        } else {
            0.0
        };
        r(pc_t, lc[s - 1].fwd) * (lc[s - 1].mis_valid + inner)
    };
    // Camera side: the techniques with more light vertices. `pl[t - 1]`, then `pl[t - 2]`,
    // replace the camera vertices' forward densities.
    let c = if t >= 2 {
        let pl_t1 = bridge.light_next as f64 * if s >= 2 { lc[s - 1].q as f64 } else { 1.0 };
        let inner = if t >= 3 {
            let pl_t2 = bridge.cam_back as f64 * cc[t - 1].q as f64;
            r(pl_t2, cc[t - 2].fwd) * (cc[t - 2].mis_valid_inside + cc[t - 3].mis_sum)
        } else {
            0.0
        };
        let sum = r(pl_t1, cc[t - 1].fwd) * (cc[t - 1].mis_valid + inner);
        // Next-event estimation's own density has `p_nee` where the others have `p_origin`.
        if nee { sum * r(lc[0].fwd, nee_k) } else { sum }
    } else {
        0.0
    };
    inverse_or_zero(1.0 + c + l)
}

impl<'a> Tracer<'a> {
    /// Recursive MIS weight of s = 0 (see [`weight_recursive`]): only techniques with more
    /// light vertices, next-event estimation's among them.
    fn weight_emitter_hit_recursive(
        &self,
        c: &[Vertex<'a>],
        cc: &[Cached],
        emitter: &Vertex<'a>,
        light: usize,
    ) -> f64 {
        let scene = self.scene;
        let r = |num: f64, den: f64| heuristic(self.settings.heuristic, num / den);
        if !hittable(scene, light) {
            return 0.0;
        }
        let k = c.len() - 1;
        let pl_k = origin_density(scene, emitter, light) as f64;
        let others = if k == 1 {
            // The light point connected to the pinhole, unless the emitter fills the pixel
            // with nothing but vacuum between (then it is left to s = 0: `PathTerms`).
            let left_to_camera =
                emitter.edge.first.is_none() && self.left_to_camera(light, emitter.p);
            let connects = cc[0].connectible && emitter.connectible(scene) && !left_to_camera;
            if connects { r(pl_k, cc[1].fwd) } else { 0.0 }
        } else {
            let nee = if cc[k - 1].connectible && !c[k - 1].is_specular_surface() {
                r(nee_density(scene, &c[k - 1], emitter, light), cc[k].fwd)
            } else {
                0.0
            };
            let pl_k1 = emitter_back(scene, c, emitter);
            let before = r(pl_k1, cc[k - 1].fwd) * (cc[k - 1].mis_valid_inside + cc[k - 2].mis_sum);
            nee + r(pl_k, cc[k].fwd) * before
        };
        inverse_or_zero(1.0 + others)
    }
}
