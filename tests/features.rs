//! Scene features every integrator family must handle alike: rough plastic, smooth plastic
//! (a delta lobe beside a diffuse one), the smooth conductor of complex index, the thin
//! dielectric, the rough diffuse BSDF, textures and normal maps, anisotropic roughness,
//! blended BSDFs, and the tent and Gaussian
//! pixel filters (the environment map's is in `envmap.rs`). Each renders a 16 x 16 Cornell
//! box with the feature by pt, bdpt, vcm, guided-bdpt and mmlt, tile by tile within noise of
//! pt's image (`util::assert_same_image`, family-wise false-failure rate 1e-4; vcm's merging
//! bias at its default radius is below these renders' noise); pt's images mirrored must fail.
//! Every comparison takes 10 renders a side, many short renders rather than a few long ones
//! (more degrees of freedom make Welch's test sharper for the same work): pt at 64 samples
//! per pixel, bdpt and vcm at 16, guided-bdpt at 32 and mmlt at 128 mutations per pixel
//! after a bootstrap of 10,000 samples per path length. The comparisons pixel by pixel
//! through the filters take 5 renders a side of 4 times the samples: the pixels that the
//! filter's tail reaches the light from get rare bright samples in pt (camera rays sent onto
//! the light), and Welch's test needs renders of many samples each for their means to be
//! near normal.

use crate::util;

use lodestar::film::Image;
use lodestar::scene::Scene;
use util::{assert_same_image, differs, seeded_renders};

/// The Cornell box at 16 x 16 with `edit` applied to its text.
fn cornell(edit: impl Fn(String) -> String) -> Scene {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell-box.toml");
    let text = std::fs::read_to_string(path)
        .unwrap()
        .replace("resolution = [256, 256]", "resolution = [16, 16]");
    util::scene(&edit(text))
}

/// Renders a side of the comparisons tile by tile.
const RENDERS: u64 = 10;

/// Renders a side of the comparisons pixel by pixel (see the module docs).
const PIXEL_RENDERS: u64 = 5;

/// [`RENDERS`] renders of `name` at depth 6, seeds from `seed0`.
fn renders(scene: &Scene, name: &str, options: &[&str], spp: u64, seed0: u64) -> Vec<Image> {
    seeded_renders(scene, name, 6, options, spp, RENDERS, seed0)
}

/// [`PIXEL_RENDERS`] renders of `name` at depth 6, seeds from `seed0`.
fn pixel_renders(scene: &Scene, name: &str, spp: u64, seed0: u64) -> Vec<Image> {
    seeded_renders(scene, name, 6, &[], spp, PIXEL_RENDERS, seed0)
}

/// pt's renders of `scene` at 64 samples per pixel, the reference of the comparisons tile by
/// tile and of the controls.
fn pt_renders(scene: &Scene, seed0: u64) -> Vec<Image> {
    renders(scene, "pt", &[], 64, seed0)
}

/// bdpt, vcm, guided-bdpt (with `guided` its options) and mmlt render pt's image of `scene`
/// tile by tile (see the module docs); pt's renders.
fn others_agree(scene: &Scene, what: &str, guided: &[&str]) -> Vec<Image> {
    let pt = pt_renders(scene, 10);
    for (name, options, spp) in [
        ("bdpt", &[][..], 16),
        ("vcm", &[][..], 16),
        ("guided-bdpt", guided, 32),
        ("mmlt", &["bootstrap=10000"][..], 128),
    ] {
        let other = renders(scene, name, options, spp, 20);
        assert_same_image(&pt, &other, 4, &format!("{name} vs pt on {what}"));
    }
    pt
}

/// Every integrator family renders `scene` as pt does (see the module docs); pt's renders,
/// for the caller's controls.
fn every_integrator_agrees(scene: &Scene, what: &str) -> Vec<Image> {
    let pt = others_agree(scene, what, &["learn_fraction=0.25"]);
    let mirrored: Vec<_> = pt.iter().map(util::mirrored).collect();
    assert!(differs(&pt, &mirrored, 4), "{what}: mirrored pt passes");
    pt
}

