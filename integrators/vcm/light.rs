//! Tracing the light subpaths of a pass: each from a light chosen by power, its connectible
//! vertices kept for connections and merging (in `light_paths.rs`), and each vertex
//! connected to the pinhole (light tracing, t = 1, splatted). Light path k uses the stream
//! (seed, pass, N + k) in `vcm` (the stream base is a parameter: guided-vcm's passes use
//! their own).
//!
//! With a [`HeldPaths`] test (guided-vcm's passes), every light-tracing path it holds is kept
//! unweighted as a [`Claimed`](super::Claimed) path instead of splatted, and every path's
//! vertices are recorded (`full`), as they are for inspection; the structure hash's part of
//! each subpath is kept beside its stored vertices (`LightRow::keys`), which the camera
//! tracer's claims test first.

use super::light_paths::{LightPaths, LightRow, pinhole};
use super::vertex::{Edge, MisVertex, connectible_light, emission, emission_densities, hittable};
use super::walk::{Step, Walk};
use super::{ClaimHead, Inspector, PassConstants, Record, Technique, VcmSettings, joined};
use crate::bsdf::TransportMode;
use crate::geometry::{Ray, gamma, offset_origin};
use crate::integrators::paths::direct_to_camera;
use crate::integrators::paths::structure::{HeldKey, LightSideHash};
use crate::integrators::unguided::HeldPaths;
use crate::math::{IndependentSampler, Sampler, Spectrum};
use crate::path::{MAX_VERTICES, Vertex as PathVertex, VertexKind};
use crate::scene::{Endpoint, Scene};
use glam::Vec3;
use rayon::prelude::*;

impl<'a> LightPaths<'a> {
    /// Trace `rows` rows of `row_len` paths each (row y holds paths `y row_len ..`) of pass
    /// `pass`, path k from stream `(seed, pass, streams + k)`, a row per task, into these
    /// buffers; light-tracing paths that `claims` holds are kept as [`Claimed`](super::Claimed) paths.
    #[allow(clippy::too_many_arguments)]
    pub fn trace(
        &mut self,
        scene: &'a Scene,
        settings: &VcmSettings,
        pc: &PassConstants,
        (seed, pass, streams): (u64, u64, u64),
        rows: usize,
        row_len: usize,
        claims: Option<&dyn HeldPaths>,
    ) {
        self.rows.resize_with(rows, LightRow::default);
        self.row_len = row_len;
        self.pinhole = pinhole(scene);
        self.rows.par_iter_mut().enumerate().for_each(|(y, row)| {
            let lt = LightTracer {
                scene,
                settings,
                pc,
                inspector: None,
                claims,
            };
            let rays = crate::geometry::bvh::rays_traced();
            lt.row_into(
                (seed, pass, streams),
                (y * row_len) as u64,
                row_len as u64,
                row,
            );
            row.rays = crate::geometry::bvh::rays_traced() - rays;
        });
        self.index();
    }

    /// All `n` paths of pass `pass` as one row, on this thread, by `tracer` (inspection).
    pub fn trace_one_row(
        &mut self,
        tracer: &LightTracer<'a, '_>,
        (seed, pass): (u64, u64),
        n: usize,
    ) {
        self.rows.resize_with(1, LightRow::default);
        self.row_len = n;
        self.pinhole = pinhole(tracer.scene);
        let streams = tracer.pc.light_paths as u64;
        tracer.row_into((seed, pass, streams), 0, n as u64, &mut self.rows[0]);
        self.index();
    }
}

/// Traces light subpaths and connects them to the camera.
pub struct LightTracer<'a, 'p> {
    pub scene: &'a Scene,
    pub settings: &'p VcmSettings,
    pub pc: &'p PassConstants,
    pub inspector: Option<&'p Inspector<'p>>,
    /// Light-tracing paths this holds are kept unweighted (`LightRow::claimed`).
    pub claims: Option<&'p dyn HeldPaths>,
}

