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

/// A cache of the paths pt forms in `n` samples (`trace_pt`, seed 5), equal weights: guide
/// paths all over the image.
pub fn cache_of_pt_paths(scene: &Scene, max_depth: u32, n: u64) -> GuideCache {
    struct Keep(Vec<Install>);
    impl PathRecorder for Keep {
        fn record(&mut self, path: &Path, _: glam::DVec3, _: usize, density: f64, other: f64) {
            if path.segments() >= 2 && path.f != glam::Vec3::ZERO {
                let f = lodestar::math::luminance(path.f) as f64;
                self.0
                    .push((path.vertices().to_vec(), f, density + other, 1.0, 0));
            }
        }
    }
    let mut keep = Keep(Vec::new());
    trace_pt(scene, max_depth, 5, n, &mut keep, |_| false);
    let n = keep.0.len() as f64;
    for e in &mut keep.0 {
        e.3 = 1.0 / n;
    }
    let mut cache = GuideCache::default();
    cache.install(scene, keep.0, 10_000);
    cache
}

/// `integrator` (guided-bdpt or guided-vcm, `extra` options) with every other 16 x 16 tile
/// masked off (`tiles=checker`) and a cache of pt's paths all over the image, nine guided
/// samples per unguided one, converges to bdpt's image (per-pixel z of the mean difference,
/// |z| < 4.5: false-failure rate about 2e-5). The mask must have rejected guided samples.
pub fn masked_render_agrees_with_bdpt(scene: &Scene, integrator: &str, extra: &[&str]) {
    let dir = std::env::temp_dir().join(format!("lodestar-tiles-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join(format!("{integrator}.guides"));
    let cache = cache_of_pt_paths(scene, 6, 2000);
    lodestar::integrators::guided::io::save(scene, &cache, &file).unwrap();
    let load = format!("load_guides={}", file.display());
    let mut options = vec![load.as_str(), "share=fixed", "alpha=0.1", "tiles=checker"];
    options.extend(extra);
    let guided = super::render(scene, integrator, 6, &options, 32, 3, 2);
    let reference = super::render(scene, "bdpt", 6, &[], 64, 4, 2);
    let key = "failures_offimage_miss_structure_scatter_occluded_masked_zero_edge_nonfinite";
    let failures = super::stat(&guided, key).expect("failure counts");
    let masked: u64 = failures
        .trim_matches(['[', ']'])
        .split(", ")
        .nth(5)
        .unwrap()
        .parse()
        .unwrap();
    assert!(
        masked > 1000,
        "{integrator}: guided samples the mask rejected: {failures}"
    );
    assert_eq!(super::stat(&guided, "tiles_off"), Some("0.500"));
    super::assert_same_mean(&guided.image, &reference.image, integrator);
    std::fs::remove_dir_all(&dir).ok();
}