/// [`every_integrator_agrees`] with guided-bdpt's guiding kept on (its `auto` share turns it
/// off where it does not pay), so that guided paths rebuilt from the cache evaluate their
/// vertices as the walks did (textures looked up, tangents kept); returns pt's renders for
/// the caller's controls.
fn every_integrator_agrees_guiding_on(scene: &Scene, what: &str) -> Vec<Image> {
    others_agree(
        scene,
        what,
        &["learn_fraction=0.25", "share=fixed", "alpha=0.5"],
    )
}

/// The Cornell box with its white walls and boxes in rough plastic (GGX 0.15, eta 1.5), its
/// red and green sides in smooth plastic (eta 1.5: the light and the sphere mirrored in the
/// coating, paths that take the coating's delta lobe at some vertices and the base's diffuse
/// lobe at others), and its glass sphere a smooth gold mirror (a conductor of complex index);
/// two opacity masks: the mirror 60 % opaque, the red wall a checkerboard texture of opaque
/// and 20 % opaque squares with a white wall outside it (paths through a mask take its null
/// lobe, a delta lobe, at some vertices).
#[test]
fn every_integrator_renders_plastic_and_masks_alike() {
    let plastic = |name: &str, albedo: &str| {
        let smooth = name != "white";
        format!(
            "name = \"{name}\"\ntype = \"{}\"\nalbedo = {albedo}\nior = 1.5{}",
            if smooth { "plastic" } else { "roughplastic" },
            if smooth { "" } else { "\nalpha = 0.15" }
        )
    };
    let scene = cornell(|text| {
        let text = text
            .replace(
                "name = \"white\"\ntype = \"diffuse\"\nalbedo = [0.73, 0.73, 0.73]",
                &plastic("white", "[0.73, 0.73, 0.73]"),
            )
            .replace(
                "name = \"red\"\ntype = \"diffuse\"\nalbedo = [0.65, 0.05, 0.05]",
                &plastic("red", "[0.65, 0.05, 0.05]"),
            )
            .replace(
                "name = \"green\"\ntype = \"diffuse\"\nalbedo = [0.12, 0.45, 0.15]",
                &plastic("green", "[0.12, 0.45, 0.15]"),
            );
        let text = text.replace(
            "name = \"glass\"\ntype = \"dielectric\"\nior = 1.5",
            "name = \"glass\"\ntype = \"conductor\"\neta = [0.143, 0.374, 1.442]\nk = [3.983, 2.385, 1.603]\nopacity = 0.6",
        );
        // The red wall is cut into a checkerboard of opaque and 20 % opaque squares, with a
        // white wall behind it that the light through the squares reaches.
        let text = text.replacen(
            "name = \"red\"\ntype = \"plastic\"",
            "name = \"red\"\nopacity_texture = { type = \"checkerboard\", color0 = [1, 1, 1], color1 = [0.2, 0.2, 0.2], scale = [3, 3] }\ntype = \"plastic\"",
            1,
        ) + "\n[[shape]]\nname = \"outside\"\ntype = \"quad\"\norigin = [-1.5, -1, -1]\nedge_u = [0, 2, 0]\nedge_v = [0, 0, 2]\nmaterial = \"white\"\n";
        assert_eq!(text.matches("roughplastic").count(), 1);
        assert_eq!(text.matches("type = \"plastic\"").count(), 2);
        assert!(text.contains("k = [3.983") && text.contains("opacity_texture"));
        text
    });
    assert!(scene.features.specular_surfaces);
    let masks = scene
        .materials
        .iter()
        .filter(|m| matches!(m.bsdf, lodestar::bsdf::Bsdf::Mask(_)));
    assert_eq!(masks.count(), 2);
    every_integrator_agrees(&scene, "rough and smooth plastic, a gold mirror and masks");
}

/// The Cornell box with its glass sphere a thin dielectric shell (a bubble of eta 1.5) and
/// its red and green walls rough diffuse (alpha 0.8 and 0.3).
#[test]
fn every_integrator_renders_a_thin_dielectric_and_rough_diffuse_alike() {
    let scene = cornell(|text| {
        let text = text
            .replace(
                "name = \"glass\"\ntype = \"dielectric\"",
                "name = \"glass\"\ntype = \"thindielectric\"",
            )
            .replace(
                "name = \"red\"\ntype = \"diffuse\"",
                "name = \"red\"\ntype = \"roughdiffuse\"\nalpha = 0.8",
            )
            .replace(
                "name = \"green\"\ntype = \"diffuse\"",
                "name = \"green\"\ntype = \"roughdiffuse\"\nalpha = 0.3",
            );
        assert!(text.contains("thindielectric") && text.matches("roughdiffuse").count() == 2);
        text
    });
    every_integrator_agrees(&scene, "a thin dielectric and rough diffuse walls");
}

