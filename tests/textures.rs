//! Textures in the scene formats: what the Mitsuba reader and the TOML loader build from each
//! texture property, texture coordinates from OBJ and PLY files (v flipped, as Mitsuba reads
//! them), from the rectangle and the sphere, and the errors for what is outside the subset.
//! The lookups themselves are unit-tested in `src/texture.rs`; every integrator renders
//! textures alike in `features.rs`; Mitsuba 3's own render of `scenes/mitsuba/textured.xml`
//! is compared in docs/results.md.

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

/// A normal map's value `c` is the direction `2 c - 1` in the frame of the shading normal and
/// the tangent along u (projected perpendicular to the normal): flat blue keeps the normal, a
/// tilt towards the tangent turns it, and a map leaning behind the geometric normal keeps the
/// surface's own normal.
#[test]
fn normal_maps_turn_the_shading_normal_in_the_tangent_frame() {
    use lodestar::scene::perturbed_normal;
    let close = |a: Vec3, b: Vec3| (a - b).abs().max_element() < 1e-6;
    let (z, x) = (Vec3::Z, Vec3::X);
    assert!(close(
        perturbed_normal(Vec3::new(0.5, 0.5, 1.0), z, z, x),
        z
    ));
    // (1, 0.5, 1) is the local (1, 0, 1): half-way between the tangent and the normal; a
    // tangent with a component along the normal is projected first.
    let tilted = perturbed_normal(Vec3::new(1.0, 0.5, 1.0), z, z, Vec3::new(3.0, 0.0, 2.0));
    assert!(
        close(tilted, Vec3::new(1.0, 0.0, 1.0).normalize()),
        "{tilted}"
    );
    // Towards the bitangent n x s = +y.
    let tilted = perturbed_normal(Vec3::new(0.5, 1.0, 1.0), z, z, x);
    assert!(
        close(tilted, Vec3::new(0.0, 1.0, 1.0).normalize()),
        "{tilted}"
    );
    // Below the surface, or no tangent at all: the normal stays, or any tangent serves.
    assert_eq!(perturbed_normal(Vec3::new(1.0, 0.5, 0.2), z, z, x), z);
    let any = perturbed_normal(Vec3::new(1.0, 0.5, 1.0), z, z, Vec3::ZERO);
    assert!((any.dot(z) - 0.5f32.sqrt()).abs() < 1e-6, "{any}");
}

