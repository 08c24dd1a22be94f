//! guided-vcm: its unguided side's density sum `p_u` (BDPT's techniques plus merging) against
//! vcm's independently computed recursive weights, the densities its tracer reports against
//! the recomputation from the vertices, its image against bdpt's, thread-count independence,
//! and its option errors.
//!
//! Statistical checks are z-tests at |z| < 4.5 per pixel and channel (`util::assert_same_mean`,
//! false-failure rate about 2e-5 for three channels) with fixed seeds.

use crate::util;

use glam::DVec3;
use lodestar::integrators::bdpt::BdptSettings;
use lodestar::integrators::paths::{self, Heuristic, Vertex};
use lodestar::integrators::unguided::{HeldPaths, PathSink, Unguided};
use lodestar::integrators::vcm::{self, Record, Technique, VcmPass, VcmSettings, VcmUnguided};
use lodestar::path::{Path, Vertex as PathVertex};
use lodestar::scene::Scene;
use std::sync::Arc;
use util::guided::{CAUSTIC, sample_stream};

const MAX_DEPTH: u32 = 6;
const RADIUS: f32 = 0.05;

pub(crate) fn box_scene(name: &str, res: u32) -> Scene {
    let text =
        std::fs::read_to_string(format!("{}/scenes/{name}", env!("CARGO_MANIFEST_DIR"))).unwrap();
    util::scene(&text.replace(
        "resolution = [256, 256]",
        &format!("resolution = [{res}, {res}]"),
    ))
}

pub(crate) fn unguided() -> VcmUnguided {
    VcmUnguided {
        settings: BdptSettings {
            max_depth: MAX_DEPTH,
            rr_depth: 1,
            heuristic: Heuristic::Balance,
            light_tracing: false,
            techniques: Default::default(),
            direct_splats: false,
        },
        radius: Some(RADIUS),
        alpha: 0.75,
    }
}

/// vcm weighs each connection by the balance heuristic over every connection and every merge
/// of its path, recursively (`integrators/vcm`, tested against densities from scratch in
/// `tests/vcm.rs`). guided-vcm's `pdf_unguided` must be that heuristic's denominator: for
/// every connection vcm makes in a pass, its technique density over guided-vcm's `p_u` of
/// the same pass equals vcm's weight (relative 2e-3: f32 densities). With eta off by a factor
/// (a merge counted per pixel instead of per light subpath, say) the weights of paths with a
/// mergeable vertex differ by far more, which the count of such paths below makes visible.
#[test]
fn p_u_is_the_denominator_of_vcms_weights() {
    for name in ["cornell-box.toml", "cornell-fog.toml"] {
        let scene = box_scene(name, 16);
        let u = unguided();
        let st = VcmSettings {
            max_depth: MAX_DEPTH,
            radius: Some(RADIUS),
            alpha: 0.75,
            connect: true,
            merge: true,
            direct_splats: false,
        };
        let (mut n, mut with_merges, mut bad) = (0usize, 0usize, Vec::new());
        for pass in 0..2u64 {
            let shared = u.begin_pass(&scene, 7, pass, pass);
            vcm::inspect_pass(&scene, &st, 7, pass, &mut |r: &Record| {
                let Technique::Connect { s } = r.technique else {
                    return;
                };
                let Some(y) = paths::from_path(&scene, &r.path) else {
                    return;
                };
                let k = y.len() - 1;
                let mut p = [0.0f64; lodestar::path::MAX_VERTICES];
                paths::path_terms(&scene, &y, 1).technique_densities(&mut p);
                let p_u = u.pdf_unguided(&scene, &shared, &y);
                if p_u.is_nan() || p_u <= 0.0 || p[s] == 0.0 {
                    return;
                }
                n += 1;
                let vc: f64 = p[..=k].iter().sum();
                with_merges += (p_u > vc * 1.01) as usize;
                let w = p[s] / p_u;
                if (w - r.weight).abs() > 2e-3 * r.weight.max(1e-3) && bad.len() < 6 {
                    bad.push(format!(
                        "k {k}, s {s}: vcm {} vs guided-vcm {w} (no merges {})",
                        r.weight,
                        p[s] / vc
                    ));
                }
            });
        }
        assert!(n > 1000, "{name}: only {n} connections");
        assert!(
            with_merges > n / 10,
            "{name}: merges weigh on only {with_merges} of {n}"
        );
        assert!(bad.is_empty(), "{name}:\n{}", bad.join("\n"));
    }
}

