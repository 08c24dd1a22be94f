//! guided-pt: sampling and evaluation agree, the estimator is unbiased, caches round-trip.

use crate::util;

use util::guided::{CAUSTIC, installs_of, trace_pt, twin_caustic_cache};

use lodestar::integrators::guided::cache::{self, GuideCache, Install};
use lodestar::integrators::guided::{
    GuidedBdpt, GuidedPt, GuidedSettings, contribution, kernel, sampler,
};
use lodestar::integrators::pt::PtSettings;
use lodestar::integrators::pt::{PathRecorder, PathTracer};
use lodestar::integrators::{bdpt, paths};
use lodestar::math::IndependentSampler;
use lodestar::math::Sampler;
use lodestar::path::MAX_VERTICES;
use lodestar::path::Path;
use lodestar::render::{Budget, Integrator, RenderContext};
use lodestar::scene::Scene;

fn scene(name: &str, res: u32, edit: impl Fn(String) -> String) -> Scene {
    let text =
        std::fs::read_to_string(format!("{}/scenes/{name}", env!("CARGO_MANIFEST_DIR"))).unwrap();
    util::scene(&edit(text.replace(
        "resolution = [256, 256]",
        &format!("resolution = [{res}, {res}]"),
    )))
}

fn settings(learn_fraction: f64) -> GuidedSettings {
    GuidedSettings {
        learn_fraction,
        ..GuidedSettings::default()
    }
}

/// guided-pt of `max_depth` (roulette from 5 segments).
fn guided_pt(max_depth: u32, settings: GuidedSettings, cache: Option<GuideCache>) -> GuidedPt {
    let pt = PtSettings {
        max_depth,
        rr_depth: 5,
        ..PtSettings::default()
    };
    GuidedPt::new(pt, settings, cache)
}

/// Learn a cache: `spp` passes of which all but the last are learning iterations.
fn learn(scene: &Scene, max_depth: u32, spp: u64, seed: u64) -> GuideCache {
    let mut g = guided_pt(max_depth, settings(1.0 - 1.0 / spp as f64), None);
    let ctx = RenderContext::new(scene, seed, false);
    g.render(&ctx, Budget::Spp(spp));
    g.cache.take().expect("a cache")
}