/// The scenes' normal maps: TOML's `normal_map` and Mitsuba's `normalmap` around a BSDF (with
/// Mitsuba's view-dependent flip and shadowing term off; on, the default, they are refused)
/// put the map on the material, and a hit's shading normal (the frame's and the hit's alike)
/// is the perturbed one, its tangent from the mesh's texture coordinates (Mitsuba's `dp_du`).
#[test]
fn normal_maps_perturb_the_hits_shading_frame() {
    // The rectangle's u runs along +x: a constant map tilted towards the tangent.
    let xml = r#"<scene version="3.0.0">
    <sensor type="perspective"><float name="fov" value="40"/><film type="hdrfilm"><rfilter type="box"/></film></sensor>
    <shape type="rectangle">
        <bsdf type="normalmap">
            <boolean name="flip_invalid_normals" value="false"/><boolean name="use_shadowing_function" value="false"/>
            <texture name="normalmap" type="checkerboard"><rgb name="color0" value="1, 0.5, 1"/><rgb name="color1" value="1, 0.5, 1"/></texture>
            <bsdf type="twosided"><bsdf type="diffuse"/></bsdf>
        </bsdf>
    </shape>
</scene>"#;
    let scene = load_mitsuba_str(xml, "t.xml", None, &[]).unwrap();
    assert!(scene.materials[0].normal_map.is_some() && scene.features.normal_maps);
    assert!(!scene.materials[0].one_sided);
    let sp = scene
        .intersect(&Ray::new(Vec3::new(0.2, 0.3, 10.0), -Vec3::Z))
        .unwrap();
    let want = Vec3::new(1.0, 0.0, 1.0).normalize();
    assert!(
        (sp.hit.ns - want).abs().max_element() < 1e-6,
        "{}",
        sp.hit.ns
    );
    assert!((sp.frame.frame.n - want).abs().max_element() < 1e-6);
    assert_eq!(sp.hit.ng, Vec3::Z);
    // TOML: the same map on a quad; black takes none.
    let toml = |material: &str| {
        let text = format!(
            "[camera]\nposition = [0, 0, 5]\nlook_at = [0, 0, 0]\nup = [0, 1, 0]\nfov = 40\n\
             resolution = [4, 4]\n\n[[material]]\nname = \"w\"\n{material}\n\n[[shape]]\n\
             type = \"quad\"\norigin = [-1, -1, 0]\nedge_u = [2, 0, 0]\nedge_v = [0, 2, 0]\n\
             material = \"w\"\n"
        );
        lodestar::scene::loader::load_str(&text, "t.toml", None)
    };
    let map =
        "normal_map = { type = \"checkerboard\", color0 = [1, 0.5, 1], color1 = [1, 0.5, 1] }";
    let scene = toml(&format!(
        "type = \"diffuse\"\nalbedo = [0.5, 0.5, 0.5]\n{map}"
    ))
    .unwrap();
    let sp = scene
        .intersect(&Ray::new(Vec3::new(0.2, 0.3, 10.0), -Vec3::Z))
        .unwrap();
    assert!(
        (sp.hit.ns - want).abs().max_element() < 1e-6,
        "{}",
        sp.hit.ns
    );
    let e = toml(&format!("type = \"black\"\n{map}"))
        .err()
        .unwrap()
        .to_string();
    assert!(e.contains("t.toml:") && e.contains("normal_map"), "{e}");
    let bad = |inner: &str| {
        let text = format!(
            "<scene version=\"3.0.0\">\n<shape type=\"sphere\">\n<bsdf type=\"normalmap\">\n{inner}\n</bsdf>\n</shape>\n</scene>"
        );
        load_mitsuba_str(&text, "t.xml", None, &[])
            .err()
            .unwrap()
            .to_string()
    };
    let e = bad("<bsdf type=\"diffuse\"/>");
    assert!(
        e.contains("t.xml:3") && e.contains("needs a <texture name=\"normalmap\">"),
        "{e}"
    );
    let plain = "<boolean name=\"flip_invalid_normals\" value=\"false\"/>\n\
                 <boolean name=\"use_shadowing_function\" value=\"false\"/>";
    // Mitsuba's defaults (the flip towards the viewer, the shadowing term) are refused.
    let e = bad("<texture name=\"normalmap\" type=\"checkerboard\"/><bsdf type=\"diffuse\"/>");
    assert!(
        e.contains("t.xml:3") && e.contains("'flip_invalid_normals' true"),
        "{e}"
    );
    let e = bad(&format!(
        "{plain}<texture name=\"normalmap\" type=\"checkerboard\"/>"
    ));
    assert!(
        e.contains("t.xml:3") && e.contains("one nested <bsdf>"),
        "{e}"
    );
}

/// A bump map tilts the normal against the height's slope: the displaced surface's tangents are
/// `dp_du + ns h_u` and `dp_dv + ns h_v`, so a height rising by `a` per unit of u along a
/// tangent of length `l` turns the normal to `(-a / l, 0, 1)` (normalised); a flat height
/// keeps the normal, and degenerate tangents keep it too.
#[test]
fn bump_maps_tilt_the_normal_against_the_heights_slope() {
    use lodestar::scene::bumped_normal;
    let close = |a: Vec3, b: Vec3| (a - b).abs().max_element() < 1e-6;
    let (x, y, z) = (Vec3::X, Vec3::Y, Vec3::Z);
    assert_eq!(bumped_normal(Vec2::ZERO, z, z, [x, y]), z);
    let n = bumped_normal(Vec2::new(0.5, 0.0), z, z, [x, y]);
    assert!(close(n, Vec3::new(-0.5, 0.0, 1.0).normalize()), "{n}");
    // A longer tangent: the same rise per unit of u is a gentler slope.
    let n = bumped_normal(Vec2::new(0.5, 0.0), z, z, [2.0 * x, y]);
    assert!(close(n, Vec3::new(-0.25, 0.0, 1.0).normalize()), "{n}");
    // Along v, with the tangents ordered the other way round (a mirrored parametrisation): the
    // normal still comes out on the geometric normal's side.
    let n = bumped_normal(Vec2::new(0.0, 1.0), z, z, [y, x]);
    assert!(close(n, Vec3::new(-1.0, 0.0, 1.0).normalize()), "{n}");
    assert_eq!(bumped_normal(Vec2::new(1.0, 1.0), z, z, [Vec3::ZERO; 2]), z);
}

