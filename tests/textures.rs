//! Textures in the scene formats: what the Mitsuba reader and the TOML loader build from each
//! texture property, texture coordinates from OBJ and PLY files (v flipped, as Mitsuba reads
//! them), from the rectangle and the sphere, and the errors for what is outside the subset.
//! The lookups themselves are unit-tested in `src/texture.rs`; every integrator renders
//! textures alike in `features.rs` (normal and bump maps: `normal_maps.rs`); Mitsuba 3's own
//! render of `scenes/mitsuba/textured.xml` is compared in docs/results.md.

use crate::util;

use glam::{Affine2, Vec2, Vec3};
use lodestar::bsdf::{Bsdf, ShadingFrame};
use lodestar::geometry::Ray;
use lodestar::geometry::bvh::ShapeGeometry;
use lodestar::scene::Scene;
use lodestar::scene::loader::{load_file, load_mitsuba_str};
use lodestar::texture::{Texture, Wrap};
use std::path::PathBuf;

fn scene_file() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("scenes/mitsuba/textured.xml")
}

fn albedo_texture(scene: &Scene, shape: usize) -> &Texture {
    let m = scene.shape_info[shape].material as usize;
    match &scene.materials[m].bsdf {
        Bsdf::TexturedDiffuse { albedo } => albedo,
        other => panic!("shape {shape}: {other:?} is not textured"),
    }
}

/// The texture coordinates a ray straight down -z through (x, y) finds on `scene`'s shapes.
fn uv_at(scene: &Scene, x: f32, y: f32) -> Vec2 {
    let ray = Ray::new(Vec3::new(x, y, 10.0), -Vec3::Z);
    let sp = scene.intersect(&ray).expect("a hit");
    sp.frame.uv
}

#[test]
fn the_mitsuba_reader_builds_bitmaps_and_checkerboards_with_their_properties() {
    let scene = load_file(&scene_file()).unwrap();
    // Shapes in file order: rectangle, OBJ quad, sphere, ground.
    let (a, b) = (albedo_texture(&scene, 0), albedo_texture(&scene, 1));
    assert_eq!(a, b, "the referenced texture differs between its users");
    let Texture::Bitmap { bitmap, to_uv } = a else {
        panic!("{a:?}")
    };
    assert_eq!((bitmap.width, bitmap.height), (8, 4));
    assert!(!bitmap.bilinear && bitmap.wrap == Wrap::Repeat);
    assert_eq!(*to_uv, Affine2::IDENTITY);
    // texel (0, 0) of grid.png is sRGB (30, 230, 40).
    let t0 = bitmap.texels[0];
    let srgb = |c: f32| lodestar::texture::srgb_to_linear(c / 255.0);
    assert!(
        (t0 - Vec3::new(srgb(30.0), srgb(230.0), srgb(40.0)))
            .abs()
            .max_element()
            < 1e-6
    );
    let Texture::Checkerboard { color0, to_uv, .. } = albedo_texture(&scene, 2) else {
        panic!()
    };
    assert_eq!(*color0, Vec3::new(0.9, 0.8, 0.2));
    assert_eq!(to_uv.transform_point2(Vec2::ONE), Vec2::new(4.0, 2.0));
    let Texture::Bitmap { bitmap, to_uv } = albedo_texture(&scene, 3) else {
        panic!()
    };
    assert!(bitmap.bilinear && bitmap.wrap == Wrap::Mirror);
    assert_eq!(to_uv.transform_point2(Vec2::ZERO), Vec2::new(0.25, 0.0));
    assert_eq!(to_uv.transform_point2(Vec2::ONE), Vec2::new(1.75, 3.0));
}

