//! Helpers shared by the guided integrators' tests: a caustic scene, a cache that carries its
//! caustic, pt paths traced into a recorder.

use lodestar::integrators::guided::cache::{GuideCache, Install};
use lodestar::integrators::pt::{PathRecorder, PathTracer, PtSettings};
use lodestar::math::{IndependentSampler, Sampler};
use lodestar::path::{Path, VertexKind};
use lodestar::scene::Scene;

/// A caustic: a glass sphere on a diffuse floor beside a small light, seen from above; pt
/// finds the caustic only when a floor bounce happens to refract into the light.
pub const CAUSTIC: &str = r#"
[camera]
position = [0, 2.2, 1.6]
look_at = [0, 0, 0]
up = [0, 1, 0]
fov = 40
resolution = [48, 48]

[[material]]
name = "floor"
type = "diffuse"
albedo = [0.7, 0.7, 0.7]

[[material]]
name = "glass"
type = "dielectric"
ior = 1.5

[[material]]
name = "black"
type = "black"

[[shape]]
type = "quad"
origin = [-1.5, 0, -1.5]
edge_u = [0, 0, 3]
edge_v = [3, 0, 0]
material = "floor"

[[shape]]
type = "sphere"
center = [0, 0.35, 0]
radius = 0.35
material = "glass"

[[shape]]
type = "quad"
origin = [0.8, 1.2, -0.2]
edge_u = [0.4, 0, 0]
edge_v = [0, 0, 0.4]
material = "black"
emission = [50, 50, 50]
"#;

/// The guide paths of `cache` as installs (vertices, f, p_u, weight, age).
pub fn installs_of(scene: &Scene, cache: &GuideCache) -> Vec<Install> {
    (0..cache.len())
        .map(|l| {
            let g = &cache.guides[l];
            (cache.path_vertices(scene, l), g.f, g.p_u, g.weight, g.age)
        })
        .collect()
}

/// A cache of two copies (or one, `single`) of the first caustic path (floor, two refractions
/// through the glass sphere, light) pt forms in `scene`.
pub fn twin_caustic_cache(scene: &Scene, single: bool) -> GuideCache {
    struct First(Option<Install>);
    impl PathRecorder for First {
        fn record(&mut self, path: &Path, _: glam::DVec3, _: usize, density: f64, other: f64) {
            let v = path.vertices();
            let caustic = v.len() == 5
                && matches!(v[1].kind, VertexKind::Surface { delta: false, .. })
                && matches!(v[2].kind, VertexKind::Surface { delta: true, .. })
                && matches!(v[3].kind, VertexKind::Surface { delta: true, .. });
            if caustic && self.0.is_none() && path.f != glam::Vec3::ZERO {
                let f = lodestar::math::luminance(path.f) as f64;
                self.0 = Some((v.to_vec(), f, density + other, 0.5, 0));
            }
        }
    }
    let mut first = First(None);
    trace_pt(scene, 6, 21, 200_000, &mut first, |f| f.0.is_some());
    let twin = first.0.expect("pt finds a caustic path");
    let mut cache = GuideCache::default();
    if single {
        cache.install(scene, vec![(twin.0, twin.1, twin.2, 1.0, twin.4)], 10_000);
    } else {
        cache.install(scene, vec![twin.clone(), twin], 10_000);
    }
    cache
}

/// Trace `n` pt camera paths (pixel i mod the image, stream (seed, 0, i)) into `recorder`,
/// stopping early once `done` says so.
pub fn trace_pt<R: PathRecorder>(
    scene: &Scene,
    max_depth: u32,
    seed: u64,
    n: u64,
    recorder: &mut R,
    done: impl Fn(&R) -> bool,
) {
    let pt = PathTracer {
        settings: PtSettings {
            max_depth,
            ..PtSettings::default()
        },
    };
    for i in 0..n {
        let (raster, mut s) = sample_stream(scene, seed, i);
        pt.li_recorded(scene, raster, &mut s, Some(recorder));
        if done(recorder) {
            break;
        }
    }
}

/// Sample i of a test trace: stream (seed, 0, i) and a jittered raster position in pixel
/// i mod the image.
pub fn sample_stream(scene: &Scene, seed: u64, i: u64) -> (glam::Vec2, IndependentSampler) {
    let res = scene.camera.resolution;
    let mut s = IndependentSampler::new(seed, 0, i);
    let raster = lodestar::camera::Camera::jittered(
        (i % res.x as u64) as u32,
        ((i / res.x as u64) % res.y as u64) as u32,
        s.next_2d(),
    );
    (raster, s)
}
