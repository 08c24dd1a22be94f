//! `pdf_unguided` of pt and bdpt (DESIGN.md §3) against the densities the samplers used.
//!
//! * pt hands out every path it forms with the density it sampled it with; that density must
//!   equal the path's term for the same technique in `pdf_unguided` (recomputed from the
//!   `Path` alone), in a diffuse, a glass and a fog scene.
//! * bdpt: every technique's path, converted to a `Path` and back, gives the same technique
//!   densities as the technique assembled while rendering.

use crate::util;

use glam::Vec2;
use lodestar::integrators::bdpt::{BdptSettings, Tracer};
use lodestar::integrators::paths::{self, Heuristic, PathTerms};
use lodestar::integrators::pt::{PathRecorder, PathTracer, PtSettings};
use lodestar::math::{IndependentSampler, Sampler};
use lodestar::path::{MAX_VERTICES, Path};
use lodestar::scene::Scene;
use std::cell::RefCell;
use std::rc::Rc;

fn scene(name: &str, edit: impl Fn(String) -> String) -> Scene {
    let text =
        std::fs::read_to_string(format!("{}/scenes/{name}", env!("CARGO_MANIFEST_DIR"))).unwrap();
    util::scene(&edit(
        text.replace("resolution = [256, 256]", "resolution = [20, 20]"),
    ))
}

fn scenes() -> Vec<(&'static str, Scene)> {
    vec![
        (
            "diffuse box",
            scene("cornell-box.toml", |t| {
                t.replace("material = \"glass\"", "material = \"white\"")
            }),
        ),
        ("glass box", scene("cornell-box.toml", |t| t)),
        ("fog box", scene("cornell-fog.toml", |t| t)),
    ]
}

struct Collect<'a> {
    scene: &'a Scene,
    pt: &'a PathTracer,
    checked: usize,
    /// Paths whose two densities differ by more than 1e-3 (relative).
    loose: usize,
    /// Paths whose pdf_unguided differs from the sampler's two densities' sum by more than
    /// 1e-3 (relative).
    loose_total: usize,
    worst: f64,
    failures: Vec<String>,
}

impl PathRecorder for Collect<'_> {
    fn record(&mut self, path: &Path, _f: glam::DVec3, technique: usize, density: f64, other: f64) {
        let s = &self.pt.settings;
        let (p, k) = paths::technique_densities_of(self.scene, path, s.max_depth, s.rr_depth)
            .expect("a complete path within max_depth");
        let rel = (p[technique] - density).abs() / density.max(1e-300);
        self.checked += 1;
        self.worst = self.worst.max(rel);
        // The sampler's density uses the sampled direction, the recomputation the direction
        // between the stored vertices, and those differ: each ray leaves its surface from an
        // origin pushed off along the normal by twice the hit's error bound (a few 1e-6 here),
        // which tilts the segment by about offset / length. That is negligible except on short
        // segments leaving or reaching a surface at a grazing angle (in the box's corners:
        // 2 % on a 1.7e-3 segment at cos 0.06), so every path must agree within 1e-3 plus
        // that path's own bound ([`offset_error_bound`]), and at most 1 % of paths may use
        // more than 1e-3. A missing roulette or free-flight factor is off by 5 % or more on
        // most paths, with a bound of about 1e-5.
        let bound = 1e-3 + offset_error_bound(path);
        if rel > 1e-3 {
            self.loose += 1;
        }
        if rel > bound && self.failures.len() < 5 {
            self.failures.push(format!(
                "k {k}, technique {technique}: sampled with {density}, pdf_unguided term {} (allowed relative {bound:.2e})",
                p[technique]
            ));
        }
        // pt's techniques are s = 0 and next-event estimation (s = 1 with t >= 2); s = 1 on a
        // one-segment path would be light tracing, which pt does not do.
        let nee = if k >= 2 { p[1] } else { 0.0 };
        // pt's pdf_unguided against what the sampler reported: the density it drew the path
        // with plus the other technique's (not against its own definition from `p`).
        let total = self.pt.pdf_unguided(self.scene, path);
        let sampled_total = density + other;
        if (total - sampled_total).abs() > 1e-3 * total {
            self.loose_total += 1;
        }
        if (total - sampled_total).abs() > bound * total && self.failures.len() < 5 {
            self.failures.push(format!(
                "k {k}: pdf_unguided {total} vs sampled {density} + other {other}"
            ));
        }
        // The other technique's density, reported by the sampler, is the other term.
        let expected_other = if technique == 0 { nee } else { p[0] };
        let rel_other = (expected_other - other).abs() / total.max(1e-300);
        if rel_other > 1e-3 {
            self.loose += 1;
        }
        if rel_other > bound && self.failures.len() < 5 {
            self.failures.push(format!(
                "k {k}, technique {technique}: other technique reported {other}, pdf_unguided term {expected_other}"
            ));
        }
    }
}

