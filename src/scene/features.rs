//! What a scene contains, so integrators can skip work it does not need.

use std::fmt;

/// Which kinds of content a scene has (media, delta lights, specular surfaces, an
/// environment, emissive shapes, normal maps).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct SceneFeatures {
    /// Participating media (a world medium or a shape's interior or exterior).
    pub media: bool,
    /// Point (or other delta) lights.
    pub delta_lights: bool,
    /// Surfaces with a delta lobe (mirrors, glass, smooth plastic).
    pub specular_surfaces: bool,
    /// A constant environment light.
    pub environment: bool,
    /// Emissive shapes (area lights).
    pub emissive_geometry: bool,
    /// Materials with a normal map (`Material::normal_map`).
    pub normal_maps: bool,
}

impl fmt::Display for SceneFeatures {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let names = [
            (self.media, "media"),
            (self.delta_lights, "delta-lights"),
            (self.specular_surfaces, "specular-surfaces"),
            (self.environment, "environment"),
            (self.emissive_geometry, "emissive-geometry"),
            (self.normal_maps, "normal-maps"),
        ];
        let on: Vec<&str> = names.iter().filter(|(b, _)| *b).map(|(_, n)| *n).collect();
        if on.is_empty() {
            f.write_str("none")
        } else {
            f.write_str(&on.join(", "))
        }
    }
}
