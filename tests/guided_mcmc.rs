//! The Markov-chain seeder (`seeder = mcmc`): its chains add guide paths to the cache, the
//! guided integrators stay unbiased with a cache it learned (and a broken p_g is still
//! caught), a chain replays the outlier it starts at, and renders do not depend on the thread
//! count.

use crate::util;

use lodestar::film::Image;

use lodestar::integrators::bdpt::BdptSettings;
use lodestar::integrators::guided::cache::GuideCache;
use lodestar::integrators::guided::{ChainSettings, Guided, GuidedSettings, Mcmc, Seeder};
use lodestar::integrators::paths::Heuristic;
use lodestar::integrators::pt::PtSettings;
use lodestar::render::{Budget, Integrator, RenderContext, RenderResult};
use lodestar::scene::Scene;
use util::guided::{CAUSTIC, installs_of};

const MAX_DEPTH: u32 = 6;

fn pt_settings() -> PtSettings {
    PtSettings {
        max_depth: MAX_DEPTH,
        ..PtSettings::default()
    }
}

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

/// A guided integrator over `unguided` ("pt" or "bdpt") with seeder `seeder`.
fn guided<S: Seeder + 'static>(
    unguided: &str,
    settings: GuidedSettings,
    seeder: S,
    cache: Option<GuideCache>,
) -> Box<dyn Integrator> {
    match unguided {
        "pt" => Box::new(Guided::over_pt(pt_settings(), settings, seeder, cache)),
        _ => Box::new(Guided::over_bdpt(bdpt_settings(), settings, seeder, cache)),
    }
}

fn stat(r: &RenderResult, key: &str) -> String {
    util::stat(r, key)
        .unwrap_or_else(|| panic!("no stat {key}"))
        .to_string()
}

/// Learn a cache on the caustic scene with the chain seeder (8 learning iterations) and
/// return it with the learning render's statistics.
fn learn_with_chains(scene: &Scene, unguided: &str) -> (GuideCache, RenderResult) {
    let settings = GuidedSettings {
        learn_fraction: 0.5,
        ..GuidedSettings::default()
    };
    let seeder = Mcmc::new(settings.intake, ChainSettings::default());
    let pt = pt_settings();
    let mut integ = Guided::over_pt(pt, settings.clone(), seeder, None);
    let ctx = RenderContext::new(scene, 9, false);
    if unguided == "pt" {
        let r = integ.render(&ctx, Budget::Spp(16));
        (integ.cache.take().expect("a learned cache"), r)
    } else {
        let seeder = Mcmc::new(settings.intake, ChainSettings::default());
        let mut integ = Guided::over_bdpt(bdpt_settings(), settings, seeder, None);
        let r = integ.render(&ctx, Budget::Spp(16));
        (integ.cache.take().expect("a learned cache"), r)
    }
}

/// How the p_g of a control is broken.
#[derive(Clone, Copy, PartialEq)]
enum Broken {
    No,
    /// The cache's heaviest guide path is left out of p_g.
    Heaviest,
    /// The heaviest guide path alone, left out of p_g (where U finds the caustic well, one
    /// guide among many carries too little of the image for its omission to show).
    Alone,
}

/// `seeds` renders of `spp` samples with the guided integrator over `unguided` (frozen copy
/// of `cache`, α = 0.05, p_g broken as `broken` says), seeds 1, 2, ...
fn guided_renders(
    scene: &Scene,
    unguided: &str,
    cache: &GuideCache,
    broken: Broken,
    spp: u64,
    seeds: u64,
) -> Vec<Image> {
    let heaviest = (0..cache.len())
        .max_by(|&a, &b| cache.guides[a].weight.total_cmp(&cache.guides[b].weight))
        .expect("non-empty cache");
    let mut installs = installs_of(scene, cache);
    if broken == Broken::Alone {
        installs = vec![installs.swap_remove(heaviest)];
        installs[0].3 = 1.0;
    }
    (1..=seeds)
        .map(|seed| {
            let mut c = GuideCache::default();
            c.install(scene, installs.clone(), 100_000);
            c.skip_in_pdf = match broken {
                Broken::No => None,
                Broken::Heaviest => Some(heaviest),
                Broken::Alone => Some(0),
            };
            let settings = GuidedSettings {
                alpha: 0.05,
                share: lodestar::integrators::guided::Share::Fixed,
                learn_fraction: 0.0,
                ..GuidedSettings::default()
            };
            let seeder = Mcmc::new(settings.intake, ChainSettings::default());
            let mut integ = guided(unguided, settings, seeder, Some(c));
            let ctx = RenderContext::new(scene, seed, false);
            integ.render(&ctx, Budget::Spp(spp)).image
        })
        .collect()
}

