//! The light subpaths of a pass: traced from a light chosen by power, their connectible
//! vertices stored for connections and merging, and each vertex connected to the pinhole
//! (light tracing, t = 1, splatted). Light path k uses the stream (seed, pass, N + k).

use super::vertex::{Edge, Vertex, connectible_light, emission, emission_densities, hittable};
use super::walk::{Step, Walk};
use super::{Inspector, PassConstants, Record, Technique, VcmSettings};
use crate::bsdf::TransportMode;
use crate::geometry::{Ray, gamma, offset_origin};
use crate::integrators::paths::direct_to_camera;
use crate::math::{IndependentSampler, Sampler, Spectrum};
use crate::path::{Path, Vertex as PathVertex, VertexKind};
use crate::scene::{Endpoint, Scene};
use glam::Vec3;
use rayon::prelude::*;

/// The light subpaths of one row of path indices.
#[derive(Default)]
pub struct LightRow<'a> {
    pub vertices: Vec<Vertex<'a>>,
    /// The row's i-th path has vertices `starts[i] .. starts[i + 1]`.
    pub starts: Vec<u32>,
    /// Light-tracing contributions (pixel, value), in path order.
    pub splats: Vec<(u32, Spectrum)>,
    /// Every vertex of every path, light first (inspection only).
    pub full: Vec<Vec<PathVertex>>,
}

impl LightRow<'_> {
    fn clear(&mut self) {
        self.vertices.clear();
        self.starts.clear();
        self.starts.push(0);
        self.splats.clear();
        self.full.clear();
    }
}

/// What merging needs of a stored light vertex (global index `index`), kept in the hash
/// grid beside its position.
#[derive(Clone, Copy, Default)]
pub struct Photon {
    /// Unit direction towards the light walk's previous vertex.
    pub wo: Vec3,
    pub beta: Spectrum,
    pub d_vcm: f32,
    pub d_vm: f32,
    pub depth: u32,
    pub index: u32,
}

impl Photon {
    pub fn of(v: &Vertex, index: usize) -> Photon {
        Photon {
            wo: v.wo,
            beta: v.beta,
            d_vcm: v.mis.d_vcm,
            d_vm: v.mis.d_vm,
            depth: v.depth,
            index: index as u32,
        }
    }
}

/// All stored light vertices of a pass, path by path, in the rows the light pass traced
/// them in. Rows keep their memory from pass to pass and are read where they were written:
/// at 512 x 512 a pass's light vertices are tens of megabytes, and allocating them afresh
/// every pass cost vcm about 7 % of its time in page faults, copying them into one array 2 %.
/// A vertex's global index counts row by row (row 0's vertices first).
#[derive(Default)]
pub struct LightPaths<'a> {
    rows: Vec<LightRow<'a>>,
    /// Paths per row.
    row_len: usize,
    /// Global index of each row's first vertex, and the total at the end.
    offsets: Vec<u32>,
}