/// A cache holding every path of two or more segments that pt forms from `n` camera paths
/// (equal weights), installed as after many learning iterations (first-vertex kernels a few pixels wide).
fn cache_of_pt_paths(scene: &Scene, max_depth: u32, n: u64) -> GuideCache {
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

/// Draw guided samples from a frozen cache and check, for each, that the density it was drawn
/// with along its guide path equals the cache's evaluation of that term from the finished
/// path, and that the pruned p_g equals the sum over every guide path.
fn check_sampling_matches_evaluation(name: &str, scene: &Scene, max_depth: u32) {
    check_cache_sampling(name, scene, &cache_of_pt_paths(scene, max_depth, 600));
}

fn check_cache_sampling(name: &str, scene: &Scene, cache: &GuideCache) {
    assert!(cache.len() > 20, "{name}: only {} guide paths", cache.len());
    let (mut ok, mut loose, mut failed) = (0usize, 0usize, 0usize);
    let mut worst = 0.0f64;
    let mut scratch = Vec::new();
    let mut reasons = std::collections::BTreeMap::new();
    for i in 0..4000u64 {
        let mut s = IndependentSampler::new(11, 0, i);
        let g = match sampler::sample_path(scene, cache, &mut s) {
            Ok(g) => g,
            Err(e) => {
                failed += 1;
                *reasons.entry(format!("{e:?}")).or_insert(0usize) += 1;
                continue;
            }
        };
        let y = paths::from_path(scene, &g.path).expect("a complete path");
        let (sig, nodes) = kernel::structure(scene, &g.path, MAX_VERTICES).expect("structure");
        assert_eq!(
            sig, cache.guides[g.guide].sig,
            "{name}: structure differs from the guide's"
        );
        let term = cache.pdf_given(scene, g.guide, &y);
        let rel = (term - g.density).abs() / term.max(1e-300);
        worst = worst.max(rel);
        // Sampling uses the drawn point and direction, evaluation the rounded (f32) hit
        // position: they agree to about 1e-4; a missing factor (branch probability, area
        // conversion, truncation mass) is off by far more.
        if rel > 1e-3 {
            loose += 1;
        }
        assert!(
            rel < 5e-2,
            "{name}: drawn with {}, evaluated {term}",
            g.density
        );
        let (p_g, _) = cache.pdf(scene, &y, sig, &nodes, &mut scratch);
        let brute = cache.terms_brute_force(scene, &y, sig, &nodes).sum;
        assert!(
            (p_g - brute).abs() <= 1e-12 * brute,
            "{name}: pruned p_g {p_g} vs all guide paths {brute}"
        );
        assert!(p_g >= cache.guides[g.guide].weight * term * (1.0 - 1e-12));
        ok += 1;
    }
    eprintln!("{name}: {ok} ok, {failed} failed {reasons:?}, worst {worst:e}, loose {loose}");
    assert!(
        ok > 100,
        "{name}: only {ok} successful guided samples ({failed} failed: {reasons:?})"
    );
    assert!(
        loose * 100 <= ok,
        "{name}: {loose} of {ok} differ by more than 1e-3 (worst {worst})"
    );
}

#[test]
fn guided_densities_match_their_evaluation_diffuse_and_glass() {
    check_sampling_matches_evaluation("glass box", &scene("cornell-box.toml", 32, |t| t), 6);
}

#[test]
fn guided_densities_match_their_evaluation_glossy() {
    check_sampling_matches_evaluation("glossy box", &scene("cornell-glossy.toml", 32, |t| t), 6);
}

#[test]
fn guided_densities_match_their_evaluation_fog() {
    check_sampling_matches_evaluation("fog box", &scene("cornell-fog.toml", 32, |t| t), 5);
}

/// Where first vertices are dense, each first-vertex kernel is at most as wide as the distance
/// to the `SPACING_RANK`-th nearest other first vertex of its structure (never below a pixel
/// footprint), and sampling and the pruned p_g still agree exactly with the narrowed kernels.
#[test]
fn first_vertex_kernels_narrow_where_guides_are_dense() {
    let scene = scene("cornell-box.toml", 32, |t| t);
    let cache = cache_of_pt_paths(&scene, 6, 6000);
    let bounds = SpacingBounds::new(&scene, &cache);
    let (mut at_bound, mut dense) = (0usize, 0usize);
    for l in 0..cache.len() {
        let Some(bound) = bounds.bound(&scene, l) else {
            continue;
        };
        dense += 1;
        let sigma1 = cache.guides[l].sigma1 as f64;
        assert!(
            sigma1 <= bound * (1.0 + 1e-4),
            "guide {l}: sigma1 {sigma1} above the spacing bound {bound}"
        );
        at_bound += ((sigma1 - bound).abs() <= 1e-4 * bound) as usize;
    }
    eprintln!(
        "{} guide paths, {dense} dense, {at_bound} at the spacing bound",
        cache.len()
    );
    assert!(
        at_bound * 2 > cache.len(),
        "only {at_bound} of {} first-vertex kernels narrowed",
        cache.len()
    );
    check_cache_sampling("dense glass box", &scene, &cache);
}

/// guided-pt (with a learned cache, alpha 0.5) and pt converge to the same image: per-channel
/// z-test of the mean pixel difference, |z| < 4.5 (false-failure rate about 2e-5 for three
/// channels). Its control is not here: on a caustic, pixel values are so heavy-tailed that
/// this z stays below 4 even for a broken p_g that makes the image 18x too bright (measured),
/// so the controls of wrong weights are in the per-tile caustic test below.
fn guided_vs_pt_z(scene: &Scene, spp: u64, cache: GuideCache) -> glam::DVec3 {
    let max_depth = 6;
    let pt = util::render(scene, "pt", max_depth, &[], spp, 1, 2);
    let settings = GuidedSettings {
        alpha: 0.5,
        ..settings(0.0)
    };
    let mut g = guided_pt(max_depth, settings, Some(cache));
    let ctx = RenderContext::new(scene, 9, false);
    let guided = g.render(&ctx, Budget::Spp(spp));
    let z = util::z_same_mean(&guided.image, &pt.image);
    eprintln!(
        "z {z:?}, means {:?} vs {:?}, stats {:?}",
        guided.image.mean(),
        pt.image.mean(),
        guided.stats
    );
    z
}

#[test]
fn guided_pt_is_unbiased_on_the_glass_cornell_box() {
    let scene = scene("cornell-box.toml", 64, |t| t);
    let z = guided_vs_pt_z(&scene, 64, learn(&scene, 6, 12, 2));
    assert!(z.abs().max_element() < 4.5, "z {z:?}");
}

/// Renders per side of the per-tile tests on the caustic (the reference's, and guided-pt's and
/// guided-bdpt's with a correct cache).
const TILE_SEEDS: u64 = 24;

/// The caustic scene at 24 x 24, the size of the per-tile tests on it (here and in
/// `guided_vcm.rs`).
pub(crate) fn caustic_tile_scene() -> Scene {
    util::scene(&CAUSTIC.replace("resolution = [48, 48]", "resolution = [24, 24]"))
}

/// The reference of the per-tile tests on the caustic here and in `guided_vcm.rs`:
/// `TILE_SEEDS` renders of [`caustic_tile_scene`] by bdpt (max_depth 6, 64 passes, seeds 100,
/// 101, ...), rendered once for all of them.
pub(crate) fn caustic_reference() -> &'static [lodestar::film::Image] {
    static REFERENCE: std::sync::OnceLock<Vec<lodestar::film::Image>> = std::sync::OnceLock::new();
    REFERENCE.get_or_init(|| {
        let scene = caustic_tile_scene();
        (0..TILE_SEEDS)
            .map(|s| util::render(&scene, "bdpt", 6, &[], 64, 100 + s, 2).image)
            .collect()
    })
}