/// A bound on the relative density difference that spawn offsets explain (see `record`): per
/// segment, the surface ends' offsets (at most `2 gamma(8) 4 max|p|` along the normal, from
/// `offset_origin` and the triangle hit's error bound) over the segment's length, times the
/// reciprocal cosines at both ends (the direction's tilt changes each end's cosine by about
/// the tilt over the cosine).
fn offset_error_bound(path: &Path) -> f64 {
    use lodestar::path::Vertex;
    let offset = |x: &Vertex| {
        if x.n == glam::Vec3::ZERO {
            0.0 // the camera, a medium vertex, a point light: no offset
        } else {
            let gamma8 = 8.0 * f32::EPSILON as f64 * 0.5;
            2.0 * gamma8 * 4.0 * x.p.abs().max_element() as f64
        }
    };
    let mut bound = 0.0;
    for w in path.vertices().windows(2) {
        let (a, b) = (&w[0], &w[1]);
        let d = (b.p - a.p).as_dvec3();
        let length = d.length();
        let cos = |x: &Vertex| {
            if x.n == glam::Vec3::ZERO {
                1.0
            } else {
                x.n.as_dvec3().dot(d / length).abs().max(1e-9)
            }
        };
        bound += (offset(a) + offset(b)) / length * (1.0 / cos(a) + 1.0 / cos(b));
    }
    bound
}

#[test]
fn pt_densities_equal_its_pdf_unguided_terms() {
    for (name, scene) in scenes() {
        let pt = PathTracer {
            settings: PtSettings {
                max_depth: 6,
                rr_depth: 3,
                ..PtSettings::default()
            },
        };
        let mut c = Collect {
            scene: &scene,
            pt: &pt,
            checked: 0,
            loose: 0,
            loose_total: 0,
            worst: 0.0,
            failures: Vec::new(),
        };
        for i in 0..400u64 {
            let mut sampler = IndependentSampler::new(9, 0, i);
            let raster = Vec2::new((i % 20) as f32, (i / 20) as f32) + sampler.next_2d();
            pt.li_recorded(&scene, raster, &mut sampler, Some(&mut c));
        }
        assert!(c.checked > 300, "{name}: only {} paths", c.checked);
        assert!(
            c.loose * 100 <= c.checked,
            "{name}: {} of {} paths differ by more than 1e-3 (worst {})",
            c.loose,
            c.checked,
            c.worst
        );
        assert!(
            c.loose_total * 100 <= c.checked,
            "{name}: pdf_unguided differs from the sampled densities by more than 1e-3 on {} of {} paths",
            c.loose_total,
            c.checked
        );
        assert!(
            c.failures.is_empty(),
            "{name}: {} paths, worst relative difference {}:\n{}",
            c.checked,
            c.worst,
            c.failures.join("\n")
        );
    }
}

#[test]
fn bdpt_paths_round_trip_through_path() {
    for (name, scene) in scenes() {
        let settings = BdptSettings {
            max_depth: 6,
            rr_depth: 3,
            heuristic: Heuristic::Balance,
            light_tracing: false,
            techniques: Default::default(),
            direct_splats: false,
        };
        let failures = Rc::new(RefCell::new((0usize, Vec::<String>::new())));
        let sink = failures.clone();
        let sc = &scene;
        let mut tracer = Tracer::new(sc, &settings);
        tracer.inspector = Some(RefCell::new(Box::new(
            move |vertices: &[_], s: usize, terms: &PathTerms| {
                let path = paths::to_path(vertices, glam::Vec3::ONE, 0);
                let mut own = [0.0f64; MAX_VERTICES];
                terms.technique_densities(&mut own);
                let (p, k) = paths::technique_densities_of(sc, &path, 6, 3).expect("complete path");
                let total: f64 = own[..=k].iter().sum();
                let pu = paths::pdf_unguided(sc, &path, 6, 3);
                let mut f = sink.borrow_mut();
                f.0 += 1;
                if ((pu - total).abs() > 1e-4 * total || (p[s] - own[s]).abs() > 1e-4 * own[s])
                    && f.1.len() < 5
                {
                    f.1.push(format!("k {k}, s {s}: assembled {} (sum {total}) vs from Path {} (pdf_unguided {pu})", own[s], p[s]));
                }
            },
        )));
        for i in 0..400u64 {
            let mut sampler = IndependentSampler::new(5, 0, i);
            let raster = Vec2::new((i % 20) as f32, (i / 20) as f32) + sampler.next_2d();
            tracer.sample(raster, &mut sampler);
        }
        drop(tracer);
        let f = failures.borrow();
        assert!(f.0 > 500, "{name}: only {} paths", f.0);
        assert!(
            f.1.is_empty(),
            "{name}: {} paths; mismatches:\n{}",
            f.0,
            f.1.join("\n")
        );
    }
}
