//! The camera subpath of one pixel and everything done at its vertices: emitter hits
//! (s = 0), next-event estimation (s = 1), connections to every stored vertex of the light
//! path with the same index (s, t >= 2), and merging with the stored vertices of all light
//! paths within the pass's radius. Each contribution is weighed by the balance heuristic
//! over all techniques, from the O(1) quantities of the two vertices it joins (VCM tech.
//! report §5; the equation numbers below are that report's).
//!
//! With a [`HeldPaths`] test (guided-vcm's render passes), a contribution whose path it holds
//! is kept, unweighted, as a [`Claimed`] path instead of added (the caller weighs it). The
//! exact test is made only where the low bits of the path's structure hash pass
//! (`HeldPaths::may_hold_hash`): the hash is joined from the camera subpath's part, kept as
//! the walk goes (`CameraSideHash`), and the light side's, an emitter's term or the
//! [`HeldKey`] kept with each light vertex and photon (`paths::structure`), so a merge reads
//! its photon's subpath only when the cache may hold the path.

use super::light_paths::{LightPaths, Photon};
use super::vertex::{
    Edge, Mis, MisVertex, connectible_light, emission_densities, hittable, nee_density,
};
use super::walk::{Step, Walk};
use super::{Claims, Inspector, PassConstants, Record, Technique, VcmSettings, joined};
use crate::bsdf::TransportMode;
use crate::geometry::{HashGrid, gamma};
use crate::integrators::paths::Kind;
use crate::integrators::paths::structure::{CameraSideHash, HeldKey, emitter_hash};
use crate::integrators::unguided::HeldPaths;
use crate::math::{Sampler, Spectrum, luminance};
use crate::path::{MAX_VERTICES, Vertex as PathVertex, VertexKind};
use crate::scene::{Endpoint, Scene};
use glam::{Vec2, Vec3};
use std::cell::RefCell;

/// vcm's camera side: traces a camera subpath and, at every vertex, connects to the pass's
/// light subpaths and merges with their photons, with recursive MIS weights.
pub struct CameraTracer<'a, 'p> {
    /// The scene rendered.
    pub scene: &'a Scene,
    /// vcm's settings.
    pub settings: &'p VcmSettings,
    /// The pass's radius and MIS factors.
    pub pc: &'p PassConstants,
    /// The pass's light subpaths, connected to.
    pub lights: &'p LightPaths<'a>,
    /// The pass's photons, merged with (`None` with merging off).
    pub grid: Option<&'p HashGrid<Photon>>,
    /// Receives every weighted contribution, when inspecting.
    pub inspector: Option<&'p Inspector<'p>>,
    /// Contributions whose path this holds are kept in `claimed` instead of added.
    pub claims: Option<&'p dyn HeldPaths>,
    claimed: RefCell<Claims>,
    /// Claimed contributions whose luminance under vcm's weight is at most this are kept
    /// without their vertices (`Claims::dim`; the sink's `PathSink::own_weight_floor`).
    pub dim_floor: f64,
    /// The camera subpath's vertices (inspection and claims only).
    path: Vec<PathVertex>,
    /// Their structure hash (claims only), which a claim tests first (`may_claim`).
    side: CameraSideHash,
    /// The pixel being traced.
    pixel: u32,
}

impl<'a, 'p> CameraTracer<'a, 'p> {
    /// A tracer of the pass given by `pc`, `lights` and `grid`.
    pub fn new(
        scene: &'a Scene,
        settings: &'p VcmSettings,
        pc: &'p PassConstants,
        lights: &'p LightPaths<'a>,
        grid: Option<&'p HashGrid<Photon>>,
        inspector: Option<&'p Inspector<'p>>,
        claims: Option<&'p dyn HeldPaths>,
    ) -> Self {
        CameraTracer {
            scene,
            settings,
            pc,
            lights,
            grid,
            inspector,
            claims,
            claimed: RefCell::default(),
            dim_floor: f64::NEG_INFINITY,
            path: Vec::new(),
            side: CameraSideHash::default(),
            pixel: 0,
        }
    }

