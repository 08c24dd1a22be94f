//! The two connection techniques of bdpt's tracer that join two subpaths by a segment: t = 1
//! (a light vertex seen by the pinhole, splatted) and s, t >= 2 (a camera vertex and a light
//! vertex). Each evaluates both ends once (`connection_end`) and hands the densities across
//! the segment to the weight (`weights.rs`).

use super::*;

impl<'a> Tracer<'a> {
    /// t = 1: connect the last light vertex to the pinhole; returns the raster position and
    /// the value to splat there.
    pub(super) fn connect_camera(
        &mut self,
        c: &[Vertex<'a>],
        cc: &[Cached],
        lp: &[Vertex<'a>],
        lc: &[Cached],
    ) -> Option<(Vec2, Spectrum)> {
        let scene = self.scene;
        let s = lp.len();
        let (cam, y, cy) = (&c[0], &lp[s - 1], &lc[s - 1]);
        if !cy.connectible {
            return None;
        }
        // A directly seen emitter is left to the camera walk (s = 0) in a pixel it fills when
        // nothing but vacuum lies between (`PathTerms`' module doc); with media that is known
        // after the trace.
        let direct_to_camera =
            s == 1 && matches!(y.kind, Kind::Light { light } if self.left_to_camera(light, y.p));
        if direct_to_camera && !scene.features.media {
            return None;
        }
        let cs = scene.camera.sample_wi(y.p)?;
        let to_cam = cs.wi;
        let end = if s == 1 {
            let Kind::Light { light } = y.kind else {
                return None;
            };
            ConnectionEnd {
                f: emission(&scene.lights[light], y.p, y.n, to_cam) * y.abs_cos_to(cam.p),
                pdf_other: 0.0,
                pdf_prev: 0.0,
            }
        } else {
            connection_end(scene, y, cy.wo, to_cam, TransportMode::Importance)
        };
        if end.f == Spectrum::ZERO {
            return None;
        }
        let tr = scene.transmittance(
            &endpoint(y),
            Some(&Endpoint::point(cam.p)),
            to_cam,
            medium_towards(scene, y, to_cam),
        )?;
        if direct_to_camera && tr.first.is_none() {
            return None;
        }
        let cos_cam = scene.camera.forward.dot(-to_cam);
        let contribution = y.beta * end.f * tr.tr * (cs.we * cos_cam / (cs.dist * cs.dist));
        let w = if self.settings.light_tracing {
            1.0
        } else {
            // Traced from the light vertex towards the camera: reverse it to run camera first.
            let conn = Edge::along(&tr).reversed();
            let cam_next = if y.is_infinite_light(scene) {
                cs.pdf_we
            } else {
                cs.pdf_we * measure_factor(y, to_cam, cs.dist * cs.dist)
            };
            let bridge = Bridge {
                cam_next: cam_next * conn.factor(scene, y.is_medium(), true),
                light_back: if s >= 2 {
                    end.pdf_prev * cy.to_prev * y.edge.factor(scene, lp[s - 2].is_medium(), false)
                } else {
                    0.0
                },
                ..Bridge::default()
            };
            let nee_k = if s >= 2 {
                self.light_nee
            } else {
                let Kind::Light { light } = y.kind else {
                    return None;
                };
                nee_density(scene, cam, y, light)
            };
            self.weight_connection(c, cc, lp, lc, &bridge, nee_k)
        };
        Some((cs.raster, contribution * w as f32))
    }

    /// s, t >= 2: connect the last camera vertex with the last light vertex.
    pub(super) fn connect(
        &mut self,
        c: &[Vertex<'a>],
        cc: &[Cached],
        lp: &[Vertex<'a>],
        lc: &[Cached],
    ) -> Spectrum {
        let scene = self.scene;
        let (t, s) = (c.len(), lp.len());
        let (a, b) = (&c[t - 1], &lp[s - 1]);
        let (ca, cb) = (&cc[t - 1], &lc[s - 1]);
        if !ca.connectible || !cb.connectible {
            return Spectrum::ZERO;
        }
        let d = b.p - a.p;
        let d2 = d.length_squared();
        let w = d / d2.sqrt();
        let ea = connection_end(scene, a, ca.wo, w, TransportMode::Radiance);
        if ea.f == Spectrum::ZERO {
            return Spectrum::ZERO;
        }
        let eb = connection_end(scene, b, cb.wo, -w, TransportMode::Importance);
        if eb.f == Spectrum::ZERO {
            return Spectrum::ZERO;
        }
        let Some(tr) = scene.transmittance(
            &endpoint(a),
            Some(&endpoint(b)),
            w,
            medium_towards(scene, a, d),
        ) else {
            return Spectrum::ZERO;
        };
        let contribution = a.beta * ea.f * eb.f * b.beta * tr.tr / d2;
        let conn = Edge::along(&tr);
        let bridge = Bridge {
            cam_next: ea.pdf_other
                * measure_factor(b, w, d2)
                * conn.factor(scene, b.is_medium(), true),
            light_next: eb.pdf_other
                * measure_factor(a, w, d2)
                * conn.factor(scene, a.is_medium(), false),
            cam_back: ea.pdf_prev * ca.to_prev * a.edge.factor(scene, c[t - 2].is_medium(), false),
            light_back: eb.pdf_prev
                * cb.to_prev
                * b.edge.factor(scene, lp[s - 2].is_medium(), false),
        };
        let w = self.weight_connection(c, cc, lp, lc, &bridge, self.light_nee);
        contribution * w as f32
    }
}
