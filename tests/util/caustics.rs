//! Small caustic scenes of the specular-chain tests (`tests/manifold*.rs`): a diffuse floor
//! under glass or water, lit by a sun.

/// A scene of `resolution` (w, h) seen from `position` towards `look_at` with field of view
/// `fov`, a diffuse floor 8 m wide at `floor_y` (front side up), the materials "glass" (ior 1.5)
/// and "water" (ior 1.33), and `rest` (shapes, lights, media) appended.
pub fn floor_scene(
    position: [f32; 3],
    look_at: [f32; 3],
    fov: f32,
    resolution: [u32; 2],
    floor_y: f32,
    rest: &str,
) -> String {
    format!(
        r#"
[camera]
position = {position:?}
look_at = {look_at:?}
up = [0, 1, 0]
fov = {fov}
resolution = {resolution:?}

[[material]]
name = "floor"
type = "diffuse"
albedo = [0.8, 0.8, 0.8]

[[material]]
name = "glass"
type = "dielectric"
ior = 1.5

[[material]]
name = "water"
type = "dielectric"
ior = 1.33

[[shape]]
type = "quad"
origin = [-4, {floor_y}, -4]
edge_u = [0, 0, 8]
edge_v = [8, 0, 0]
material = "floor"
{rest}"#
    )
}

/// A sun in `direction` of `angle` degrees and irradiance 3.
pub fn sun(direction: [f32; 3], angle: f32) -> String {
    format!(
        r#"
[[light]]
type = "sun"
direction = {direction:?}
angle = {angle}
irradiance = [3, 3, 3]
"#
    )
}

/// A glass sphere of `radius` at `center`.
pub fn glass_sphere(center: [f32; 3], radius: f32) -> String {
    format!(
        r#"
[[shape]]
type = "sphere"
center = {center:?}
radius = {radius}
material = "glass"
"#
    )
}
