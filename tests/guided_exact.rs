//! Exactness of the guided estimator: one selection pmf, selection at f64 resolution, f(X)
//! without underflow on long paths in large scenes, one source of p_u, every failed guided
//! sample counted with its reason.

use crate::util;

use glam::DVec3;
use lodestar::integrators::guided::cache::{GuideCache, Install};
use lodestar::integrators::guided::estimator::X1Candidates;
use lodestar::integrators::guided::{Estimator, Stats, contribution};
use lodestar::integrators::paths::{self, Vertex};
use lodestar::integrators::pt::{PathRecorder, PathTracer, PtSettings};
use lodestar::integrators::unguided::Unguided;
use lodestar::math::alias::AliasTable;
use lodestar::math::{IndependentSampler, Sampler, luminance};
use lodestar::path::Path;
use lodestar::scene::Scene;
use util::guided::trace_pt;

fn pt(max_depth: u32) -> PathTracer {
    PathTracer {
        settings: PtSettings {
            max_depth,
            ..PtSettings::default()
        },
    }
}

/// pt's paths of two or more segments from `n` camera paths, as installs of equal weight
/// 1 / (number of paths), plus `extra` installs appended as given.
fn pt_installs(scene: &Scene, n: u64) -> Vec<Install> {
    struct Keep(Vec<Install>);
    impl PathRecorder for Keep {
        fn record(&mut self, path: &Path, f: DVec3, _: usize, density: f64, other: f64) {
            if path.segments() >= 2 && f != DVec3::ZERO {
                let lum = luminance(f.as_vec3());
                self.0.push((
                    path.vertices().to_vec(),
                    lum as f64,
                    density + other,
                    1.0,
                    0,
                ));
            }
        }
    }
    let mut keep = Keep(Vec::new());
    trace_pt(scene, 6, 5, n, &mut keep, |_| false);
    let w = 1.0 / keep.0.len() as f64;
    for e in &mut keep.0 {
        e.3 = w;
    }
    keep.0
}

/// A path without structure (camera straight to the light: one segment) is dropped by
/// `install`; the weights of the rest no longer sum to one. p_g must weigh each guide path by
/// the probability with which sampling selects it, not by its given weight.
#[test]
fn p_g_weighs_guides_by_their_selection_probability() {
    let scene = util::cornell(16);
    let mut installs = pt_installs(&scene, 64);
    let n = installs.len();
    let w = 1.0 / (n + 10) as f64;
    for e in &mut installs {
        e.3 = w;
    }
    // Ten one-segment paths (camera to the light's centre) carry the rest of the weight.
    let light = (
        glam::Vec3::new(0.0, 0.98, 0.0),
        glam::Vec3::new(0.0, -1.0, 0.0),
    );
    let camera_first = installs[0].0[0];
    for _ in 0..10 {
        let v = vec![
            camera_first,
            lodestar::path::Vertex {
                p: light.0,
                n: light.1,
                ns: glam::Vec3::ZERO,
                uv: glam::Vec2::ZERO,
                tangent: glam::Vec3::ZERO,
                kind: lodestar::path::VertexKind::Emitter {
                    light: 0,
                    delta: false,
                },
            },
        ];
        installs.push((v, 1.0, 1.0, w, 0));
    }
    let mut cache = GuideCache::default();
    cache.install(&scene, installs, 10_000);
    assert_eq!(cache.len(), n, "the one-segment paths are not guide paths");
    let mut total = 0.0;
    for l in 0..cache.len() {
        let pmf = cache.selection_pmf(l);
        assert_eq!(
            cache.guides[l].weight, pmf,
            "guide {l}: p_g weight {} vs selection pmf {pmf}",
            cache.guides[l].weight
        );
        total += pmf;
    }
    assert!((total - 1.0).abs() < 1e-12, "selection pmf sums to {total}");
}

/// Selection among 100k guide paths resolves buckets of width 1e-5 to 1e-10: an f32 uniform
/// (24 bits) cannot, which skews some probabilities by 0.6 %. The sampler's f64 uniforms carry
/// at least 48 bits.
#[test]
fn guide_selection_has_f64_resolution() {
    let n = 100_000usize;
    let table = AliasTable::new(&vec![1.0; n]);
    for i in (0..n).step_by(997) {
        let lo = i as f64 / n as f64 + 1e-10;
        let hi = (i + 1) as f64 / n as f64 - 1e-10;
        assert_eq!(table.sample(lo, 0.5), i, "just above bucket {i}'s start");
        assert_eq!(table.sample(hi, 0.5), i, "just below bucket {i}'s end");
    }
    let mut s = IndependentSampler::new(1, 2, 3);
    let fine = (0..1000)
        .filter(|_| (s.next_f64() * (1u64 << 24) as f64).fract() != 0.0)
        .count();
    assert!(
        fine > 990,
        "only {fine} of 1000 uniforms have more than 24 bits"
    );
}

