//! The path algebra every estimator and the guider share: complete paths as vertices
//! (`vertex.rs`: kinds, per-vertex direction densities, the solid-angle to area / volume
//! measure conversion), the densities of every technique that can form a path
//! (`terms.rs`, [`path_terms`]), f(X) from the vertices (`contribution.rs`), roulette as a
//! function of the path, and the conversions between the compact [`Path`] the guider stores
//! and these vertices.
//!
//! Measures (DESIGN.md §3): surface and emitter vertices in area measure, medium vertices in
//! volume measure, lights at infinity in solid angle; a solid-angle density at `x` converts
//! with [`area_factor`] (`|cos θ_x| / d²`, or `1 / d²` in a medium).

pub mod contribution;
pub mod structure;
pub mod terms;
pub mod vertex;

pub use terms::{Heuristic, PathTerms};
pub use vertex::{Edge, Kind, Vertex};

use crate::geometry::gamma;
use crate::light::Light;
use crate::math::Spectrum;
use crate::path::{MAX_VERTICES, Path, VertexKind};
use crate::scene::{Endpoint, Scene};
use glam::{DVec3, Vec2, Vec3};
use vertex::{pdf, to_measure};

/// `|cos θ_x| / d²` at `x` (normal `n`; zero in a medium, giving `1 / d²`) seen from `from`:
/// the factor that turns a solid-angle density at `from` into the area (volume) density of
/// `x`. In f64, as whole-path products are.
pub fn area_factor(from: Vec3, x: Vec3, n: Vec3) -> f64 {
    let d: DVec3 = x.as_dvec3() - from.as_dvec3();
    let d2 = d.length_squared();
    if n == Vec3::ZERO {
        1.0 / d2
    } else {
        n.as_dvec3().dot(d).abs() / (d2 * d2.sqrt())
    }
}

/// Russian-roulette continuation probability when leaving `v` (1 before `rr_depth`).
pub fn continuation(scene: &Scene, v: &Vertex, segments: usize, rr_depth: u32) -> f32 {
    roulette(local_continuation(scene, v), segments, rr_depth)
}

/// The continuation probability of `v` once roulette applies (its surface's or medium's).
pub fn local_continuation(scene: &Scene, v: &Vertex) -> f32 {
    match v.kind {
        Kind::Surface { bsdf, .. } => bsdf.continuation(),
        Kind::Medium { medium } => scene.media[medium as usize].continuation(),
        Kind::Camera | Kind::Light { .. } => 1.0,
    }
}

/// Subpath length (segments) from which every continuation probability is at most
/// [`DEEP_CONTINUATION`]: between perfect mirrors or inside glass (local probability 1) paths
/// then still end, so `max_depth` can be unlimited. No path within the stored-path limit
/// (`MAX_VERTICES - 1` segments) reaches it, so depth-limited renders are unchanged.
pub const DEEP_SEGMENTS: usize = crate::path::MAX_VERTICES;

/// Largest continuation probability past [`DEEP_SEGMENTS`] (Mitsuba caps every step at 0.95).
pub const DEEP_CONTINUATION: f32 = 0.99;

/// The local continuation probability `q` applied after `segments` segments: 1 before
/// `rr_depth`, `q` from then on, at most [`DEEP_CONTINUATION`] past [`DEEP_SEGMENTS`]. A
/// function of the vertex and its distance from the subpath's start only, so BDPT's densities
/// apply it from either end.
#[inline]
pub fn roulette(q: f32, segments: usize, rr_depth: u32) -> f32 {
    if segments >= DEEP_SEGMENTS {
        q.min(DEEP_CONTINUATION)
    } else if (segments as u32) < rr_depth {
        1.0
    } else {
        q
    }
}