    /// The paths claimed since they were last cleared (`claims`), in the order formed.
    pub fn claimed(&mut self) -> &mut Claims {
        self.claimed.get_mut()
    }

    /// Whether the camera subpath's vertices are recorded.
    fn records(&self) -> bool {
        self.inspector.is_some() || self.claims.is_some()
    }

    /// The value of camera path `k` through raster position `raster`.
    pub fn sample(&mut self, k: usize, raster: Vec2, sampler: &mut impl Sampler) -> Spectrum {
        let (scene, st) = (self.scene, self.settings);
        let max = st.max_depth;
        let cam = &scene.camera;
        let ray = cam.generate_ray(raster);
        let pdf_we = cam.pdf_we(ray.d);
        if pdf_we <= 0.0 {
            return Spectrum::ZERO;
        }
        self.pixel = k as u32;
        if self.records() {
            self.path.clear();
            self.path.push(PathVertex {
                p: cam.position,
                n: Vec3::ZERO,
                ns: Vec3::ZERO,
                uv: glam::Vec2::ZERO,
                tangent: Vec3::ZERO,
                kind: VertexKind::Camera,
            });
            if self.claims.is_some() {
                self.side = CameraSideHash::default();
                self.side.push(scene, &self.path[0]);
            }
        }
        let mut walk = Walk::camera(scene, ray, pdf_we);
        walk.q_cap = super::walk::deep_continuation(self.settings.max_depth);
        let mut l = Spectrum::ZERO;
        // No vertex so far where merging could take over (bpm counts emitter hits only then).
        let mut no_merge_vertex = true;
        loop {
            let prev_p = walk.prev_p;
            let (v, light) = match walk.trace(scene, sampler) {
                Step::Vertex { v, light } => (v, light),
                Step::Escaped { dir, mis } => {
                    l += self.escaped(&walk, prev_p, dir, &mis, no_merge_vertex);
                    break;
                }
                Step::Dead => break,
            };
            let i = v.depth;
            if let Some(li) = light {
                l += self.emitter_hit(&v, li, prev_p, walk.vacuum, no_merge_vertex);
            }
            if i >= max {
                break;
            }
            if self.records() {
                let x = v.path_vertex();
                self.path.push(x);
                if self.claims.is_some() {
                    self.side.push(scene, &x);
                }
            }
            // Merging's bucket, asked for now so that its cache misses overlap the
            // connections below.
            let bucket = match self.grid {
                Some(grid) if v.mergeable() => {
                    let b = grid.bucket_of(v.p);
                    grid.prefetch_range(b);
                    Some((grid, b))
                }
                _ => None,
            };
            if v.connectible() && st.connect {
                l += self.next_event(&v, sampler);
                if let Some((grid, b)) = bucket {
                    grid.prefetch_entries(b);
                }
                let keys = self.lights.connect_keys(k);
                for (j, y) in self.lights.path(k).iter().enumerate() {
                    if y.depth + 1 + i <= max {
                        let key = keys.get(j).map_or(HeldKey::NONE, |k| k[1]);
                        l += self.connect(&v, y, k, key);
                    }
                }
            }
            if v.mergeable() {
                no_merge_vertex = false;
                if let Some(grid) = self.grid {
                    l += self.merge(&v, grid);
                }
            }
            if !walk.scatter(scene, &v, self.pc.factors, sampler) {
                break;
            }
            if walk.left_delta
                && self.records()
                && let Some(x) = self.path.last_mut()
            {
                // The recorded vertex is inside every path that goes on from here.
                x.set_delta(true);
            }
        }
        l
    }

