//! An image depends on the seed only: bit-identical for 1 and 2 threads, and for repeated
//! runs; different for another seed.

use crate::util;

#[test]
fn bit_identical_across_thread_counts() {
    let scene = util::cornell(40);
    let one = util::render(&scene, "pt", 8, &[], 8, 42, 1).image;
    let two = util::render(&scene, "pt", 8, &[], 8, 42, 2).image;
    let three = util::render(&scene, "pt", 8, &[], 8, 42, 3).image;
    assert!(
        one.pixels
            .iter()
            .zip(&two.pixels)
            .all(|(a, b)| a.to_array().map(f32::to_bits) == b.to_array().map(f32::to_bits))
    );
    assert_eq!(one, three);
    let other_seed = util::render(&scene, "pt", 8, &[], 8, 43, 2).image;
    assert_ne!(one, other_seed);
}

/// Integrators that splat (bdpt's t = 1, lt) merge splats in row order: still bit-identical.
#[test]
fn splatting_integrators_are_bit_identical_across_thread_counts() {
    let scene = util::cornell(24);
    for name in ["bdpt", "lt"] {
        let one = util::render(&scene, name, 6, &[], 4, 9, 1).image;
        let two = util::render(&scene, name, 6, &[], 4, 9, 2).image;
        assert_eq!(one, two, "{name}");
        assert!(one.mean().x > 0.0);
    }
}

/// Every integrator, in a scene with a medium, with learning inside the render for the guided
/// ones and the firefly cascade (`--dbor`) on: bit-identical images (and DBOR images) for 1, 2
/// and 3 threads.
#[test]
fn every_integrator_in_fog_with_dbor_is_bit_identical_for_1_2_3_threads() {
    use lodestar::integrators::{self, IntegratorParams, Options, RunSettings};
    use lodestar::render::Budget;
    let text = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/scenes/cornell-fog.toml"
    ))
    .unwrap()
    .replace("resolution = [256, 256]", "resolution = [12, 12]");
    let scene = util::scene(&text);
    for (name, options, spp) in [
        ("pt", vec![], 4),
        ("lt", vec![], 4),
        ("bdpt", vec![], 4),
        ("vcm", vec![], 4),
        ("bpm", vec![], 4),
        ("guided-pt", vec!["learn_fraction=0.5"], 8),
        ("guided-bdpt", vec!["learn_fraction=0.5"], 8),
        ("guided-pt", vec!["learn_fraction=0.5", "seeder=mcmc"], 8),
        ("pssmlt", vec!["bootstrap=2000", "chains=8"], 2),
        ("mmlt", vec!["bootstrap=2000", "chains=8"], 2),
    ] {
        let run = |threads: usize| {
            let options: Vec<String> = options.iter().map(|s| s.to_string()).collect();
            let params = IntegratorParams {
                max_depth: 5,
                options: Options::parse(&options).unwrap(),
            };
            let run = RunSettings {
                seed: 5,
                threads,
                progress: false,
                snapshots: None,
                dbor: !name.ends_with("mlt"),
                first_pass: 0,
                control: None,
                clock: None,
            };
            integrators::render_named_with(&scene, name, &params, Budget::Spp(spp), &run)
                .unwrap()
                .result
        };
        let one = run(1);
        assert!(one.image.mean().max_element() > 0.0, "{name}: black");
        for threads in [2, 3] {
            let other = run(threads);
            assert_eq!(
                one.image, other.image,
                "{name} {options:?}: 1 vs {threads} threads"
            );
            assert_eq!(
                one.dbor, other.dbor,
                "{name}: DBOR image, 1 vs {threads} threads"
            );
        }
    }
}

/// Bit for bit: the same f32 bits in every channel of every pixel (`==` takes -0 for 0).
fn same_bits(a: &lodestar::film::Image, b: &lodestar::film::Image) -> bool {
    let bits = |i: &lodestar::film::Image| -> Vec<[u32; 3]> {
        i.pixels
            .iter()
            .map(|p| p.to_array().map(f32::to_bits))
            .collect()
    };
    (a.width, a.height) == (b.width, b.height) && bits(a) == bits(b)
}

/// guided-vcm, guided-bdpt with the chain seeder and pt with SD-tree guiding, learning inside
/// the render, on the caustic scene at 16 x 16 and 16 samples per pixel (where guided-vcm and
/// guided-bdpt learn guide paths; in the fog scene above at this size they learn none), with
/// the guided share fixed so that the render passes draw guided samples: the same image bit
/// for bit on 1 and 2 threads. Each run must have done the work that could depend on the
/// thread count (a statistic above 0: guided samples, chain steps, learning passes), or it
/// proves nothing.
#[test]
fn guided_vcm_chain_seeded_bdpt_and_sdtree_pt_are_bit_identical_for_1_and_2_threads() {
    let scene = util::scene(
        &util::guided::CAUSTIC.replace("resolution = [48, 48]", "resolution = [16, 16]"),
    );
    for (name, options, worked) in [
        (
            "guided-vcm",
            &["learn_fraction=0.5", "share=fixed"][..],
            "guided_samples",
        ),
        (
            "guided-bdpt",
            &["learn_fraction=0.5", "seeder=mcmc", "share=fixed"][..],
            "seeder_chain_steps",
        ),
        (
            "pt",
            &["guiding=sdtree", "learn_fraction=0.5"][..],
            "learning_passes",
        ),
    ] {
        let one = util::render(&scene, name, 6, options, 16, 5, 1);
        let n: f64 = util::stat(&one, worked).map_or(0.0, |v| v.parse().unwrap());
        assert!(n > 0.0, "{name} {options:?}: {worked} = {n}");
        assert!(one.image.mean().max_element() > 0.0, "{name}: black");
        let two = util::render(&scene, name, 6, options, 16, 5, 2);
        assert!(
            same_bits(&one.image, &two.image),
            "{name} {options:?}: 1 and 2 threads differ"
        );
    }
}