/// The technique densities of a complete path y_0 (pinhole) .. y_k (a `Kind::Light` vertex),
/// computed from scratch: every direction density, free-flight factor (by tracing each
/// segment) and roulette probability is evaluated from the vertices alone. BDPT's rendering
/// assembles the same terms from cached walk densities; the tests check that they agree, which
/// makes the MIS weights of all techniques that can produce a path sum to one.
/// `terms.technique_densities` summed over s is BDPT's `pdf_unguided` for the path (with
/// bdpt's default settings: `direct_by_camera` is set for a directly seen emitter through
/// vacuum in a pixel it fills; a caller with `BdptSettings::direct_splats` clears it).
pub fn path_terms(scene: &Scene, y: &[Vertex], rr_depth: u32) -> PathTerms {
    let mut terms = PathTerms::new(0);
    path_terms_into(scene, y, rr_depth, &mut terms);
    terms
}

/// [`path_terms`] into `terms`, whose storage is reused (no allocation once it has grown to
/// the path's length).
pub fn path_terms_into(scene: &Scene, y: &[Vertex], rr_depth: u32, terms: &mut PathTerms) {
    let k = y.len() - 1;
    terms.reset(k);
    terms.eta = 0.0;
    let Kind::Light { light } = y[k].kind else {
        return;
    };
    terms.hittable = hittable(scene, light);
    for (j, v) in y.iter().enumerate() {
        terms.connectible[j] = v.connectible(scene);
    }
    // Free-flight factors of each segment y_j -> y_{j+1}, towards either end.
    let mut to_next = [1.0f32; MAX_VERTICES];
    let mut to_prev = [1.0f32; MAX_VERTICES];
    terms.direct_by_camera = k == 1 && direct_to_camera(scene, light, y[1].p);
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
                return;
            };
            let edge = Edge::along(&tr);
            if j == 0 && edge.first.is_some() {
                terms.direct_by_camera = false;
            }
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

/// The technique densities of `y` (camera first, a light last) by BDPT's strategy index s;
/// `None` past `max_depth`. With `direct_splats` (`BdptSettings::direct_splats`) a directly
/// seen emitter keeps (1, 1). pt's and bdpt's `Unguided::pdf_unguided` sum them.
pub(crate) fn technique_densities_of_vertices(
    y: &[Vertex],
    scene: &Scene,
    max_depth: u32,
    rr_depth: u32,
    direct_splats: bool,
) -> Option<[f64; MAX_VERTICES]> {
    let k = y.len().checked_sub(1)?;
    if k == 0 || k > max_depth as usize {
        return None;
    }
    let mut p = [0.0f64; MAX_VERTICES];
    TERMS.with_borrow_mut(|terms| {
        path_terms_into(scene, y, rr_depth, terms);
        terms.direct_by_camera &= !direct_splats;
        terms.technique_densities(&mut p);
    });
    Some(p)
}

