//! guided-bdpt: BDPT's techniques report f(X) exactly, the MIS weights of all of BDPT's
//! techniques plus the guided one sum to one, the estimator converges to bdpt's image (and a
//! broken p_g is caught), bad options are errors.

use crate::util;

use glam::DVec3;
use lodestar::bsdf::Bsdf;
use lodestar::integrators::bdpt::{BdptSettings, BdptUnguided, Tracer};
use lodestar::integrators::guided::cache::{GuideCache, Install};
use lodestar::integrators::guided::estimator::X1Candidates;
use lodestar::integrators::guided::{Estimator, GuidedBdpt, GuidedSettings, Stats, contribution};
use lodestar::integrators::paths::{self, Heuristic, Vertex};
use lodestar::integrators::unguided::{PathSink, Unguided};
use lodestar::math::luminance;
use lodestar::path::{MAX_VERTICES, Path};
use lodestar::render::{Budget, Integrator, RenderContext};
use lodestar::scene::Scene;
use util::guided::{CAUSTIC, installs_of, sample_stream, twin_caustic_cache};

const MAX_DEPTH: u32 = 6;

fn bdpt_settings() -> BdptSettings {
    BdptSettings {
        max_depth: MAX_DEPTH,
        rr_depth: 5,
        heuristic: Heuristic::Balance,
        light_tracing: false,
        techniques: Default::default(),
        direct_splats: false,
    }
}

fn box_scene(name: &str, res: u32) -> Scene {
    let text =
        std::fs::read_to_string(format!("{}/scenes/{name}", env!("CARGO_MANIFEST_DIR"))).unwrap();
    util::scene(&text.replace(
        "resolution = [256, 256]",
        &format!("resolution = [{res}, {res}]"),
    ))
}

/// Run `n` BDPT samples (pixel i mod the image, stream (seed, 0, i)) in recording mode.
fn trace_bdpt(scene: &Scene, seed: u64, n: u64, sink: &mut dyn PathSink) {
    let settings = bdpt_settings();
    let mut tracer = Tracer::new(scene, &settings);
    for i in 0..n {
        let (raster, mut s) = sample_stream(scene, seed, i);
        tracer.sample_recorded(raster, &mut s, sink);
    }
}

/// A cache of every third path of two or more segments that BDPT forms from `n` samples
/// (light-tracing paths included, camera first), equal weights, installed as after many
/// learning iterations.
fn cache_of_bdpt_paths(scene: &Scene, n: u64) -> GuideCache {
    struct Keep(Vec<Install>, usize);
    impl PathSink for Keep {
        fn record(&mut self, path: &Path, _: Option<&[Vertex]>, f: DVec3, p_u: f64, _: bool) {
            if path.segments() >= 2 && f != DVec3::ZERO {
                self.1 += 1;
                if self.1.is_multiple_of(3) {
                    let lum = luminance(f.as_vec3());
                    self.0
                        .push((path.vertices().to_vec(), lum as f64, p_u, 1.0, 0));
                }
            }
        }
    }
    let mut keep = Keep(Vec::new(), 0);
    trace_bdpt(scene, 5, n, &mut keep);
    let mut cache = GuideCache::default();
    cache.install(scene, keep.0, 10_000);
    cache
}