/// One side of a per-tile comparison: renders and samples per pixel.
struct Side {
    renders: u64,
    spp: u64,
}

/// With a cache the chain seeder learned on a caustic (24 x 24), guided-pt and guided-bdpt
/// render pt's and bdpt's images tile by tile (4 x 4 tiles, Welch's t over independently
/// seeded renders, Bonferroni over tiles and channels, family-wise false-failure rate 1e-4),
/// and a broken p_g fails the same test against the same unguided renders (guided-pt: the
/// heaviest guide path left out; guided-bdpt: see [`Broken::Alone`]).
///
/// guided-pt: 16 renders of 24 spp against 48 of pt at 64 spp (pt's side carries much of the
/// variance there, so its cheap renders buy power: with 16 broken renders against 48 of pt
/// the control fails at p = 3e-38, with 24 against 24 at p = 1e-30). guided-bdpt: 24 renders
/// of 8 spp against 24 of bdpt at 16 spp (the variance there is guided-bdpt's). Each control
/// renders 8 seeds; measured against the bound 9.3e-7: guided-pt p = 3.5e-14, guided-bdpt
/// p = 1.9e-14.
#[test]
fn mcmc_seeded_guiding_is_unbiased_and_a_broken_pg_is_caught() {
    let scene = util::scene(&CAUSTIC.replace("resolution = [48, 48]", "resolution = [24, 24]"));
    for (unguided, broken, guided_side, unguided_side) in [
        (
            "pt",
            Broken::Heaviest,
            Side {
                renders: 16,
                spp: 24,
            },
            Side {
                renders: 48,
                spp: 64,
            },
        ),
        (
            "bdpt",
            Broken::Alone,
            Side {
                renders: 24,
                spp: 8,
            },
            Side {
                renders: 24,
                spp: 16,
            },
        ),
    ] {
        let (cache, learned) = learn_with_chains(&scene, unguided);
        let chain_guides: u64 = stat(&learned, "seeder_chain_guides").parse().unwrap();
        assert_eq!(stat(&learned, "seeder"), "mcmc");
        assert!(
            chain_guides > 0 && !cache.is_empty(),
            "{unguided}: the chains added no guide path ({} guides)",
            cache.len()
        );
        let u: Vec<Image> = (1..=unguided_side.renders)
            .map(|seed| {
                util::render(
                    &scene,
                    unguided,
                    MAX_DEPTH,
                    &[],
                    unguided_side.spp,
                    100 + seed,
                    2,
                )
                .image
            })
            .collect();
        let g = guided_renders(
            &scene,
            unguided,
            &cache,
            Broken::No,
            guided_side.spp,
            guided_side.renders,
        );
        util::assert_same_image(&g, &u, 4, &format!("guided-{unguided}"));
        let g = guided_renders(&scene, unguided, &cache, broken, guided_side.spp, 8);
        let caught = std::panic::catch_unwind(|| {
            util::assert_same_image(
                &g,
                &u,
                4,
                &format!("guided-{unguided}, broken p_g (control)"),
            )
        });
        assert!(
            caught.is_err(),
            "guided-{unguided}: the broken p_g went unnoticed"
        );
    }
}

/// guided-pt and guided-bdpt with the chain seeder, learning inside the render, give
/// bit-identical images on 1 and 2 threads.
#[test]
fn mcmc_seeded_renders_do_not_depend_on_the_thread_count() {
    let scene = util::scene(CAUSTIC);
    for name in ["guided-pt", "guided-bdpt"] {
        let options = ["learn_fraction=0.5", "seeder=mcmc"];
        let one = util::render(&scene, name, MAX_DEPTH, &options, 8, 5, 1);
        let two = util::render(&scene, name, MAX_DEPTH, &options, 8, 5, 2);
        assert!(stat(&one, "seeder_chain_steps").parse::<u64>().unwrap() > 0);
        assert!(
            one.image.pixels == two.image.pixels,
            "{name}: 1 and 2 threads differ"
        );
        assert_eq!(
            stat(&one, "seeder_chain_guides"),
            stat(&two, "seeder_chain_guides")
        );
    }
}