thread_local! {
    /// [`technique_densities_of_vertices`]' scratch: the guided estimators ask for the
    /// densities of every path U forms, and a fresh `PathTerms` per path was three allocations.
    static TERMS: std::cell::RefCell<PathTerms> = std::cell::RefCell::new(PathTerms::new(0));
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
                let frame = crate::bsdf::ShadingFrame::new(ns, pv.n)
                    .with_uv(pv.uv)
                    .with_stored_tangent(pv.tangent);
                (
                    Kind::Surface {
                        bsdf: &scene.materials[material as usize].bsdf,
                        frame,
                        info,
                        material,
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
    to_path_into(vertices, f, pixel, &mut path);
    path
}

/// The path of camera subpath `c` and light subpath `lp` into `out`: `c` then `lp` reversed.
/// When a connection joins the two (`connected`; not when the camera walk itself reached the
/// emitter that `lp` holds), the two joined vertices are not delta: `Vertex::delta` of a
/// subpath's vertex says how its walk left it, which the connection does not (the two differ
/// on smooth plastic).
pub fn join_subpaths<'a>(
    c: &[Vertex<'a>],
    lp: &[Vertex<'a>],
    connected: bool,
    out: &mut Vec<Vertex<'a>>,
) {
    out.clear();
    out.extend(c.iter().chain(lp.iter().rev()));
    if connected && !lp.is_empty() {
        for j in [c.len().wrapping_sub(1), c.len()] {
            if let Some(v) = out.get_mut(j)
                && matches!(v.kind, Kind::Surface { .. })
            {
                v.delta = false;
            }
        }
    }
}

/// [`to_path`] into an existing path (no fresh 64-vertex array per call).
pub fn to_path_into(vertices: &[Vertex], f: Spectrum, pixel: u32, path: &mut Path) {
    path.clear();
    for v in vertices {
        path.push(path_vertex(v));
    }
    path.f = f;
    path.pixel = pixel;
}

/// One vertex of a [`Path`] from a BDPT vertex.
pub fn path_vertex(v: &Vertex) -> crate::path::Vertex {
    let (kind, ns, uv, tangent) = match v.kind {
        Kind::Camera => (VertexKind::Camera, Vec3::ZERO, Vec2::ZERO, Vec3::ZERO),
        Kind::Surface {
            bsdf,
            frame,
            info,
            material,
        } => (
            VertexKind::Surface {
                material,
                shape: info.index,
                delta: v.delta,
            },
            frame.frame.n,
            frame.uv,
            crate::path::Vertex::tangent_of(bsdf, &frame),
        ),
        Kind::Medium { medium } => (
            VertexKind::Medium { medium },
            Vec3::ZERO,
            Vec2::ZERO,
            Vec3::ZERO,
        ),
        Kind::Light { light } => (
            VertexKind::Emitter {
                light: light as u32,
                delta: v.delta,
            },
            Vec3::ZERO,
            Vec2::ZERO,
            Vec3::ZERO,
        ),
    };
    crate::path::Vertex {
        p: v.p,
        n: v.n,
        ns,
        uv,
        tangent,
        kind,
    }
}

/// Emitted radiance (area lights, at point `p` of normal `n`; intensity for point and spot
/// lights) towards `w`.
pub fn emission(light: &Light, p: Vec3, n: Vec3, w: Vec3) -> Spectrum {
    match light {
        Light::Point(p) => p.intensity,
        Light::Spot(s) => s.intensity_towards(w),
        other => other.le(p, n, w),
    }
}

/// Whether a path pinhole -> `x1` on light `light` (through vacuum) is left to the camera ray:
/// `light` is an area light and an emitter fills the pixel `x1` projects to (`terms.rs`,
/// `Scene::emitter_fills_pixel`). Every technique asks this of the same light and point, so
/// their weights stay a partition of unity.
pub fn direct_to_camera(scene: &Scene, light: usize, x1: Vec3) -> bool {
    matches!(scene.lights[light], Light::Area(_))
        && scene
            .camera
            .world_to_raster(x1)
            .is_some_and(|r| scene.emitter_fills_pixel(scene.camera.pixel_index(r)))
}

/// Whether a camera walk can hit this light (it has area or extent at infinity).
pub fn hittable(scene: &Scene, light: usize) -> bool {
    matches!(
        scene.lights[light],
        Light::Area(_) | Light::Environment(_) | Light::EnvMap(_) | Light::Sun(_)
    )
}

/// Density of the light vertex as an emission origin: light choice times the area density of
/// the point (delta lights: 1), or the solid-angle density of the direction at infinity.
pub fn origin_density(scene: &Scene, v: &Vertex, light: usize) -> f32 {
    let l = &scene.lights[light];
    let pmf = scene.light_sampler.pmf(light);
    if l.is_infinite() {
        pmf * l.pdf_le(v.n, -v.n).1
    } else {
        pmf * l.pdf_le(v.n, v.n).0
    }
}

/// Density of next-event estimation from `from` choosing the light vertex `v` on `light`.
pub fn nee_density(scene: &Scene, from: &Vertex, v: &Vertex, light: usize) -> f64 {
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
        Kind::Light { light } => scene.light_medium(light, v.n, d),
    }
}