/// A learning pass (`Unguided::begin_pass`) is a pass of vcm's tracer in which every path is
/// held: traced on the same streams, it hands the sink the same paths with the same values as
/// `renew_render_pass` with a test that holds every path (compared path by path below), and
/// those carry densities from their vertices (the next test shows that they add up to vcm's
/// image). Merges are among them.
#[test]
fn a_learning_pass_hands_over_every_path_with_its_densities() {
    struct All;
    impl HeldPaths for All {
        fn holds(&self, _: &Scene, _: &[PathVertex], _: &[PathVertex]) -> bool {
            true
        }
    }
    #[derive(Default)]
    struct Log {
        recorded: Vec<(u32, bool, usize, DVec3, f64)>,
        weighted: Vec<(u32, bool, DVec3)>,
    }
    impl PathSink for Log {
        fn record(&mut self, path: &Path, y: Option<&[Vertex]>, f: DVec3, p_u: f64, splat: bool) {
            assert!(y.is_some(), "a learning pass hands over the vertices");
            self.recorded
                .push((path.pixel, splat, path.segments(), f, p_u));
        }
        fn record_weighted(&mut self, pixel: u32, value: DVec3, splat: bool) {
            self.weighted.push((pixel, splat, value));
        }
    }
    let scene = box_scene("cornell-box.toml", 16);
    let u = unguided();
    let n = scene.camera.pixel_count() as u64;
    let log = |pass: VcmPass| {
        let mut tracer = u.tracer(&scene, &pass);
        let mut log = Log::default();
        for i in 0..n {
            let (raster, mut s) = sample_stream(&scene, 11, i);
            u.trace(&mut tracer, &scene, raster, &mut s, &mut log);
        }
        log
    };
    let all: Arc<dyn HeldPaths> = Arc::new(All);
    let learning = log(u.begin_pass(&scene, 3, 0, 0));
    let held = log(u.renew_render_pass(&scene, 3, 0, 0, None, Some(&all)));
    assert_eq!(learning.recorded, held.recorded);
    assert_eq!(learning.weighted, held.weighted);
    let recorded = learning.recorded.len() as u64;
    assert!(recorded > 2 * n, "only {recorded} paths with densities");
    // Merges are handed over too: the same pass at a radius of 1e-9 (no merges) hands over
    // fewer paths (measured: 952 against 897; 256 light subpaths leave few photons near).
    let without = VcmUnguided {
        radius: Some(1e-9),
        ..unguided()
    };
    let connections = {
        let pass = without.begin_pass(&scene, 3, 0, 0);
        let mut tracer = without.tracer(&scene, &pass);
        let mut log = Log::default();
        for i in 0..n {
            let (raster, mut s) = sample_stream(&scene, 11, i);
            without.trace(&mut tracer, &scene, raster, &mut s, &mut log);
        }
        log.recorded.len() as u64
    };
    assert!(
        recorded > connections + 20,
        "{recorded} paths with merging, {connections} without: no merges handed over"
    );
}