    /// s = 0: the camera walk's vertex `v` lies on light `li`, reached from `prev_p` along a
    /// segment that crossed no medium if `vacuum`.
    fn emitter_hit(
        &self,
        v: &MisVertex<'a>,
        li: usize,
        prev_p: Vec3,
        vacuum: bool,
        only: bool,
    ) -> Spectrum {
        let scene = self.scene;
        let l = &scene.lights[li];
        let le = l.le(v.p, v.n, v.wo);
        if le == Spectrum::ZERO {
            return Spectrum::ZERO;
        }
        let w = if !self.settings.connect {
            // Merging only: emitter hits count where no merge can produce the path.
            if only { 1.0 } else { 0.0 }
        } else {
            let (p_origin, p_emit) = emission_densities(scene, li, v.n, v.wo);
            let m = &v.mis;
            // (49); a directly seen emitter competes with light tracing its origin, unless it
            // fills the pixel with nothing but vacuum between (then it is left to this
            // technique).
            let w_cam = if v.depth == 1 {
                let left_to_camera = !self.settings.direct_splats
                    && vacuum
                    && crate::integrators::paths::direct_to_camera(scene, li, v.p);
                if connectible_light(l) && !left_to_camera {
                    p_origin * m.d_vcm
                } else {
                    0.0
                }
            } else {
                let p_nee = nee_density(scene, li, prev_p, v.p, v.n, -v.wo);
                p_nee * m.d_vcm + p_origin * p_emit * m.d_vc
            };
            1.0 / (1.0 + w_cam)
        };
        crate::check::weight(crate::check::Technique::named("vcm emitter hit"), w as f64);
        if self.inspector.is_some() {
            self.record_emitter(0, li, v.p, v.n, false, w);
        }
        let y = emitter_vertex(li, v.p, v.n, false);
        if self.may_claim_emitter(&y)
            && self.claim(Technique::Connect { s: 0 }, &[y], v.beta * le, w)
        {
            return Spectrum::ZERO;
        }
        v.beta * le * w
    }

    /// s = 0 at infinity: the walk escaped along `dir`; every light at infinity is seen.
    fn escaped(&self, walk: &Walk, prev_p: Vec3, dir: Vec3, m: &Mis, only: bool) -> Spectrum {
        let scene = self.scene;
        let mut sum = Spectrum::ZERO;
        for &li in &scene.infinite_lights {
            let le = scene.lights[li].le(Vec3::ZERO, Vec3::ZERO, dir);
            if le == Spectrum::ZERO {
                continue;
            }
            let w = if !self.settings.connect {
                if only { 1.0 } else { 0.0 }
            } else if walk.depth == 1 {
                1.0
            } else {
                let p_nee = nee_density(scene, li, prev_p, prev_p + dir, dir, dir);
                let (p_origin, p_emit) = emission_densities(scene, li, dir, -dir);
                1.0 / (1.0 + p_nee * m.d_vcm + p_origin * p_emit * m.d_vc)
            };
            if self.inspector.is_some() {
                self.record_emitter(0, li, prev_p + dir, dir, false, w);
            }
            let y = emitter_vertex(li, prev_p + dir, dir, false);
            if !(self.may_claim_emitter(&y)
                && self.claim(Technique::Connect { s: 0 }, &[y], walk.beta * le, w))
            {
                sum += walk.beta * le * w;
            }
        }
        sum
    }

