//! The options the integrators declare (`integrators/options.rs`) are the ones they read,
//! and `docs/integrators.md` (generated from the declarations) is current:
//! - every option key an integrator asks for (building it with no options and with each
//!   switch that enables more: `seeder=mcmc`, `guiding=sdtree`, `small_step=gaussian`) is
//!   declared in its registry entry, and every declared option is asked for;
//! - every declared default that is a value (not computed from the scene or absent), passed
//!   explicitly, renders the same image bit for bit and the same settings as leaving it out
//!   (where the option is read only under a switch, with that switch on both sides; the
//!   Markov-chain integrators with a small bootstrap and few chains on both sides);
//! - `docs/integrators.md` equals `lodestar integrators --markdown`.

use crate::util;

use lodestar::integrators::option_docs;
use lodestar::integrators::{self, IntegratorParams, Options};
use lodestar::render::Budget;
use lodestar::scene::Scene;

/// Options that make an integrator read more options.
const SWITCHES: &[&str] = &["seeder=mcmc", "guiding=sdtree", "small_step=gaussian"];

fn params(options: &[String]) -> IntegratorParams {
    IntegratorParams {
        max_depth: 4,
        options: Options::parse(options).unwrap(),
    }
}

/// Image and settings of a 2-pass render, or the build's error.
fn render(
    scene: &Scene,
    name: &str,
    options: &[String],
) -> Result<(Vec<[f32; 3]>, String), String> {
    let p = params(options);
    let r = integrators::render_named(scene, name, &p, Budget::Spp(2), 7, 2, false)
        .map_err(|e| e.to_string())?;
    Ok((
        r.result.image.pixels.iter().map(|p| p.to_array()).collect(),
        r.settings,
    ))
}

#[test]
fn every_option_read_is_declared_and_every_declared_option_is_read() {
    for e in integrators::entries() {
        let declared: Vec<&str> = option_docs::options(&e).iter().map(|s| s.name).collect();
        let mut asked = Vec::new();
        for switch in std::iter::once(None).chain(SWITCHES.iter().map(Some)) {
            let p = params(
                &switch
                    .map(|s| s.to_string())
                    .into_iter()
                    .collect::<Vec<_>>(),
            );
            let _ = (e.build)(&p);
            asked.extend(p.options.asked());
        }
        for key in &asked {
            assert!(
                declared.contains(&key.as_str()),
                "{}: reads option '{key}', which its entry does not declare",
                e.name
            );
        }
        for key in &declared {
            assert!(
                asked.iter().any(|a| a == key),
                "{}: declares option '{key}', which it never reads",
                e.name
            );
        }
    }
}

/// Options given to both renders of every comparison below (except when the option itself is
/// the one checked): the Markov-chain integrators' bootstrap of 100 000 paths is most of an
/// 8 x 8 render's time, and no other default depends on its size.
const CHEAP: &[&str] = &["bootstrap=2000", "chains=64"];

#[test]
fn every_literal_default_is_the_default_used() {
    let scene = util::cornell(8);
    let mut checked = 0;
    for e in &integrators::entries() {
        let declared: Vec<&str> = option_docs::options(e).iter().map(|s| s.name).collect();
        // The cheap options this integrator declares, but not `skip`: each check renders with
        // the others.
        let context = |skip: &str| -> Vec<String> {
            CHEAP
                .iter()
                .filter(|o| {
                    let key = o.split('=').next().unwrap();
                    key != skip && declared.contains(&key)
                })
                .map(|o| o.to_string())
                .collect()
        };
        let with = |skip: &str, more: &[String]| -> Vec<String> {
            let mut options = context(skip);
            options.extend_from_slice(more);
            options
        };
        for spec in option_docs::options(e) {
            let Some(value) = spec.default.literal() else {
                continue;
            };
            let base = render(&scene, e.name, &context(spec.name)).unwrap();
            let given = format!("{}={value}", spec.name);
            let mut verdict = match render(
                &scene,
                e.name,
                &with(spec.name, std::slice::from_ref(&given)),
            ) {
                Ok(r) => Some(r == base),
                // Read only under a switch.
                Err(msg)
                    if ["only a setting", "belongs to"]
                        .iter()
                        .any(|w| msg.contains(w)) =>
                {
                    None
                }
                Err(msg) => panic!("{}: -O {given} (the declared default): {msg}", e.name),
            };
            // Read only under a switch: compare with the switch on both sides.
            for switch in SWITCHES {
                if verdict.is_some() || switch.starts_with(&format!("{}=", spec.name)) {
                    continue;
                }
                let on = with(spec.name, &[switch.to_string()]);
                let both = with(spec.name, &[switch.to_string(), given.clone()]);
                let (Ok(without), Ok(given)) =
                    (render(&scene, e.name, &on), render(&scene, e.name, &both))
                else {
                    continue;
                };
                verdict = Some(given == without);
            }
            let same = verdict
                .unwrap_or_else(|| panic!("{}: -O {given} is accepted under no switch", e.name));
            assert!(
                same,
                "{}: -O {given}, the declared default, changes the render",
                e.name
            );
            checked += 1;
        }
    }
    assert!(checked >= 60, "only {checked} defaults checked");
}

#[test]
fn a_wrong_default_in_a_table_would_be_caught() {
    // The check above, with pt's rr_depth written as 4 instead of 5: the image changes.
    let scene = util::cornell(8);
    let base = render(&scene, "pt", &[]).unwrap();
    let wrong = render(&scene, "pt", &["rr_depth=4".to_string()]).unwrap();
    assert_ne!(base, wrong);
}

#[test]
fn docs_integrators_md_is_current() {
    // The built-in integrators: the suite also registers the example's (example_integrator).
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/docs/integrators.md");
    let written = std::fs::read_to_string(path).unwrap_or_default();
    let generated = option_docs::markdown(integrators::REGISTRY);
    assert!(
        written == generated,
        "docs/integrators.md is out of date: run `lodestar integrators --markdown > docs/integrators.md`"
    );
}