/// guided-vcm's render passes trace with vcm's own tracer (`Unguided::renew_render_pass`),
/// which hands the sink, with their densities, only the paths the pass's `HeldPaths` holds
/// (vcm's unweighted estimate times its technique's density from the vertices gives f), and
/// every other path weighted by vcm's recursive weights. Traced on the same streams, a pass
/// in which every path is held (each weighed f / p_u) and one in which none is give the same
/// image: in total to 2e-3 (measured 7e-4 and 1e-4) and nine pixels in ten to 1 %; merged
/// paths (the camera vertex standing in for the light vertex, see above) differ more on a
/// few. A technique density off by one strategy (`vc[s + 1]`) or merges weighed by a
/// connection's density fail it (checked against such a broken build). U's own estimate of such a pass (`estimate`: the
/// claimed paths at vcm's weights) is vcm's image, pixel by pixel to f32 rounding (1e-4).
/// "Every path" is every path with a structure: the tracer asks about no path of two
/// vertices (`paths::structure`), so those go weighted, only in pixels that see an emitter.
#[test]
fn held_paths_of_vcms_tracer_carry_their_densities() {
    struct Held(bool);
    impl HeldPaths for Held {
        fn holds(&self, _: &Scene, _: &[PathVertex], _: &[PathVertex]) -> bool {
            self.0
        }
    }
    struct Image {
        pixels: Vec<DVec3>,
        weighted: Vec<DVec3>,
        recorded: usize,
    }
    impl PathSink for Image {
        fn record(&mut self, path: &Path, y: Option<&[Vertex]>, f: DVec3, p_u: f64, _: bool) {
            assert!(y.is_some(), "held paths come with their vertices");
            self.pixels[path.pixel as usize] += f / p_u;
            self.recorded += 1;
        }
        fn needs_densities(&mut self, _: &[Vertex], _: &[Vertex]) -> bool {
            unreachable!("vcm's tracer asks its HeldPaths")
        }
        fn record_weighted(&mut self, pixel: u32, value: DVec3, _: bool) {
            self.pixels[pixel as usize] += value;
            self.weighted[pixel as usize] += value;
        }
    }
    for name in ["cornell-box.toml", "cornell-fog.toml"] {
        let scene = box_scene(name, 24);
        let u = unguided();
        let n = scene.camera.pixel_count();
        let image = |all: bool| {
            let held: Arc<dyn HeldPaths> = Arc::new(Held(all));
            let mut img = Image {
                pixels: vec![DVec3::ZERO; n],
                weighted: vec![DVec3::ZERO; n],
                recorded: 0,
            };
            for pass in 0..4u64 {
                let state = u.renew_render_pass(&scene, 7, pass, pass, None, Some(&held));
                let mut tracer = u.tracer(&scene, &state);
                for i in 0..n as u64 {
                    let (raster, mut s) = sample_stream(&scene, 5 + pass, i);
                    u.trace(&mut tracer, &scene, raster, &mut s, &mut img);
                }
            }
            img
        };
        let (held, own) = (image(true), image(false));
        // U's own estimate from the same pass (what the guider renders with when it has no
        // guided samples): the claimed paths at vcm's weights, so vcm's image again.
        let mut estimated = vec![DVec3::ZERO; n];
        let held_all: Arc<dyn HeldPaths> = Arc::new(Held(true));
        for pass in 0..4u64 {
            let state = u.renew_render_pass(&scene, 7, pass, pass, None, Some(&held_all));
            let mut tracer = u.tracer(&scene, &state);
            let mut splats = Vec::new();
            for i in 0..n as u64 {
                let (raster, mut s) = sample_stream(&scene, 5 + pass, i);
                estimated[i as usize] +=
                    u.estimate(&mut tracer, &scene, raster, &mut s, &mut splats);
            }
            for (p, v) in splats {
                estimated[p as usize] += v;
            }
        }
        for (p, (a, b)) in estimated.iter().zip(&own.pixels).enumerate() {
            assert!(
                ((*a - *b).abs() / b.max(DVec3::splat(1e-6))).max_element() < 1e-4,
                "{name}: pixel {p}: estimate {a} vs vcm's weights {b}"
            );
        }
        assert_eq!(own.recorded, 0, "{name}: nothing held, nothing recorded");
        assert!(
            held.recorded > 10 * n,
            "{name}: only {} held paths",
            held.recorded
        );
        let total = |img: &Image| img.pixels.iter().sum::<DVec3>();
        let (a, b) = (total(&held), total(&own));
        // Paths of two vertices (an emitter seen directly) have no structure and go
        // weighted; so would paths the explicit densities do not take (none expected here):
        // nothing goes weighted in a pixel where no emitter is seen (rays on an 8 x 8 grid).
        let width = scene.camera.resolution.x as usize;
        let sees_emitter: Vec<bool> = (0..n)
            .map(|i| {
                let corner = glam::Vec2::new((i % width) as f32, (i / width) as f32);
                (0..64).any(|j| {
                    let at = glam::Vec2::new((j % 8) as f32 + 0.5, (j / 8) as f32 + 0.5) / 8.0;
                    let hit = scene.intersect(&scene.camera.generate_ray(corner + at));
                    hit.is_some_and(|sp| sp.info.light.is_some())
                })
            })
            .collect();
        let stray = (0..n)
            .filter(|&i| !sees_emitter[i] && held.weighted[i] != DVec3::ZERO)
            .count();
        assert_eq!(
            stray, 0,
            "{name}: pixels with weighted paths but no emitter seen"
        );
        assert!(
            sees_emitter.iter().filter(|&&s| s).count() < n / 4,
            "{name}: the emitter fills the image"
        );
        let rel = ((a - b).abs() / b).max_element();
        assert!(rel < 2e-3, "{name}: held {a} vs vcm's weights {b}");
        // Measured: the pixels' median difference 4e-4 and 2e-4, the 90th percentile 4e-3
        // and 3e-3 (box, fog); up to 30 % on a few pixels (merges in the corners).
        let off = (held.pixels.iter().zip(&own.pixels))
            .filter(|(p, q)| ((**p - **q).abs() / q.max(DVec3::splat(1e-3))).max_element() > 0.01)
            .count();
        assert!(
            off < n / 10,
            "{name}: {off} of {n} pixels differ by more than 1 %"
        );
    }
}

