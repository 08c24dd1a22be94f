//! `bdpt` — bidirectional path tracing (Veach 1997) with every (s, t) technique and full MIS;
//! `lt` — light tracing, its t = 1 techniques alone.
//!
//! Unbiased. Per pixel and pass: a camera subpath and a light subpath (one light chosen by
//! power), both random walks with media (`walk.rs`); every prefix pair is connected: s = 0
//! (the camera walk hits an emitter, including lights at infinity), s = 1 (next-event
//! estimation), t = 1 (the light vertex connected to the pinhole and splatted), and
//! s, t >= 2 (a deterministic connection with transmittance through index-matched
//! boundaries). The MIS weights come from explicit densities of each technique
//! (`strategies.rs`), with Russian roulette (a local continuation probability, so the
//! densities exist in both directions) and free-flight probabilities included.
//!
//! | option    | type                 | default   | meaning |
//! |-----------|----------------------|-----------|---------|
//! | max_depth | integer >= 1         | 8         | maximum number of segments, as for `pt` |
//! | rr_depth  | integer >= 1         | 5         | roulette on subpaths of this many segments or more |
//! | mis       | `balance` / `power`  | `balance` | MIS heuristic (`bdpt` only) |
//!
//! Limits: light subpaths start in vacuum (an emitter inside a medium is not supported); `lt`
//! cannot see lights at infinity directly, nor anything seen through a specular surface.
//!
//! ```text
//! lodestar render scenes/cornell-box.toml --integrator bdpt --spp 64 -O mis=power
//! ```

mod strategies;
pub mod vertex;
mod walk;

pub use strategies::{Heuristic, PathTerms};
pub use vertex::{Kind, Vertex};

use super::IntegratorParams;
use crate::bsdf::TransportMode;
use crate::error::{Error, Result};
use crate::geometry::gamma;
use crate::light::Light;
use crate::math::{IndependentSampler, Sampler, Spectrum};
use crate::path::{MAX_VERTICES, Path, VertexKind};
use crate::render::{Budget, Integrator, RenderContext, RenderResult, RowTracer, render_rows};
use crate::scene::{Endpoint, Scene};
use glam::{Vec2, Vec3};
use vertex::{Edge, pdf, to_measure};
use walk::continuation;

#[derive(Debug, Clone, PartialEq)]
pub struct BdptSettings {
    /// Maximum number of path segments (default 8).
    pub max_depth: u32,
    /// Subpath length (segments) from which Russian roulette applies (default 5).
    pub rr_depth: u32,
    /// Default `Balance`.
    pub heuristic: Heuristic,
    /// Light tracing: only the t = 1 techniques, unweighted.
    pub light_tracing: bool,
}

fn settings(params: &IntegratorParams, light_tracing: bool) -> Result<BdptSettings> {
    let o = &params.options;
    let rr_depth = o.get("rr_depth", 5u32, "an integer >= 1")?;
    if rr_depth == 0 {
        return Err(Error::new(
            "option 'rr_depth': expected an integer >= 1, got 0",
        ));
    }
    let heuristic = if light_tracing {
        Heuristic::Balance
    } else {
        match o.choice("mis", "balance", &["balance", "power"])? {
            "power" => Heuristic::Power,
            _ => Heuristic::Balance,
        }
    };
    Ok(BdptSettings {
        max_depth: params.max_depth,
        rr_depth,
        heuristic,
        light_tracing,
    })
}

pub fn build(params: &IntegratorParams) -> Result<Box<dyn Integrator>> {
    Ok(Box::new(Bdpt {
        settings: settings(params, false)?,
    }))
}

pub fn build_lt(params: &IntegratorParams) -> Result<Box<dyn Integrator>> {
    Ok(Box::new(Bdpt {
        settings: settings(params, true)?,
    }))
}

pub struct Bdpt {
    pub settings: BdptSettings,
}

impl Integrator for Bdpt {
    fn name(&self) -> &'static str {
        if self.settings.light_tracing {
            "lt"
        } else {
            "bdpt"
        }
    }

    fn settings(&self) -> String {
        format!("{:?}", self.settings)
    }

    fn render(&mut self, ctx: &RenderContext, budget: Budget) -> RenderResult {
        render_rows(ctx, budget, || Tracer::new(ctx.scene, &self.settings))
    }
}

