//! The measurement contribution f(X) of a complete path, evaluated from its vertices in the
//! measure of DESIGN.md §3 (the same f that `pt` records: its estimate times its density).
//!
//! `f = We(ω_0) cos θ_0 · Π_segments [Tr · G_end] · Π_inner [f_s |cos| or σ_s ρ_phase] · Le`,
//! where `G_end` is `|cos| / d²` at the segment's far end (`1 / d²` at medium points, 1 for
//! lights at infinity). Delta lights contribute their incident radiance at `x_{k-1}`
//! (intensity / d², or irradiance for a directional light) in place of `G_end · Le`.
//!
//! The product is formed in f64: in a centimetre-scale scene a long path's `Π 1/d²` and its
//! densities leave f32's range, and an underflow to 0 would silently drop the path.

use super::{Kind, Vertex, area_factor, endpoint, medium_towards};
use crate::bsdf::TransportMode;
use crate::scene::Scene;
use glam::{DVec3, Vec2, Vec3};

/// f(X) of path `y` (camera first, a light last). Segments whose bit is set in
/// `known_visible` were found by tracing and skip the visibility test in scenes without media;
/// all others are tested (and attenuated in media). Zero if a segment is blocked.
pub fn contribution(scene: &Scene, y: &[Vertex], known_visible: u64) -> DVec3 {
    let k = y.len() - 1;
    let Kind::Light { light } = y[k].kind else {
        return DVec3::ZERO;
    };
    let lt = &scene.lights[light];
    let dir_to = |j: usize| -> Vec3 {
        if y[j + 1].is_infinite_light(scene) {
            y[j + 1].n
        } else {
            (y[j + 1].p - y[j].p).normalize()
        }
    };
    let w0 = dir_to(0);
    let mut f = DVec3::splat(scene.camera.we(w0) as f64 * w0.dot(scene.camera.forward) as f64);
    let mut medium = scene.camera_medium;
    for j in 0..k {
        let d = dir_to(j);
        let start = if j == 0 {
            medium
        } else {
            medium_towards(scene, &y[j], d)
        };
        let visible = known_visible & (1 << j.min(63)) != 0;
        if scene.features.media || !visible {
            let end = (!y[j + 1].is_infinite_light(scene)).then(|| endpoint(&y[j + 1]));
            let Some(tr) = scene.transmittance(&endpoint(&y[j]), end.as_ref(), d, start) else {
                return DVec3::ZERO;
            };
            f *= tr.tr.as_dvec3();
            medium = tr.end_medium;
        }
        if j >= 1 {
            let next = if y[j + 1].is_infinite_light(scene) {
                y[j].p + d
            } else {
                y[j + 1].p
            };
            f *= match y[j].kind {
                // The delta lobe the path takes here, the Dirac left out.
                Kind::Surface { bsdf, frame, .. } if y[j].delta => bsdf.delta_value(
                    &frame,
                    (y[j - 1].p - y[j].p).normalize(),
                    (next - y[j].p).normalize(),
                ),
                _ => y[j].f(scene, y[j - 1].p, next, TransportMode::Radiance),
            }
            .as_dvec3();
        }
        if j + 1 == k && lt.is_delta() {
            let Some(ls) = lt.sample_li(y[k - 1].p, Vec2::splat(0.5)) else {
                return DVec3::ZERO;
            };
            return f * ls.li.as_dvec3();
        }
        if !y[j + 1].is_infinite_light(scene) {
            let n = if y[j + 1].is_medium() {
                Vec3::ZERO
            } else {
                y[j + 1].n
            };
            f *= area_factor(y[j].p, y[j + 1].p, n);
        }
        if let Kind::Medium { medium: m } = y[j + 1].kind {
            f *= scene.media[m as usize].sigma_s.as_dvec3();
        }
        if f == DVec3::ZERO {
            return f;
        }
    }
    let le = if lt.is_infinite() {
        lt.le(Vec3::ZERO, Vec3::ZERO, y[k].n)
    } else {
        lt.le(y[k].p, y[k].n, (y[k - 1].p - y[k].p).normalize())
    };
    f * le.as_dvec3()
}