/// vcm's tracer asks the cache's held structures (`GuideCache::held`) of each path split in two
/// (the camera subpath and the light subpath, light first): its answer is the cache's for
/// the joined path (`kernel::signature`, which the guided density sums over), for every path
/// vcm forms in a pass, with a cache of some of bdpt's paths of the glass box in which both
/// answers occur often.
#[test]
fn vcm_claims_the_paths_whose_structure_the_cache_holds() {
    use lodestar::integrators::guided::cache::{GuideCache, HeldStructures};
    use lodestar::integrators::guided::kernel;
    use std::sync::Mutex;
    /// Claims every path, recording where the held structures and the joined path disagree.
    struct Compare {
        held: HeldStructures,
        cache: GuideCache,
        counts: Mutex<[usize; 2]>,
        bad: Mutex<Vec<String>>,
    }
    impl HeldPaths for Compare {
        fn holds(&self, scene: &Scene, head: &[PathVertex], tail: &[PathVertex]) -> bool {
            let split = self.held.holds(scene, head, tail);
            let mut path = Path::default();
            for v in head.iter().chain(tail.iter().rev()) {
                path.push(*v);
            }
            let joined = kernel::signature(scene, &path, lodestar::path::MAX_VERTICES)
                .is_some_and(|sig| self.cache.holds(sig));
            self.counts.lock().unwrap()[split as usize] += 1;
            if split != joined {
                self.bad.lock().unwrap().push(format!(
                    "{} + {} vertices: split {split}, joined {joined}",
                    head.len(),
                    tail.len()
                ));
            }
            true
        }
    }
    struct Nothing;
    impl PathSink for Nothing {
        fn record(&mut self, _: &Path, _: Option<&[Vertex]>, _: DVec3, _: f64, _: bool) {}
        fn record_weighted(&mut self, _: u32, _: DVec3, _: bool) {}
    }
    let scene = box_scene("cornell-box.toml", 24);
    let u = unguided();
    let cache = learning_paths_cache(&scene, &u, 3);
    let compare = Arc::new(Compare {
        held: cache.held(),
        cache,
        counts: Mutex::default(),
        bad: Mutex::default(),
    });
    let held: Arc<dyn HeldPaths> = compare.clone();
    two_render_passes(&scene, &u, &held, &mut Nothing);
    let [not_held, held] = *compare.counts.lock().unwrap();
    assert!(
        held > 500 && not_held > 500,
        "held {held}, not held {not_held}"
    );
    let bad = compare.bad.lock().unwrap();
    assert!(
        bad.is_empty(),
        "{} disagree, e.g.\n{}",
        bad.len(),
        bad[..bad.len().min(6)].join("\n")
    );
}

/// Render passes 1 and 2 of `u` (seed 3) with the claims test `held`, into `sink`.
fn two_render_passes(
    scene: &Scene,
    u: &VcmUnguided,
    held: &Arc<dyn HeldPaths>,
    sink: &mut dyn PathSink,
) {
    for pass in 1..3 {
        let state = u.renew_render_pass(scene, 3, pass, pass, None, Some(held));
        let mut tracer = u.tracer(scene, &state);
        for i in 0..scene.camera.pixel_count() as u64 {
            let (raster, mut s) = sample_stream(scene, 5 + pass, i);
            u.trace(&mut tracer, scene, raster, &mut s, sink);
        }
    }
}

/// A cache of every `stride`-th of the paths of one learning pass of `scene` that
/// have at least three segments (so that the paths vcm forms most, of two, are not held).
pub(crate) fn learning_paths_cache(
    scene: &Scene,
    u: &VcmUnguided,
    stride: usize,
) -> lodestar::integrators::guided::cache::GuideCache {
    struct Keep(
        Vec<lodestar::integrators::guided::cache::Install>,
        usize,
        usize,
    );
    impl PathSink for Keep {
        fn record(&mut self, path: &Path, _: Option<&[Vertex]>, f: DVec3, p_u: f64, _: bool) {
            self.1 += 1;
            if path.segments() >= 3 && f != DVec3::ZERO && self.1.is_multiple_of(self.2) {
                let lum = lodestar::math::luminance64(f);
                self.0.push((path.vertices().to_vec(), lum, p_u, 1.0, 0));
            }
        }
        /// Paths of two vertices (no structure to guide).
        fn record_weighted(&mut self, _: u32, _: DVec3, _: bool) {}
    }
    let pass = u.begin_pass(scene, 3, 0, 0);
    let mut tracer = u.tracer(scene, &pass);
    let mut keep = Keep(Vec::new(), 0, stride);
    for i in 0..scene.camera.pixel_count() as u64 {
        let (raster, mut s) = sample_stream(scene, 4, i);
        u.trace(&mut tracer, scene, raster, &mut s, &mut keep);
    }
    let mut cache = lodestar::integrators::guided::cache::GuideCache::default();
    cache.install(scene, keep.0, 10_000);
    assert!(cache.structures() > 5, "{} structures", cache.structures());
    cache
}

