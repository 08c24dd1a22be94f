//! `[camera]` and `[render]` tables.

use super::*;
use crate::filter::{Filter, FilterKind};

impl Builder<'_> {
    pub(super) fn camera(&self, c: &Spanned<CameraDesc>) -> Result<Camera> {
        let src = self.src;
        let d = c.get_ref();
        let position = src.finite3(&d.position, "position")?;
        let look_at = src.finite3(&d.look_at, "look_at")?;
        for (p, v, key) in [
            (position, &d.position, "position"),
            (look_at, &d.look_at, "look_at"),
        ] {
            if !in_bounds(p) {
                return src.err(
                    v.span(),
                    format!(
                        "camera '{key}' must lie within +-{MAX_COORDINATE:e} per axis, got {p}"
                    ),
                );
            }
        }
        let up = match &d.up {
            Some(u) => src.finite3(u, "up")?,
            None => Vec3::Y,
        };
        // Unit length whatever its magnitude (zero stays zero and is rejected below).
        let up = unit_vector(up).unwrap_or(Vec3::ZERO);
        let fov = *d.fov.get_ref();
        if !(fov > 0.0 && fov < 180.0) {
            return src.err(
                d.fov.span(),
                format!("'fov' must be in (0, 180) degrees, got {fov}"),
            );
        }
        let [w, h] = *d.resolution.get_ref();
        if w == 0 || h == 0 || w > 16384 || h > 16384 {
            return src.err(
                d.resolution.span(),
                format!("'resolution' must be two integers in [1, 16384] (at most 2^28 pixels), got [{w}, {h}]"),
            );
        }
        let forward = look_at - position;
        // `Camera::new` normalises `look_at - position`: its length must not underflow.
        let Some(forward) = forward.try_normalize() else {
            return src.err(
                d.look_at.span(),
                format!(
                    "'look_at' must differ from 'position' (by more than 1e-18), got {look_at} and {position}"
                ),
            );
        };
        if forward.cross(up).length_squared() < 1e-10 {
            return src.err(
                d.up.as_ref().map_or(c.span(), |u| u.span()),
                "'up' must not be zero or parallel to the viewing direction",
            );
        }
        let filter = match &d.filter {
            Some(f) => self.filter(f)?,
            None => Filter::default(),
        };
        Ok(Camera::new(position, look_at, up, fov, UVec2::new(w, h)).with_filter(filter))
    }

    /// `filter = { type = "box" | "tent" | "gaussian", radius, stddev }`.
    fn filter(&self, f: &Spanned<FilterDesc>) -> Result<Filter> {
        let src = self.src;
        let d = f.get_ref();
        // A parameter in (0, max] pixels: supports up to 8 pixels wide (wider filters only
        // blur, at a cost per splat).
        let param = |v: &Option<Spanned<f32>>, key: &str, default: f32, max: f32| -> Result<f32> {
            let Some(v) = v else { return Ok(default) };
            let x = *v.get_ref();
            if !(x > 0.0 && x <= max) {
                return src.err(
                    v.span(),
                    format!("filter '{key}' must be in (0, {max}] pixels, got {x}"),
                );
            }
            Ok(x)
        };
        let refuse = |v: &Option<Spanned<f32>>, key: &str, kind: &str| -> Result<()> {
            match v {
                Some(v) => src.err(v.span(), format!("filter '{kind}' has no '{key}'")),
                None => Ok(()),
            }
        };
        let kind = d.kind.get_ref().as_str();
        let kind = match kind {
            "box" => {
                refuse(&d.radius, "radius", kind)?;
                refuse(&d.stddev, "stddev", kind)?;
                FilterKind::Box
            }
            "tent" => {
                refuse(&d.stddev, "stddev", kind)?;
                FilterKind::Tent {
                    radius: param(&d.radius, "radius", 1.0, 8.0)?,
                }
            }
            "gaussian" => {
                refuse(&d.radius, "radius", kind)?;
                FilterKind::Gaussian {
                    stddev: param(&d.stddev, "stddev", 0.5, 2.0)?,
                }
            }
            other => {
                return src.err(
                    d.kind.span(),
                    format!("unknown filter type '{other}' (expected box, tent or gaussian)"),
                );
            }
        };
        Ok(Filter::new(kind))
    }

    pub(super) fn render(&self, r: Option<&RenderDesc>) -> Result<RenderDefaults> {
        let mut out = RenderDefaults::default();
        let Some(r) = r else { return Ok(out) };
        if let Some(d) = &r.max_depth {
            match crate::path::parse_max_depth(*d.get_ref()) {
                Ok(v) => out.max_depth = v,
                Err(e) => return self.src.err(d.span(), format!("'max_depth' {e}")),
            }
        }
        if let Some(s) = &r.spp {
            if *s.get_ref() == 0 {
                return self.src.err(s.span(), "'spp' must be at least 1");
            }
            out.spp = *s.get_ref();
        }
        if let Some(i) = &r.integrator {
            let registry = crate::integrators::entries();
            if !registry.iter().any(|e| e.name == i.get_ref()) {
                let names: Vec<&str> = registry.iter().map(|e| e.name).collect();
                return self.src.err(
                    i.span(),
                    format!(
                        "unknown integrator '{}' (available: {})",
                        i.get_ref(),
                        names.join(", ")
                    ),
                );
            }
            out.integrator = i.get_ref().clone();
        }
        Ok(out)
    }
}