/// In a box a kilometre wide, f(X) of a path of six or more segments is below f32's range
/// (each segment's G is about 1e-6): pt's recorded f and f from the vertices must both be
/// non-zero and agree (an f32 product gives 0 from the vertices).
#[test]
fn long_paths_in_a_large_scene_keep_their_contribution() {
    let scene = util::scene(
        r#"
[camera]
position = [0, 0, 900]
look_at = [0, 0, 0]
up = [0, 1, 0]
fov = 60
resolution = [8, 8]

[[material]]
name = "white"
type = "diffuse"
albedo = [0.9, 0.9, 0.9]

[[material]]
name = "black"
type = "black"

[[shape]]
type = "cube"
material = "white"
transform = { scale = 1000 }

[[shape]]
type = "quad"
origin = [-300, 990, -300]
edge_u = [600, 0, 0]
edge_v = [0, 0, 600]
material = "black"
emission = [1e6, 1e6, 1e6]
"#,
    );
    struct Check<'a> {
        scene: &'a Scene,
        long: usize,
        tiny: usize,
        bad: Vec<String>,
    }
    impl PathRecorder for Check<'_> {
        fn record(&mut self, path: &Path, f: DVec3, technique: usize, _: f64, _: f64) {
            if path.segments() < 6 || f == DVec3::ZERO {
                return;
            }
            self.long += 1;
            if f.max_element() < 1e-38 {
                self.tiny += 1;
            }
            let y = paths::from_path(self.scene, path).unwrap();
            let fx = contribution::contribution(self.scene, &y, 0);
            let rel = ((f - fx).abs() / f.abs()).max_element();
            // Hit points are f32: at 1000 units from the origin they are rounded by 6e-5, which
            // is 1e-3 of a corner bounce's 0.1-unit segment. So f from the vertices may differ
            // from pt's by what moving the vertices within their error bounds changes
            // (`util::rounding_sensitivity`), times 4: a vertex as traced differs from its
            // stored position by its rounding (one bound) and, as a ray origin, by the offset
            // along the normal (up to sqrt(3) bounds). Measured: at most 2.97 times the
            // sensitivity over 12 835 paths (median 0.8); the relative difference reaches 0.28
            // at a corner and is below 1e-4 for 90 % of paths.
            let bound = crate::util::rounding_sensitivity(&y, |y| {
                contribution::contribution(self.scene, y, 0).x
            });
            // (The scene is grey: every channel of f is the same.)
            let within = (f - fx).abs().max_element() <= 4.0 * bound;
            if (fx == DVec3::ZERO || rel.is_nan() || !within) && self.bad.len() < 4 {
                self.bad.push(format!(
                    "k {} technique {technique}: pt {f} vs {fx}, rounding explains {bound} {:?}",
                    path.segments(),
                    path.vertices().iter().map(|v| v.p).collect::<Vec<_>>()
                ));
            }
        }
    }
    let mut c = Check {
        scene: &scene,
        long: 0,
        tiny: 0,
        bad: Vec::new(),
    };
    let tracer = pt(10);
    for i in 0..4000u64 {
        let mut s = IndependentSampler::new(9, 0, i);
        let raster = glam::Vec2::new((i % 8) as f32, ((i / 8) % 8) as f32) + s.next_2d();
        tracer.li_recorded(&scene, raster, &mut s, Some(&mut c));
    }
    assert!(c.long > 100, "only {} long paths", c.long);
    assert!(
        c.tiny > c.long / 2,
        "the scene does not push f below f32's range ({} of {})",
        c.tiny,
        c.long
    );
    assert!(c.bad.is_empty(), "{}", c.bad.join("\n"));
}