/// The chain options are checked and belong to the chain seeder.
#[test]
fn chain_options_are_checked() {
    use lodestar::integrators::{IntegratorParams, Options, build};
    let err = |opts: &[&str]| {
        let params = IntegratorParams {
            max_depth: 6,
            options: Options::parse(&opts.iter().map(|s| s.to_string()).collect::<Vec<_>>())
                .unwrap(),
        };
        build("guided-pt", &params).err().map(|e| e.to_string())
    };
    assert!(err(&["seeder=mcmc"]).is_none());
    let e = err(&["seeder=chains"]).expect("unknown seeder");
    assert!(e.contains("seeder") && e.contains("mcmc"), "{e}");
    let e = err(&["chain_share=0.5"]).expect("chain option without the chain seeder");
    assert!(
        e.contains("chain_share") && e.contains("seeder=mcmc"),
        "{e}"
    );
    let e = err(&["seeder=mcmc", "chain_large_step=2"]).expect("large step out of range");
    assert!(e.contains("chain_large_step"), "{e}");
    assert!(err(&["seeder=mcmc", "chain_target=uncovered"]).is_none());
    assert!(err(&["seeder=mcmc", "chain_target=unguided"]).is_none());
    let e = err(&["chain_target=uncovered"]).expect("chain target without the chain seeder");
    assert!(
        e.contains("chain_target") && e.contains("seeder=mcmc"),
        "{e}"
    );
    let e = err(&["seeder=mcmc", "chain_target=dark"]).expect("unknown chain target");
    assert!(e.contains("chain_target") && e.contains("uncovered"), "{e}");
    assert!(err(&["seeder=mcmc", "chain_spread=0"]).is_none());
    let e = err(&["seeder=mcmc", "chain_spread=-2"]).expect("negative spread");
    assert!(
        e.contains("chain_spread") && e.contains("integer >= 0"),
        "{e}"
    );
    let e = err(&["chain_spread=3"]).expect("chain spread without the chain seeder");
    assert!(
        e.contains("chain_spread") && e.contains("seeder=mcmc"),
        "{e}"
    );
}

/// A chain started at U's sample (seed, pass, pixel) of a learning pass replays it: the
/// chain's initial state traces the same path (the raster position goes through a fraction of
/// the image and back, so it may move by an ulp). Of two passes of pt samples on the caustic scene,
/// every one's value is reproduced to 1e-4 relative, but for at most 1 % (an ulp can cross an
/// edge).
#[test]
fn a_chain_replays_the_sample_it_starts_at() {
    use lodestar::integrators::guided::chains::replayed_state;
    use lodestar::integrators::mcmc::{PrimarySampler, SmallStep};
    use lodestar::integrators::pt::PathTracer;
    use lodestar::math::{IndependentSampler, Sampler};
    let scene = util::scene(CAUSTIC);
    let pt = PathTracer {
        settings: pt_settings(),
    };
    let res = scene.camera.resolution;
    let seed = 3u64;
    let (mut nonzero, mut differ) = (0, 0);
    let pixels = (res.x * res.y) as u64;
    for (pass, index) in [2u64, 5]
        .into_iter()
        .flat_map(|p| (0..pixels).map(move |i| (p, i)))
    {
        let mut s = IndependentSampler::new(seed, pass, index);
        let pixel = glam::Vec2::new((index % res.x as u64) as f32, (index / res.x as u64) as f32);
        let raster = pixel + s.next_2d();
        let a = pt.li(&scene, raster, &mut s);
        let state = replayed_state(seed, pass, index, res);
        let mut chain = PrimarySampler::with_prefix(&state, 1, SmallStep::default(), 0.1);
        let raster_b = chain.next_2d() * res.as_vec2();
        assert!(
            (raster_b - raster).abs().max_element() < 1e-3,
            "{raster} {raster_b}"
        );
        let b = pt.li(&scene, raster_b, &mut chain);
        if a != glam::Vec3::ZERO || b != glam::Vec3::ZERO {
            nonzero += 1;
            let rel = (a - b).abs().max_element() / a.abs().max_element().max(1e-12);
            if rel > 1e-4 {
                differ += 1;
            }
        }
    }
    assert!(nonzero > 1000, "{nonzero} non-zero samples");
    assert!(differ * 100 <= nonzero, "{differ} of {nonzero} differ");
}