impl<'a> RowTracer for Tracer<'a> {
    fn sample(&mut self, raster: Vec2, sampler: &mut IndependentSampler) -> Spectrum {
        Tracer::sample(self, raster, sampler)
    }

    fn take_splats(&mut self) -> Vec<(u32, Spectrum)> {
        std::mem::take(&mut self.splats)
    }
}

/// Called with every complete path a technique forms: the path (camera first), the
/// technique's s, and the density terms it assembled for its MIS weight (for tests).
pub type Inspector<'a> = Box<dyn FnMut(&[Vertex<'a>], usize, &PathTerms) + 'a>;

/// Per-thread state: subpath buffers (reused) and the splats of the current row.
pub struct Tracer<'a> {
    scene: &'a Scene,
    settings: &'a BdptSettings,
    camera: Vec<Vertex<'a>>,
    light: Vec<Vertex<'a>>,
    pub splats: Vec<(u32, Spectrum)>,
    pub inspector: Option<std::cell::RefCell<Inspector<'a>>>,
}

impl<'a> Tracer<'a> {
    pub fn new(scene: &'a Scene, settings: &'a BdptSettings) -> Tracer<'a> {
        let n = settings.max_depth as usize + 2;
        Tracer {
            scene,
            settings,
            camera: Vec::with_capacity(n),
            light: Vec::with_capacity(n),
            splats: Vec::new(),
            inspector: None,
        }
    }

    /// One BDPT sample: returns the value for the pixel at `raster` (t >= 2) and pushes the
    /// light-tracing contributions (t = 1) to `splats`.
    pub fn sample(&mut self, raster: Vec2, sampler: &mut impl Sampler) -> Spectrum {
        let (scene, st) = (self.scene, self.settings);
        let max_depth = st.max_depth as usize;
        let mut camera = std::mem::take(&mut self.camera);
        let mut light = std::mem::take(&mut self.light);
        if st.light_tracing {
            camera.clear();
            walk::camera_subpath(scene, raster, 1, st.rr_depth, sampler, &mut camera);
        } else {
            walk::camera_subpath(
                scene,
                raster,
                max_depth + 1,
                st.rr_depth,
                sampler,
                &mut camera,
            );
        }
        walk::light_subpath(scene, max_depth + 1, st.rr_depth, sampler, &mut light);
        let mut l = Spectrum::ZERO;
        for t in 1..=camera.len() {
            for s in 0..=light.len() {
                let k = s + t - 1;
                if k == 0 || k > max_depth || (st.light_tracing && t != 1) {
                    continue;
                }
                if s == 0 {
                    l += self.hit_emitter(&camera[..t]);
                } else if t == 1 {
                    if let Some((raster, c)) = self.connect_camera(&light[..s], &camera[0]) {
                        self.splats
                            .push((scene.camera.pixel_index(raster) as u32, c));
                    }
                } else if s == 1 {
                    l += self.next_event(&camera[..t], sampler);
                } else {
                    l += self.connect(&camera[..t], &light[..s]);
                }
            }
        }
        self.camera = camera;
        self.light = light;
        l
    }

    /// s = 0: the last camera vertex is on an emitter (or at infinity).
    fn hit_emitter(&self, c: &[Vertex<'a>]) -> Spectrum {
        let scene = self.scene;
        let t = c.len();
        let y = &c[t - 1];
        let prev = c[t - 2].p;
        let mut sum = Spectrum::ZERO;
        let mut add = |light: usize, le: Spectrum, emitter: Vertex<'a>| {
            if le == Spectrum::ZERO {
                return;
            }
            let w = if self.settings.light_tracing {
                1.0
            } else {
                self.weight_emitter_hit(c, &emitter, light)
            };
            sum += y.beta * le * w as f32;
        };
        match y.kind {
            Kind::Light { .. } => {
                // Escaped: every light at infinity, each with its own densities.
                for &li in &scene.infinite_lights {
                    let le = scene.lights[li].le(Vec3::ZERO, y.n);
                    add(
                        li,
                        le,
                        Vertex {
                            kind: Kind::Light { light: li },
                            ..*y
                        },
                    );
                }
            }
            Kind::Surface { info, .. } => {
                if let Some(li) = info.light {
                    let li = li as usize;
                    let le = scene.lights[li].le(y.n, (prev - y.p).normalize());
                    add(
                        li,
                        le,
                        Vertex {
                            kind: Kind::Light { light: li },
                            delta: false,
                            ..*y
                        },
                    );
                }
            }
            _ => {}
        }
        sum
    }

    /// s = 1, t >= 2: next-event estimation from the last camera vertex.
    fn next_event(&self, c: &[Vertex<'a>], sampler: &mut impl Sampler) -> Spectrum {
        let scene = self.scene;
        let t = c.len();
        let y = &c[t - 1];
        let (u_light, u) = (sampler.next_1d(), sampler.next_2d());
        if !y.connectible(scene) {
            return Spectrum::ZERO;
        }
        let Some((light, pmf)) = scene.light_sampler.sample(u_light) else {
            return Spectrum::ZERO;
        };
        let l = &scene.lights[light];
        let Some(ls) = l.sample_li(y.p, u) else {
            return Spectrum::ZERO;
        };
        let infinite = l.is_infinite();
        // A light at infinity sits one unit along its direction (see the walk).
        let target = if infinite { y.p + ls.wi } else { ls.p };
        let n = if infinite { ls.wi } else { ls.n };
        let lv = Vertex {
            p_err: gamma(8) * ls.p.abs(),
            delta: l.is_delta(),
            ..Vertex::new(Kind::Light { light }, target, n)
        };
        let f = y.f(scene, c[t - 2].p, target, TransportMode::Radiance);
        if f == Spectrum::ZERO {
            return Spectrum::ZERO;
        }
        let end = (!infinite).then_some(Endpoint {
            p: ls.p,
            n: ls.n,
            err: lv.p_err,
        });
        let Some(tr) = scene.transmittance(
            &endpoint(y),
            end.as_ref(),
            ls.wi,
            medium_towards(scene, y, ls.wi),
        ) else {
            return Spectrum::ZERO;
        };
        let contribution = y.beta * f * ls.li * tr.tr / (pmf * ls.pdf);
        let edge = Edge::along(&tr);
        let w = self.weight_connection(c, std::slice::from_ref(&lv), &edge, Some(pmf * ls.pdf));
        contribution * w as f32
    }

    /// t = 1: connect the last light vertex to the pinhole; returns the raster position and
    /// the value to splat there.
    fn connect_camera(&self, lp: &[Vertex<'a>], cam: &Vertex<'a>) -> Option<(Vec2, Spectrum)> {
        let scene = self.scene;
        let s = lp.len();
        let y = &lp[s - 1];
        if !y.connectible(scene) {
            return None;
        }
        let cs = scene.camera.sample_wi(y.p)?;
        let to_cam = cs.wi;
        let f = if s == 1 {
            let Kind::Light { light } = y.kind else {
                return None;
            };
            emission(&scene.lights[light], y.n, to_cam) * y.abs_cos_to(cam.p)
        } else {
            y.f(scene, lp[s - 2].p, cam.p, TransportMode::Importance)
        };
        if f == Spectrum::ZERO {
            return None;
        }
        let tr = scene.transmittance(
            &endpoint(y),
            Some(&Endpoint::point(cam.p)),
            to_cam,
            medium_towards(scene, y, to_cam),
        )?;
        let cos_cam = scene.camera.forward.dot(-to_cam);
        let contribution = y.beta * f * tr.tr * (cs.we * cos_cam / (cs.dist * cs.dist));
        let w = if self.settings.light_tracing {
            1.0
        } else {
            // Traced from the light vertex towards the camera: reverse it to run camera first.
            let edge = Edge::along(&tr).reversed();
            self.weight_connection(std::slice::from_ref(cam), lp, &edge, None)
        };
        Some((cs.raster, contribution * w as f32))
    }

    /// s, t >= 2: connect the last camera vertex with the last light vertex.
    fn connect(&self, c: &[Vertex<'a>], lp: &[Vertex<'a>]) -> Spectrum {
        let scene = self.scene;
        let (t, s) = (c.len(), lp.len());
        let (a, b) = (&c[t - 1], &lp[s - 1]);
        if !a.connectible(scene) || !b.connectible(scene) {
            return Spectrum::ZERO;
        }
        let fa = a.f(scene, c[t - 2].p, b.p, TransportMode::Radiance);
        let fb = b.f(scene, lp[s - 2].p, a.p, TransportMode::Importance);
        if fa == Spectrum::ZERO || fb == Spectrum::ZERO {
            return Spectrum::ZERO;
        }
        let d = b.p - a.p;
        let d2 = d.length_squared();
        let Some(tr) = scene.transmittance(
            &endpoint(a),
            Some(&endpoint(b)),
            d / d2.sqrt(),
            medium_towards(scene, a, d),
        ) else {
            return Spectrum::ZERO;
        };
        let contribution = a.beta * fa * fb * b.beta * tr.tr / d2;
        let edge = Edge::along(&tr);
        contribution * self.weight_connection(c, lp, &edge, None) as f32
    }

    /// MIS weight of technique (s, t) for the path camera prefix `c` + reversed light prefix
    /// `lp`, connected through `conn` (free flight from c's end to lp's end). `nee` is the
    /// next-event density when s = 1 and t >= 2.
    fn weight_connection(
        &self,
        c: &[Vertex<'a>],
        lp: &[Vertex<'a>],
        conn: &Edge,
        nee: Option<f32>,
    ) -> f64 {
        let scene = self.scene;
        let (t, s) = (c.len(), lp.len());
        let k = s + t - 1;
        let y = |j: usize| if j < t { &c[j] } else { &lp[k - j] };
        let rr_cam = |j: usize| continuation(scene, y(j), j, self.settings.rr_depth) as f64;
        let rr_light = |j: usize| continuation(scene, y(j), k - j, self.settings.rr_depth) as f64;
        let mut terms = PathTerms::new(k);
        for j in 0..=k {
            terms.connectible[j] = y(j).connectible(scene);
        }
        let light_vertex = y(k);
        let Kind::Light { light } = light_vertex.kind else {
            return 0.0;
        };
        terms.hittable = hittable(scene, light);
        // Camera side.
        for j in 1..=k {
            let rr = if j >= 2 { rr_cam(j - 1) } else { 1.0 };
            terms.pc[j] = rr
                * if j < t {
                    c[j].pdf_fwd as f64
                } else if j == t {
                    let prev = (t >= 2).then(|| c[t - 2].p);
                    (pdf(scene, &c[t - 1], prev, y(t)) * conn.factor(scene, y(t).is_medium(), true))
                        as f64
                } else if j == t + 1 {
                    (pdf(scene, y(t), Some(c[t - 1].p), y(t + 1))
                        * y(t).edge.factor(scene, y(t + 1).is_medium(), false))
                        as f64
                } else {
                    y(j).pdf_rev as f64
                };
        }
        // Light side.
        terms.pl[k] = origin_density(scene, light_vertex, light) as f64;
        for j in (1..k).rev() {
            let rr = if j + 1 < k { rr_light(j + 1) } else { 1.0 };
            terms.pl[j] = rr
                * if j >= t {
                    y(j).pdf_fwd as f64
                } else if j == t - 1 {
                    let next = (t < k).then(|| y(t + 1).p);
                    (pdf(scene, y(t), next, &c[t - 1])
                        * conn.factor(scene, c[t - 1].is_medium(), false))
                        as f64
                } else if j == t - 2 {
                    (pdf(scene, &c[t - 1], Some(y(t).p), &c[t - 2])
                        * c[t - 1].edge.factor(scene, c[t - 2].is_medium(), false))
                        as f64
                } else {
                    c[j].pdf_rev as f64
                };
        }
        terms.nee_k = match nee {
            Some(p) if !light_vertex.delta => to_measure(scene, p, y(k - 1).p, light_vertex) as f64,
            Some(p) => p as f64,
            None => nee_density(scene, y(k - 1), light_vertex, light),
        };
        self.inspect(|| (0..=k).map(|j| *y(j)).collect(), s, &terms);
        terms.weight(s, self.settings.heuristic)
    }

    fn inspect(&self, path: impl FnOnce() -> Vec<Vertex<'a>>, s: usize, terms: &PathTerms) {
        if let Some(f) = &self.inspector {
            (f.borrow_mut())(&path(), s, terms);
        }
    }

    /// MIS weight of s = 0 for the camera path `c` whose last vertex is `emitter` (on `light`).
    fn weight_emitter_hit(&self, c: &[Vertex<'a>], emitter: &Vertex<'a>, light: usize) -> f64 {
        let scene = self.scene;
        let k = c.len() - 1;
        let y = |j: usize| if j < k { &c[j] } else { emitter };
        let mut terms = PathTerms::new(k);
        for j in 0..=k {
            terms.connectible[j] = y(j).connectible(scene);
        }
        terms.hittable = hittable(scene, light);
        for j in 1..=k {
            let rr = if j >= 2 {
                continuation(scene, y(j - 1), j - 1, self.settings.rr_depth) as f64
            } else {
                1.0
            };
            terms.pc[j] = rr * y(j).pdf_fwd as f64;
        }
        terms.pl[k] = origin_density(scene, emitter, light) as f64;
        for j in (1..k).rev() {
            let rr = if j + 1 < k {
                continuation(scene, y(j + 1), k - j - 1, self.settings.rr_depth) as f64
            } else {
                1.0
            };
            terms.pl[j] = rr
                * if j == k - 1 {
                    (pdf(scene, emitter, None, y(j))
                        * emitter.edge.factor(scene, y(j).is_medium(), false))
                        as f64
                } else {
                    y(j).pdf_rev as f64
                };
        }
        terms.nee_k = nee_density(scene, y(k - 1), emitter, light);
        self.inspect(|| (0..=k).map(|j| *y(j)).collect(), 0, &terms);
        terms.weight(0, self.settings.heuristic)
    }
}

/// The technique densities of a complete path y_0 (pinhole) .. y_k (a `Kind::Light` vertex),
/// computed from scratch: every direction density, free-flight factor (by tracing each
/// segment) and roulette probability is evaluated from the vertices alone. BDPT's rendering
/// assembles the same terms from cached walk densities; the tests check that they agree, which
/// makes the MIS weights of all techniques that can produce a path sum to one.
/// `terms.technique_densities` summed over s is BDPT's `pdf_unguided` for the path.
pub fn path_terms(scene: &Scene, y: &[Vertex], rr_depth: u32) -> PathTerms {
    let k = y.len() - 1;
    let mut terms = PathTerms::new(k);
    let Kind::Light { light } = y[k].kind else {
        return terms;
    };
    terms.hittable = hittable(scene, light);
    for (j, v) in y.iter().enumerate() {
        terms.connectible[j] = v.connectible(scene);
    }
    // Free-flight factors of each segment y_j -> y_{j+1}, towards either end.
    let mut to_next = [1.0f32; MAX_VERTICES];
    let mut to_prev = [1.0f32; MAX_VERTICES];
    if scene.features.media {
        let mut medium = scene.camera_medium;
        for j in 0..k {
            let d = if y[j + 1].is_infinite_light(scene) {
                y[j + 1].n
            } else {
                (y[j + 1].p - y[j].p).normalize()
            };
            let start = match y[j].kind {
                Kind::Camera => medium,
                _ => medium_towards(scene, &y[j], d),
            };
            let end = (!y[j + 1].is_infinite_light(scene)).then(|| endpoint(&y[j + 1]));
            let Some(tr) = scene.transmittance(&endpoint(&y[j]), end.as_ref(), d, start) else {
                return terms;
            };
            let edge = Edge::along(&tr);
            to_next[j] = edge.factor(scene, y[j + 1].is_medium(), true);
            to_prev[j] = edge.factor(scene, y[j].is_medium(), false);
            medium = tr.end_medium;
        }
    }
    let dir_pdf =
        |j: usize, from: Option<usize>, to: usize| pdf(scene, &y[j], from.map(|f| y[f].p), &y[to]);
    for j in 1..=k {
        let rr = if j >= 2 {
            continuation(scene, &y[j - 1], j - 1, rr_depth)
        } else {
            1.0
        };
        let prev = (j >= 2).then(|| j - 2);
        terms.pc[j] = (dir_pdf(j - 1, prev, j) * to_next[j - 1] * rr) as f64;
    }
    terms.pl[k] = origin_density(scene, &y[k], light) as f64;
    for j in (1..k).rev() {
        let rr = if j + 1 < k {
            continuation(scene, &y[j + 1], k - j - 1, rr_depth)
        } else {
            1.0
        };
        let next = (j + 2 <= k).then(|| j + 2);
        terms.pl[j] = (dir_pdf(j + 1, next, j) * to_prev[j] * rr) as f64;
    }
    terms.nee_k = nee_density(scene, &y[k - 1], &y[k], light);
    terms
}

/// BDPT's `pdf_unguided` (DESIGN.md §3): the sum over its techniques of the density of
/// producing `path` (one sample of each technique per pixel and pass, image-wide densities);
/// 0 for paths longer than `max_depth`.
pub fn pdf_unguided(scene: &Scene, path: &Path, max_depth: u32, rr_depth: u32) -> f64 {
    technique_densities_of(scene, path, max_depth, rr_depth)
        .map_or(0.0, |(p, k)| p[..=k].iter().sum())
}

/// Densities of every BDPT technique (index s) for `path`, and its number of segments k;
/// `None` if the path does not end on a light or is longer than `max_depth`.
pub fn technique_densities_of(
    scene: &Scene,
    path: &Path,
    max_depth: u32,
    rr_depth: u32,
) -> Option<([f64; MAX_VERTICES], usize)> {
    let y = from_path(scene, path)?;
    let k = y.len() - 1;
    if k > max_depth as usize {
        return None;
    }
    let mut p = [0.0f64; MAX_VERTICES];
    path_terms(scene, &y, rr_depth).technique_densities(&mut p);
    Some((p, k))
}

/// The vertices of a `Path` as BDPT vertices (scene references, shading frames, and the
/// medium each was reached in, tracked from the camera). `None` if it does not end on a light.
pub fn from_path<'a>(scene: &'a Scene, path: &Path) -> Option<Vec<Vertex<'a>>> {
    let vs = path.vertices();
    if vs.len() < 2 {
        return None;
    }
    let mut out = Vec::with_capacity(vs.len());
    let mut medium = scene.camera_medium;
    for (j, pv) in vs.iter().enumerate() {
        let (kind, delta) = match pv.kind {
            VertexKind::Camera => (Kind::Camera, false),
            VertexKind::Surface {
                material,
                shape,
                delta,
            } => {
                let info = &scene.shape_info[shape as usize];
                let ns = if pv.ns == Vec3::ZERO { pv.n } else { pv.ns };
                let frame = crate::bsdf::ShadingFrame::new(ns, pv.n);
                (
                    Kind::Surface {
                        bsdf: &scene.materials[material as usize].bsdf,
                        frame,
                        info,
                    },
                    delta,
                )
            }
            VertexKind::Medium { medium } => (Kind::Medium { medium }, false),
            VertexKind::Emitter { light, delta } => (
                Kind::Light {
                    light: light as usize,
                },
                delta,
            ),
        };
        let v = Vertex {
            p_err: gamma(8) * pv.p.abs(),
            delta,
            medium,
            ..Vertex::new(kind, pv.p, pv.n)
        };
        // The medium the next segment ends in (index-matched crossings resolved by tracing).
        if j + 1 < vs.len() && scene.features.media {
            let next = &vs[j + 1];
            let infinite = matches!(next.kind, VertexKind::Emitter { light, .. } if scene.lights[light as usize].is_infinite());
            let d = if infinite {
                next.n
            } else {
                (next.p - pv.p).normalize()
            };
            let start = if j == 0 {
                medium
            } else {
                medium_towards(scene, &v, d)
            };
            let end = Endpoint {
                p: next.p,
                n: next.n,
                err: gamma(8) * next.p.abs(),
            };
            medium = scene
                .transmittance(&endpoint(&v), (!infinite).then_some(&end), d, start)
                .map_or(start, |tr| tr.end_medium);
        }
        out.push(v);
    }
    matches!(out.last()?.kind, Kind::Light { .. }).then_some(out)
}

/// BDPT vertices as a `Path` (camera first) with contribution f(X) and pixel.
pub fn to_path(vertices: &[Vertex], f: Spectrum, pixel: u32) -> Path {
    let mut path = Path::default();
    for v in vertices {
        let (kind, ns) = match v.kind {
            Kind::Camera => (VertexKind::Camera, Vec3::ZERO),
            Kind::Surface { bsdf, frame, info } => (
                VertexKind::Surface {
                    material: info.material,
                    shape: info.index,
                    delta: bsdf.is_delta(),
                },
                frame.frame.n,
            ),
            Kind::Medium { medium } => (VertexKind::Medium { medium }, Vec3::ZERO),
            Kind::Light { light } => (
                VertexKind::Emitter {
                    light: light as u32,
                    delta: v.delta,
                },
                Vec3::ZERO,
            ),
        };
        path.push(crate::path::Vertex {
            p: v.p,
            n: v.n,
            ns,
            kind,
        });
    }
    path.f = f;
    path.pixel = pixel;
    path
}

/// Emitted radiance (area lights; intensity for point and spot lights) towards `w`.
fn emission(light: &Light, n: Vec3, w: Vec3) -> Spectrum {
    match light {
        Light::Point(p) => p.intensity,
        Light::Spot(s) => s.intensity_towards(w),
        other => other.le(n, w),
    }
}

/// Whether a camera walk can hit this light (it has area or extent at infinity).
fn hittable(scene: &Scene, light: usize) -> bool {
    matches!(
        scene.lights[light],
        Light::Area(_) | Light::Environment(_) | Light::Sun(_)
    )
}

/// Density of the light vertex as an emission origin: light choice times the area density of
/// the point (delta lights: 1), or the solid-angle density of the direction at infinity.
fn origin_density(scene: &Scene, v: &Vertex, light: usize) -> f32 {
    let l = &scene.lights[light];
    let pmf = scene.light_sampler.pmf(light);
    if l.is_infinite() {
        pmf * l.pdf_le(v.n, -v.n).1
    } else {
        pmf * l.pdf_le(v.n, v.n).0
    }
}

/// Density of next-event estimation from `from` choosing the light vertex `v` on `light`.
fn nee_density(scene: &Scene, from: &Vertex, v: &Vertex, light: usize) -> f64 {
    let l = &scene.lights[light];
    let pmf = scene.light_sampler.pmf(light) as f64;
    if l.is_delta() {
        return pmf;
    }
    let wi = if l.is_infinite() {
        v.n
    } else {
        (v.p - from.p).normalize()
    };
    let pdf_w = l.pdf_li(from.p, v.p, v.n, wi);
    pmf * to_measure(scene, pdf_w, from.p, v) as f64
}

/// A vertex as the end of a visibility test: surfaces and lights on surfaces are offset along
/// their normal; medium points, the pinhole and point lights are not.
pub fn endpoint(v: &Vertex) -> Endpoint {
    match v.kind {
        Kind::Surface { .. } | Kind::Light { .. } => Endpoint {
            p: v.p,
            n: v.n,
            err: v.p_err,
        },
        Kind::Medium { .. } | Kind::Camera => Endpoint::point(v.p),
    }
}

/// Medium a connection leaving `v` along `d` starts in.
pub fn medium_towards(scene: &Scene, v: &Vertex, d: Vec3) -> Option<u32> {
    match v.kind {
        Kind::Medium { medium } => Some(medium),
        Kind::Surface { info, .. } => info.interface.map_or(v.medium, |mi| mi.crossing(d, v.n)),
        Kind::Camera => scene.camera_medium,
        Kind::Light { .. } => None,
    }
}