/// A stored path keeps its vertices' texture coordinates: in a box whose walls are a
/// checkerboard (0.9 against 0.1), f(X) from a recorded path's vertices is pt's f to rounding
/// (it would take the texture at (0, 0) for every vertex without them, wrong by up to 9x per
/// vertex: checked by hand with the stored coordinates left out of `paths::from_path`).
#[test]
fn textured_paths_keep_their_contribution_when_stored() {
    let scene = util::scene(
        r#"
[camera]
position = [0, 0, 0.9]
look_at = [0, 0, 0]
up = [0, 1, 0]
fov = 60
resolution = [8, 8]

[[material]]
name = "checker"
type = "diffuse"
albedo_texture = { type = "checkerboard", color0 = [0.9, 0.9, 0.9], color1 = [0.1, 0.1, 0.1], scale = [3, 3] }

[[material]]
name = "black"
type = "black"

[[shape]]
type = "cube"
material = "checker"

[[shape]]
type = "quad"
origin = [-0.3, 0.99, -0.3]
edge_u = [0.6, 0, 0]
edge_v = [0, 0, 0.6]
material = "black"
emission = [10, 10, 10]
"#,
    );
    struct Check<'a> {
        scene: &'a Scene,
        paths: usize,
        worst: f64,
    }
    impl PathRecorder for Check<'_> {
        fn record(&mut self, path: &Path, f: DVec3, _: usize, _: f64, _: f64) {
            if path.segments() < 2 || f == DVec3::ZERO {
                return;
            }
            self.paths += 1;
            let y = paths::from_path(self.scene, path).unwrap();
            let fx = contribution::contribution(self.scene, &y, 0);
            // As in the long-paths test: within 4 times what moving the vertices within
            // their error bounds changes (near the box's corners that reaches 1e-2).
            let bound = crate::util::rounding_sensitivity(&y, |y| {
                contribution::contribution(self.scene, y, 0).x
            });
            self.worst = self
                .worst
                .max((f - fx).abs().max_element() / (4.0 * bound).max(1e-300));
        }
    }
    let mut c = Check {
        scene: &scene,
        paths: 0,
        worst: 0.0,
    };
    let tracer = pt(6);
    for i in 0..2000u64 {
        let mut s = IndependentSampler::new(9, 0, i);
        let raster = glam::Vec2::new((i % 8) as f32, ((i / 8) % 8) as f32) + s.next_2d();
        tracer.li_recorded(&scene, raster, &mut s, Some(&mut c));
    }
    assert!(c.paths > 1000, "only {} paths", c.paths);
    assert!(
        c.worst <= 1.0,
        "f from the stored vertices is off by {} times what rounding explains",
        c.worst
    );
}

/// Where a path's p_g is non-zero, the unguided side's p_u is `pdf_unguided`'s value, the one
/// a guided sample of the same path gets (pt's recorder gives the same number up to rounding,
/// which would leave the weights of one path summing to 1 ± 1e-7, not exactly).
#[test]
fn p_u_has_one_source_where_guiding_can_make_the_path() {
    let scene = util::cornell(16);
    let mut cache = GuideCache::default();
    cache.install(&scene, pt_installs(&scene, 256), 10_000);
    let u = pt(6);
    let est = Estimator::new(&scene, &u, (), &cache, 0.5);
    struct Check<'e, 'a> {
        est: &'e Estimator<'a, PathTracer>,
        scene: &'a Scene,
        with_pg: usize,
        differs: usize,
        bad: Vec<String>,
    }
    impl PathRecorder for Check<'_, '_> {
        fn record(&mut self, path: &Path, f: DVec3, _: usize, density: f64, other: f64) {
            if f == DVec3::ZERO {
                return;
            }
            let recorded = density + other;
            let mut stats = Stats::default();
            let d = self.est.densities(
                path,
                None,
                recorded,
                &mut stats,
                &mut X1Candidates::default(),
            );
            let (p_u, p_g) = (d.p_u, d.p_g);
            if p_g > 0.0 {
                self.with_pg += 1;
                let y: Vec<Vertex> = paths::from_path(self.scene, path).unwrap();
                let reference = Unguided::pdf_unguided(self.est.unguided, self.scene, &(), &y);
                self.differs += (recorded != reference) as usize;
                if p_u != reference && self.bad.len() < 4 {
                    self.bad
                        .push(format!("p_u {p_u} vs pdf_unguided {reference}"));
                }
            }
        }
    }
    let mut c = Check {
        est: &est,
        scene: &scene,
        with_pg: 0,
        differs: 0,
        bad: Vec::new(),
    };
    trace_pt(&scene, 6, 31, 2000, &mut c, |_| false);
    eprintln!(
        "{} paths with p_g > 0; recorder and pdf_unguided differ in {}",
        c.with_pg, c.differs
    );
    assert!(c.with_pg > 100, "only {} paths with p_g > 0", c.with_pg);
    assert!(c.bad.is_empty(), "{}", c.bad.join("\n"));
}

/// pt, except that its `pdf_unguided` calls every path impossible: what the recomputation from
/// the vertices returns when f32 visibility is not symmetric (fog-dragon: a segment the light
/// subpath saw clear is blocked when re-traced from the camera side, by the open rim of the
/// bunny's base).
struct Disagreeing(PathTracer);