/// For every path BDPT forms in `scene` with a frozen cache of BDPT's own paths:
/// * f(X) as the technique reports it equals f(X) from the vertices (so its density p_s, by
///   which the raw estimate is multiplied, is the technique's);
/// * the balance weights of all BDPT techniques (densities from scratch, `path_terms`) with
///   the denominator the estimator forms for a path BDPT found, plus the guided technique's
///   with the denominator a guided sample of the same path gets, sum to 1;
/// * where p_g > 0, both sides use the same p_u, bit for bit.
///
/// Tolerances: f(X) 2e-3 relative (f32 hit points and densities); the weight sum 1e-3 (BDPT's
/// cached f32 densities against `path_terms`). Leaving n_g p_g out of the unguided paths'
/// denominator puts the sum at 1 + the guided weight, which is checked to be large on many paths.
fn check_weights(name: &str, scene: &Scene) {
    let cache = cache_of_bdpt_paths(scene, 3000);
    assert!(cache.len() > 50, "{name}: {} guide paths", cache.len());
    let u = BdptUnguided {
        settings: bdpt_settings(),
    };
    let est = Estimator::new(scene, &u, (), &cache, 0.5);
    assert_eq!(
        est.n_g, est.n_u,
        "alpha 0.5 gives one guided path per pixel"
    );
    struct Check<'e, 'a> {
        scene: &'a Scene,
        est: &'e Estimator<'a, BdptUnguided>,
        stats: Stats,
        candidates: X1Candidates,
        n: usize,
        guided_heavy: usize,
        ill_conditioned: usize,
        bad: Vec<String>,
    }
    impl PathSink for Check<'_, '_> {
        fn record(&mut self, path: &Path, y: Option<&[Vertex]>, f: DVec3, p_u: f64, _: bool) {
            let (scene, est) = (self.scene, self.est);
            let y = y.expect("bdpt hands over its vertices");
            let k = y.len() - 1;
            self.n += 1;
            let fx = contribution::contribution(scene, y, 0);
            let rel = ((f - fx).abs() / fx.abs().max(DVec3::splat(1e-300))).max_element();
            // The walk evaluates each BSDF with the direction it sampled, the check with the
            // direction between the stored f32 vertices; the two differ by the rounding of the
            // hit points over the segment's length, which a sharp lobe turns into a relative
            // difference of f: measured up to 8e-3 across segments shorter than 0.03 at the
            // rough metal (alpha 0.1) and up to 4e-2 through two or more rough-glass
            // (alpha 0.05) vertices in a row, against at most 2e-3 elsewhere (seeds 77-83).
            // Such ill-conditioned paths get 5e-2 and must stay a small minority.
            let short = y.windows(2).any(|w| (w[1].p - w[0].p).length() < 0.05);
            let rough_glass = |v: &Vertex| {
                matches!(v.kind, paths::Kind::Surface { bsdf, .. }
                    if matches!(bsdf, Bsdf::RoughDielectric { .. }))
            };
            let through_glass = y
                .windows(2)
                .any(|w| rough_glass(&w[0]) && rough_glass(&w[1]));
            let tolerance = if short || through_glass {
                self.ill_conditioned += 1;
                5e-2
            } else {
                2e-3
            };
            if rel > tolerance && self.bad.len() < 6 {
                self.bad
                    .push(format!("k {k}: f reported {f}, from vertices {fx}"));
            }
            let d = est.densities(path, Some(y), p_u, &mut self.stats, &mut self.candidates);
            let (p_u_mix, p_g) = (d.p_u, d.p_g);
            let mut p = [0.0f64; MAX_VERTICES];
            paths::path_terms(scene, y, 5).technique_densities(&mut p);
            let bdpt_weights: f64 = p[..=k].iter().sum::<f64>() / est.mix(p_u_mix, p_g);
            let p_u_guided = est.unguided.pdf_unguided(scene, &(), y);
            let r = est.n_g / est.n_u;
            let guided_weight = r * p_g / est.mix(p_u_guided, p_g);
            if guided_weight > 0.05 {
                self.guided_heavy += 1;
            }
            if p_g > 0.0 && p_u_mix != p_u_guided && self.bad.len() < 6 {
                self.bad
                    .push(format!("k {k}: p_u {p_u_mix} vs {p_u_guided}"));
            }
            let sum = bdpt_weights + guided_weight;
            if (sum - 1.0).abs() > 1e-3 && self.bad.len() < 6 {
                self.bad.push(format!(
                    "k {k}: weights sum to {sum} (bdpt {bdpt_weights}, guided {guided_weight})"
                ));
            }
        }
    }
    let mut check = Check {
        scene,
        est: &est,
        stats: Stats::default(),
        candidates: X1Candidates::default(),
        n: 0,
        guided_heavy: 0,
        ill_conditioned: 0,
        bad: Vec::new(),
    };
    trace_bdpt(scene, 77, 1500, &mut check);
    eprintln!(
        "{name}: {} paths, {} with guided weight > 0.05, {} guide paths",
        check.n,
        check.guided_heavy,
        cache.len()
    );
    assert!(check.n > 2000, "{name}: only {} paths", check.n);
    assert!(
        check.ill_conditioned * 10 < check.n,
        "{name}: {} of {} paths checked at the looser tolerance",
        check.ill_conditioned,
        check.n
    );
    assert!(
        check.guided_heavy > 20,
        "{name}: the guided technique weighs little on {} paths only: the test would not see a missing term",
        check.guided_heavy
    );
    assert!(check.bad.is_empty(), "{name}:\n{}", check.bad.join("\n"));
}

#[test]
fn mis_weights_with_the_guided_technique_sum_to_one_glass() {
    check_weights("cornell-box", &box_scene("cornell-box.toml", 16));
}

#[test]
fn mis_weights_with_the_guided_technique_sum_to_one_glossy() {
    check_weights("cornell-glossy", &box_scene("cornell-glossy.toml", 16));
}

#[test]
fn mis_weights_with_the_guided_technique_sum_to_one_fog() {
    check_weights("cornell-fog", &box_scene("cornell-fog.toml", 16));
}