    /// s = 1: next-event estimation from `v`.
    fn next_event(&self, v: &MisVertex<'a>, sampler: &mut impl Sampler) -> Spectrum {
        let scene = self.scene;
        let (u_light, u) = (sampler.next_1d(), sampler.next_2d());
        let Some((li, pick)) = scene.light_sampler.sample(u_light) else {
            return Spectrum::ZERO;
        };
        let l = &scene.lights[li];
        let Some(ls) = l.sample_li(v.p, u) else {
            return Spectrum::ZERO;
        };
        if ls.pdf <= 0.0 {
            return Spectrum::ZERO;
        }
        let (f, pdf_to_light, pdf_back) = v.f_pdfs(scene, ls.wi, TransportMode::Radiance);
        if f == Spectrum::ZERO {
            return Spectrum::ZERO;
        }
        let infinite = l.is_infinite();
        let end = (!infinite).then_some(Endpoint {
            p: ls.p,
            n: ls.n,
            err: gamma(8) * ls.p.abs(),
        });
        let Some(tr) = scene.transmittance(
            &v.endpoint(),
            end.as_ref(),
            ls.wi,
            v.medium_towards(scene, ls.wi),
        ) else {
            return Spectrum::ZERO;
        };
        let c = v.beta * f * ls.li * tr.tr / (pick * ls.pdf);
        // Densities of the light vertex y (NEE and the BSDF hitting it) and of v from y.
        let (y_p, y_n) = if infinite {
            (v.p + ls.wi, ls.wi)
        } else {
            (ls.p, ls.n)
        };
        let p_nee = nee_density(scene, li, v.p, y_p, y_n, ls.wi);
        let (d2, cos_y) = if infinite {
            (1.0, 1.0)
        } else {
            ((ls.p - v.p).length_squared(), ls.n.dot(ls.wi).abs())
        };
        let edge = Edge::along(&tr);
        // (44): the BSDF sampling the light point (s = 0).
        let w_light = if hittable(scene, li) {
            pdf_to_light * cos_y / d2 * edge.pass / p_nee
        } else {
            0.0
        };
        // (45): the light's emission sampling v, and the camera side's techniques.
        let (p_origin, p_emit) = emission_densities(scene, li, y_n, -ls.wi);
        let p_rev_v = p_emit * v.cos(ls.wi) / if infinite { 1.0 } else { d2 }
            * edge.factor(scene, v.is_medium(), false);
        let merge = if v.mergeable() {
            self.pc.factors.vm
        } else {
            0.0
        };
        let m = &v.mis;
        let w_cam = p_origin * p_rev_v / p_nee * (merge + m.d_vcm + m.d_vc * pdf_back);
        let w = 1.0 / (w_light + 1.0 + w_cam);
        crate::check::weight(crate::check::Technique::named("vcm next-event"), w as f64);
        if self.inspector.is_some() {
            self.record_emitter(1, li, y_p, y_n, l.is_delta(), w);
        }
        let y = emitter_vertex(li, y_p, y_n, l.is_delta());
        if self.may_claim_emitter(&y) && self.claim(Technique::Connect { s: 1 }, &[y], c, w) {
            return Spectrum::ZERO;
        }
        c * w
    }

    /// s, t >= 2: connect camera vertex `v` with light vertex `y`.
    fn connect(&self, v: &MisVertex<'a>, y: &MisVertex<'a>, k: usize, key: HeldKey) -> Spectrum {
        let scene = self.scene;
        let d = y.p - v.p;
        let d2 = d.length_squared();
        if d2 == 0.0 {
            return Spectrum::ZERO;
        }
        let dir = d / d2.sqrt();
        // f at each end, and each end's densities towards the other and back.
        let (fv, pdf_v_to_y, pdf_v_back) = v.f_pdfs(scene, dir, TransportMode::Radiance);
        if fv == Spectrum::ZERO {
            return Spectrum::ZERO;
        }
        let (fy, pdf_y_to_v, pdf_y_back) = y.f_pdfs(scene, -dir, TransportMode::Importance);
        if fy == Spectrum::ZERO {
            return Spectrum::ZERO;
        }
        let Some(tr) = scene.transmittance(
            &v.endpoint(),
            Some(&y.endpoint()),
            dir,
            v.medium_towards(scene, dir),
        ) else {
            return Spectrum::ZERO;
        };
        let c = v.beta * fv * tr.tr * fy * y.beta / d2;
        let edge = Edge::along(&tr);
        let vm = self.pc.factors.vm;
        // (40): the camera side sampling y, then the light side's techniques.
        let p_y = pdf_v_to_y * y.cos(dir) / d2 * edge.factor(scene, y.is_medium(), true);
        let w_light =
            p_y * (if y.mergeable() { vm } else { 0.0 } + y.mis.d_vcm + y.mis.d_vc * pdf_y_back);
        // (41): the light side sampling v, then the camera side's techniques.
        let p_v = pdf_y_to_v * v.cos(dir) / d2 * edge.factor(scene, v.is_medium(), false);
        let w_cam =
            p_v * (if v.mergeable() { vm } else { 0.0 } + v.mis.d_vcm + v.mis.d_vc * pdf_v_back);
        let w = 1.0 / (w_light + 1.0 + w_cam);
        crate::check::weight(crate::check::Technique::named("vcm connection"), w as f64);
        if self.records() {
            let recorded = &self.lights.full(k)[..=y.depth as usize];
            // The vertex the connection leaves is not delta in the connected path, whatever
            // lobe its light walk took next (the record says the latter, `Walk::left_delta`;
            // only smooth plastic makes the two differ): then a copy, on the stack, says so.
            let patched;
            let light = match recorded.last().map(|x| x.kind) {
                Some(VertexKind::Surface { delta: true, .. }) => {
                    let mut copy = [PathVertex::EMPTY; MAX_VERTICES];
                    copy[..recorded.len()].copy_from_slice(recorded);
                    copy[recorded.len() - 1].set_delta(false);
                    patched = copy;
                    &patched[..recorded.len()]
                }
                _ => recorded,
            };
            let technique = Technique::Connect { s: light.len() };
            if let Some(insp) = self.inspector {
                self.record(insp, technique, light, w);
            }
            let (d, next) = (y.depth as usize + 1, Some(y.p));
            if self.may_claim(key, d, next) && self.claim(technique, light, c, w) {
                return Spectrum::ZERO;
            }
        }
        c * w
    }