/// A 2 x 1 grey PNG, black then white (raw values 0 and 1), in a fresh directory: a height
/// that rises by 2 per unit of u between the two texel centres (u = 1/4 and 3/4).
fn ramp_png() -> PathBuf {
    let dir = std::env::temp_dir().join(format!("lodestar-bump-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("ramp.png");
    let mut enc = png::Encoder::new(std::fs::File::create(&path).unwrap(), 2, 1);
    enc.set_color(png::ColorType::Grayscale);
    enc.set_depth(png::BitDepth::Eight);
    enc.write_header()
        .unwrap()
        .write_image_data(&[0, 255])
        .unwrap();
    path
}

/// The scenes' bump maps: Mitsuba's `bumpmap` (its one texture by whatever name, `scale`)
/// and TOML's `bump_map` with `bump_scale` put the height on the material, and a hit's
/// shading normal is the bumped one. On a 2-wide rectangle with u along +x, the ramp's rise
/// of 2 per unit of u times the scale 0.5 is a slope of 0.5 per unit length: the normal
/// `(-0.5, 0, 1)` normalised. Errors name the file, the line and what was expected.
#[test]
fn bump_maps_turn_the_hits_shading_normal() {
    let png = ramp_png();
    let want = Vec3::new(-0.5, 0.0, 1.0).normalize();
    let hit_normal = |scene: &Scene| {
        scene
            .intersect(&Ray::new(Vec3::new(0.1, 0.3, 10.0), -Vec3::Z))
            .unwrap()
            .hit
            .ns
    };
    let plain = "<boolean name=\"flip_invalid_normals\" value=\"false\"/>\
                 <boolean name=\"use_shadowing_function\" value=\"false\"/>";
    let xml = |inner: &str| {
        format!(
            "<scene version=\"3.0.0\"><sensor type=\"perspective\"><film type=\"hdrfilm\"/></sensor>\n<shape type=\"rectangle\">\n<bsdf type=\"bumpmap\">\n{inner}\n</bsdf>\n</shape>\n</scene>"
        )
    };
    let texture = format!(
        "<texture name=\"height\" type=\"bitmap\"><boolean name=\"raw\" value=\"true\"/><string name=\"filename\" value=\"{}\"/></texture>",
        png.display()
    );
    let scene = load_mitsuba_str(
        &xml(&format!(
            "{plain}<float name=\"scale\" value=\"0.5\"/>{texture}<bsdf type=\"diffuse\"/>"
        )),
        "t.xml",
        None,
        &[],
    )
    .unwrap();
    assert!(scene.features.normal_maps);
    let n = hit_normal(&scene);
    assert!((n - want).abs().max_element() < 1e-5, "{n}");
    // TOML: the same height on a quad.
    let toml = |keys: &str| {
        let text = format!(
            "[camera]\nposition = [0, 0, 5]\nlook_at = [0, 0, 0]\nup = [0, 1, 0]\nfov = 40\n\
             resolution = [4, 4]\n\n[[material]]\nname = \"w\"\ntype = \"diffuse\"\n\
             albedo = [0.5, 0.5, 0.5]\n{keys}\n\n[[shape]]\ntype = \"quad\"\n\
             origin = [-1, -1, 0]\nedge_u = [2, 0, 0]\nedge_v = [0, 2, 0]\nmaterial = \"w\"\n"
        );
        lodestar::scene::loader::load_str(&text, "t.toml", None)
    };
    let bump = format!(
        "bump_map = {{ type = \"bitmap\", filename = \"{}\", raw = true }}",
        png.display()
    );
    let n = hit_normal(&toml(&format!("{bump}\nbump_scale = 0.5")).unwrap());
    assert!((n - want).abs().max_element() < 1e-5, "{n}");
    let err = |r: lodestar::error::Result<Scene>| r.err().unwrap().to_string();
    let e = err(toml("bump_scale = 0.5"));
    assert!(
        e.contains("t.toml:") && e.contains("'bump_scale' needs a 'bump_map'"),
        "{e}"
    );
    let e = err(toml(&format!(
        "{bump}\nnormal_map = {{ type = \"checkerboard\" }}"
    )));
    assert!(
        e.contains("t.toml:") && e.contains("both 'normal_map' and 'bump_map'"),
        "{e}"
    );
    let bad = |inner: &str| err(load_mitsuba_str(&xml(inner), "t.xml", None, &[]));
    let e = bad(&format!("{plain}<bsdf type=\"diffuse\"/>"));
    assert!(
        e.contains("t.xml:3") && e.contains("bumpmap needs one nested <texture>"),
        "{e}"
    );
    // Mitsuba's defaults (the flip towards the viewer, the shadowing term) are refused.
    let e = bad(&format!("{texture}<bsdf type=\"diffuse\"/>"));
    assert!(
        e.contains("t.xml:3") && e.contains("'flip_invalid_normals' true"),
        "{e}"
    );
    let e = bad(&format!(
        "{plain}{texture}<bsdf type=\"normalmap\">{plain}<texture name=\"normalmap\" type=\"checkerboard\"/><bsdf type=\"diffuse\"/></bsdf>"
    ));
    assert!(
        e.contains("t.xml:") && e.contains("cannot wrap another normalmap or bumpmap"),
        "{e}"
    );
    std::fs::remove_dir_all(png.parent().unwrap()).ok();
}
