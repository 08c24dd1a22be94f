//! The option tables in the integrators' module documentation are true, and
//! `docs/integrators.md` (generated from them) is current:
//! - every option key an integrator asks for (building it with no options and with each
//!   switch that enables more: `seeder=mcmc`, `guiding=sdtree`, `small_step=gaussian`) is a row
//!   of its table;
//! - every default the table gives literally (a number or a word in backticks), passed
//!   explicitly, renders the same image bit for bit and the same settings as leaving it out
//!   (where the option is read only under a switch, with that switch on both sides); an option
//!   the integrator does not read at all must be one its row assigns to another integrator;
//! - `docs/integrators.md` equals `lodestar integrators --markdown`.

mod util;

use lodestar::integrators::option_docs::{self, OptionRow};
use lodestar::integrators::{self, Entry, IntegratorParams, Options};
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

fn documented(rows: &[OptionRow], key: &str) -> bool {
    rows.iter().any(|r| r.names().any(|n| n == key))
}

#[test]
fn every_option_read_is_documented() {
    for e in integrators::entries() {
        let rows = option_docs::options(&e);
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
        assert!(
            !asked.is_empty() || rows.is_empty(),
            "{}: asked for nothing",
            e.name
        );
        for key in asked {
            assert!(
                documented(&rows, &key),
                "{}: reads option '{key}', which its table does not document",
                e.name
            );
        }
    }
}

/// Whether `row` names an integrator other than `entry` as the one that reads it.
fn assigned_elsewhere(row: &OptionRow, entry: &Entry, all: &[Entry]) -> bool {
    all.iter().filter(|o| o.name != entry.name).any(|o| {
        let m = &row.meaning;
        m.contains(&format!("`{}`", o.name))
            || m.starts_with(&format!("{} ", o.name))
            || m.starts_with(&format!("{}:", o.name))
            || m.starts_with(&format!("{},", o.name))
    })
}

#[test]
fn every_literal_default_is_the_default_used() {
    let scene = util::cornell(8);
    let all = integrators::entries();
    let mut checked = 0;
    for e in &all {
        let base = render(&scene, e.name, &[]).unwrap();
        for row in option_docs::options(e) {
            let Some(value) = row.literal_default() else {
                continue;
            };
            for key in row.names() {
                // `--max-depth`, not an `-O` option.
                if key == "max_depth" {
                    continue;
                }
                let given = format!("{key}={value}");
                let mut verdict = match render(&scene, e.name, std::slice::from_ref(&given)) {
                    Ok(r) => Some(r == base),
                    // Not read here, or read only under a switch.
                    Err(msg)
                        if ["is not a setting", "only a setting", "belongs to"]
                            .iter()
                            .any(|w| msg.contains(w)) =>
                    {
                        None
                    }
                    Err(msg) => panic!("{}: -O {given} (the documented default): {msg}", e.name),
                };
                // Read only under a switch: compare with the switch on both sides.
                for switch in SWITCHES {
                    if verdict.is_some() || switch.starts_with(&format!("{key}=")) {
                        continue;
                    }
                    let on = [switch.to_string()];
                    let (Ok(without), Ok(with)) = (
                        render(&scene, e.name, &on),
                        render(&scene, e.name, &[switch.to_string(), given.clone()]),
                    ) else {
                        continue;
                    };
                    verdict = Some(with == without);
                }
                match verdict {
                    Some(same) => {
                        assert!(
                            same,
                            "{}: -O {given}, the documented default, changes the render",
                            e.name
                        );
                        checked += 1;
                    }
                    // Or documented for a switch this integrator refuses (guided-vcm takes no
                    // `seeder=mcmc`, so no `chain_*` option).
                    None => assert!(
                        assigned_elsewhere(&row, e, &all)
                            || SWITCHES.iter().any(|sw| {
                                let v = sw.split_once('=').unwrap().1;
                                row.meaning.starts_with(&format!("`{v}`"))
                                    && render(&scene, e.name, &[sw.to_string()]).is_err()
                            }),
                        "{}: its table documents '{key}', which it does not read",
                        e.name
                    ),
                }
            }
        }
    }
    assert!(checked >= 40, "only {checked} defaults checked");
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
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/docs/integrators.md");
    let written = std::fs::read_to_string(path).unwrap_or_default();
    let generated = option_docs::markdown(&integrators::entries());
    assert!(
        written == generated,
        "docs/integrators.md is out of date: run `lodestar integrators --markdown > docs/integrators.md`"
    );
}