/// vcm's tracer first tests the low bits of a path's structure hash, joined from partial
/// hashes kept along the camera subpath and with each light vertex (`paths::structure`:
/// `CameraSideHash`, `LightSideHash`, `HeldKey`; merges read no light subpath for it), and
/// makes the exact test of the cache's structures only where they pass. On the glass box
/// with a cache of some of bdpt's paths (a few hundred structures' worth of paths):
/// - the partial hashes join into the whole path's signature exactly, for every path the
///   exact test is asked about, and a photon's key (either side of its subpath's last
///   surface) and a merge's two camera-side nodes cover the exact value's low bits;
/// - two passes claim the same paths with the low-bit test as without it (every claimed
///   path handed over with the same f and p_u, every other path with the same weighted
///   value), so the test drops no held path (a table missing one held structure's bit,
///   or a photon keyed after its own vertex, fails this (checked against such a broken build));
/// - and it spares at least 90 % of the exact tests that answer no.
#[test]
fn the_low_bit_test_keeps_every_held_path() {
    use lodestar::integrators::guided::cache::HeldStructures;
    use lodestar::integrators::guided::kernel;
    use lodestar::integrators::paths::structure::{CameraSideHash, HeldKey, LightSideHash};
    use lodestar::path::MAX_VERTICES;
    use std::sync::Mutex;
    use std::sync::atomic::{AtomicUsize, Ordering};
    struct Counting {
        held: HeldStructures,
        /// Exact tests asked, and answered yes.
        calls: [AtomicUsize; 2],
        bad: Mutex<Vec<String>>,
    }
    impl HeldPaths for Counting {
        fn holds(&self, scene: &Scene, head: &[PathVertex], tail: &[PathVertex]) -> bool {
            let mut path = Path::default();
            for v in head.iter().chain(tail.iter().rev()) {
                path.push(*v);
            }
            let (mut cam, mut light) = (CameraSideHash::default(), LightSideHash::default());
            head.iter().for_each(|v| cam.push(scene, v));
            tail.iter().for_each(|v| light.push(scene, v));
            let (near_cam, near_light) = (head.last().unwrap().p, tail.last().unwrap().p);
            let low = |h: u64| h & ((1 << HeldKey::BITS) - 1);
            if let Some(sig) = kernel::signature(scene, &path, MAX_VERTICES) {
                let d = tail.len();
                let lh = light.closed_by(scene, near_cam);
                let (hs, m) = lh.map_or(([0; 2], 0), |lh| {
                    cam.joined(scene, Some(near_light), lh, d, MAX_VERTICES)
                });
                let (keys, k) = light.key(scene).hashes(d - 1);
                let keyed = keys[..k].iter().any(|&kh| {
                    let (hs, m) = cam.joined(scene, None, kh, d, MAX_VERTICES);
                    hs[..m].iter().any(|&h| low(h) == low(sig))
                });
                if m != 1 || hs[0] != sig || !keyed {
                    self.bad.lock().unwrap().push(format!(
                        "{} + {d} vertices: joined {:?} (keyed {keyed}) vs {sig}",
                        head.len(),
                        &hs[..m]
                    ));
                }
            }
            let yes = self.held.holds(scene, head, tail);
            self.calls[0].fetch_add(1, Ordering::Relaxed);
            self.calls[1].fetch_add(yes as usize, Ordering::Relaxed);
            yes
        }
        fn may_hold_hash(&self, h: u64) -> bool {
            self.held.may_hold_hash(h)
        }
    }
    #[derive(Default, PartialEq, Debug)]
    struct Paths {
        recorded: Vec<(u32, [u64; 3], u64)>,
        weighted: Vec<(u32, [u64; 3])>,
    }
    impl PathSink for Paths {
        fn record(&mut self, path: &Path, _: Option<&[Vertex]>, f: DVec3, p_u: f64, _: bool) {
            let f = f.to_array().map(f64::to_bits);
            self.recorded.push((path.pixel, f, p_u.to_bits()));
        }
        fn record_weighted(&mut self, pixel: u32, value: DVec3, _: bool) {
            self.weighted
                .push((pixel, value.to_array().map(f64::to_bits)));
        }
    }
    let scene = box_scene("cornell-box.toml", 24);
    let u = unguided();
    let cache = learning_paths_cache(&scene, &u, 3);
    let run = |filter: bool| {
        let mut held = cache.held();
        held.filter = filter;
        let counting = Arc::new(Counting {
            held,
            calls: Default::default(),
            bad: Mutex::default(),
        });
        let held: Arc<dyn HeldPaths> = counting.clone();
        let mut paths = Paths::default();
        two_render_passes(&scene, &u, &held, &mut paths);
        let bad = counting.bad.lock().unwrap();
        assert!(
            bad.is_empty(),
            "{} partial hashes disagree, e.g.\n{}",
            bad.len(),
            bad[..bad.len().min(6)].join("\n")
        );
        let calls = counting.calls.each_ref().map(|c| c.load(Ordering::Relaxed));
        (paths, calls)
    };
    let ((with, [tested, yes]), (without, [all, yes_all])) = (run(true), run(false));
    assert!(
        yes_all > 1000 && all - yes_all > 1000,
        "{yes_all} of {all} paths held: too few of either kind"
    );
    assert_eq!(yes, yes_all, "paths held");
    assert_eq!(with.recorded.len(), without.recorded.len(), "claimed paths");
    assert!(with == without, "the same paths, the same values");
    // The exact tests the low bits leave to answer no: hash collisions in 14 bits.
    assert!(
        10 * (tested - yes) < all - yes_all,
        "the low bits spared only {} of {} exact tests that answer no",
        all - tested,
        all - yes_all
    );
}