    /// Merge at `v` with every stored light vertex within the radius (whose path is not too
    /// long), normalised by 1 / (pi r^2 N).
    fn merge(&self, v: &MisVertex<'a>, grid: &HashGrid<Photon>) -> Spectrum {
        let max = self.settings.max_depth;
        let vc = self.pc.factors.vc;
        let mut sum = Spectrum::ZERO;
        let Kind::Surface { bsdf, frame, .. } = v.kind else {
            return Spectrum::ZERO;
        };
        // Both directions' densities at v, as `MisVertex::f_pdfs` gives them (v is not delta).
        let q = bsdf.continuation().min(v.q_cap);
        let w_cam_vertex = v.mis.d_vcm * vc;
        let mut photons = 0u64;
        grid.query(v.p, |y| {
            if y.depth as u32 + v.depth > max {
                return;
            }
            photons += 1;
            // f, and the densities of y.wo from v.wo and back, in one evaluation.
            let e = bsdf.eval_pdfs(&frame, v.wo, y.wo, TransportMode::Radiance);
            if e.f == Spectrum::ZERO {
                return;
            }
            let f = e.f;
            // (42)-(43): both sides' techniques from the camera BSDF's densities at v.
            let w_light = y.d_vcm * vc + y.d_vm * (e.pdf_fwd * q);
            let w_cam = w_cam_vertex + v.mis.d_vm * (e.pdf_rev * q);
            let w = 1.0 / (w_light + 1.0 + w_cam);
            crate::check::weight(crate::check::Technique::named("vcm merge"), w as f64);
            if self.records() {
                // The subpath is read only for inspection, or where its structure hash's
                // low bits say the cache may hold the path.
                let may_claim = self.may_claim(y.held, y.depth as usize, None);
                if may_claim && self.inspector.is_none() {
                    let c = v.beta * f * y.beta * self.pc.vm_normalization;
                    if self.claim_dim(c * w) {
                        return;
                    }
                }
                if may_claim || self.inspector.is_some() {
                    let full = self
                        .lights
                        .full(self.lights.path_of_vertex(y.index as usize));
                    let light = &full[..y.depth as usize];
                    let technique = Technique::Merge {
                        t: self.path.len() - 1,
                    };
                    if let Some(insp) = self.inspector {
                        self.record(insp, technique, light, w);
                    }
                    let c = v.beta * f * y.beta * self.pc.vm_normalization;
                    if may_claim && self.claim(technique, light, c, w) {
                        return;
                    }
                }
            }
            sum += f * y.beta * w;
        });
        if self.claims.is_some() {
            // Inside the guider, whose share compares techniques by rays traced: a photon's
            // evaluation (its cache misses, BSDF and weight) costs about a ray (measured on
            // dining, one thread: 0.55 M photons took 0.3-0.7 s where 4.9 M rays took 3.9-5.1 s).
            crate::geometry::bvh::count_ray_equivalents(photons);
        }
        v.beta * sum * self.pc.vm_normalization
    }