/// The Cornell box seen through a tent filter of radius 1.5 pixels and, in a second render, a
/// Gaussian of standard deviation 0.9 (radius 3.6): camera samples drawn from the filter (pt)
/// and splats spread by it (bdpt's and vcm's t = 1, mmlt's t = 1, guided samples; lt, on the
/// box with its glass sphere diffuse, as light tracing cannot see glass) measure the same
/// filtered pixels, the border pixels included (their filters cut at the image's edge and
/// renormalised), and so do pt's and bdpt's camera samples splatted into the pixels around
/// them (`--film splatted`); pixel by pixel (`assert_same_image` with tiles of one pixel).
/// Controls: pt's box-filtered image must differ from its tent-filtered one, and lt's
/// unfiltered splats from pt's filtered image (the filters blur the box's edges by more
/// than the noise).
#[test]
fn every_integrator_renders_through_tent_and_gaussian_filters_alike() {
    let with = |filter: &str, diffuse_sphere: bool| {
        cornell(|text| {
            let mut text = text.replace(
                "resolution = [16, 16]",
                &format!("resolution = [16, 16]\nfilter = {filter}"),
            );
            if diffuse_sphere {
                text = text.replace(
                    "name = \"glass\"\ntype = \"dielectric\"\nior = 1.5",
                    "name = \"glass\"\ntype = \"diffuse\"\nalbedo = [0.5, 0.5, 0.5]",
                );
                assert!(!text.contains("dielectric"));
            }
            assert!(text.contains("filter = {"));
            text
        })
    };
    let tent = with("{ type = \"tent\", radius = 1.5 }", false);
    let pt_tent = every_integrator_agrees(&tent, "a tent filter");
    let pt_box = pt_renders(&cornell(|text| text), 30);
    assert!(
        differs(&pt_box, &pt_tent, 1),
        "the tent filter changes nothing"
    );
    // Control: splats that ignore the filter (lt on the same box without it) must fail.
    let lt_box = pixel_renders(&with("{ type = \"box\" }", true), "lt", 256, 20);
    for (filter, what) in [
        ("{ type = \"tent\", radius = 1.5 }", "a tent filter"),
        ("{ type = \"gaussian\", stddev = 0.9 }", "a Gaussian filter"),
    ] {
        let scene = with(filter, true);
        let pt = pixel_renders(&scene, "pt", 256, 10);
        assert!(differs(&pt, &lt_box, 1), "{what}: unfiltered splats pass");
        for (name, spp) in [("lt", 256), ("bdpt", 64), ("vcm", 64)] {
            let other = pixel_renders(&scene, name, spp, 20);
            assert_same_image(&pt, &other, 1, &format!("{name} vs pt through {what}"));
        }
        // Mitsuba's film: camera samples spread over the pixels their filter covers, each
        // pixel divided by its weight sum (consistent; its bias at these sample counts is far
        // below the noise).
        let mut splatted = with(filter, true);
        splatted.camera.splat_samples = true;
        for (name, spp) in [("pt", 256), ("bdpt", 64)] {
            let other = pixel_renders(&splatted, name, spp, 40);
            assert_same_image(
                &pt,
                &other,
                1,
                &format!("{name}, splatted, vs pt through {what}"),
            );
        }
    }
}

/// A 4 x 2 PNG whose texels differ in every channel, written to a fresh directory; its path.
fn gradient_png(tag: &str) -> std::path::PathBuf {
    let texels: Vec<u8> = (0..8u8)
        .flat_map(|i| [40 + 25 * i, 220 - 20 * i, if i < 4 { 200 } else { 30 }])
        .collect();
    crate::common::write_png(tag, "gradient.png", (4, 2), png::ColorType::Rgb, &texels)
}