/// The coverage classes the guided integrators report (`unguided_second_moment_by_coverage`)
/// sort BDPT's paths as the cache says: `Covered` exactly when p_g > 0 summed over the whole
/// cache (no first-vertex BVH; the estimator's p_g agrees with that sum to 1e-9), `NotHeld`
/// exactly when no guide path has the path's structure, `Zero` otherwise; for `Zero`, the
/// vertex where p_g vanished
/// (`pg_zero_second_moment_by_vertex`) is the furthest any guide path of the structure
/// reaches, computed over the whole cache without the first-vertex BVH; for covered paths, the
/// terms and credits of `weights = second_moment` (below). A cache of a few BDPT
/// paths of the glass box leaves every class and at least two vanishing vertices populated
/// (checked, so that a classifier with a constant answer fails).
#[test]
fn coverage_classes_follow_the_cache_and_p_g() {
    use lodestar::integrators::guided::estimator::Coverage;
    use lodestar::integrators::guided::kernel;
    let scene = box_scene("cornell-box.toml", 16);
    let cache = cache_of_bdpt_paths(&scene, 150);
    assert!(cache.len() > 5, "{} guide paths", cache.len());
    let u = BdptUnguided {
        settings: bdpt_settings(),
    };
    let est = Estimator::new(&scene, &u, (), &cache, 0.5);
    struct Classify<'e, 'a> {
        scene: &'a Scene,
        est: &'e Estimator<'a, BdptUnguided>,
        cache: &'e GuideCache,
        stats: Stats,
        candidates: X1Candidates,
        counts: [usize; 3],
        vanished: std::collections::BTreeMap<usize, usize>,
        bad: Vec<String>,
    }
    impl PathSink for Classify<'_, '_> {
        fn record(&mut self, path: &Path, y: Option<&[Vertex]>, f: DVec3, p_u: f64, _: bool) {
            if f == DVec3::ZERO {
                return;
            }
            let (est, scene) = (self.est, self.scene);
            let d = est.densities(path, y, p_u, &mut self.stats, &mut self.candidates);
            let (p_u1, p_g1, class) = (d.p_u, d.p_g, d.coverage);
            if class == Coverage::Zero {
                let (sig, nodes) = kernel::structure(scene, path, MAX_VERTICES).unwrap();
                let y = y.expect("BDPT paths come with their vertices");
                let expected = self.cache.terms_brute_force(scene, y, sig, &nodes).reach;
                *self.vanished.entry(d.vanished_at).or_default() += 1;
                if d.vanished_at != expected && self.bad.len() < 6 {
                    self.bad.push(format!(
                        "{} segments: p_g vanished at x_{}, over the whole cache at x_{expected}",
                        path.segments(),
                        d.vanished_at
                    ));
                }
            }
            let held = kernel::signature(scene, path, MAX_VERTICES)
                .is_some_and(|sig| self.cache.holds(sig));
            // The collector's first test (vertex count and emitter) never rules out a held
            // structure.
            let vs = path.vertices();
            if held
                && !matches!(vs.last().map(|v| v.kind), Some(lodestar::path::VertexKind::Emitter { light, .. })
                    if self.cache.may_hold(vs.len(), light))
                && self.bad.len() < 6
            {
                self.bad.push(format!(
                    "a held path of {} vertices fails may_hold",
                    vs.len()
                ));
            }
            let p_g_all = match (held, kernel::structure(scene, path, MAX_VERTICES), y) {
                (true, Some((sig, nodes)), Some(y)) => {
                    self.cache.terms_brute_force(scene, y, sig, &nodes).sum
                }
                _ => 0.0,
            };
            let expected = if p_g_all > 0.0 {
                Coverage::Covered
            } else if held {
                Coverage::Zero
            } else {
                Coverage::NotHeld
            };
            self.counts[class as usize] += 1;
            if class == Coverage::Covered {
                // The terms left for `weights = second_moment` are the sum's terms, and a
                // sample's credits add up to V² r p_g / (p_u + r p_g): its squared value
                // shared out by the guided part of the mixture.
                let terms = &self.candidates.terms;
                let sum: f64 = terms.iter().map(|t| t.1).sum();
                let value = f / est.mix(p_u1, p_g1);
                let mut credits = Vec::new();
                est.credit(value, p_u1, p_g1, terms, &mut credits);
                let (v, r) = (lodestar::math::luminance64(value), est.n_g / est.n_u);
                let expected = v * v * r * p_g1 / (p_u1 + r * p_g1);
                let got: f64 = credits.iter().map(|c| c.1).sum();
                let off = |a: f64, b: f64| (a - b).abs() > 1e-12 * b.abs().max(1e-300);
                if (off(sum, p_g1) || off(got, expected)) && self.bad.len() < 6 {
                    self.bad.push(format!(
                        "terms sum to {sum} against p_g {p_g1}; credits {got} against {expected}"
                    ));
                }
            }
            let p_g_off = (p_g1 - p_g_all).abs() > 1e-9 * p_g_all;
            if (class != expected || p_g_off) && self.bad.len() < 6 {
                self.bad.push(format!(
                    "{} segments: {class:?}, expected {expected:?} (p_g {p_g1}, over the whole \
                     cache {p_g_all}, held {held}, p_u {p_u1})",
                    path.segments(),
                ));
            }
        }
    }
    let mut candidates = X1Candidates::default();
    candidates.collect_terms = true;
    let mut check = Classify {
        scene: &scene,
        est: &est,
        cache: &cache,
        stats: Stats::default(),
        candidates,
        counts: [0; 3],
        vanished: Default::default(),
        bad: Vec::new(),
    };
    trace_bdpt(&scene, 78, 1500, &mut check);
    eprintln!(
        "paths by class (not held, p_g = 0, covered): {:?}",
        check.counts
    );
    assert!(check.bad.is_empty(), "{}", check.bad.join("\n"));
    assert!(
        check.counts.iter().all(|&n| n >= 20),
        "a class is (nearly) empty, the test would not see a misclassification: {:?}",
        check.counts
    );
    eprintln!(
        "p_g = 0 paths by the vertex where it vanished: {:?}",
        check.vanished
    );
    assert!(
        check.vanished.values().filter(|&&n| n >= 10).count() >= 2,
        "fewer than two vanishing vertices seen: {:?}",
        check.vanished
    );
}