/// guided-vcm, learning its cache inside the render with guided samples forced on, converges
/// to bdpt's image on the Cornell box (merging's bias at this radius is below the noise of
/// these renders, as for vcm in `tests/vcm.rs`).
#[test]
fn guided_vcm_agrees_with_bdpt_on_the_cornell_box() {
    let scene = box_scene("cornell-box.toml", 32);
    let options = ["learn_fraction=0.5", "share=fixed", "radius=0.02"];
    let guided = util::render(&scene, "guided-vcm", MAX_DEPTH, &options, 32, 3, 2);
    let reference = util::render(&scene, "bdpt", MAX_DEPTH, &[], 64, 4, 2);
    let guided_samples: u64 = util::stat(&guided, "guided_samples")
        .unwrap()
        .parse()
        .unwrap();
    assert!(guided_samples > 10_000, "{:?}", guided.stats);
    util::assert_same_mean(&guided.image, &reference.image, "guided-vcm vs bdpt");
}

/// guided-vcm on `scene` with a frozen cache installed from `twin` (no learning; α = 0.05, so
/// most samples are guided), p_g scaled by `p_g_factor` where paths are weighed (1: none).
fn frozen_guided_vcm(
    scene: &Scene,
    twin: &lodestar::integrators::guided::cache::GuideCache,
    p_g_factor: f64,
    seed: u64,
    spp: u64,
) -> lodestar::film::Image {
    use lodestar::integrators::guided::cache::GuideCache;
    use lodestar::integrators::guided::{Guided, GuidedSettings, Outliers};
    use lodestar::render::{Budget, Integrator, RenderContext};
    let mut c = GuideCache::default();
    c.install(scene, util::guided::installs_of(scene, twin), 10_000);
    c.weight_faults.p_g = p_g_factor;
    let settings = GuidedSettings {
        alpha: 0.05,
        learn_fraction: 0.0,
        ..GuidedSettings::default()
    };
    let mut g = Guided {
        name: "guided-vcm",
        seeder: Outliers::new(settings.intake),
        unguided: VcmUnguided {
            radius: None,
            ..unguided()
        },
        settings,
        cache: Some(c),
    };
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(2)
        .build()
        .unwrap();
    let r = pool.install(|| g.render(&RenderContext::new(scene, seed, false), Budget::Spp(spp)));
    let guided: f64 = util::stat(&r, "guided_samples").unwrap().parse().unwrap();
    assert!(guided > 0.0, "no guided samples");
    r.image
}

/// Per tile (4 x 4 pixels of the caustic scene at 24 x 24, Welch's t, Bonferroni over tiles and
/// channels, family-wise false-failure rate 1e-4), guided-vcm with a frozen cache that carries
/// the caustic (one caustic path twice, weights 1/2; α = 0.05, so most samples are guided; 16
/// renders of 16 passes) renders bdpt's image (the 24 renders of
/// [`crate::guided::caustic_reference`]) and vcm's (24 renders of 32 passes; merging's bias at
/// the default radius is below these renders' noise). p_g x 1.5 where paths are weighed fails
/// the same test against bdpt with as many renders as the correct cache.
#[test]
fn guided_vcm_renders_bdpt_image_on_a_caustic_tile_by_tile() {
    use util::guided::twin_caustic_cache;
    const SEEDS: u64 = 16;
    let scene = crate::guided::caustic_tile_scene();
    let reference = crate::guided::caustic_reference();
    let twin = twin_caustic_cache(&scene, false);
    let renders = |p_g_factor: f64| -> Vec<lodestar::film::Image> {
        (0..SEEDS)
            .map(|seed| frozen_guided_vcm(&scene, &twin, p_g_factor, seed, 16))
            .collect()
    };
    let ok = renders(1.0);
    util::assert_same_image(&ok, reference, 4, "guided-vcm against bdpt");
    // And against vcm itself at the same radius schedule.
    let vcm: Vec<_> = (0..24)
        .map(|s| util::render(&scene, "vcm", MAX_DEPTH, &[], 32, 200 + s, 2).image)
        .collect();
    util::assert_same_image(&ok, &vcm, 4, "guided-vcm against vcm");
    let wrong = renders(1.5);
    let caught = std::panic::catch_unwind(|| {
        util::assert_same_image(&wrong, reference, 4, "guided-vcm, p_g x 1.5 (control)")
    });
    assert!(
        caught.is_err(),
        "guided-vcm with p_g x 1.5 passed the per-tile test"
    );
}