impl<'a> LightPaths<'a> {
    /// Trace `rows` rows of `row_len` paths each (row y holds paths `y row_len ..`) of pass
    /// `pass`, a row per task, into these buffers.
    pub fn trace(
        &mut self,
        scene: &'a Scene,
        settings: &VcmSettings,
        pc: &PassConstants,
        (seed, pass): (u64, u64),
        rows: usize,
        row_len: usize,
    ) {
        self.rows.resize_with(rows, LightRow::default);
        self.row_len = row_len;
        self.rows.par_iter_mut().enumerate().for_each(|(y, row)| {
            let lt = LightTracer {
                scene,
                settings,
                pc,
                inspector: None,
            };
            lt.row_into(seed, pass, (y * row_len) as u64, row_len as u64, row)
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
        tracer.row_into(seed, pass, 0, n as u64, &mut self.rows[0]);
        self.index();
    }

    fn index(&mut self) {
        self.offsets.clear();
        let mut total = 0u32;
        for row in &self.rows {
            self.offsets.push(total);
            total += row.vertices.len() as u32;
        }
        self.offsets.push(total);
    }

    /// The stored vertices of light path `k`.
    #[inline]
    pub fn path(&self, k: usize) -> &[Vertex<'a>] {
        let (row, i) = (&self.rows[k / self.row_len], k % self.row_len);
        &row.vertices[row.starts[i] as usize..row.starts[i + 1] as usize]
    }

    /// Every stored vertex with its global index.
    pub fn vertices(&self) -> impl Iterator<Item = (usize, &Vertex<'a>)> {
        self.rows.iter().zip(&self.offsets).flat_map(|(row, &o)| {
            row.vertices
                .iter()
                .enumerate()
                .map(move |(i, v)| (o as usize + i, v))
        })
    }

    /// The light-tracing splats, in path order, row by row.
    pub fn splats(&self) -> impl Iterator<Item = &[(u32, Spectrum)]> {
        self.rows.iter().map(|row| row.splats.as_slice())
    }

    /// Inspection only: every vertex of light path `k`, light first.
    pub fn full(&self, k: usize) -> &[PathVertex] {
        &self.rows[k / self.row_len].full[k % self.row_len]
    }

    /// Inspection only: the light path of the stored vertex of global index `index`.
    pub fn path_of_vertex(&self, index: usize) -> usize {
        let r = self.offsets.partition_point(|&o| o as usize <= index) - 1;
        let local = (index - self.offsets[r] as usize) as u32;
        let i = self.rows[r].starts.partition_point(|&s| s <= local) - 1;
        r * self.row_len + i
    }
}

/// Traces light subpaths and connects them to the camera.
pub struct LightTracer<'a, 'p> {
    pub scene: &'a Scene,
    pub settings: &'p VcmSettings,
    pub pc: &'p PassConstants,
    pub inspector: Option<&'p Inspector<'p>>,
}

impl<'a> LightTracer<'a, '_> {
    /// Light paths `first .. first + count` of pass `pass`, into `row` (cleared first).
    pub fn row_into(&self, seed: u64, pass: u64, first: u64, count: u64, row: &mut LightRow<'a>) {
        row.clear();
        let n = self.pc.light_paths as u64;
        for k in first..first + count {
            let mut sampler = IndependentSampler::new(seed, pass, n + k);
            let mut full = Vec::new();
            let full_ref = self.inspector.is_some().then_some(&mut full);
            self.trace(&mut sampler, &mut row.vertices, &mut row.splats, full_ref);
            row.starts.push(row.vertices.len() as u32);
            if self.inspector.is_some() {
                row.full.push(full);
            }
        }
    }

    /// One light subpath: stores its connectible vertices in `out`, pushes its light-tracing
    /// contributions to `splats`, and (inspection) all its vertices to `full`.
    pub fn trace(
        &self,
        sampler: &mut impl Sampler,
        out: &mut Vec<Vertex<'a>>,
        splats: &mut Vec<(u32, Spectrum)>,
        mut full: Option<&mut Vec<PathVertex>>,
    ) {
        let (scene, st) = (self.scene, self.settings);
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
            kind: VertexKind::Emitter {
                light: li as u32,
                delta: l.is_delta(),
            },
        };
        if let Some(f) = full.as_deref_mut() {
            f.push(origin);
        }
        let err = gamma(8) * e.p.abs();
        if st.connect && max >= 1 && connectible_light(l) {
            self.connect_origin(li, &e, densities.0, err, splats, &origin);
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
            hittable(l),
            self.pc.factors,
        );
        walk.medium = scene.light_medium(li, n0, e.dir);
        walk.q_cap = super::walk::deep_continuation(st.max_depth);
        while let Step::Vertex { v, .. } = walk.trace(scene, sampler) {
            if let Some(f) = full.as_deref_mut() {
                f.push(v.path_vertex());
            }
            let j = v.depth;
            if v.connectible() {
                if st.connect && j < max {
                    self.connect_camera(&v, splats, full.as_deref());
                }
                if j < max && (st.connect || v.mergeable()) {
                    out.push(v);
                }
            }
            if j + 2 > max || !walk.scatter(scene, &v, self.pc.factors, sampler) {
                break;
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
        splats: &mut Vec<(u32, Spectrum)>,
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
        let le = emission(l, e.n, cs.wi) * cos0;
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
        let w_cam = if hittable(l) {
            cs.pdf_we * cos0 / (cs.dist * cs.dist) * tr.pass / p_origin
        } else {
            0.0
        };
        let w = 1.0 / (1.0 + w_cam);
        crate::check::weight(crate::check::Technique::named("vcm light origin"), w as f64);
        let pixel = cam.pixel_index(cs.raster) as u32;
        splats.push((pixel, c * w));
        self.record(Technique::Connect { s: 1 }, &[*origin], w);
    }

    /// t = 1, s >= 2: light vertex `v` seen by the pinhole.
    fn connect_camera(
        &self,
        v: &Vertex<'a>,
        splats: &mut Vec<(u32, Spectrum)>,
        full: Option<&Vec<PathVertex>>,
    ) {
        let scene = self.scene;
        let cam = &scene.camera;
        let Some(cs) = cam.sample_wi(v.p) else {
            return;
        };
        let f = v.f(scene, cs.wi, TransportMode::Importance);
        if f == Spectrum::ZERO {
            return;
        }
        let Some(tr) = scene.transmittance(
            &v.endpoint(),
            Some(&Endpoint::point(cam.position)),
            cs.wi,
            v.medium_towards(cs.wi),
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
        let pdf_rev = v.pdf_w(scene, cs.wi, v.wo);
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
        splats.push((cam.pixel_index(cs.raster) as u32, c * w));
        if let Some(full) = full {
            self.record(Technique::Connect { s: full.len() }, full, w);
        }
    }

    /// Hand a technique's path (pinhole, then `light` reversed) and weight to the inspector.
    fn record(&self, technique: Technique, light: &[PathVertex], weight: f32) {
        let Some(insp) = self.inspector else { return };
        let mut path = Path::default();
        path.push(PathVertex {
            p: self.scene.camera.position,
            n: Vec3::ZERO,
            ns: Vec3::ZERO,
            kind: VertexKind::Camera,
        });
        for v in light.iter().rev() {
            path.push(*v);
        }
        (insp.borrow_mut())(&Record {
            technique,
            path,
            weight: weight as f64,
        });
    }
}