/// Texture coordinates as Mitsuba gives them: the rectangle's (0, 0) at its local (-1, -1);
/// the OBJ quad's `vt` flipped in v (its `vt 0 0` corner at v = 1); a mesh without them, its
/// barycentric coordinates.
#[test]
fn texture_coordinates_come_from_the_shapes_as_in_mitsuba() {
    let scene = load_file(&scene_file()).unwrap();
    // The rectangle spans x in [-1.7, -0.1], y in [0.6, 1.4]; the OBJ quad is 1.8 to the right.
    for (x0, what) in [(-0.9, "rectangle"), (0.9, "obj")] {
        let at = |u: f32, v: f32| {
            uv_at(
                &scene,
                x0 + 0.8 * (2.0 * u - 1.0),
                1.0 + 0.4 * (2.0 * v - 1.0),
            )
        };
        let (lo, hi) = (at(0.1, 0.1), at(0.9, 0.8));
        let expect = |u: f32, v: f32| match what {
            "rectangle" => Vec2::new(u, v),
            _ => Vec2::new(u, 1.0 - v),
        };
        assert!(
            (lo - expect(0.1, 0.1)).abs().max_element() < 1e-5,
            "{what}: {lo}"
        );
        assert!(
            (hi - expect(0.9, 0.8)).abs().max_element() < 1e-5,
            "{what}: {hi}"
        );
    }
    let mesh = match &scene.shapes[1] {
        ShapeGeometry::Mesh(m) => m,
        _ => panic!(),
    };
    let bare = lodestar::geometry::TriangleMesh {
        uvs: None,
        ..mesh.clone()
    };
    let b = Vec2::new(0.2, 0.3);
    assert_eq!(bare.tex_coords(0, b), b);
    // The sphere: (phi / 2 pi, theta / pi) about +z, phi from +x.
    let ShapeGeometry::Sphere(s) = &scene.shapes[2] else {
        panic!()
    };
    let uv = s.tex_coords(s.center + s.radius * Vec3::new(0.0, 1.0, 0.0));
    assert!(
        (uv - Vec2::new(0.25, 0.5)).abs().max_element() < 1e-6,
        "{uv}"
    );
    let uv = s.tex_coords(s.center + s.radius * Vec3::new(-1.0, -1.0, 1.0).normalize());
    let theta = (1.0f32 / 3f32.sqrt()).acos();
    assert!(
        (uv - Vec2::new(0.625, theta / std::f32::consts::PI))
            .abs()
            .max_element()
            < 1e-6,
        "{uv}"
    );
}