/// guided-vcm is consistent: on the caustic scene at 16 x 16 (frozen caustic cache, as above)
/// its MSE against a bdpt reference (4096 passes, its own noise taken out) falls from 4 to 64
/// passes as vcm's does. The median MSE over 6 seeds (the MSE of one render is heavy-tailed
/// here) would fall to 1/16 of it for pure variance; merging's shrinking radius makes vcm's
/// fall slower (measured 0.09-0.16 for guided-vcm over four sets of seeds, 0.15 for vcm). Both
/// must fall below 0.25 of it. Control: with p_g x 1.5 (a bias that stays) the error falls
/// only to 0.36-0.42 of it (measured over the same four sets), and must stay above 0.25.
#[test]
fn guided_vcm_error_falls_with_the_budget_like_vcms() {
    use util::guided::twin_caustic_cache;
    let scene = util::scene(&CAUSTIC.replace("resolution = [48, 48]", "resolution = [16, 16]"));
    let twin = twin_caustic_cache(&scene, false);
    // The reference's own noise is taken out of each MSE: with R the mean of two independent
    // references R1, R2, E|X - R|^2 = MSE(X) + E|R1 - R2|^2 / 4.
    let r1 = util::render(&scene, "bdpt", MAX_DEPTH, &[], 2048, 7, 2).image;
    let r2 = util::render(&scene, "bdpt", MAX_DEPTH, &[], 2048, 8, 2).image;
    let sq = |a: &lodestar::film::Image, b: &[DVec3]| {
        a.pixels
            .iter()
            .zip(b)
            .map(|(x, y)| (x.as_dvec3() - *y).length_squared())
            .sum::<f64>()
            / b.len() as f64
    };
    let reference: Vec<DVec3> = (r1.pixels.iter().zip(&r2.pixels))
        .map(|(a, b)| 0.5 * (a.as_dvec3() + b.as_dvec3()))
        .collect();
    let r2d: Vec<DVec3> = r2.pixels.iter().map(|p| p.as_dvec3()).collect();
    let noise = sq(&r1, &r2d) / 4.0;
    let mse = |img: &lodestar::film::Image| sq(img, &reference) - noise;
    let fall = |render: &dyn Fn(u64, u64) -> lodestar::film::Image| {
        let at = |spp| {
            let mut m: Vec<f64> = (0..6).map(|s| mse(&render(s, spp))).collect();
            m.sort_by(f64::total_cmp);
            0.5 * (m[2] + m[3])
        };
        let (few, many) = (at(4), at(64));
        eprintln!(
            "median MSE {few:.4e} at 4 passes, {many:.4e} at 64 (reference noise {noise:.2e}): {:.3}",
            many / few
        );
        many / few
    };
    let vcm =
        fall(&|seed, spp| util::render(&scene, "vcm", MAX_DEPTH, &[], spp, 320 + seed, 2).image);
    let guided = fall(&|seed, spp| frozen_guided_vcm(&scene, &twin, 1.0, 420 + seed, spp));
    assert!(vcm < 0.25, "vcm's MSE falls to only {vcm:.3} of it");
    assert!(
        guided < 0.25,
        "guided-vcm's MSE falls to only {guided:.3} of it"
    );
    let control = fall(&|seed, spp| frozen_guided_vcm(&scene, &twin, 1.5, 420 + seed, spp));
    assert!(
        control > 0.25,
        "control: with p_g x 1.5 the MSE falls to {control:.3} of it"
    );
}

/// guided-vcm gives bit-identical images on 1 and 2 threads (light subpaths are traced from
/// their own streams and laid out in path order, whatever thread traced them).
#[test]
fn guided_vcm_does_not_depend_on_the_thread_count() {
    let scene = util::scene(CAUSTIC);
    let options = ["learn_fraction=0.5"];
    let one = util::render(&scene, "guided-vcm", MAX_DEPTH, &options, 8, 5, 1);
    let two = util::render(&scene, "guided-vcm", MAX_DEPTH, &options, 8, 5, 2);
    assert!(
        one.image.pixels == two.image.pixels,
        "1 and 2 threads differ"
    );
}

/// The chain seeder, the power heuristic and roulette past the first bounce are errors that
/// say why; vcm's options are read.
#[test]
fn guided_vcm_option_errors() {
    use lodestar::integrators::{IntegratorParams, Options, build};
    let build_with = |opts: &[&str]| {
        let params = IntegratorParams {
            max_depth: 6,
            options: Options::parse(&opts.iter().map(|s| s.to_string()).collect::<Vec<_>>())
                .unwrap(),
        };
        build("guided-vcm", &params).map(|_| ())
    };
    let err = build_with(&["seeder=mcmc"]).unwrap_err().to_string();
    assert!(
        err.contains("option 'seeder'") && err.contains("replays one sample alone"),
        "{err}"
    );
    let err = build_with(&["mis=power"]).unwrap_err().to_string();
    assert!(
        err.contains("option 'mis': guided-vcm needs 'balance'"),
        "{err}"
    );
    let err = build_with(&["radius=-1"]).unwrap_err().to_string();
    assert!(err.contains("option 'radius'"), "{err}");
    let err = build_with(&["radius_alpha=0"]).unwrap_err().to_string();
    assert!(err.contains("option 'radius_alpha'"), "{err}");
    let err = build_with(&["rr_depth=3"]).unwrap_err().to_string();
    assert!(
        err.contains("option 'rr_depth'") && err.contains("expected 1, got 3"),
        "{err}"
    );
    assert!(build_with(&["radius=0.01", "radius_alpha=0.5", "rr_depth=1"]).is_ok());
}