/// `seeds` renders (seeds 0, 1, ...) of the caustic scene at 24 x 24 by guided-pt (`bdpt`
/// false) or guided-bdpt with a frozen copy of `cache` (α = 0.05: 19 guided paths per pixel
/// and pass), 16 passes each, `edit` applied to each copy (the controls' faults).
fn guided_caustic_renders(
    scene: &Scene,
    cache: &GuideCache,
    bdpt: bool,
    seeds: u64,
    edit: impl Fn(&mut GuideCache),
) -> Vec<lodestar::film::Image> {
    (0..seeds)
        .map(|seed| {
            let mut c = GuideCache::default();
            c.install(scene, installs_of(scene, cache), 10_000);
            edit(&mut c);
            let settings = GuidedSettings {
                alpha: 0.05,
                ..settings(0.0)
            };
            let ctx = RenderContext::new(scene, seed, false);
            let r = if bdpt {
                let b = bdpt::BdptSettings {
                    max_depth: 6,
                    rr_depth: 5,
                    heuristic: paths::Heuristic::Balance,
                    light_tracing: false,
                    techniques: Default::default(),
                    direct_splats: false,
                };
                GuidedBdpt::new(b, settings, Some(c)).render(&ctx, Budget::Spp(16))
            } else {
                guided_pt(6, settings, Some(c)).render(&ctx, Budget::Spp(16))
            };
            let guided: f64 = util::stat(&r, "guided_samples").unwrap().parse().unwrap();
            assert!(guided > 0.0, "no guided samples");
            r.image
        })
        .collect()
}

/// Per tile (4 x 4 pixels of 24 x 24, Welch's t over `TILE_SEEDS` renders a side, Bonferroni
/// over tiles and channels, family-wise false-failure rate 1e-4), guided-pt and guided-bdpt
/// with a cache that carries the caustic (one caustic path twice, weights 1/2, most samples
/// guided) render bdpt's image ([`caustic_reference`]). Three wrong weights fail the same test
/// against the same reference, each with guided-pt renders: p_g without the path (a cache of
/// that path alone, left out of the evaluation: p_g = 0 for its samples; 8 renders, the
/// caustic's tiles about 1,400 times too bright), p_g scaled by 1.5 where paths are weighed
/// (`TILE_SEEDS` renders) and n_g / n_u scaled by 2 there (12 renders).
#[test]
fn guided_renders_bdpt_image_on_a_caustic_tile_by_tile_and_wrong_weights_do_not() {
    let scene = caustic_tile_scene();
    let reference = caustic_reference();
    let twin = twin_caustic_cache(&scene, false);
    for bdpt in [false, true] {
        let name = if bdpt { "guided-bdpt" } else { "guided-pt" };
        let ok = guided_caustic_renders(&scene, &twin, bdpt, TILE_SEEDS, |_| {});
        util::assert_same_image(&ok, reference, 4, name);
    }
    let single = twin_caustic_cache(&scene, true);
    type Control<'c> = (&'c str, &'c GuideCache, u64, &'c dyn Fn(&mut GuideCache));
    let controls: [Control; 3] = [
        ("p_g without the path", &single, 8, &|c| {
            c.skip_in_pdf = Some(0)
        }),
        ("p_g x 1.5 in the weights", &twin, TILE_SEEDS, &|c| {
            c.weight_faults.p_g = 1.5
        }),
        ("n_g / n_u x 2 in the weights", &twin, 12, &|c| {
            c.weight_faults.ratio = 2.0
        }),
    ];
    for (what, cache, seeds, edit) in controls {
        let wrong = guided_caustic_renders(&scene, cache, false, seeds, edit);
        let caught = std::panic::catch_unwind(|| {
            util::assert_same_image(&wrong, reference, 4, &format!("control: {what}"))
        });
        assert!(caught.is_err(), "control '{what}' passed the per-tile test");
    }
}