/// PLY's `u, v` (and `s, t`) are read and flipped in v like OBJ's `vt`.
#[test]
fn ply_texture_coordinates_are_read_and_flipped() {
    let dir = std::env::temp_dir().join(format!("lodestar-ply-uv-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    for (u, v) in [("u", "v"), ("s", "t")] {
        let ply = format!(
            "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n\
             property float z\nproperty float {u}\nproperty float {v}\nelement face 1\n\
             property list uchar int vertex_indices\nend_header\n0 0 0 0 0\n1 0 0 1 0.25\n\
             0 1 0 0.5 1\n3 0 1 2\n"
        );
        std::fs::write(dir.join("t.ply"), ply).unwrap();
        let scene = util::scene(&format!(
            "[camera]\nposition = [0, 0, 5]\nlook_at = [0, 0, 0]\nup = [0, 1, 0]\nfov = 40\n\
             resolution = [4, 4]\n\n[[material]]\nname = \"w\"\ntype = \"diffuse\"\nalbedo = \
             [0.5, 0.5, 0.5]\n\n[[shape]]\ntype = \"ply\"\nfile = \"{}\"\nmaterial = \"w\"\n",
            dir.join("t.ply").display()
        ));
        let ShapeGeometry::Mesh(m) = &scene.shapes[0] else {
            panic!()
        };
        assert_eq!(
            m.uvs.as_deref(),
            Some(
                &[
                    Vec2::new(0.0, 1.0),
                    Vec2::new(1.0, 0.75),
                    Vec2::new(0.5, 0.0)
                ][..]
            ),
            "{u}, {v}"
        );
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// A textured BSDF looks its albedo up at the frame's texture coordinates.
#[test]
fn a_textured_diffuse_bsdf_reads_the_frames_coordinates() {
    let scene = load_file(&scene_file()).unwrap();
    let m = scene.shape_info[2].material as usize;
    let bsdf = &scene.materials[m].bsdf;
    let frame = ShadingFrame::new(Vec3::Z, Vec3::Z);
    let (wo, wi) = (Vec3::new(0.3, 0.0, 0.9).normalize(), Vec3::Z);
    let f = |uv: Vec2| {
        bsdf.eval(
            &frame.with_uv(uv),
            wo,
            wi,
            lodestar::bsdf::TransportMode::Radiance,
        )
    };
    let pi = std::f32::consts::PI;
    // to_uv scales by (4, 2): (0.05, 0.1) maps to (0.2, 0.2), color0; (0.2, 0.1) to (0.8, 0.2).
    assert!(
        (f(Vec2::new(0.05, 0.1)) - Vec3::new(0.9, 0.8, 0.2) / pi)
            .abs()
            .max_element()
            < 1e-6
    );
    assert!(
        (f(Vec2::new(0.2, 0.1)) - Vec3::new(0.1, 0.2, 0.6) / pi)
            .abs()
            .max_element()
            < 1e-6
    );
    assert!((bsdf.continuation() - 0.9).abs() < 1e-6);
}

#[test]
fn texture_errors_name_the_file_line_and_what_was_expected() {
    let xml = |body: &str| {
        let text = format!(
            "<scene version=\"3.0.0\">\n<shape type=\"sphere\">\n<bsdf type=\"{body}\n</bsdf>\n</shape>\n\
             <sensor type=\"perspective\"><float name=\"fov\" value=\"40\"/><film type=\"hdrfilm\"><rfilter type=\"box\"/></film></sensor>\n</scene>"
        );
        match load_mitsuba_str(&text, "t.xml", None, &[]) {
            Ok(_) => panic!("expected an error for {body}"),
            Err(e) => e.to_string(),
        }
    };
    let e = xml("diffuse\">\n<texture type=\"wood\" name=\"reflectance\"/>");
    assert!(
        e.contains("t.xml:4") && e.contains("'wood' is not supported"),
        "{e}"
    );
    let e = xml("diffuse\">\n<texture type=\"bitmap\" name=\"reflectance\"/>");
    assert!(
        e.contains("t.xml:4") && e.contains("needs 'filename'"),
        "{e}"
    );
    let e = xml(
        "diffuse\">\n<texture type=\"bitmap\" name=\"reflectance\">\n<string name=\"filename\" value=\"/no/such.png\"/>\n</texture>",
    );
    assert!(e.contains("t.xml:5") && e.contains("/no/such.png"), "{e}");
    let e = xml("roughplastic\">\n<texture type=\"checkerboard\" name=\"specular_reflectance\"/>");
    assert!(e.contains("t.xml:4") && e.contains("is a texture"), "{e}");
    let e = xml(
        "diffuse\">\n<texture type=\"checkerboard\" name=\"reflectance\">\n<float name=\"colour0\" value=\"1\"/>\n</texture>",
    );
    assert!(e.contains("t.xml:5") && e.contains("colour0"), "{e}");
    let toml = |texture: &str| {
        let text = format!(
            "[camera]\nposition = [0, 0, 5]\nlook_at = [0, 0, 0]\nup = [0, 1, 0]\nfov = 40\n\
             resolution = [4, 4]\n\n[[material]]\nname = \"w\"\ntype = \"diffuse\"\n{texture}\n"
        );
        match lodestar::scene::loader::load_str(&text, "t.toml", None) {
            Ok(_) => panic!("expected an error for {texture}"),
            Err(e) => e.to_string(),
        }
    };
    let e = toml("albedo = [0.5, 0.5, 0.5]\nalbedo_texture = { type = \"checkerboard\" }");
    assert!(
        e.contains("t.toml:12") && e.contains("both 'albedo' and 'albedo_texture'"),
        "{e}"
    );
    let e = toml("albedo_texture = { type = \"checkerboard\", color0 = [2, 2, 2] }");
    assert!(
        e.contains("t.toml:11") && e.contains("must lie in [0, 1]"),
        "{e}"
    );
    let e = toml("albedo_texture = { type = \"bitmap\", filename = \"x.png\", wrap = \"tile\" }");
    assert!(
        e.contains("'tile' is not one of repeat, mirror, clamp"),
        "{e}"
    );
    let e = toml("albedo_texture = { type = \"noise\" }");
    assert!(e.contains("unknown texture type 'noise'"), "{e}");
    // Opacity masks (`bsdf/mask.rs`).
    let e = toml("albedo = [0.5, 0.5, 0.5]\nopacity = 1.5");
    assert!(
        e.contains("t.toml:12") && e.contains("'opacity' must be in [0, 1], got 1.5"),
        "{e}"
    );
    let e = toml(
        "albedo = [0.5, 0.5, 0.5]\nopacity = 0.5\nopacity_texture = { type = \"checkerboard\" }",
    );
    assert!(
        e.contains("t.toml:13") && e.contains("both 'opacity' and 'opacity_texture'"),
        "{e}"
    );
}

/// A textured roughness (Mitsuba's `<texture name="alpha">` on `roughconductor` and
/// `roughdielectric`, TOML's `alpha_texture`) is the texture's luminance at the point: the
/// BSDF's value, density and samples at texture coordinates `uv` are exactly those of the
/// same BSDF with that roughness as a number. Errors name the file, line and what was expected.
#[test]
fn textured_roughness_is_the_roughness_looked_up_at_the_point() {
    use lodestar::bsdf::{Alpha, TransportMode};
    let xml = |kind: &str, alpha: &str| {
        let text = format!(
            "<scene version=\"3.0.0\">\n<sensor type=\"perspective\"><film type=\"hdrfilm\"/></sensor>\n\
             <shape type=\"sphere\">\n<bsdf type=\"{kind}\">\n{alpha}\n</bsdf>\n</shape>\n</scene>"
        );
        load_mitsuba_str(&text, "t.xml", None, &[]).map(|s| s.materials[0].bsdf.clone())
    };
    // Checkerboard alpha: 0.6 where both fractional parts lie on one side of 1/2, else 0.05:
    // Mitsuba's scalar lookup of a checkerboard swaps its colours (`scalar_texture_desc`).
    let checker = "<texture name=\"alpha\" type=\"checkerboard\"><float name=\"color0\" value=\"0.05\"/><float name=\"color1\" value=\"0.6\"/></texture>";
    let number = |a: f32| format!("<float name=\"alpha\" value=\"{a}\"/>");
    let frame = ShadingFrame::new(Vec3::Z, Vec3::Z);
    let wo = Vec3::new(0.4, -0.2, 0.8).normalize();
    let wi = Vec3::new(-0.3, 0.1, 0.9).normalize();
    for kind in ["roughconductor", "roughdielectric"] {
        let textured = xml(kind, checker).unwrap();
        assert!(textured.is_textured(), "{kind}");
        assert!(
            (textured.roughness() - 0.05f32.sqrt()).abs() < 1e-6,
            "the smoothest"
        );
        for (uv, a) in [(Vec2::new(0.1, 0.2), 0.6), (Vec2::new(0.7, 0.2), 0.05)] {
            let plain = xml(kind, &number(a)).unwrap();
            assert!(!plain.is_textured());
            let sf = frame.with_uv(uv);
            let mode = TransportMode::Radiance;
            assert_eq!(
                textured.eval(&sf, wo, wi, mode),
                plain.eval(&sf, wo, wi, mode)
            );
            assert_eq!(
                textured.pdf(&sf, wo, wi, mode),
                plain.pdf(&sf, wo, wi, mode)
            );
            for k in 0..16 {
                let u = Vec2::new((k as f32 + 0.5) / 16.0, 0.37);
                let (s, t) = (
                    textured.sample(&sf, wo, 0.3, u, mode),
                    plain.sample(&sf, wo, 0.3, u, mode),
                );
                assert_eq!(s.map(|s| (s.wi, s.weight)), t.map(|t| (t.wi, t.weight)));
            }
        }
    }
    // TOML's `alpha_texture`.
    let toml = |keys: &str| {
        let text = format!(
            "[camera]\nposition = [0, 0, 5]\nlook_at = [0, 0, 0]\nup = [0, 1, 0]\nfov = 40\n\
             resolution = [4, 4]\n\n[[material]]\nname = \"m\"\ntype = \"roughconductor\"\n\
             reflectance = [0.9, 0.9, 0.9]\n{keys}\n"
        );
        lodestar::scene::loader::load_str(&text, "t.toml", None)
    };
    let scene = toml("alpha_texture = { type = \"checkerboard\", color0 = [0.05, 0.05, 0.05], color1 = [0.6, 0.6, 0.6] }").unwrap();
    match &scene.materials[0].bsdf {
        Bsdf::RoughConductor {
            alpha: Alpha::Texture(t),
            ..
        } => assert_eq!(t.range(), (0.05, 0.6)),
        other => panic!("{other:?}"),
    }
    let err = |r: lodestar::error::Result<Scene>| r.err().unwrap().to_string();
    let e = err(toml(
        "alpha = 0.1\nalpha_texture = { type = \"checkerboard\" }",
    ));
    assert!(
        e.contains("t.toml:13") && e.contains("both 'alpha' and 'alpha_texture'"),
        "{e}"
    );
    let e = err(toml(
        "alpha_texture = { type = \"checkerboard\", color0 = [-1, 0, 0] }",
    ));
    assert!(
        e.contains("t.toml:12") && e.contains("finite roughnesses >= 0"),
        "{e}"
    );
    let e = xml("roughplastic", checker).err().unwrap().to_string();
    assert!(
        e.contains("t.xml:5") && e.contains("a textured 'alpha' is not supported"),
        "{e}"
    );
}