/// Outside learning, a held path whose x_1 no first-vertex kernel of its structure reaches is
/// booked at vcm's own weight (`PathSink::record_if_own_weight`) instead of from its explicit
/// densities: with a cache of some of bdpt's paths of the glass box and two render passes
/// through the guider's collector, every path booked so has p_g = 0 by the sum over every
/// guide path of its structure (`GuideCache::terms_brute_force`), and both kinds of held path
/// occur often (measured: 774 booked at vcm's weight, 2248 from their densities, with a cache
/// of 6 structures). Booking every held path at vcm's weight fails it (checked against such a broken build at stride 100:
/// 212 of 2651 had p_g > 0).
#[test]
fn held_paths_no_guide_reaches_keep_vcms_weight() {
    use lodestar::integrators::guided::cache::GuideCache;
    use lodestar::integrators::guided::collector::Collector;
    use lodestar::integrators::guided::estimator::{Estimator, RowOutput};
    use lodestar::integrators::guided::kernel;
    use lodestar::integrators::guided::seeder::Source;
    use lodestar::path::MAX_VERTICES;
    #[derive(Default)]
    struct Counts {
        own: usize,
        explicit: usize,
        bad: Vec<String>,
    }
    struct Checked<'e, 'a> {
        inner: Collector<'e, 'a, VcmUnguided>,
        scene: &'a Scene,
        cache: &'a GuideCache,
        counts: &'e mut Counts,
    }
    impl PathSink for Checked<'_, '_> {
        fn record(&mut self, path: &Path, y: Option<&[Vertex]>, f: DVec3, p_u: f64, s: bool) {
            self.inner.record(path, y, f, p_u, s);
        }
        fn needs_densities(&mut self, head: &[Vertex], tail: &[Vertex]) -> bool {
            self.inner.needs_densities(head, tail)
        }
        fn record_from_vertices(&mut self, p: &Path, y: &[Vertex], f: DVec3, p_u: f64, s: bool) {
            self.counts.explicit += 1;
            self.inner.record_from_vertices(p, y, f, p_u, s);
        }
        fn record_if_own_weight(&mut self, path: &Path, value: DVec3, splat: bool) -> bool {
            let took = self.inner.record_if_own_weight(path, value, splat);
            if took {
                self.counts.own += 1;
                let (sig, nodes) = kernel::structure(self.scene, path, MAX_VERTICES)
                    .expect("a held path has a structure");
                let y = paths::from_path(self.scene, path).expect("a path of vertices");
                let p_g = (self.cache)
                    .terms_brute_force(self.scene, &y, sig, &nodes)
                    .sum;
                if p_g != 0.0 {
                    let n = path.vertices().len();
                    (self.counts.bad).push(format!("{n} vertices, pixel {}: {p_g}", path.pixel));
                }
            }
            took
        }
        fn record_weighted(&mut self, pixel: u32, value: DVec3, splat: bool) {
            self.inner.record_weighted(pixel, value, splat);
        }
    }
    let scene = box_scene("cornell-box.toml", 24);
    let u = unguided();
    // Every 90th path: sparse enough that many held paths' x_1 lie outside every kernel (every
    // 100th gave 5 structures, below the helper's floor, once quad lights became parallelograms).
    let cache = learning_paths_cache(&scene, &u, 90);
    let held: Arc<dyn HeldPaths> = Arc::new(cache.held());
    let mut counts = Counts::default();
    for pass in 1..3u64 {
        let state = u.renew_render_pass(&scene, 3, pass, pass, None, Some(&held));
        let est = Estimator::new(&scene, &u, state, &cache, 0.5);
        assert!(est.n_g > 0.0, "the estimator has guided samples");
        let mut tracer = u.tracer(&scene, &est.pass);
        let mut out = RowOutput::default();
        for i in 0..scene.camera.pixel_count() as u64 {
            let (raster, mut s) = sample_stream(&scene, 5 + pass, i);
            let source = Source::Unguided { pass, index: i };
            let mut sink = Checked {
                inner: Collector::new(&est, &mut out, source, false, false),
                scene: &scene,
                cache: &cache,
                counts: &mut counts,
            };
            u.trace(&mut tracer, &scene, raster, &mut s, &mut sink);
        }
    }
    let Counts { own, explicit, bad } = counts;
    assert!(
        own > 500 && explicit > 500,
        "held paths at vcm's weight {own}, with explicit densities {explicit}"
    );
    assert!(
        bad.is_empty(),
        "{} of {own} paths booked at vcm's weight have p_g > 0, e.g.\n{}",
        bad.len(),
        bad[..bad.len().min(6)].join("\n")
    );
}