/// `chain_target=unguided` chains on U's own estimate, its paths weighted by U's techniques
/// alone under the balance heuristic (f / p_u). bdpt's weights are the balance heuristic's:
/// `own_estimate` of a sample's stream is the luminance of what `Unguided::estimate` adds to
/// the image from the same stream (its pixel plus its splats), to 1e-4 relative on all but
/// 1 % of the non-zero samples (an ulp can cross an edge). pt weighs by the power heuristic,
/// so there the two agree in the mean: over 96 passes the paired difference's mean is within
/// 5 standard errors of 0 (false-failure rate below 1e-6). Checked to fail when the sink
/// drops the paths bdpt splats to other pixels (1277 of 3637 samples differ) or scales
/// f / p_u by 1.05 (bdpt: every sample differs; pt alone: z = 88).
#[test]
fn the_unguided_chain_target_is_us_own_estimate() {
    use lodestar::integrators::bdpt::BdptUnguided;
    use lodestar::integrators::guided::chains::own_estimate;
    use lodestar::integrators::pt::PathTracer;
    use lodestar::integrators::unguided::Unguided;
    use lodestar::math::{IndependentSampler, Sampler, luminance64};

    /// (U's estimate, the target) of every sample of `passes` passes.
    fn pairs<U: Unguided>(
        u: &U,
        pass: &U::Pass<'_>,
        scene: &Scene,
        passes: u64,
    ) -> Vec<(f64, f64)> {
        let res = scene.camera.resolution;
        let mut tracer = u.tracer(scene, pass);
        let mut splats = Vec::new();
        let pixels = (res.x * res.y) as u64;
        let mut out = Vec::new();
        for (p, index) in (0..passes).flat_map(|p| (0..pixels).map(move |i| (p, i))) {
            let mut a = IndependentSampler::new(7, p, index);
            let raster = a.next_2d() * res.as_vec2();
            splats.clear();
            let mut value = u.estimate(&mut tracer, scene, raster, &mut a, &mut splats);
            for (_, c) in &splats {
                value += *c;
            }
            let mut b = IndependentSampler::new(7, p, index);
            out.push((
                luminance64(value),
                own_estimate(u, &mut tracer, scene, &mut b),
            ));
        }
        out
    }
    let scene = util::scene(CAUSTIC);
    let bdpt = BdptUnguided {
        settings: bdpt_settings(),
    };
    let samples = pairs(&bdpt, &(), &scene, 2);
    let nonzero: Vec<_> = samples
        .iter()
        .filter(|(e, g)| *e > 0.0 || *g > 0.0)
        .collect();
    let differ = nonzero
        .iter()
        .filter(|(e, g)| (e - g).abs() > 1e-4 * e.max(*g))
        .count();
    assert!(
        nonzero.len() > 1000,
        "bdpt: {} non-zero samples",
        nonzero.len()
    );
    assert!(
        differ * 100 <= nonzero.len(),
        "bdpt: {differ} of {} differ",
        nonzero.len()
    );

    let pt = PathTracer {
        settings: pt_settings(),
    };
    let samples = pairs(&pt, &(), &scene, 96);
    let n = samples.len() as f64;
    let d: Vec<f64> = samples.iter().map(|(e, g)| g - e).collect();
    let mean = d.iter().sum::<f64>() / n;
    let var = d.iter().map(|x| (x - mean) * (x - mean)).sum::<f64>() / (n - 1.0);
    let z = mean / (var / n).sqrt();
    let image = samples.iter().map(|s| s.0).sum::<f64>() / n;
    assert!(
        z.abs() < 5.0,
        "pt: the target's mean differs from pt's by {mean} (pt's {image}, z {z})"
    );
}