/// The Cornell box with a checkerboard floor (4 x 4 squares, diffuse, its normals tilted by a
/// normal map of 10 x 10 squares), its back wall a rough
/// plastic over a bitmap (bilinear, repeated twice across; bumped by the same bitmap's
/// luminance as a height) and its left wall a rough
/// conductor tinted by a checkerboard (`specular_texture`), its roughness another
/// (`alpha_texture`, 0.05 and 0.5): textured reflectances and roughness, looked up
/// at the texture coordinates every integrator carries with its vertices. bdpt, vcm, mmlt and
/// guided-bdpt (guiding kept on, so that its stored guide paths carry them too) render pt's
/// image tile by tile. Controls: the checkerboard at 6 x 6 squares, the floor without its
/// normal map and the back wall without its bump map must change pt's image pixel by pixel (tile means average the squares
/// away).
#[test]
fn every_integrator_renders_textures_alike() {
    let png = gradient_png("textures");
    let with = |checks: u32, normal_map: bool, bump_map: bool| {
        cornell(|text| {
            let text = text
                .replacen(
                    "[[material]]",
                    &format!(
                        "[[material]]\nname = \"checker\"\ntype = \"diffuse\"\nalbedo_texture = \
                         {{ type = \"checkerboard\", color0 = [0.8, 0.8, 0.8], color1 = [0.1, \
                         0.1, 0.5], scale = [{checks}, {checks}] }}\n{}\n[[material]]\nname = \
                         \"picture\"\ntype = \"roughplastic\"\nior = 1.5\nalpha = 0.2\nalbedo_texture = \
                         {{ type = \"bitmap\", filename = \"{}\", scale = [2, 1] }}\n{}\n[[material]]\nname \
                         = \"tinted\"\ntype = \"roughconductor\"\nalpha_texture = {{ type = \
                         \"checkerboard\", color0 = [0.05, 0.05, 0.05], color1 = [0.5, 0.5, \
                         0.5], scale = [4, 4] }}\neta = [0.2, 0.9, \
                         1.1]\nk = [3.9, 2.4, 2.1]\nspecular_texture = {{ type = \"checkerboard\", \
                         color0 = [0.9, 0.3, 0.3], color1 = [0.2, 0.2, 0.9], scale = [3, 3] \
                         }}\n\n[[material]]",
                        if normal_map {
                            "normal_map = { type = \"checkerboard\", color0 = [0.8, 0.5, 0.9], \
                             color1 = [0.4, 0.7, 0.9], scale = [5, 5] }\n"
                        } else {
                            ""
                        },
                        png.display(),
                        if bump_map {
                            format!(
                                "bump_map = {{ type = \"bitmap\", filename = \"{}\", scale = \
                                 [2, 1] }}\nbump_scale = 2\n",
                                png.display()
                            )
                        } else {
                            String::new()
                        }
                    ),
                    1,
                )
                .replacen(
                    "edge_v = [2, 0, 0]\nmaterial = \"white\"",
                    "edge_v = [2, 0, 0]\nmaterial = \"checker\"",
                    1,
                )
                .replacen(
                    "edge_v = [0, 2, 0]\nmaterial = \"white\"",
                    "edge_v = [0, 2, 0]\nmaterial = \"picture\"",
                    1,
                )
                .replacen(
                    "edge_v = [0, 0, 2]\nmaterial = \"red\"",
                    "edge_v = [0, 0, 2]\nmaterial = \"tinted\"",
                    1,
                );
            assert_eq!(text.matches("material = \"checker\"").count(), 1);
            assert_eq!(text.matches("material = \"picture\"").count(), 1);
            assert_eq!(text.matches("material = \"tinted\"").count(), 1);
            text
        })
    };
    let scene = with(2, true, true);
    let pt = every_integrator_agrees_guiding_on(&scene, "textures");
    let other = pt_renders(&with(3, true, true), 30);
    assert!(
        differs(&pt, &other, 1),
        "the checkerboard's scale changes nothing"
    );
    let flat = pt_renders(&with(2, false, true), 40);
    assert!(differs(&pt, &flat, 1), "the normal map changes nothing");
    let flat = pt_renders(&with(2, true, false), 50);
    assert!(differs(&pt, &flat, 1), "the bump map changes nothing");
    std::fs::remove_dir_all(png.parent().unwrap()).ok();
}