/// Renders per side of [`guided_bdpt_is_unbiased_on_a_caustic_and_a_broken_pg_is_caught`].
const CAUSTIC_SEEDS: u64 = 8;

/// Image means of `CAUSTIC_SEEDS` renders (seeds 1, 2, ...) by guided-bdpt with a frozen copy of
/// `cache` and split `alpha`, `spp` passes each. `broken` leaves guide path 0 out of p_g.
fn guided_bdpt_means(
    scene: &Scene,
    cache: &GuideCache,
    alpha: f64,
    broken: bool,
    spp: u64,
) -> Vec<DVec3> {
    (1..=CAUSTIC_SEEDS)
        .map(|seed| {
            let mut c = GuideCache::default();
            c.install(scene, installs_of(scene, cache), 10_000);
            if broken {
                c.skip_in_pdf = Some(0);
            }
            let settings = GuidedSettings {
                alpha,
                learn_fraction: 0.0,
                ..GuidedSettings::default()
            };
            let mut integ = GuidedBdpt::new(bdpt_settings(), settings, Some(c));
            let ctx = RenderContext::new(scene, seed, false);
            integ.render(&ctx, Budget::Spp(spp)).image.mean()
        })
        .collect()
}

/// guided-bdpt is unbiased on a caustic with a cache that carries the caustic (one caustic
/// path twice, weights 1/2, α = 0.05: most samples guided); leaving the path out of the
/// evaluation is caught by the same test. Welch's t per channel of the whole-image means of 8
/// guided-bdpt renders of 4 passes (seeds 1..=8) against 8 bdpt renders of 32 passes (seeds
/// 101..=108, one set for both comparisons): whole-image means across seeds, as caustics make
/// pixel values heavy-tailed. |t| < 6: false-failure rate below 1e-3 for the three channels
/// (t with about 14 degrees of freedom); the broken p_g makes the image about 12 times too
/// bright (t = 535, measured).
#[test]
fn guided_bdpt_is_unbiased_on_a_caustic_and_a_broken_pg_is_caught() {
    let scene = util::scene(CAUSTIC);
    let reference: Vec<DVec3> = (1..=CAUSTIC_SEEDS)
        .map(|seed| {
            util::render(&scene, "bdpt", MAX_DEPTH, &[], 32, 100 + seed, 2)
                .image
                .mean()
        })
        .collect();
    let twin = twin_caustic_cache(&scene, false);
    let t = util::welch_t(
        &guided_bdpt_means(&scene, &twin, 0.05, false, 4),
        &reference,
    );
    assert!(t.abs().max_element() < 6.0, "t {t:?}");
    let single = twin_caustic_cache(&scene, true);
    let tb = util::welch_t(
        &guided_bdpt_means(&scene, &single, 0.05, true, 4),
        &reference,
    );
    assert!(
        tb.abs().max_element() > 6.0,
        "the broken p_g went unnoticed: t {tb:?}"
    );
}

/// On the Cornell box (nothing hard but the glass sphere) guided-bdpt, learning its own cache
/// inside the render, converges to bdpt's image: per-pixel z-test of the mean difference,
/// |z| < 4.5 (false-failure rate about 2e-5 for three channels).
#[test]
fn guided_bdpt_agrees_with_bdpt_on_the_cornell_box() {
    agrees_with_bdpt_on_the_cornell_box(&[]);
}

/// The same with the spec's weight rule (`weights=c`; the default is `second_moment`). The
/// two rules must give different weights (and so images) and be equally exact.
#[test]
fn guided_bdpt_with_the_specs_weights_agrees_with_bdpt() {
    let spec = agrees_with_bdpt_on_the_cornell_box(&["weights=c"]);
    let default = agrees_with_bdpt_on_the_cornell_box(&[]);
    let second_moment = agrees_with_bdpt_on_the_cornell_box(&["weights=second_moment"]);
    assert!(
        default.pixels == second_moment.pixels,
        "the default rule is not second_moment"
    );
    assert!(
        spec.pixels != default.pixels,
        "weights=c and weights=second_moment gave the same image"
    );
}

fn agrees_with_bdpt_on_the_cornell_box(extra: &[&str]) -> lodestar::film::Image {
    let scene = box_scene("cornell-box.toml", 32);
    let mut options = vec!["learn_fraction=0.5", "share=fixed"];
    options.extend(extra);
    let guided = util::render(&scene, "guided-bdpt", MAX_DEPTH, &options, 32, 3, 2);
    let reference = util::render(&scene, "bdpt", MAX_DEPTH, &[], 64, 4, 2);
    let stat = |k: &str| {
        guided
            .stats
            .iter()
            .find(|s| s.0 == k)
            .map(|s| s.1.clone())
            .unwrap()
    };
    let guided_samples: u64 = stat("guided_samples").parse().unwrap();
    assert!(
        guided_samples > 10_000,
        "no guided samples: {:?}",
        guided.stats
    );
    util::assert_same_mean(&guided.image, &reference.image, "guided-bdpt vs bdpt");
    guided.image
}