/// f(X) evaluated from the vertices equals what pt's estimate times its density gives, for
/// every path pt forms in a glass, a glossy and a fog box.
#[test]
fn contribution_matches_pt() {
    struct Check<'a> {
        scene: &'a Scene,
        n: usize,
        bad: Vec<String>,
    }
    impl PathRecorder for Check<'_> {
        fn record(&mut self, path: &Path, f_pt: glam::DVec3, technique: usize, _: f64, _: f64) {
            if f_pt == glam::DVec3::ZERO {
                return;
            }
            let y = paths::from_path(self.scene, path).unwrap();
            let f = contribution::contribution(self.scene, &y, 0);
            let rel = ((f - f_pt).abs() / f_pt.abs().max(glam::DVec3::splat(1e-300))).max_element();
            self.n += 1;
            if rel > 2e-3 && self.bad.len() < 4 {
                self.bad.push(format!(
                    "k {} technique {technique}: pt {f_pt} vs {f}",
                    path.segments(),
                ));
            }
        }
    }
    for (name, res) in [
        ("cornell-box.toml", 16),
        ("cornell-glossy.toml", 16),
        ("cornell-fog.toml", 16),
    ] {
        let scene = scene(name, res, |t| t);
        let pt = PathTracer {
            settings: PtSettings {
                max_depth: 6,
                ..PtSettings::default()
            },
        };
        let mut c = Check {
            scene: &scene,
            n: 0,
            bad: Vec::new(),
        };
        for i in 0..256u64 {
            let mut s = IndependentSampler::new(3, 0, i);
            let raster = glam::Vec2::new((i % 16) as f32, (i / 16) as f32) + s.next_2d();
            pt.li_recorded(&scene, raster, &mut s, Some(&mut c));
        }
        assert!(c.n > 200, "{name}: {} paths", c.n);
        assert!(c.bad.is_empty(), "{name}: {}", c.bad.join("\n"));
    }
}