    /// Record a technique ending on light `li` (at `p`, normal `n`): s = 0 (hit) or 1 (NEE).
    fn record_emitter(&self, s: usize, li: usize, p: Vec3, n: Vec3, delta: bool, w: f32) {
        let Some(insp) = self.inspector else { return };
        let y = emitter_vertex(li, p, n, delta);
        self.record(insp, Technique::Connect { s }, &[y], w);
    }

    /// Hand the camera path so far, then `light` reversed, to the inspector.
    fn record(&self, insp: &Inspector, technique: Technique, light: &[PathVertex], w: f32) {
        (insp.borrow_mut())(&Record {
            technique,
            path: joined(&self.path, light),
            weight: w as f64,
        });
    }

    /// Whether `claims` may hold the camera path so far followed by a light side of `d`
    /// vertices with structure hash `key` (`HeldKey`, low bits) whose vertex next to the
    /// camera side is at `next` (`None`: a merge, where it is not read): the test of the
    /// hashes' low bits, which [`Self::claim`]'s exact test follows only where it passes.
    fn may_claim(&self, key: HeldKey, d: usize, next: Option<Vec3>) -> bool {
        let Some(claims) = self.claims else {
            return false;
        };
        if key.is_none() {
            return false;
        }
        let (lights, n) = key.hashes(d - 1);
        lights[..n].iter().any(|&light| {
            let (hs, m) = self.side.joined(self.scene, next, light, d, MAX_VERTICES);
            hs[..m].iter().any(|&h| claims.may_hold_hash(h))
        })
    }

    /// [`Self::may_claim`] for a light side of one vertex, the emitter `y`.
    fn may_claim_emitter(&self, y: &PathVertex) -> bool {
        let Some(claims) = self.claims else {
            return false;
        };
        let Some(light) = emitter_hash(self.scene, y) else {
            return false;
        };
        let (hs, m) = self
            .side
            .joined(self.scene, Some(y.p), light, 1, MAX_VERTICES);
        hs[..m].iter().any(|&h| claims.may_hold_hash(h))
    }

    /// If `claims` holds the camera path so far followed by `light` reversed, keep it with
    /// its unweighted value `c` (vcm's weight `w` beside it) and return true.
    fn claim(&self, technique: Technique, light: &[PathVertex], c: Spectrum, w: f32) -> bool {
        let Some(claims) = self.claims else {
            return false;
        };
        if self.claim_dim(c * w) {
            return true;
        }
        if !claims.holds(self.scene, &self.path, light) {
            return false;
        }
        let (path, pixel) = (&self.path[..], self.pixel);
        (self.claimed.borrow_mut()).push(technique, (path, light), (pixel, c, w));
        true
    }

    /// Keep a contribution of value `weighted` under vcm's weight without its path when it
    /// is at or below `dim_floor` (whatever `claims` holds: the caller books it at vcm's
    /// weight either way), and return true.
    fn claim_dim(&self, weighted: Spectrum) -> bool {
        // NaN compares false: an invalid value keeps its path (the sink counts it).
        let dim = luminance(weighted) as f64 <= self.dim_floor;
        if !dim {
            return false;
        }
        (self.claimed.borrow_mut()).push_dim(self.pixel, weighted);
        true
    }
}

/// The vertex of a path on light `li` at `p` (normal `n`; for lights at infinity the
/// direction towards them).
fn emitter_vertex(li: usize, p: Vec3, n: Vec3, delta: bool) -> PathVertex {
    PathVertex {
        p,
        n,
        ns: Vec3::ZERO,
        uv: glam::Vec2::ZERO,
        tangent: Vec3::ZERO,
        kind: VertexKind::Emitter {
            light: li as u32,
            delta,
        },
    }
}
