//! Normal and bump maps: the shading normal a tangent-space normal map or a height's slope
//! gives (Mitsuba's `normalmap` and `bumpmap`), what the Mitsuba reader and the TOML loader
//! build from them, and their errors. Every integrator renders them alike in `features.rs`;
//! Mitsuba 3's own renders of its normal- and bump-mapped scenes are compared in
//! docs/results.md.

use glam::{Vec2, Vec3};
use lodestar::geometry::Ray;
use lodestar::scene::Scene;
use lodestar::scene::loader::load_mitsuba_str;
use std::path::PathBuf;

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
    crate::common::write_png(
        "bump",
        "ramp.png",
        (2, 1),
        png::ColorType::Grayscale,
        &[0, 255],
    )
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