fn temp_dir(tag: &str) -> std::path::PathBuf {
    let d = std::env::temp_dir().join(format!("lodestar-guided-{tag}-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// A cache saved after learning and loaded again renders the same image, bit for bit, as the
/// render phase of the run that learned it (that run with `keep_learning=false`, so that its
/// image is its render phase's alone); damaged files are clear errors.
#[test]
fn saved_caches_render_identically_and_bad_files_are_errors() {
    let scene = util::scene(CAUSTIC);
    let dir = temp_dir("io");
    let file = dir.join("caustic.guides");
    let opt = |k: &str, v: &std::path::Path| format!("{k}={}", v.display());
    let params = |extra: Vec<String>| {
        let mut o = vec!["learn_fraction=0.5".to_string()];
        o.extend(extra);
        lodestar::integrators::IntegratorParams {
            max_depth: 6,
            options: lodestar::integrators::Options::parse(&o).unwrap(),
        }
    };
    let run = |p: &lodestar::integrators::IntegratorParams, spp: u64, sc: &Scene| {
        lodestar::integrators::render_named(sc, "guided-pt", p, Budget::Spp(spp), 4, 2, false)
    };
    // Learned with non-default kernel widths, loaded without them: the file carries them.
    let widths = || vec!["kernel_width=1.5".to_string(), "first_width=1".to_string()];
    let mut save = widths();
    save.push(opt("save_guides", &file));
    save.push("keep_learning=false".to_string());
    let learned = run(&params(save), 8, &scene).unwrap();
    let loaded = run(&params(vec![opt("load_guides", &file)]), 4, &scene).unwrap();
    assert_eq!(learned.result.passes, 4);
    assert_eq!(loaded.result.passes, 4);
    assert!(
        learned.result.image.pixels == loaded.result.image.pixels,
        "a loaded cache renders differently"
    );
    let stat = |r: &lodestar::integrators::NamedRender, k: &str| {
        r.result
            .stats
            .iter()
            .find(|s| s.0 == k)
            .map(|s| s.1.clone())
    };
    assert_eq!(stat(&learned, "guide_paths"), stat(&loaded, "guide_paths"));

    let bytes = std::fs::read(&file).unwrap();
    let load_err = |name: &str, data: &[u8], sc: &Scene| -> String {
        let f = dir.join(name);
        std::fs::write(&f, data).unwrap();
        match run(&params(vec![opt("load_guides", &f)]), 2, sc) {
            Ok(_) => panic!("{name}: loaded"),
            Err(e) => e.to_string(),
        }
    };
    let mut wrong_version = bytes.clone();
    wrong_version[8] = 99;
    let e = load_err("version.guides", &wrong_version, &scene);
    assert!(
        e.contains("version 99") && e.contains("version.guides"),
        "{e}"
    );
    let e = load_err("short.guides", &bytes[..bytes.len() - 7], &scene);
    assert!(e.contains("truncated") && e.contains("short.guides"), "{e}");
    let mut bad_width = bytes.clone();
    bad_width[24..32].copy_from_slice(&f64::NAN.to_le_bytes());
    let e = load_err("width.guides", &bad_width, &scene);
    assert!(e.contains("invalid kernel widths"), "{e}");
    let e = load_err("magic.guides", b"not a cache at all", &scene);
    assert!(e.contains("bad magic"), "{e}");
    let other = util::scene(&CAUSTIC.replace("fov = 40", "fov = 41"));
    let e = load_err("other.guides", &bytes, &other);
    assert!(e.contains("another scene"), "{e}");
    // Guide paths longer than the render's max_depth would add paths U leaves out.
    let mut shallow = params(vec![opt("load_guides", &file)]);
    shallow.max_depth = 2;
    match run(&shallow, 2, &scene) {
        Ok(_) => panic!("a cache of longer paths rendered at max_depth 2"),
        Err(e) => {
            let e = e.to_string();
            assert!(
                e.contains("max_depth 2") && e.contains("caustic.guides"),
                "{e}"
            );
        }
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// The first vertices of a cache's guide paths grouped by structure, for the bound on each
/// guide's first-vertex width where first vertices are dense ([`SpacingBounds::bound`]).
struct SpacingBounds {
    /// The camera position.
    o: glam::DVec3,
    /// g_1 of every guide path and the unit direction to it from the camera.
    first: Vec<(glam::DVec3, glam::DVec3)>,
    /// The guide paths of every structure (in index order), and the structure of each.
    groups: Vec<Vec<usize>>,
    group_of: Vec<usize>,
}

impl SpacingBounds {
    fn new(scene: &Scene, cache: &GuideCache) -> SpacingBounds {
        let o = scene.camera.position.as_dvec3();
        let first = (0..cache.len())
            .map(|l| {
                let g1 = cache.vertex(scene, l, 1).p.as_dvec3();
                (g1, (g1 - o).normalize())
            })
            .collect();
        let mut index = std::collections::HashMap::new();
        let mut groups: Vec<Vec<usize>> = Vec::new();
        let group_of = (0..cache.len())
            .map(|l| {
                let g = *index.entry(cache.nodes_of(l)).or_insert_with(|| {
                    groups.push(Vec::new());
                    groups.len() - 1
                });
                groups[g].push(l);
                g
            })
            .collect();
        SpacingBounds {
            o,
            first,
            groups,
            group_of,
        }
    }

    /// The bound on guide `l`'s first-vertex width where first vertices are dense: the
    /// distance to the `SPACING_RANK`-th nearest other first vertex of its structure in `l`'s
    /// kernel plane (brute force over the structure's guide paths), never below a pixel
    /// footprint; `None` where fewer guide paths share the structure.
    fn bound(&self, scene: &Scene, l: usize) -> Option<f64> {
        let (o, g1) = (self.o, self.first[l].0);
        let (dist, w) = ((g1 - o).length(), (g1 - o).normalize());
        let mut gaps: Vec<f64> = self.groups[self.group_of[l]]
            .iter()
            .filter(|&&j| j != l)
            .map(|&j| {
                let wj = self.first[j].1;
                (o + wj * (dist / wj.dot(w)) - g1).length()
            })
            .collect();
        if gaps.len() < cache::SPACING_RANK {
            return None;
        }
        let (_, nth, _) = gaps.select_nth_unstable_by(cache::SPACING_RANK - 1, f64::total_cmp);
        let footprint = dist * scene.camera.pixel_angle() as f64;
        Some(nth.max(footprint))
    }
}

/// `first_width_specular` widens the first-vertex kernels of guide paths whose g_1 is specular
/// and leaves those of rough g_1 alone (the spacing bound may still narrow a kernel), and the
/// wider kernels still sample exactly what p_g evaluates.
#[test]
fn specular_first_vertex_width_applies_to_specular_first_vertices_only() {
    use lodestar::path::VertexKind;
    let scene = util::scene(CAUSTIC);
    // From the spec's specular width (factor 1), so that the spacing bound leaves some
    // specular kernels free to widen.
    let widths = cache::KernelWidths {
        first_vertex_specular: 1.0,
        ..Default::default()
    };
    let wide = cache::KernelWidths {
        first_vertex_specular: 3.0 * widths.first_vertex_specular,
        ..widths
    };
    let base = cache_of_pt_paths(&scene, 6, 2000);
    let mut paths = Vec::new();
    for l in 0..base.len() {
        let g = base.guides[l];
        let vertices = (0..g.len as usize)
            .map(|v| base.vertex(&scene, l, v))
            .collect();
        paths.push((vertices, g.f, g.p_u, g.weight, g.age));
    }
    let mut narrow_cache = GuideCache::with_widths(widths);
    narrow_cache.install(&scene, paths.clone(), 10_000);
    let mut wide_cache = GuideCache::with_widths(wide);
    wide_cache.install(&scene, paths, 10_000);
    assert_eq!(narrow_cache.len(), wide_cache.len());
    let wide_bounds = SpacingBounds::new(&scene, &wide_cache);
    let (mut specular, mut tripled, mut widened, mut rough) = (0usize, 0usize, 0usize, 0usize);
    for l in 0..narrow_cache.len() {
        let (a, b) = (
            narrow_cache.guides[l].sigma1 as f64,
            wide_cache.guides[l].sigma1 as f64,
        );
        let VertexKind::Surface { material, .. } = narrow_cache.vertex(&scene, l, 1).kind else {
            continue;
        };
        let rho = scene.materials[material as usize].bsdf.roughness();
        if rho == 1.0 {
            rough += 1;
            assert_eq!(a, b, "guide {l}: a rough g_1's kernel changed");
        } else if rho == 0.0 {
            specular += 1;
            // Unless the spacing bound held the narrow kernel, the wide one is three times
            // as wide, or held by the bound itself.
            let bound = wide_bounds.bound(&scene, l).unwrap_or(f64::INFINITY);
            let expect = if a >= bound * (1.0 - 1e-4) {
                a
            } else {
                (3.0 * a).min(bound)
            };
            assert!(
                (b - expect).abs() <= 1e-4 * expect,
                "guide {l}: specular kernel {a} -> {b}, expected {expect} (bound {bound})"
            );
            tripled += ((b / a - 3.0).abs() < 1e-4) as usize;
            widened += (b > a * 1.01) as usize;
        }
    }
    eprintln!(
        "{rough} rough, {specular} specular first vertices, {widened} widened, {tripled} tripled"
    );
    assert!(
        rough > 20 && specular > 5,
        "{rough} rough, {specular} specular"
    );
    assert!(
        tripled >= 5 && widened > tripled,
        "{widened} widened, {tripled} tripled"
    );
    check_cache_sampling("wide specular first vertices", &scene, &wide_cache);
}

/// Bad guided-pt settings are errors naming the option and what was expected.
#[test]
fn bad_guided_options_are_errors() {
    use lodestar::integrators::{IntegratorParams, Options, build};
    for (opt, expect) in [
        (
            "kernel_width=0",
            "option 'kernel_width': expected a number > 0",
        ),
        (
            "kernel_width=nan",
            "option 'kernel_width': expected a number > 0",
        ),
        (
            "first_width=-1",
            "option 'first_width': expected a number > 0",
        ),
        (
            "first_width=inf",
            "option 'first_width': expected a number > 0",
        ),
        (
            "first_width_specular=0",
            "option 'first_width_specular': expected a number > 0",
        ),
        ("alpha=0", "option 'alpha': expected a number in (0, 1]"),
        ("intake=0", "option 'intake': expected an integer >= 1"),
        (
            "kernel_width=2,load_guides=x.guides",
            "option 'kernel_width' has no effect with load_guides",
        ),
    ] {
        let opts: Vec<String> = opt.split(',').map(String::from).collect();
        let params = IntegratorParams {
            max_depth: 6,
            options: Options::parse(&opts).unwrap(),
        };
        let err = build("guided-pt", &params)
            .err()
            .unwrap_or_else(|| panic!("{opt}: accepted"));
        assert!(err.to_string().contains(expect), "{opt}: {err}");
    }
}

/// guided-pt end to end (learning inside the render) in the fog box converges to bdpt's image
/// tile by tile over 5 seeded renders each (`util::assert_same_image`, family-wise
/// false-failure rate 1e-4; no invalid sample or path in any render). Control: guided-pt's
/// images mirrored left to right must fail the same comparison.
#[test]
fn guided_pt_learning_in_fog_agrees_with_bdpt_tile_by_tile() {
    let scene = scene("cornell-fog.toml", 16, |t| t);
    let guided = util::seeded_renders(&scene, "guided-pt", 6, &["learn_fraction=0.25"], 128, 5, 40);
    let bdpt = util::seeded_renders(&scene, "bdpt", 6, &[], 64, 5, 50);
    util::assert_same_image(&bdpt, &guided, 4, "guided-pt (learning) vs bdpt in fog");
    let flipped: Vec<_> = guided.iter().map(util::mirrored).collect();
    assert!(
        util::differs(&bdpt, &flipped, 4),
        "mirrored guided-pt passes"
    );
}

/// Far from the origin, where f32 hit points are coarse and ray origins move off surfaces by
/// their error bounds: guided rays leave each vertex on the line through the vertex itself
/// (`Hit::spawn_along`), so the density recomputed from the vertices sees the direction that
/// was drawn. 100 units away, sampling and evaluation agree as at the origin (the strict
/// check above). 1e4 away the hit points' own rounding (an ulp is 1e-3 there) limits
/// agreement, so every sample's disagreement must be within what that rounding explains:
/// [`util::rounding_sensitivity`] of the recomputed density, the change it makes when the
/// vertices move within their error bounds (measured: at most 0.48 of it, median 0.03; the
/// relative disagreement itself has median 4e-3 and reaches 0.75 where the density is that
/// sensitive). With rays offset along the normal instead, the worst sample was off by a factor
/// 1e302.
#[test]
fn guided_densities_match_their_evaluation_far_from_the_origin() {
    let near = util::scene(&util::transformed_cornell(1.0, 100.0, 32));
    check_cache_sampling("box 100 away", &near, &cache_of_pt_paths(&near, 6, 600));
    let far = util::scene(&util::transformed_cornell(1.0, 1e4, 32));
    let cache = cache_of_pt_paths(&far, 6, 600);
    let mut samples = 0;
    for i in 0..4000u64 {
        let mut s = IndependentSampler::new(11, 0, i);
        let Ok(g) = sampler::sample_path(&far, &cache, &mut s) else {
            continue;
        };
        let y = paths::from_path(&far, &g.path).expect("a complete path");
        let term = cache.pdf_given(&far, g.guide, &y);
        assert!(term.is_finite() && g.density.is_finite());
        let bound = util::rounding_sensitivity(&y, |y| cache.pdf_given(&far, g.guide, y));
        assert!(
            (term - g.density).abs() <= bound,
            "1e4 away, sample {i}: sampled density {} against {term} recomputed; rounding \
             explains {bound}",
            g.density
        );
        samples += 1;
    }
    assert!(samples > 100, "only {samples} guided samples");
}

/// A failed walk says why and where: with a quad across the Cornell box 5 mm under its light
/// (a false ceiling), every walk that gets to its step to the light fails there as
/// `Failure::Light`, with the vertices before that step in its path, and none succeeds; in
/// the open box the same cache's walks succeed, and those that fail as `Light` fail at the
/// same step. The path left by a failed walk is what `failed_walks_by_vertex` counts from.
/// (Before the `Light` reason, a blocked step to an area light counted as a `Miss` like any
/// other: then this test fails, 84 `light` failures under the false ceiling against 162
/// open.)
#[test]
fn a_walk_whose_step_to_the_light_is_blocked_fails_there_as_light() {
    let open = util::cornell(32);
    let cache = cache_of_pt_paths(&open, 6, 600);
    let occluder = "\n[[shape]]\nname = \"occluder\"\ntype = \"quad\"\n\
                    origin = [-1, 0.985, -1]\nedge_u = [2, 0, 0]\n\
                    edge_v = [0, 0, 2]\nmaterial = \"white\"\n";
    let blocked = util::scene(
        &(lodestar::scene::CORNELL_BOX_TOML
            .replace("resolution = [256, 256]", "resolution = [32, 32]")
            + occluder),
    );
    let walks = |scene: &Scene| {
        let (mut ok, mut light) = (0, 0);
        let mut path = Path::default();
        for i in 0..4000u64 {
            // The walk's first two numbers select its guide.
            let mut pick = IndependentSampler::new(17, 0, i);
            let (l, _) = cache.select(pick.next_f64(), pick.next_f64());
            let mut s = IndependentSampler::new(17, 0, i);
            match sampler::sample_path_into(scene, &cache, &mut s, &mut path) {
                Ok(_) => ok += 1,
                Err(sampler::Failure::Light) => {
                    assert_eq!(
                        path.vertices().len() + 1,
                        cache.guides[l].len as usize,
                        "a `Light` failure before the step to the light"
                    );
                    light += 1;
                }
                Err(_) => {}
            }
        }
        (ok, light)
    };
    let (ok_open, light_open) = walks(&open);
    let (ok_blocked, light_blocked) = walks(&blocked);
    eprintln!(
        "open: {ok_open} drawn, {light_open} light failures; blocked: {ok_blocked}, {light_blocked}"
    );
    assert!(ok_open > 200, "open box: {ok_open} walks succeeded");
    assert_eq!(ok_blocked, 0, "a walk reached the covered light");
    assert!(
        light_blocked > light_open + ok_open / 2,
        "blocked: {light_blocked} light failures against {light_open} (+ {ok_open} drawn) open"
    );
}

/// A guided sample is booked to the pixel its first vertex x_1 projects to: for every guided
/// path drawn from a cache of pt's paths in the glass box, the pixel it carries is the one of
/// the direction from the camera to x_1 (up to f32 rounding of x_1: samples within 1e-3 of a
/// pixel edge may fall on either side and are left out; none may land further away).
#[test]
fn a_guided_sample_lands_on_the_pixel_of_its_first_vertex() {
    let scene = scene("cornell-box.toml", 32, |t| t);
    let cache = cache_of_pt_paths(&scene, 6, 4000);
    let camera = &scene.camera;
    let (mut drawn, mut checked) = (0, 0);
    let mut path = Path::default();
    for i in 0..20_000u64 {
        let mut s = IndependentSampler::new(11, 0, i);
        if sampler::sample_path_into(&scene, &cache, &mut s, &mut path).is_err() {
            continue;
        }
        drawn += 1;
        let x1 = path.vertices()[1].p;
        let raster = camera
            .raster_of_direction((x1 - camera.position).normalize())
            .expect("x_1 is on the image");
        let frac = raster - raster.floor();
        if frac.min_element() < 1e-3 || frac.max_element() > 1.0 - 1e-3 {
            continue;
        }
        checked += 1;
        assert_eq!(
            path.pixel as usize,
            camera.pixel_index(raster),
            "sample {i}: booked to pixel {}, x_1 projects to raster {raster}",
            path.pixel
        );
    }
    assert!(checked > 1000, "{checked} of {drawn} samples checked");
}