/// Anisotropic roughness (`alpha_u`, `alpha_v`) on the Cornell box's floor (GGX conductor)
/// and its sphere (Beckmann dielectric): bdpt, vcm, guided-bdpt (guiding kept on, so that
/// guide paths rebuilt from the cache carry the tangent their vertices were evaluated with)
/// and mmlt render pt's image tile by tile. Control: the two roughnesses swapped must change
/// pt's image.
#[test]
fn every_integrator_renders_anisotropic_roughness_alike() {
    let with = |(u, v): (f32, f32)| {
        cornell(|text| {
            let text = text
                .replacen(
                    "[[material]]",
                    &format!(
                        "[[material]]\nname = \"brushed\"\ntype = \"roughconductor\"\nalpha_u = {u}\n\
                         alpha_v = {v}\neta = [0.2, 0.9, 1.1]\nk = [3.9, 2.4, 2.1]\n\n\
                         [[material]]\nname = \"frosted\"\ntype = \"roughdielectric\"\nior = 1.5\n\
                         distribution = \"beckmann\"\nalpha_u = {v}\nalpha_v = {u}\n\n[[material]]"
                    ),
                    1,
                )
                .replacen(
                    "edge_v = [2, 0, 0]\nmaterial = \"white\"",
                    "edge_v = [2, 0, 0]\nmaterial = \"brushed\"",
                    1,
                )
                .replacen("material = \"glass\"", "material = \"frosted\"", 1);
            assert_eq!(text.matches("material = \"brushed\"").count(), 1);
            assert_eq!(text.matches("material = \"frosted\"").count(), 1);
            text
        })
    };
    let scene = with((0.05, 0.5));
    let pt = every_integrator_agrees_guiding_on(&scene, "anisotropic roughness");
    let swapped = pt_renders(&with((0.5, 0.05)), 30);
    assert!(
        differs(&pt, &swapped, 1),
        "swapping alpha_u and alpha_v changes nothing"
    );
}

/// A blend (`type = "blend"`) of a diffuse and a rough conductor on the Cornell box's back
/// wall, its weight a checkerboard: bdpt, vcm, guided-bdpt (guiding kept on) and mmlt render
/// pt's image tile by tile. Control: the weight's two colours swapped must change pt's image.
#[test]
fn every_integrator_renders_blends_alike() {
    let with = |(c0, c1): (f32, f32)| {
        cornell(|text| {
            let text = text
                .replacen(
                    "[[material]]",
                    &format!(
                        "[[material]]\nname = \"matte\"\ntype = \"diffuse\"\nalbedo = [0.2, 0.5, 0.8]\n\n\
                         [[material]]\nname = \"metal\"\ntype = \"roughconductor\"\nalpha = 0.15\n\
                         eta = [0.2, 0.9, 1.1]\nk = [3.9, 2.4, 2.1]\n\n[[material]]\nname = \"mix\"\n\
                         type = \"blend\"\nfirst = \"matte\"\nsecond = \"metal\"\nweight_texture = \
                         {{ type = \"checkerboard\", color0 = [{c0}, {c0}, {c0}], color1 = [{c1}, {c1}, \
                         {c1}], scale = [3, 3] }}\n\n[[material]]"
                    ),
                    1,
                )
                .replacen(
                    "edge_v = [0, 2, 0]\nmaterial = \"white\"",
                    "edge_v = [0, 2, 0]\nmaterial = \"mix\"",
                    1,
                );
            assert_eq!(text.matches("material = \"mix\"").count(), 1);
            text
        })
    };
    let scene = with((0.1, 0.9));
    let pt = every_integrator_agrees_guiding_on(&scene, "a blend");
    let swapped = pt_renders(&with((0.9, 0.1)), 30);
    assert!(
        differs(&pt, &swapped, 1),
        "swapping the weight's colours changes nothing"
    );
}

