//! Recording mode of `pt`: every complete path it forms (continuation hits and next-event
//! connections) goes to a [`PathRecorder`] with f(X) and the density pt sampled it with, built
//! vertex by vertex as the path is traced (for the guider and the `pdf_unguided` tests).

use crate::math::Spectrum;
use crate::path::{Path, Vertex as PathVertex, VertexKind};
use crate::scene::Scene;
use glam::{DVec3, Vec3};

/// Receives the complete paths `pt` forms (for guiding, and for tests of `pdf_unguided`).
pub trait PathRecorder {
    /// `path` runs from the camera to an emitter, with its pixel; `f` is f(X) (the unweighted
    /// estimate times `density`) in f64 (`path.f` holds it rounded to f32, which underflows on
    /// long paths in small scenes); `technique` is 0 when the path's continuation hit the emitter
    /// and 1 for next-event estimation; `density` is the density pt sampled the path with
    /// (image-wide, in the area / volume / solid-angle measure of DESIGN.md §3, roulette and
    /// free flight included); `other` is the density of pt's other technique for the same
    /// path, so `density + other` is `pdf_unguided(path)`.
    fn record(&mut self, path: &Path, f: DVec3, technique: usize, density: f64, other: f64);
}

/// The path being traced, with its density so far, while recording.
pub(super) struct Recording<'r> {
    sink: &'r mut dyn PathRecorder,
    pub(super) path: Path,
    /// Density of the vertices so far.
    density: f64,
    /// Solid-angle density of the direction leaving the last vertex.
    pdf_w: f32,
    /// Roulette continuation applied at the last vertex.
    q: f32,
}

impl<'r> Recording<'r> {
    pub(super) fn new(scene: &Scene, sink: &'r mut dyn PathRecorder, d: Vec3, pixel: u32) -> Self {
        let mut path = Path::default();
        path.push(PathVertex {
            p: scene.camera.position,
            n: Vec3::ZERO,
            ns: Vec3::ZERO,
            uv: glam::Vec2::ZERO,
            tangent: Vec3::ZERO,
            kind: VertexKind::Camera,
        });
        path.pixel = pixel;
        Recording {
            sink,
            path,
            density: 1.0,
            pdf_w: scene.camera.pdf_we(d),
            q: 1.0,
        }
    }

    /// Density of reaching `v` from the last vertex (free-flight factor `ff`).
    pub(super) fn step(&self, scene: &Scene, v: &PathVertex, ff: f32) -> f64 {
        let last = self.path.vertices().last().map_or(Vec3::ZERO, |l| l.p);
        let infinite = matches!(v.kind, VertexKind::Emitter { light, .. } if scene.lights[light as usize].is_infinite());
        let conv = if infinite {
            1.0
        } else {
            crate::integrators::paths::area_factor(last, v.p, v.n)
        };
        self.density * conv * (self.pdf_w * ff * self.q) as f64
    }

    pub(super) fn arrive(&mut self, scene: &Scene, v: PathVertex, ff: f32) {
        self.density = self.step(scene, &v, ff);
        self.path.push(v);
    }

    /// The path leaves the last vertex with direction density `pdf_w` (a lobe probability
    /// if `delta`) and continuation `q`. Through a delta lobe the vertex is delta in the
    /// paths that go on from it (it was recorded on arrival as the end of next-event
    /// estimation's path; the two differ on smooth plastic).
    pub(super) fn scatter(&mut self, pdf_w: f32, q: f32, delta: bool) {
        self.pdf_w = pdf_w;
        self.q = q;
        if delta && let Some(v) = self.path.last_mut() {
            v.set_delta(true);
        }
    }

    /// Technique 0: the continuation reached emitter vertex `v`; `estimate` is beta * Le;
    /// `nee` is the density with which next-event estimation would choose `v` (0 after a
    /// delta vertex).
    pub(super) fn emitter(
        &mut self,
        scene: &Scene,
        v: PathVertex,
        ff: f32,
        nee: f64,
        estimate: Spectrum,
    ) {
        let density = self.step(scene, &v, ff);
        self.record_with(v, density / self.density, nee, estimate, 0);
    }

    /// Record the path plus `v`, whose density given the path is `factor` (`other`: the other
    /// technique's).
    pub(super) fn record_with(
        &mut self,
        v: PathVertex,
        factor: f64,
        other: f64,
        estimate: Spectrum,
        technique: usize,
    ) {
        let density = self.density * factor;
        if !self.path.push(v) {
            return;
        }
        let f = estimate.as_dvec3() * density;
        self.path.f = f.as_vec3();
        self.sink
            .record(&self.path, f, technique, density, self.density * other);
        self.path.pop();
    }
}
