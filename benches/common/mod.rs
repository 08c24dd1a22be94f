//! Shared by the iteration benchmarks: the scene SmallVCM's BPT and VCM are timed on.

use lodestar::scene::{CORNELL_BOX_TOML, Scene, loader};

/// The Cornell box at 512 x 512 with the tall box a mirror (reflectance 0.95) and the glass
/// sphere, lit by its area light.
pub fn cornell_mirror_512() -> Scene {
    let text = CORNELL_BOX_TOML
        .replace("resolution = [256, 256]", "resolution = [512, 512]")
        .replace(
            "name = \"black\"\ntype = \"black\"",
            "name = \"black\"\ntype = \"black\"\n\n[[material]]\nname = \"mirror\"\ntype = \"conductor\"\nreflectance = [0.95, 0.95, 0.95]",
        )
        .replace(
            "type = \"cube\"\nmaterial = \"white\"",
            "type = \"cube\"\nmaterial = \"mirror\"",
        );
    let scene = loader::load_str(&text, "cornell-mirror-512", None).unwrap();
    assert!(scene.features.specular_surfaces);
    scene
}