/// A cache learned by guided-pt renders in guided-bdpt (guide paths are complete paths,
/// whichever estimator found them), and the render stays unbiased.
#[test]
fn a_guided_pt_cache_loads_into_guided_bdpt() {
    let scene = util::scene(CAUSTIC);
    let dir = std::env::temp_dir().join(format!("lodestar-gb-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("pt.guides");
    let save = format!("save_guides={}", file.display());
    util::render(
        &scene,
        "guided-pt",
        MAX_DEPTH,
        &[&save, "learn_fraction=0.5"],
        16,
        1,
        2,
    );
    let load = format!("load_guides={}", file.display());
    let g = util::render(&scene, "guided-bdpt", MAX_DEPTH, &[&load], 64, 2, 2);
    let b = util::render(&scene, "bdpt", MAX_DEPTH, &[], 64, 3, 2);
    let n: usize = g
        .stats
        .iter()
        .find(|s| s.0 == "guide_paths")
        .unwrap()
        .1
        .parse()
        .unwrap();
    assert!(n > 0, "the loaded cache is empty");
    util::assert_same_mean(&g.image, &b.image, "guided-bdpt with guided-pt's cache");
    std::fs::remove_dir_all(&dir).ok();
}

/// `-O mis=power` with guided-bdpt is an error that says why.
#[test]
fn power_heuristic_with_guided_bdpt_is_an_error() {
    use lodestar::integrators::{IntegratorParams, Options, build};
    let params = IntegratorParams {
        max_depth: 6,
        options: Options::parse(&["mis=power".to_string()]).unwrap(),
    };
    let err = build("guided-bdpt", &params)
        .err()
        .expect("mis=power accepted");
    assert!(
        err.to_string()
            .contains("option 'mis': guided-bdpt needs 'balance'"),
        "{err}"
    );
    let params = IntegratorParams {
        max_depth: 6,
        options: Options::parse(&["mis=balance".to_string()]).unwrap(),
    };
    assert!(build("guided-bdpt", &params).is_ok());
}

/// guided-bdpt and guided-pt, learning and choosing their share inside the render, give
/// bit-identical images on 1 and 2 threads (the share is decided from counted rays, not time).
/// Both weight rules (the default second-moment rule sums each guide's credit in row order).
#[test]
fn guided_renders_do_not_depend_on_the_thread_count() {
    let scene = util::scene(CAUSTIC);
    let spec: &[&str] = &["learn_fraction=0.5", "weights=c"];
    for (name, options) in [
        ("guided-bdpt", &["learn_fraction=0.5"][..]),
        ("guided-pt", &["learn_fraction=0.5"][..]),
        ("guided-bdpt", spec),
    ] {
        let one = util::render(&scene, name, MAX_DEPTH, options, 8, 5, 1);
        let two = util::render(&scene, name, MAX_DEPTH, options, 8, 5, 2);
        assert!(
            one.image.pixels == two.image.pixels,
            "{name} {options:?}: 1 and 2 threads differ"
        );
        let share = |r| util::stat(r, "share_relative_cost");
        assert_eq!(share(&one), share(&two), "{name}");
    }
}

/// With guiding off, guided-bdpt keeps its learning passes' unguided samples under bdpt's own
/// estimator. A learning pass accumulates that image beside the mixed one: per sample it must
/// equal bdpt's `estimate` from the same stream (pixel value and light-tracing splats), while
/// the mixed value (f / (p_u + r p_g)) differs on many samples, which is what the image would
/// hold if the mixed estimate were kept. Tolerance 2e-3 relative: bdpt's own estimate carries
/// f32 densities, the guider's f64 densities recomputed from the vertices.
#[test]
fn learning_passes_keep_bdpts_own_estimate() {
    use lodestar::integrators::guided::collector::Collector;
    use lodestar::integrators::guided::estimator::RowOutput;
    use lodestar::integrators::guided::seeder::Source;
    let scene = box_scene("cornell-box.toml", 16);
    let cache = cache_of_bdpt_paths(&scene, 3000);
    let u = BdptUnguided {
        settings: bdpt_settings(),
    };
    let est = Estimator::new(&scene, &u, (), &cache, 0.5);
    let mut tracer = u.tracer(&scene, &());
    let (mut bad, mut mixed_differs, mut nonzero, mut splats_seen) = (Vec::new(), 0, 0, 0);
    let mut held_seen = 0;
    let rel = |a: DVec3, b: DVec3| {
        ((a - b).abs() / a.abs().max(b.abs()).max(DVec3::splat(1e-30))).max_element()
    };
    for i in 0..2000u64 {
        let (raster, mut s) = sample_stream(&scene, 7, i);
        let mut splats = Vec::new();
        let own = u.estimate(&mut tracer, &scene, raster, &mut s, &mut splats);
        let (raster, mut s) = sample_stream(&scene, 7, i);
        let mut out = RowOutput::default();
        let source = Source::Unguided { pass: 0, index: i };
        let mut col = Collector::new(&est, &mut out, source, true, false);
        col.classes = true;
        u.trace(&mut tracer, &scene, raster, &mut s, &mut col);
        let (u_sum, mixed, classes) = (col.u_sum, col.sum, col.class_sum);
        // The variance account (`coverage.rs`): the pixel's class sums add up to its mixed
        // value, splatted paths keep theirs, and a class gets luminance exactly when the
        // sample formed paths of that class (its second moment is non-zero).
        let lum = lodestar::math::luminance64(mixed);
        if (classes.iter().sum::<f64>() - lum).abs() > 1e-9 * lum.max(1e-30) && bad.len() < 6 {
            bad.push(format!(
                "sample {i}: classes {classes:?}, pixel luminance {lum}"
            ));
        }
        let splat_lums: Vec<f64> = out
            .splats
            .iter()
            .map(|(_, v)| lodestar::math::luminance64(*v))
            .collect();
        let class_splat_lums: Vec<f64> = out.class_splats.iter().map(|s| s.2).collect();
        if splat_lums != class_splat_lums && bad.len() < 6 {
            bad.push(format!(
                "sample {i}: splats {splat_lums:?}, classes {class_splat_lums:?}"
            ));
        }
        if out.stats.coverage_m2[1] + out.stats.coverage_m2[2] > 0.0 {
            held_seen += 1;
        }
        for (c, own_pixel) in classes.iter().take(3).enumerate() {
            let by_class = own_pixel
                + out
                    .class_splats
                    .iter()
                    .filter(|s| s.1 as usize == c)
                    .map(|s| s.2)
                    .sum::<f64>();
            if (by_class > 0.0) != (out.stats.coverage_m2[c] > 0.0) && bad.len() < 6 {
                bad.push(format!(
                    "sample {i}: class {c} luminance {by_class}, second moment {}",
                    out.stats.coverage_m2[c]
                ));
            }
        }
        if own != DVec3::ZERO {
            nonzero += 1;
        }
        if rel(own, u_sum) > 2e-3 && bad.len() < 6 {
            bad.push(format!("sample {i}: bdpt {own}, kept {u_sum}"));
        }
        if rel(own, mixed) > 1e-2 {
            mixed_differs += 1;
        }
        // Splats: the same pixels, the same values, in order.
        let kept: Vec<_> = out
            .u_splats
            .iter()
            .filter(|(_, v)| *v != DVec3::ZERO)
            .collect();
        splats_seen += splats.len();
        if kept.len() != splats.len() && bad.len() < 6 {
            bad.push(format!(
                "sample {i}: {} splats, kept {}",
                splats.len(),
                kept.len()
            ));
        }
        for ((p, a), (q, b)) in splats.iter().zip(kept) {
            if (p != q || rel(*a, *b) > 2e-3) && bad.len() < 6 {
                bad.push(format!("sample {i}: splat {p} {a}, kept {q} {b}"));
            }
        }
    }
    assert!(
        nonzero > 500 && splats_seen > 500,
        "{nonzero} samples, {splats_seen} splats"
    );
    assert!(
        mixed_differs > 100,
        "the mixed estimate differs on only {mixed_differs}"
    );
    assert!(
        held_seen > 100,
        "only {held_seen} samples with paths the cache holds"
    );
    assert!(bad.is_empty(), "{}", bad.join("\n"));
}

/// With guiding off (the share found nothing worth a guided sample), guided-bdpt's image is
/// bdpt's image of the same number of passes, sample for sample: the kept learning passes hold
/// bdpt's own estimate of their unguided samples and the render passes continue bdpt's
/// streams. Tolerance 2e-3 relative per pixel channel (the guider recomputes densities in f64
/// where bdpt keeps f32); renders of other streams (a different seed, the control) differ far
/// beyond it. (guided-pt's kept passes weigh pt's two techniques by the balance heuristic
/// where pt uses the power heuristic, so there the images agree in expectation only.)
#[test]
fn with_guiding_off_the_image_is_the_unguided_image_of_as_many_passes() {
    let stat = |r: &lodestar::render::RenderResult, k: &str| util::stat(r, k).unwrap().to_string();
    let worst = |a: &lodestar::film::Image, b: &lodestar::film::Image| {
        a.pixels
            .iter()
            .zip(&b.pixels)
            .map(|(x, y)| {
                let (x, y) = (x.as_dvec3(), y.as_dvec3());
                ((x - y).abs() / (x.abs().max(y.abs()) + 1e-6)).max_element()
            })
            .fold(0.0f64, f64::max)
    };
    // 16 x 16: learning finds no outlier (an empty cache); 32 x 32 with half the passes
    // learning: guide paths and guided samples, and the share chooses bdpt alone.
    for (res, learn, guides) in [
        (16, "learn_fraction=0.25", false),
        (32, "learn_fraction=0.5", true),
    ] {
        let scene = util::cornell(res);
        let g = util::render(&scene, "guided-bdpt", MAX_DEPTH, &[learn], 24, 3, 2);
        let kept: u64 = stat(&g, "learning_passes_kept").parse().unwrap();
        let cached: u64 = stat(&g, "guide_paths").parse().unwrap();
        let what = format!("{res} x {res}: kept {kept}, guide paths {cached}");
        assert!(kept > 0 && stat(&g, "unguided_share") == "1.000", "{what}");
        // Every learning pass chose U's own estimate before it was drawn.
        assert_eq!(stat(&g, "learning_passes_kept_guided"), "0", "{what}");
        assert_eq!(cached > 0, guides, "{what}");
        let guided_samples: u64 = stat(&g, "learning_guided_samples").parse().unwrap();
        assert_eq!(
            guided_samples > 0,
            guides,
            "{what}: {guided_samples} guided samples"
        );
        assert_eq!(g.passes, 24);
        let u = util::render(&scene, "bdpt", MAX_DEPTH, &[], 24, 3, 2);
        let e = worst(&g.image, &u.image);
        assert!(e < 2e-3, "{what}: worst relative difference {e}");
        let other = util::render(&scene, "bdpt", MAX_DEPTH, &[], 24, 4, 2);
        let control = worst(&other.image, &u.image);
        assert!(
            control > 0.1,
            "control: seeds 3 and 4 differ by only {control}"
        );
    }
    // keep_learning=false: the image is the render passes' alone, whatever learning chose.
    let scene = util::cornell(16);
    let opts = ["learn_fraction=0.25", "keep_learning=false"];
    let g = util::render(&scene, "guided-bdpt", MAX_DEPTH, &opts, 24, 3, 2);
    let learned: u64 = stat(&g, "learning_iterations").parse().unwrap();
    assert_eq!(stat(&g, "learning_passes_kept"), "0");
    assert!(
        learned > 0 && g.passes == 24 - learned,
        "{learned} learning passes, {} in the image",
        g.passes
    );
}

/// With guiding on, the learning passes stay in the image beside the render passes, each an
/// unbiased estimate weighed by pass count. guided-pt on the 64 x 64 Cornell box, 24 passes,
/// half of them learning, `share=fixed` (guiding on whatever learning measures, so keeping
/// the passes is exactly unbiased here): with `keep_learning=false` the image is the 12
/// render passes alone, on the same streams as with the default, so the learning passes'
/// sum is `S_L = 24 I_keep − 12 I_render`. Their mean `S_L / 12` must estimate the same image
/// as the render passes (`util::z_same_mean`, |z| < 5 per channel: false-failure rate about
/// 2e-6 for the three; guided-pt's pixels are independent estimates, the guided samples
/// included). A learning film dropped (the old behaviour), counted twice, or divided by the
/// render passes alone moves that mean by 12 passes' worth and fails it, as the control
/// checks.
#[test]
fn with_guiding_on_the_learning_passes_stay_in_the_image() {
    let stat = |r: &lodestar::render::RenderResult, k: &str| util::stat(r, k).unwrap().to_string();
    let scene = util::cornell(64);
    let opts = ["learn_fraction=0.5", "share=fixed", "alpha=0.5"];
    let keep = util::render(&scene, "guided-pt", MAX_DEPTH, &opts, 24, 3, 2);
    let no_keep = [&opts[..], &["keep_learning=false"]].concat();
    let render_only = util::render(&scene, "guided-pt", MAX_DEPTH, &no_keep, 24, 3, 2);
    let learned: u64 = stat(&keep, "learning_iterations").parse().unwrap();
    assert_eq!(learned, 12);
    assert!(stat(&keep, "guide_paths").parse::<u64>().unwrap() > 0);
    assert_eq!(stat(&keep, "unguided_share"), "0.500");
    assert_eq!(stat(&keep, "learning_passes_kept"), "12");
    // share=fixed: every pass with guide paths to draw from keeps its mixed estimate.
    let kept_guided: u64 = stat(&keep, "learning_passes_kept_guided").parse().unwrap();
    assert!((1..=12).contains(&kept_guided), "{kept_guided}");
    assert_eq!((keep.passes, render_only.passes), (24, 12));
    assert_eq!(stat(&render_only, "learning_passes_kept"), "0");
    learning_passes_estimate_the_render_image(&keep, &render_only, 12);
}

/// With `share=auto` each learning pass keeps the estimate chosen before its samples were
/// drawn (its mixed estimate where the passes before it chose guiding, U's own else), so each
/// is unbiased given the passes before it and the learning passes' mean estimates the same
/// image as the render passes'. guided-pt on the caustic scene (a glass sphere under a small
/// light that pt reaches only by chance) at 32 x 32, 24 passes, half of them learning:
/// guiding turns on, the first learning passes keep U's own estimate and the later ones their
/// mixed one. As in the test above, from the renders with and without the learning passes,
/// `S_L / 12` against the render passes' image, |z| < 5 per channel (false-failure rate about
/// 2e-6 for the three); weighing the learning passes as half as many or none fails it.
#[test]
fn with_an_auto_share_each_learning_pass_keeps_the_estimate_chosen_before_it() {
    let stat = |r: &lodestar::render::RenderResult, k: &str| util::stat(r, k).unwrap().to_string();
    let scene = util::scene(&CAUSTIC.replace("resolution = [48, 48]", "resolution = [32, 32]"));
    let opts = ["learn_fraction=0.5"];
    let keep = util::render(&scene, "guided-pt", MAX_DEPTH, &opts, 24, 3, 2);
    let no_keep = [&opts[..], &["keep_learning=false"]].concat();
    let render_only = util::render(&scene, "guided-pt", MAX_DEPTH, &no_keep, 24, 3, 2);
    let learned: u64 = stat(&keep, "learning_iterations").parse().unwrap();
    let kept: u64 = stat(&keep, "learning_passes_kept").parse().unwrap();
    let kept_guided: u64 = stat(&keep, "learning_passes_kept_guided").parse().unwrap();
    let what = format!(
        "{learned} learning passes, {kept} kept, {kept_guided} with their mixed estimate, \
         unguided share {}",
        stat(&keep, "unguided_share")
    );
    eprintln!("{what}");
    assert!(stat(&keep, "unguided_share") != "1.000", "{what}");
    assert!(
        kept == learned && kept_guided > 0 && kept_guided < kept,
        "{what}"
    );
    assert_eq!(keep.passes, 24);
    assert_eq!(render_only.passes, 24 - learned);
    learning_passes_estimate_the_render_image(&keep, &render_only, learned);
}

/// From a render of 24 passes that keeps its `learned` learning passes (`keep`) and one that
/// leaves them out (`render_only`, the same render passes), the learning passes' sum is
/// `S_L = 24 I_keep - (24 - L) I_render`; their mean `S_L / L` must estimate the same image as
/// the render passes (`util::z_same_mean`, |z| < 5 per channel: false-failure rate about 2e-6
/// for the three). Controls: the learning passes weighed as half as many (a film divided by
/// the render passes alone) or none at all fail it.
fn learning_passes_estimate_the_render_image(
    keep: &lodestar::render::RenderResult,
    render_only: &lodestar::render::RenderResult,
    learned: u64,
) {
    let (l, r) = (learned as f64, 24.0 - learned as f64);
    let learning_mean = |weight: f64| {
        let mut img = render_only.image.clone();
        for ((p, k), o) in img
            .pixels
            .iter_mut()
            .zip(&keep.image.pixels)
            .zip(&render_only.image.pixels)
        {
            let s_l = 24.0 * k.as_dvec3() - r * o.as_dvec3();
            *p = (s_l * weight / l).as_vec3();
        }
        img
    };
    let z = util::z_same_mean(&learning_mean(1.0), &render_only.image);
    assert!(
        z.abs().max_element() < 5.0,
        "learning against render passes: z = {z}"
    );
    for w in [2.0, 0.0] {
        let z = util::z_same_mean(&learning_mean(w), &render_only.image);
        assert!(z.abs().max_element() > 5.0, "control {w}: z = {z}");
    }
}

/// In the guider's recording, the recursive weights (O(1) per path: `bdpt/cache.rs`
/// `mis_sums`) give each path the value its explicitly assembled densities give, `f / p_u`:
/// bdpt's tracer run twice on the same streams, once with a sink that asks for every path's
/// densities and once with one that declines them all (`PathSink::needs_densities`), reports
/// the same paths in the same order with the same values (relative 1e-3: f32 densities), in
/// a plain, a glossy and a fog box.
#[test]
fn recursive_weights_give_the_explicit_values() {
    #[derive(Default)]
    struct Values {
        declines: bool,
        got: Vec<(u32, bool, DVec3)>,
    }
    impl PathSink for Values {
        fn record(&mut self, path: &Path, _: Option<&[Vertex]>, f: DVec3, p_u: f64, splat: bool) {
            self.got.push((path.pixel, splat, f / p_u));
        }
        fn needs_densities(&mut self, _: &[Vertex], _: &[Vertex]) -> bool {
            !self.declines
        }
        fn record_weighted(&mut self, pixel: u32, value: DVec3, splat: bool) {
            self.got.push((pixel, splat, value));
        }
    }
    fn run(
        scene: &Scene,
        mut trace: impl FnMut(glam::Vec2, &mut dyn PathSink, u64),
        declines: bool,
    ) -> Vec<(u32, bool, DVec3)> {
        let mut sink = Values {
            declines,
            ..Default::default()
        };
        for i in 0..512u64 {
            let (raster, _) = sample_stream(scene, 5, i);
            trace(raster, &mut sink, i);
        }
        sink.got
    }
    for name in ["cornell-box", "cornell-glossy", "cornell-fog"] {
        let scene = util::shipped_at(name, 16, 16);
        let bdpt_u = BdptUnguided {
            settings: BdptSettings {
                rr_depth: 1,
                ..bdpt_settings()
            },
        };
        let trace_with = |declines: bool| {
            let mut tracer = bdpt_u.tracer(&scene, &());
            run(
                &scene,
                |raster, sink, i| {
                    let (_, mut s) = sample_stream(&scene, 5, i);
                    tracer.sample_recorded(raster, &mut s, sink);
                },
                declines,
            )
        };
        let (explicit, recursive) = (trace_with(false), trace_with(true));
        assert!(explicit.len() > 2000, "{name}: {} paths", explicit.len());
        assert_eq!(explicit.len(), recursive.len(), "{name}: path counts");
        let mut bad = Vec::new();
        for (a, b) in explicit.iter().zip(&recursive) {
            let rel = ((a.2 - b.2).abs() / a.2.abs().max(DVec3::splat(1e-12))).max_element();
            if a.0 != b.0 || a.1 != b.1 || rel > 1e-3 {
                bad.push(format!("{a:?} vs {b:?}"));
            }
        }
        assert!(
            bad.is_empty(),
            "{name}: {} of {} paths differ, e.g.\n{}",
            bad.len(),
            explicit.len(),
            bad[..bad.len().min(6)].join("\n")
        );
    }
}