impl Unguided for Disagreeing {
    type Tracer<'s> = ();
    type Pass<'s> = ();
    fn name(&self) -> &'static str {
        "pt"
    }
    fn max_depth(&self) -> u32 {
        self.0.max_depth()
    }
    fn begin_pass<'s>(&'s self, _: &'s Scene, _: u64, _: u64, _: u64) {}
    fn tracer<'s, 'p: 's>(&'s self, _: &'s Scene, _: &'s ()) {}
    fn trace(
        &self,
        t: &mut (),
        scene: &Scene,
        raster: glam::Vec2,
        sampler: &mut impl Sampler,
        sink: &mut dyn lodestar::integrators::unguided::PathSink,
    ) {
        self.0.trace(t, scene, raster, sampler, sink)
    }
    fn estimate(
        &self,
        t: &mut (),
        scene: &Scene,
        raster: glam::Vec2,
        sampler: &mut impl Sampler,
        splats: &mut Vec<(u32, DVec3)>,
    ) -> DVec3 {
        self.0.estimate(t, scene, raster, sampler, splats)
    }
    fn pdf_unguided(&self, _: &Scene, _: &(), _: &[Vertex]) -> f64 {
        0.0
    }
}

/// A path U has formed keeps U's own density when the recomputation returns 0, and is counted:
/// with 0 its value would be f / (r p_g), unbounded (fog-dragon rendered single pixels of 7e4
/// in a learning pass, one seed's MSE 53 against a median of 0.8).
#[test]
fn a_path_u_formed_keeps_its_density_where_the_recomputation_calls_it_impossible() {
    let scene = util::cornell(16);
    let mut cache = GuideCache::default();
    cache.install(&scene, pt_installs(&scene, 256), 10_000);
    let u = Disagreeing(pt(6));
    let est = Estimator::new(&scene, &u, (), &cache, 0.5);
    struct Check<'e, 'a> {
        est: &'e Estimator<'a, Disagreeing>,
        with_pg: u64,
        stats: Stats,
        bad: Vec<String>,
    }
    impl PathRecorder for Check<'_, '_> {
        fn record(&mut self, path: &Path, f: DVec3, _: usize, density: f64, other: f64) {
            if f == DVec3::ZERO {
                return;
            }
            let recorded = density + other;
            let d = self.est.densities(
                path,
                None,
                recorded,
                &mut self.stats,
                &mut X1Candidates::default(),
            );
            let (p_u, p_g) = (d.p_u, d.p_g);
            if p_g > 0.0 {
                self.with_pg += 1;
                let value = f.max_element() / self.est.mix(p_u, p_g);
                if (p_u != recorded || value > f.max_element() / recorded) && self.bad.len() < 4 {
                    self.bad
                        .push(format!("p_u {p_u} (U's own {recorded}), value {value}"));
                }
            }
        }
    }
    let mut c = Check {
        est: &est,
        with_pg: 0,
        stats: Stats::default(),
        bad: Vec::new(),
    };
    trace_pt(&scene, 6, 31, 2000, &mut c, |_| false);
    assert!(c.with_pg > 100, "only {} paths with p_g > 0", c.with_pg);
    assert!(c.bad.is_empty(), "{}", c.bad.join("\n"));
    assert_eq!(c.stats.pu_disagreements, c.with_pg);
}

/// Every failed guided sample is counted under a reason (none is dropped silently), on the
/// glass and the fog boxes.
#[test]
fn every_failed_guided_sample_has_a_reason() {
    for name in ["cornell-box.toml", "cornell-fog.toml"] {
        let text = std::fs::read_to_string(format!("{}/scenes/{name}", env!("CARGO_MANIFEST_DIR")))
            .unwrap();
        let scene = util::scene(&text.replace("resolution = [256, 256]", "resolution = [16, 16]"));
        let mut cache = GuideCache::default();
        cache.install(&scene, pt_installs(&scene, 256), 10_000);
        let u = pt(6);
        let est = Estimator::new(&scene, &u, (), &cache, 0.5);
        let mut stats = Stats::default();
        let mut candidates = X1Candidates::default();
        let mut path = lodestar::path::Path::default();
        let mut ok = 0;
        for i in 0..3000u64 {
            let mut s = IndependentSampler::new(4, 0, i);
            ok += est
                .guided(&mut s, false, &mut stats, &mut candidates, &mut path)
                .is_some() as u64;
        }
        let reasons: u64 = stats.reasons.iter().sum();
        assert_eq!(stats.guided, 3000);
        assert_eq!(ok + stats.failed, 3000, "{name}: {stats:?}");
        assert_eq!(reasons, stats.failed, "{name}: {stats:?}");
        assert!(ok > 100, "{name}: {ok} successes");
    }
}