impl<'a> LightTracer<'a, '_> {
    /// Light paths `first .. first + count` of pass `pass`, path k from stream
    /// `(seed, pass, streams + k)`, into `row` (cleared first).
    pub fn row_into(
        &self,
        (seed, pass, streams): (u64, u64, u64),
        first: u64,
        count: u64,
        row: &mut LightRow<'a>,
    ) {
        row.clear();
        for k in first..first + count {
            let mut sampler = IndependentSampler::new(seed, pass, streams + k);
            self.trace(&mut sampler, row);
            row.end_path();
        }
    }

    /// Whether every vertex of the paths is recorded (`LightRow::full`).
    fn records(&self) -> bool {
        self.inspector.is_some() || self.claims.is_some()
    }

    /// One light subpath into `row`: its connectible vertices, its light-tracing
    /// contributions (splats, or claimed paths), and (when recorded) all its vertices.
    pub fn trace(&self, sampler: &mut impl Sampler, row: &mut LightRow<'a>) {
        let (scene, st) = (self.scene, self.settings);
        let full_start = row.full.len();
        let max = st.max_depth;
        let Some((li, pick, e)) = scene.sample_emission(sampler) else {
            return;
        };
        let l = &scene.lights[li];
        let infinite = l.is_infinite();
        // For lights at infinity the origin's "normal" is the direction towards the light.
        let n0 = if infinite { -e.dir } else { e.n };
        let densities = emission_densities(scene, li, n0, e.dir);
        let cos0 = if e.n == Vec3::ZERO || infinite {
            1.0
        } else {
            e.n.dot(e.dir).abs()
        };
        let origin = PathVertex {
            p: e.p,
            n: n0,
            ns: Vec3::ZERO,
            uv: glam::Vec2::ZERO,
            tangent: Vec3::ZERO,
            kind: VertexKind::Emitter {
                light: li as u32,
                delta: l.is_delta(),
            },
        };
        // The structure hash of the subpath so far, when claims are tested.
        let mut side = LightSideHash::default();
        if self.records() {
            row.full.push(origin);
        }
        // The key of the subpath so far (`LightRow::keys`: a vertex's first key is the
        // second of the one before it).
        let mut key = HeldKey::NONE;
        if self.claims.is_some() {
            side.push(scene, &origin);
            key = side.key(scene);
        }
        let err = gamma(8) * e.p.abs();
        if st.connect && max >= 1 && connectible_light(l) {
            let u = scene.camera.splat_number(sampler);
            self.connect_origin(li, &e, densities.0, err, (row, u), &origin);
        }
        let beta = e.le * cos0 / (pick * e.pdf_pos * e.pdf_dir);
        let start = if e.n == Vec3::ZERO || infinite {
            e.p
        } else {
            offset_origin(e.p, err, e.n, e.dir)
        };
        let mut walk = Walk::light(
            Ray::new(start, e.dir),
            beta,
            li,
            e.p,
            n0,
            densities,
            cos0,
            infinite,
            hittable(scene, li),
            self.pc.factors,
        );
        walk.medium = scene.light_medium(li, n0, e.dir);
        walk.q_cap = super::walk::deep_continuation(st.max_depth);
        while let Step::Vertex { v, .. } = walk.trace(scene, sampler) {
            let mut keys = [HeldKey::NONE; 2];
            if self.records() {
                let x = v.path_vertex();
                row.full.push(x);
                if self.claims.is_some() {
                    side.push(scene, &x);
                    keys = [key, side.key(scene)];
                    key = keys[1];
                }
            }
            let j = v.depth;
            if v.connectible() {
                if st.connect && j < max {
                    let u = scene.camera.splat_number(sampler);
                    self.connect_camera(&v, (row, u), full_start, &side);
                }
                if j < max && (st.connect || v.mergeable()) {
                    row.vertices.push(v);
                    if self.claims.is_some() {
                        row.keys.push(keys);
                    }
                }
            }
            if j + 2 > max || !walk.scatter(scene, &v, self.pc.factors, sampler) {
                break;
            }
            if walk.left_delta
                && self.records()
                && let Some(x) = row.full.last_mut()
            {
                // The recorded vertex is inside every path that goes on from here.
                x.set_delta(true);
            }
        }
    }

    /// t = 1 with s = 1: the light's origin seen by the pinhole (weighed against the camera
    /// ray hitting the emitter).
    fn connect_origin(
        &self,
        li: usize,
        e: &crate::light::EmissionSample,
        p_origin: f32,
        err: Vec3,
        (row, u): (&mut LightRow, f32),
        origin: &PathVertex,
    ) {
        let scene = self.scene;
        let cam = &scene.camera;
        let l = &scene.lights[li];
        // A directly seen emitter is left to the camera ray (s = 0) in a pixel it fills when
        // nothing but vacuum lies between (see `paths::PathTerms`); with media that is known
        // after the trace.
        let direct_to_camera = !self.settings.direct_splats && direct_to_camera(scene, li, e.p);
        if direct_to_camera && !scene.features.media {
            return;
        }
        let Some(cs) = cam.sample_wi(e.p) else {
            return;
        };
        let cos0 = if e.n == Vec3::ZERO {
            1.0
        } else {
            e.n.dot(cs.wi).abs()
        };
        let le = emission(l, e.p, e.n, cs.wi) * cos0;
        if le == Spectrum::ZERO {
            return;
        }
        let start = Endpoint {
            p: e.p,
            n: e.n,
            err,
        };
        let Some(tr) = scene.transmittance(
            &start,
            Some(&Endpoint::point(cam.position)),
            cs.wi,
            scene.light_medium(li, e.n, cs.wi),
        ) else {
            return;
        };
        if direct_to_camera && tr.first.is_none() {
            return;
        }
        let cos_cam = cam.forward.dot(-cs.wi);
        let c = le * tr.tr * (cs.we * cos_cam / (cs.dist * cs.dist)) / p_origin;
        // The camera ray hitting the emitter (s = 0) is the only other technique.
        let w_cam = if hittable(scene, li) {
            cs.pdf_we * cos0 / (cs.dist * cs.dist) * tr.pass / p_origin
        } else {
            0.0
        };
        let w = 1.0 / (1.0 + w_cam);
        crate::check::weight(crate::check::Technique::named("vcm light origin"), w as f64);
        // The filter's pixel for the splat (`Camera::splat_pixel`).
        let Some((pixel, filter)) = cam.splat_pixel(cs.raster, u) else {
            return;
        };
        let (pixel, c) = (pixel as u32, c * filter);
        let technique = Technique::Connect { s: 1 };
        // Two vertices: no structure (`paths::structure`), so never claimed.
        row.splats.push((pixel, c * w));
        self.record(technique, std::slice::from_ref(origin), w);
    }

    /// t = 1, s >= 2: light vertex `v` seen by the pinhole.
    fn connect_camera(
        &self,
        v: &MisVertex<'a>,
        (row, u): (&mut LightRow, f32),
        full_start: usize,
        side: &LightSideHash,
    ) {
        let scene = self.scene;
        let cam = &scene.camera;
        let Some(cs) = cam.sample_wi(v.p) else {
            return;
        };
        let (f, _, pdf_rev) = v.f_pdfs(scene, cs.wi, TransportMode::Importance);
        if f == Spectrum::ZERO {
            return;
        }
        let Some(tr) = scene.transmittance(
            &v.endpoint(),
            Some(&Endpoint::point(cam.position)),
            cs.wi,
            v.medium_towards(scene, cs.wi),
        ) else {
            return;
        };
        let d2 = cs.dist * cs.dist;
        let cos_cam = cam.forward.dot(-cs.wi);
        let c = v.beta * f * tr.tr * (cs.we * cos_cam / d2);
        // VCM tech. report (46): the camera's (image-wide) density of v, times the light
        // side's quantities.
        let p_cam =
            cs.pdf_we * v.cos(cs.wi) / d2 * Edge::along(&tr).factor(scene, v.is_medium(), false);
        let merge = if v.mergeable() {
            self.pc.factors.vm
        } else {
            0.0
        };
        let w_light = p_cam * (merge + v.mis.d_vcm + v.mis.d_vc * pdf_rev);
        let w = 1.0 / (1.0 + w_light);
        crate::check::weight(
            crate::check::Technique::named("vcm light tracing"),
            w as f64,
        );
        let Some((pixel, filter)) = cam.splat_pixel(cs.raster, u) else {
            return;
        };
        let (pixel, c) = (pixel as u32, c * filter);
        if self.records() {
            let full = std::mem::take(&mut row.full);
            let light = &full[full_start..];
            let technique = Technique::Connect { s: light.len() };
            // The pinhole has no node: the path's hash is the light side's.
            let may_hold = (self.claims).is_some_and(|claims| {
                let l = light.len() + 1;
                (3..=MAX_VERTICES).contains(&l)
                    && side
                        .closed_by(scene, cam.position)
                        .is_some_and(|h| claims.may_hold_hash(h))
            });
            let span = (full_start, full.len());
            if !(may_hold && self.claim(technique, light, span, (pixel, c, w), row)) {
                row.splats.push((pixel, c * w));
            }
            self.record(technique, light, w);
            row.full = full;
        } else {
            row.splats.push((pixel, c * w));
        }
    }

    /// The pinhole as a path vertex.
    fn pinhole(&self) -> PathVertex {
        pinhole(self.scene)
    }

    /// If `claims` holds the path (pinhole, then `light` reversed, which is `row.full[span]`),
    /// keep it in `row` with its unweighted value `c` (vcm's weight `w` beside it), landing in
    /// `pixel`, and return true.
    fn claim(
        &self,
        technique: Technique,
        light: &[PathVertex],
        span: (usize, usize),
        (pixel, c, w): (u32, Spectrum, f32),
        row: &mut LightRow,
    ) -> bool {
        let Some(claims) = self.claims else {
            return false;
        };
        if !claims.holds(self.scene, &[self.pinhole()], light) {
            return false;
        }
        row.claimed.push(ClaimHead {
            technique,
            start: span.0 as u32,
            end: span.1 as u32,
            pixel,
            value: c,
            weight: w,
        });
        true
    }

    /// Hand a technique's path (pinhole, then `light` reversed) and weight to the inspector.
    fn record(&self, technique: Technique, light: &[PathVertex], weight: f32) {
        let Some(insp) = self.inspector else { return };
        (insp.borrow_mut())(&Record {
            technique,
            path: joined(&[self.pinhole()], light),
            weight: weight as f64,
        });
    }
}