/// A path vertex on an anisotropic surface keeps the shading frame it was evaluated in: laid
/// out as a stored path (`paths::path_vertex`) and rebuilt (`paths::from_path`, what the
/// guided estimators evaluate stored paths with), its frame is the walk's, bit for bit, and
/// not the frame around the normal alone.
#[test]
fn stored_paths_keep_the_frame_of_anisotropic_surfaces() {
    use lodestar::integrators::{bdpt, paths};
    let scene = util::scene(
        &std::fs::read_to_string(
            std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell-box.toml"),
        )
        .unwrap()
        .replace("resolution = [256, 256]", "resolution = [16, 16]")
        .replacen(
            "[[material]]",
            "[[material]]\nname = \"brushed\"\ntype = \"roughconductor\"\nalpha_u = 0.05\n\
             alpha_v = 0.5\nreflectance = [0.9, 0.9, 0.9]\n\n[[material]]",
            1,
        )
        .replacen("material = \"glass\"", "material = \"brushed\"", 1),
    );
    let mut sampler = lodestar::math::IndependentSampler::new(7, 0, 0);
    let mut walk = Vec::new();
    let mut checked = 0;
    for i in 0..256u32 {
        let raster = glam::Vec2::new((i % 16) as f32 + 0.5, (i / 16) as f32 + 0.5);
        bdpt::camera_subpath(&scene, raster, 2, 1, &mut sampler, &mut walk);
        let Some(v) = walk.get(1) else { continue };
        let paths::Kind::Surface { bsdf, frame, .. } = v.kind else {
            continue;
        };
        if !bsdf.is_anisotropic() {
            continue;
        }
        let mut path = lodestar::path::Path::default();
        path.push(paths::path_vertex(&walk[0]));
        path.push(paths::path_vertex(v));
        path.push(lodestar::path::Vertex {
            kind: lodestar::path::VertexKind::Emitter {
                light: 0,
                delta: false,
            },
            p: glam::Vec3::new(0.0, 0.99, 0.0),
            n: glam::Vec3::NEG_Y,
            ..lodestar::path::Vertex::EMPTY
        });
        let rebuilt = paths::from_path(&scene, &path).unwrap();
        let paths::Kind::Surface { frame: again, .. } = rebuilt[1].kind else {
            panic!("vertex 1 rebuilt off its surface");
        };
        let (a, b) = (frame.frame, again.frame);
        assert!(
            a.s == b.s && a.t == b.t && a.n == b.n,
            "pixel {i}: walked in {a:?}, rebuilt in {b:?}"
        );
        assert_ne!(
            a.s,
            lodestar::math::Frame::from_z(a.n).s,
            "pixel {i}: no tangent"
        );
        checked += 1;
    }
    assert!(checked > 10, "only {checked} walks reached the sphere");
}

/// An emitting quad that just covers the image (a 90-degree view of a 2.02-wide quad at
/// distance 1), black beyond it. As in Mitsuba, a pixel's filter is cut at the image's edge
/// and renormalised, so every pixel, the border ones included, is the quad's radiance: pt's
/// camera rays all hit the quad (exactly 3 in every pixel, through a tent of radius 1.5 and a
/// Gaussian of 0.9: a filter reaching past the edge uncut would make the border pixels about
/// a quarter darker), and lt's splats measure the same pixel by pixel.
#[test]
fn border_pixels_renormalise_their_filter_to_the_image() {
    for filter in [
        "{ type = \"tent\", radius = 1.5 }",
        "{ type = \"gaussian\", stddev = 0.9 }",
    ] {
        let scene = util::scene(&format!(
            r#"
[camera]
position = [0, 0, 1]
look_at = [0, 0, 0]
up = [0, 1, 0]
fov = 90
resolution = [12, 12]
filter = {filter}

[[material]]
name = "black"
type = "black"

[[shape]]
type = "quad"
origin = [-1.01, -1.01, 0]
edge_u = [2.02, 0, 0]
edge_v = [0, 2.02, 0]
material = "black"
emission = [3, 3, 3]
"#
        ));
        let pt = seeded_renders(&scene, "pt", 4, &[], 16, 5, 10);
        for img in &pt {
            for (i, p) in img.pixels.iter().enumerate() {
                assert!(
                    (*p - glam::Vec3::splat(3.0)).abs().max_element() < 1e-4,
                    "{filter}: pixel {i} is {p}"
                );
            }
        }
        let lt = seeded_renders(&scene, "lt", 4, &[], 256, 5, 20);
        assert_same_image(
            &pt,
            &lt,
            1,
            &format!("lt vs pt through {filter} at the border"),
        );
    }
}
