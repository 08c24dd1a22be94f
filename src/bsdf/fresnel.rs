//! Fresnel equations.

/// Unpolarised Fresnel reflectance of a dielectric interface.
///
/// `cos_i` is the cosine of the incident direction with the normal on the outside (front);
/// negative means the direction is inside. `eta` = index inside / index outside.
/// Returns (F, |cos_t|, eta_rel) with eta_rel = n_transmitted / n_incident; F = 1 on total
/// internal reflection.
pub fn dielectric(cos_i: f32, eta: f32) -> (f32, f32, f32) {
    let (cos_i, eta) = if cos_i < 0.0 {
        (-cos_i, 1.0 / eta)
    } else {
        (cos_i, eta)
    };
    let cos_i = cos_i.min(1.0);
    let sin2_t = (1.0 - cos_i * cos_i) / (eta * eta);
    if sin2_t >= 1.0 {
        return (1.0, 0.0, eta);
    }
    let cos_t = (1.0 - sin2_t).max(0.0).sqrt();
    let rs = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    let rp = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    (0.5 * (rs * rs + rp * rp), cos_t, eta)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn normal_incidence_and_tir() {
        let (f, _, _) = dielectric(1.0, 1.5);
        assert!((f - 0.04).abs() < 1e-6);
        let (f_in, _, eta) = dielectric(-1.0, 1.5);
        assert!((f_in - 0.04).abs() < 1e-6 && (eta - 1.0 / 1.5).abs() < 1e-6);
        // Inside glass at 60 degrees: beyond the critical angle (41.8 deg).
        assert_eq!(dielectric(-0.5, 1.5).0, 1.0);
    }
}
