//! The integrator written outside the crate (`examples/bsdf_pt/`): it registers itself, renders
//! what pt renders tile by tile, and through `Guided<U, S>` is guided with no guiding code of
//! its own, again rendering pt's image. A copy whose `p_u` is off by a factor 2 (reported and
//! evaluated alike) is guided to a visibly wrong image: the per-tile test catches it.

#[path = "../examples/bsdf_pt/integrator.rs"]
#[allow(dead_code)]
mod integrator;
use crate::util;

use glam::{DVec3, Vec2};
use integrator::{BsdfPt, Walker};
use lodestar::film::Image;
use lodestar::integrators::guided::{self, Guided, GuidedSettings, Outliers, Share};
use lodestar::integrators::paths::Vertex;
use lodestar::integrators::unguided::{PathSink, Unguided};
use lodestar::integrators::{IntegratorParams, Options};
use lodestar::math::Sampler;
use lodestar::path::Path;
use lodestar::render::{Budget, Integrator, RenderContext};
use lodestar::scene::Scene;
use std::sync::Once;

static REGISTER: Once = Once::new();

fn register() {
    REGISTER.call_once(|| integrator::register().unwrap());
}

/// The Cornell box at 16 x 16 with a lamp four times the usual area, so that BSDF sampling
/// alone finds it often enough for a small test.
fn scene() -> Scene {
    let text = lodestar::scene::CORNELL_BOX_TOML
        .replace("resolution = [256, 256]", "resolution = [16, 16]");
    util::scene(&text)
}

const SEEDS: u64 = 24;
const SPP: u64 = 24;
const BLOCK: u32 = 8;

fn renders(scene: &Scene, name: &str, options: &[&str], first_seed: u64) -> Vec<Image> {
    (0..SEEDS)
        .map(|s| util::render(scene, name, 5, options, SPP, first_seed + s, 2).image)
        .collect()
}

#[test]
fn registers_once_by_name() {
    register();
    let names: Vec<&str> = lodestar::integrators::entries()
        .iter()
        .map(|e| e.name)
        .collect();
    assert!(names.contains(&"bsdf-pt") && names.contains(&"guided-bsdf-pt"));
    let again = integrator::register().unwrap_err().to_string();
    assert!(
        again.contains("'bsdf-pt'") && again.contains("taken"),
        "{again}"
    );
    // Its options are checked like any integrator's.
    let params = IntegratorParams {
        max_depth: 5,
        options: Options::parse(&["no_such=1".to_string()]).unwrap(),
    };
    let e = lodestar::integrators::build("bsdf-pt", &params)
        .err()
        .unwrap();
    assert!(e.to_string().contains("'no_such' is not a setting"), "{e}");
}

#[test]
fn bsdf_pt_renders_pt_image_tile_by_tile() {
    register();
    let scene = scene();
    let ours = renders(&scene, "bsdf-pt", &[], 0);
    let pt = renders(&scene, "pt", &[], 100);
    util::assert_same_image(&ours, &pt, BLOCK, "bsdf-pt against pt");
}

#[test]
fn guided_bsdf_pt_renders_pt_image_tile_by_tile() {
    register();
    let scene = scene();
    let options = ["share=fixed", "learn_fraction=0.25"];
    let guided: Vec<Image> = (0..SEEDS)
        .map(|s| {
            let r = util::render(&scene, "guided-bsdf-pt", 5, &options, SPP, s, 2);
            let g: f64 = util::stat(&r, "guided_samples").unwrap().parse().unwrap();
            assert!(g > 0.0, "no guided samples");
            r.image
        })
        .collect();
    let pt = renders(&scene, "pt", &[], 100);
    util::assert_same_image(&guided, &pt, BLOCK, "guided-bsdf-pt against pt");
}

/// bsdf-pt with its density doubled wherever it is reported or evaluated: a wrong `p_u` that
/// is self-consistent, so only the image can show it.
struct Doubled(BsdfPt);

struct Doubling<'k>(&'k mut dyn PathSink);

impl PathSink for Doubling<'_> {
    fn record(&mut self, path: &Path, y: Option<&[Vertex]>, f: DVec3, p_u: f64, splat: bool) {
        self.0.record(path, y, f, 2.0 * p_u, splat);
    }
}

impl Unguided for Doubled {
    type Tracer<'s> = Walker<'s>;
    type Pass<'s> = ();
    fn name(&self) -> &'static str {
        "bsdf-pt"
    }
    fn max_depth(&self) -> u32 {
        self.0.max_depth
    }
    fn begin_pass<'s>(&'s self, _: &'s Scene, _: u64, _: u64, _: u64) {}
    fn tracer<'s, 'p: 's>(&'s self, scene: &'s Scene, pass: &'s ()) -> Walker<'s> {
        self.0.tracer(scene, pass)
    }
    fn trace(
        &self,
        w: &mut Walker<'_>,
        scene: &Scene,
        raster: Vec2,
        sampler: &mut impl Sampler,
        sink: &mut dyn PathSink,
    ) {
        self.0.trace(w, scene, raster, sampler, &mut Doubling(sink));
    }
    fn estimate(
        &self,
        w: &mut Walker<'_>,
        scene: &Scene,
        raster: Vec2,
        sampler: &mut impl Sampler,
        splats: &mut Vec<(u32, DVec3)>,
    ) -> DVec3 {
        self.0.estimate(w, scene, raster, sampler, splats)
    }
    fn pdf_unguided(&self, scene: &Scene, pass: &(), y: &[Vertex]) -> f64 {
        2.0 * self.0.pdf_unguided(scene, pass, y)
    }
}

#[test]
fn a_wrong_density_is_caught_by_the_same_test() {
    let scene = scene();
    let settings = GuidedSettings {
        share: Share::Fixed,
        learn_fraction: 0.25,
        ..GuidedSettings::default()
    };
    let wrong: Vec<Image> = (0..SEEDS)
        .map(|s| {
            let mut g = Guided {
                name: "guided-bsdf-pt",
                seeder: Outliers::new(settings.intake),
                unguided: Doubled(BsdfPt::new(5, integrator::RR_DEPTH).unwrap()),
                settings: settings.clone(),
                cache: None,
            };
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(2)
                .build()
                .unwrap();
            let r =
                pool.install(|| g.render(&RenderContext::new(&scene, s, false), Budget::Spp(SPP)));
            r.image
        })
        .collect();
    let pt = renders(&scene, "pt", &[], 100);
    let caught = std::panic::catch_unwind(|| {
        util::assert_same_image(&wrong, &pt, BLOCK, "doubled p_u (control)")
    });
    assert!(caught.is_err(), "a doubled p_u passed the per-tile test");
    // `build_over` is what registered integrators use; it reads the guided options.
    let params = IntegratorParams {
        max_depth: 5,
        options: Options::parse(&["alpha=2".to_string()]).unwrap(),
    };
    let e = guided::build_over("x", &params, 5, |rr| BsdfPt::new(5, rr))
        .err()
        .unwrap();
    assert!(e.to_string().contains("alpha"), "{e}");
}
