//! Bad scene files, one test per class of error: each must be an error (never a panic) whose
//! message is one line of the form `FILE:LINE: ...` and names the offending key or value.
//!
//! Most cases edit one line of a small valid scene (`BASE`) and mark the line the error must
//! point at with the comment `# <-`; the expected line number is computed from that marker.

use glam::Vec3;
use lodestar::geometry::Ray;
use lodestar::geometry::bvh::ShapeGeometry;
use lodestar::scene::Scene;
use lodestar::scene::loader::{load_file, load_str};
use std::path::{Path, PathBuf};

/// A valid scene; every test breaks exactly one thing in it.
const BASE: &str = r#"# A valid scene.
[camera]
position = [0, 0, 3.9]
look_at = [0, 0, 0]
up = [0, 1, 0]
fov = 40
resolution = [16, 16]

[render]
max_depth = 4

[[material]]
name = "white"
type = "diffuse"
albedo = [0.7, 0.7, 0.7]

[[shape]]
name = "floor"
type = "quad"
origin = [-1, -1, -1]
material = "white"

[[light]]
type = "point"
position = [0, 0.9, 0]
intensity = [1, 1, 1]
"#;

const MARK: &str = "# <-";

/// `BASE` with the one line `from` replaced by `to`.
fn edit(from: &str, to: &str) -> String {
    let lines: Vec<&str> = BASE.lines().filter(|l| *l == from).collect();
    assert_eq!(lines.len(), 1, "BASE must contain the line {from:?} once");
    BASE.replacen(from, to, 1)
}

/// `BASE` followed by more TOML.
fn with(extra: &str) -> String {
    format!("{BASE}{extra}")
}

/// The 1-based number of the only line of `text` that contains `marker`.
fn line_of(text: &str, marker: &str) -> usize {
    let hits: Vec<usize> = text
        .lines()
        .enumerate()
        .filter(|(_, l)| l.contains(marker))
        .map(|(i, _)| i + 1)
        .collect();
    assert_eq!(
        hits.len(),
        1,
        "{marker:?} must occur on one line of:\n{text}"
    );
    hits[0]
}

fn data(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data")
        .join(name)
}

fn load_err(text: &str) -> String {
    match load_str(text, "bad.toml", None) {
        Ok(_) => panic!("expected an error for:\n{text}"),
        Err(e) => e.to_string(),
    }
}

/// The message is `bad.toml:LINE: ...` with LINE the marked line, on one line, containing
/// every fact.
fn check(text: &str, facts: &[&str]) -> String {
    check_named(load_err(text), "bad.toml", line_of(text, MARK), facts)
}

fn check_named(msg: String, file: &str, line: usize, facts: &[&str]) -> String {
    let prefix = format!("{file}:{line}: ");
    assert!(
        msg.starts_with(&prefix),
        "message should start with {prefix:?}: {msg}"
    );
    assert!(!msg.contains('\n'), "message should be one line: {msg:?}");
    for fact in facts {
        assert!(msg.contains(fact), "message should contain {fact:?}: {msg}");
    }
    msg
}

#[test]
fn base_scene_is_valid() {
    let s = load_str(BASE, "base.toml", None).unwrap();
    assert_eq!(s.shapes.len(), 1);
    assert_eq!(s.lights.len(), 1);
}

// ---- Unknown keys ----

#[test]
fn unknown_top_level_key() {
    let text = format!("bogus = 1 {MARK}\n{BASE}");
    check(&text, &["unknown field `bogus`", "camera"]);
}

#[test]
fn unknown_key_in_camera() {
    let text = edit("fov = 40", &format!("fov = 40\nzoom = 2 {MARK}"));
    check(&text, &["unknown field `zoom`", "fov"]);
}

#[test]
fn unknown_key_in_render() {
    let text = edit(
        "max_depth = 4",
        &format!("max_depth = 4\nsamples = 2 {MARK}"),
    );
    check(&text, &["unknown field `samples`", "spp"]);
}

#[test]
fn unknown_key_in_material() {
    let text = edit(
        "albedo = [0.7, 0.7, 0.7]",
        &format!("albedo = [0.7, 0.7, 0.7]\nshininess = 3 {MARK}"),
    );
    check(&text, &["unknown field `shininess`", "albedo"]);
}

#[test]
fn unknown_key_in_shape() {
    let text = edit(
        r#"material = "white""#,
        &format!("material = \"white\"\ncolour = [1, 0, 0] {MARK}"),
    );
    check(&text, &["unknown field `colour`", "material"]);
}

#[test]
fn unknown_key_in_light() {
    let text = edit(
        "intensity = [1, 1, 1]",
        &format!("intensity = [1, 1, 1]\npower = 3 {MARK}"),
    );
    check(&text, &["unknown field `power`", "intensity"]);
}

#[test]
fn unknown_key_in_transform() {
    // Inline table.
    let text = edit(
        r#"material = "white""#,
        &format!("material = \"white\"\ntransform = {{ scale = 2, spin = 30 }} {MARK}"),
    );
    check(&text, &["unknown field `spin`", "translate"]);
    // Nested inline table (rotate).
    let text = edit(
        r#"material = "white""#,
        &format!(
            "material = \"white\"\ntransform = {{ rotate = {{ axis = [0, 1, 0], degrees = 3, turns = 1 }} }} {MARK}"
        ),
    );
    check(&text, &["unknown field `turns`", "degrees"]);
    // Standard table [shape.transform].
    let text = with(&format!(
        "\n[[shape]]\ntype = \"cube\"\nmaterial = \"white\"\n[shape.transform]\nscale = 2\nshear = 1 {MARK}\n"
    ));
    check(&text, &["unknown field `shear`"]);
}

// ---- Wrong types ----

#[test]
fn string_where_a_number_is_expected() {
    let text = edit("fov = 40", &format!("fov = \"wide\" {MARK}"));
    check(&text, &["'fov'", "invalid type", "\"wide\""]);
}

#[test]
fn two_array_where_a_three_array_is_expected() {
    let text = edit(
        "position = [0, 0, 3.9]",
        &format!("position = [0, 3.9] {MARK}"),
    );
    check(&text, &["'position'", "length 2", "3"]);
}

#[test]
fn string_inside_a_vector() {
    let text = edit(
        "albedo = [0.7, 0.7, 0.7]",
        &format!("albedo = [0.7, \"grey\", 0.7] {MARK}"),
    );
    check(&text, &["'albedo'", "\"grey\""]);
}

#[test]
fn negative_integer_where_a_count_is_expected() {
    let text = edit(
        "resolution = [16, 16]",
        &format!("resolution = [16, -16] {MARK}"),
    );
    check(&text, &["'resolution'", "-16"]);
}

#[test]
fn scale_of_the_wrong_shape() {
    let text = edit(
        r#"material = "white""#,
        &format!("material = \"white\"\ntransform = {{ scale = [1, 2] }} {MARK}"),
    );
    check(&text, &["'scale'", "a number or an array of three numbers"]);
    let text = edit(
        r#"material = "white""#,
        &format!("material = \"white\"\ntransform = {{ scale = \"big\" }} {MARK}"),
    );
    check(&text, &["'scale'", "a number or an array of three numbers"]);
}

#[test]
fn toml_syntax_error() {
    let text = edit("fov = 40", &format!("fov = {MARK}"));
    check(&text, &[]);
    let text = edit("[[material]]", &format!("[[material] {MARK}"));
    check(&text, &[]);
    let text = edit(r#"name = "white""#, &format!("name = \"white {MARK}"));
    check(&text, &[]);
}

// ---- Missing required keys ----

#[test]
fn camera_needs_fov() {
    let text = edit("fov = 40", "").replace("[camera]", &format!("[camera] {MARK}"));
    check(&text, &["`fov`"]);
}

#[test]
fn scene_needs_a_camera() {
    let msg = load_err("[[material]]\nname = \"white\"\ntype = \"black\"\n");
    check_named(msg, "bad.toml", 1, &["`camera`"]);
}

#[test]
fn diffuse_material_needs_albedo() {
    let text = edit("albedo = [0.7, 0.7, 0.7]", "")
        .replace("[[material]]", &format!("[[material]] {MARK}"));
    check(&text, &["'white'", "diffuse", "'albedo'"]);
}

#[test]
fn sphere_needs_material() {
    let text = with(&format!(
        "\n[[shape]] {MARK}\nname = \"ball\"\ntype = \"sphere\"\nradius = 0.5\n"
    ));
    check(&text, &["ball", "'material'"]);
}

#[test]
fn point_light_needs_intensity() {
    let text = edit("intensity = [1, 1, 1]", "").replace("[[light]]", &format!("[[light]] {MARK}"));
    check(&text, &["point", "'intensity'"]);
}

// ---- Dangling references ----

#[test]
fn dangling_material_name() {
    let text = edit(
        r#"material = "white""#,
        &format!("material = \"whte\" {MARK}"),
    );
    check(&text, &["unknown material 'whte'", "white"]);
}

#[test]
fn missing_mesh_file() {
    let text = with(&format!(
        "\n[[shape]]\ntype = \"obj\"\nmaterial = \"white\"\nfile = \"meshes/no-such-mesh.obj\" {MARK}\n"
    ));
    let msg = load_str(&text, "bad.toml", Some(&data(""))).err().unwrap();
    let expected = data("meshes/no-such-mesh.obj").display().to_string();
    check_named(
        msg.to_string(),
        "bad.toml",
        line_of(&text, MARK),
        &[&expected, "no such file"],
    );
}

#[test]
fn missing_mesh_file_through_load_file() {
    let path = data("bad-mesh.toml");
    let text = std::fs::read_to_string(&path).unwrap();
    let msg = load_file(&path).err().unwrap().to_string();
    check_named(
        msg,
        &path.display().to_string(),
        line_of(&text, "does-not-exist.obj"),
        &["meshes/does-not-exist.obj", "no such file"],
    );
}

#[test]
fn malformed_obj_file() {
    let path = data("bad-obj.toml");
    let text = std::fs::read_to_string(&path).unwrap();
    let msg = load_file(&path).err().unwrap().to_string();
    check_named(
        msg,
        &path.display().to_string(),
        line_of(&text, "broken.obj"),
        &[
            "meshes/broken.obj",
            "line 5: vertex index 9, but the file has 3 vertices",
        ],
    );
}

#[test]
fn missing_scene_file() {
    let path = data("no-such-scene.toml");
    let msg = load_file(&path).err().unwrap().to_string();
    assert!(
        msg.starts_with(&format!("{}: ", path.display())),
        "should name the file: {msg}"
    );
    assert!(msg.contains("cannot read"), "{msg}");
    assert!(!msg.contains('\n'), "{msg:?}");
}

// ---- Out-of-range and non-finite numbers ----

#[test]
fn albedo_below_zero() {
    let text = edit(
        "albedo = [0.7, 0.7, 0.7]",
        &format!("albedo = [0.7, -0.1, 0.7] {MARK}"),
    );
    check(&text, &["'albedo'", "[0, 1]", "-0.1"]);
}

#[test]
fn albedo_above_one() {
    let text = edit(
        "albedo = [0.7, 0.7, 0.7]",
        &format!("albedo = [0.7, 0.7, 1.5] {MARK}"),
    );
    check(&text, &["'albedo'", "[0, 1]", "1.5"]);
}

#[test]
fn albedo_nan() {
    let text = edit(
        "albedo = [0.7, 0.7, 0.7]",
        &format!("albedo = [nan, 0.7, 0.7] {MARK}"),
    );
    check(&text, &["'albedo'", "finite", "NaN"]);
}

#[test]
fn reflectance_outside_unit_range() {
    let metal = |refl: &str| {
        with(&format!(
            "\n[[material]]\nname = \"gold\"\ntype = \"conductor\"\nreflectance = {refl} {MARK}\n"
        ))
    };
    check(
        &metal("[1.2, 0.8, 0.3]"),
        &["'reflectance'", "[0, 1]", "1.2"],
    );
    check(
        &metal("[0.9, -0.5, 0.3]"),
        &["'reflectance'", "[0, 1]", "-0.5"],
    );
}

#[test]
fn ior_not_positive_or_not_finite() {
    let glass = |ior: &str| {
        with(&format!(
            "\n[[material]]\nname = \"glass\"\ntype = \"dielectric\"\nior = {ior} {MARK}\n"
        ))
    };
    check(&glass("0"), &["'ior'", "> 0", "got 0"]);
    check(&glass("-1.5"), &["'ior'", "> 0", "-1.5"]);
    check(&glass("nan"), &["'ior'", "finite", "NaN"]);
    check(&glass("inf"), &["'ior'", "finite", "inf"]);
}

#[test]
fn fov_zero() {
    let text = edit("fov = 40", &format!("fov = 0 {MARK}"));
    check(&text, &["'fov'", "(0, 180)", "got 0"]);
}

#[test]
fn fov_180() {
    let text = edit("fov = 40", &format!("fov = 180 {MARK}"));
    check(&text, &["'fov'", "(0, 180)", "got 180"]);
}

#[test]
fn fov_nan() {
    let text = edit("fov = 40", &format!("fov = nan {MARK}"));
    check(&text, &["'fov'", "(0, 180)", "NaN"]);
}

#[test]
fn zero_resolution() {
    let text = edit(
        "resolution = [16, 16]",
        &format!("resolution = [0, 256] {MARK}"),
    );
    check(&text, &["'resolution'", "[0, 256]"]);
}

#[test]
fn non_finite_position() {
    let text = edit(
        "position = [0, 0, 3.9]",
        &format!("position = [0, inf, 3.9] {MARK}"),
    );
    check(&text, &["'position'", "finite", "inf"]);
    let text = edit(
        "position = [0, 0.9, 0]",
        &format!("position = [0, 0.9, -inf] {MARK}"),
    );
    check(&text, &["'position'", "finite", "-inf"]);
}

#[test]
fn negative_emission() {
    let text = edit(
        r#"material = "white""#,
        &format!("material = \"white\"\nemission = [1, -2, 1] {MARK}"),
    );
    check(&text, &["'emission'", ">= 0", "-2"]);
}

#[test]
fn nonpositive_radius() {
    let text = with(&format!(
        "\n[[shape]]\ntype = \"sphere\"\nmaterial = \"white\"\nradius = -0.5 {MARK}\n"
    ));
    check(&text, &["'radius'", "> 0", "-0.5"]);
}

#[test]
fn max_depth_zero() {
    let text = edit("max_depth = 4", &format!("max_depth = 0 {MARK}"));
    check(&text, &["'max_depth'", "got 0"]);
}

#[test]
fn spp_zero() {
    let text = edit("max_depth = 4", &format!("spp = 0 {MARK}"));
    check(&text, &["'spp'", "at least 1"]);
}

#[test]
fn unknown_integrator_in_render() {
    let text = edit("max_depth = 4", &format!("integrator = \"ptt\" {MARK}"));
    check(&text, &["unknown integrator 'ptt'", "available", "pt"]);
}

// ---- Unknown types and keys of another type ----

#[test]
fn unknown_material_type() {
    let text = edit(r#"type = "diffuse""#, &format!("type = \"lambert\" {MARK}"));
    check(&text, &["unknown material type 'lambert'", "diffuse"]);
}

#[test]
fn unknown_shape_type() {
    let text = edit(r#"type = "quad""#, &format!("type = \"torus\" {MARK}"));
    check(&text, &["unknown shape type 'torus'", "sphere"]);
}

#[test]
fn unknown_light_type() {
    let text = edit(r#"type = "point""#, &format!("type = \"laser\" {MARK}"));
    check(&text, &["unknown light type 'laser'", "spot", "sun"]);
}

#[test]
fn key_of_another_shape_type() {
    let text = edit(
        r#"material = "white""#,
        &format!("material = \"white\"\nradius = 3 {MARK}"),
    );
    check(&text, &["'quad'", "'radius'"]);
}

#[test]
fn key_of_another_material_type() {
    let text = with(&format!(
        "\n[[material]]\nname = \"glass\"\ntype = \"dielectric\"\nior = 1.5\nalbedo = [1, 1, 1] {MARK}\n"
    ));
    check(&text, &["'glass'", "dielectric", "'albedo'"]);
}

#[test]
fn key_of_another_light_type() {
    let text = edit(
        "intensity = [1, 1, 1]",
        &format!("intensity = [1, 1, 1]\nradiance = [1, 1, 1] {MARK}"),
    );
    check(&text, &["'point'", "'radiance'"]);
}

// ---- Inconsistent scenes ----

#[test]
fn non_uniform_scale_on_analytic_sphere() {
    let text = with(&format!(
        "\n[[shape]]\ntype = \"sphere\"\nmaterial = \"white\"\ntransform = {{ scale = [1, 2, 1] }} {MARK}\n"
    ));
    check(&text, &["sphere", "scale uniformly"]);
}

#[test]
fn two_environment_lights() {
    let text = with(&format!(
        "\n[[light]]\ntype = \"environment\"\nradiance = [1, 1, 1]\n\n[[light]] {MARK}\ntype = \"environment\"\nradiance = [0.5, 0.5, 0.5]\n"
    ));
    check(&text, &["only one environment light"]);
}

#[test]
fn duplicate_material_names() {
    let text = with(&format!(
        "\n[[material]]\nname = \"white\" {MARK}\ntype = \"black\"\n"
    ));
    check(&text, &["material 'white'", "twice"]);
}

#[test]
fn up_parallel_to_view_direction() {
    let text = edit("up = [0, 1, 0]", &format!("up = [0, 0, -2] {MARK}"));
    check(&text, &["'up'", "parallel"]);
}

#[test]
fn look_at_equals_position() {
    let text = edit(
        "look_at = [0, 0, 0]",
        &format!("look_at = [0, 0, 3.9] {MARK}"),
    );
    check(&text, &["'look_at'", "'position'"]);
}

// ---- Valid scenes with meshes ----

fn mesh_normals(s: &Scene, name: &str) -> bool {
    let i = s.shape_info.iter().position(|i| i.name == name).unwrap();
    match &s.shapes[i] {
        ShapeGeometry::Mesh(m) => m.normals.is_some(),
        ShapeGeometry::Sphere(_) => panic!("{name} should be a mesh"),
    }
}

#[test]
fn valid_scene_with_obj_loads() {
    let s = load_file(&data("tiny.toml")).unwrap();
    assert_eq!(s.shapes.len(), 4);
    // Two quads and the two-triangle OBJ.
    assert_eq!(s.triangle_count(), 6);
    assert_eq!(s.sphere_count(), 1);
    assert_eq!(s.lights.len(), 1);
    assert!(mesh_normals(&s, "floor mesh"), "the OBJ's normals are kept");
    // scale 2, then translate down by 1: the square spans [-1, 1] in x and z at y = -1.
    let i = s
        .shape_info
        .iter()
        .position(|i| i.name == "floor mesh")
        .unwrap();
    let ShapeGeometry::Mesh(m) = &s.shapes[i] else {
        unreachable!()
    };
    for p in &m.positions {
        assert!(
            (p.y + 1.0).abs() < 1e-6 && (p.x.abs() - 1.0).abs() < 1e-6,
            "{p}"
        );
    }
}

#[test]
fn relative_mesh_path_resolves_against_the_scene_directory() {
    // The tests run in the package root, where "meshes/quad.obj" does not exist; the scene
    // refers to it relative to its own directory.
    assert!(!Path::new("meshes/quad.obj").exists());
    let relative = Path::new("tests/data/tiny.toml");
    assert!(relative.is_file(), "tests run in the package root");
    let s = load_file(relative).unwrap();
    assert_eq!(s.triangle_count(), 6);
    assert_eq!(s.source, "tests/data/tiny.toml");
    // Through load_str: resolved against `dir` when given, else against the current directory.
    let text = std::fs::read_to_string(relative).unwrap();
    assert!(load_str(&text, "tiny.toml", Some(&data(""))).is_ok());
    let msg = load_str(&text, "tiny.toml", None)
        .err()
        .unwrap()
        .to_string();
    assert!(msg.contains("cannot load mesh 'meshes/quad.obj'"), "{msg}");
}

#[test]
fn every_bad_fixture_fails_and_names_itself() {
    let mut n = 0;
    for entry in std::fs::read_dir(data("")).unwrap() {
        let path = entry.unwrap().path();
        let name = path.file_name().unwrap().to_string_lossy().into_owned();
        if name.starts_with("bad-") && name.ends_with(".toml") {
            let msg = load_file(&path).err().unwrap().to_string();
            assert!(
                msg.starts_with(&format!("{}:", path.display())),
                "{name}: {msg}"
            );
            n += 1;
        }
    }
    assert!(n >= 3);
}

// ---------------------------------------------------------------------------------------------
// Media, rough materials, spot / directional / sun lights, heightfields
// ---------------------------------------------------------------------------------------------

const FOG: &str =
    "[[medium]]\nname = \"fog\"\nsigma_a = [0.1, 0.1, 0.1]\nsigma_s = [0.5, 0.5, 0.5]\n";

#[test]
fn unknown_medium_name() {
    let text = with(&format!(
        "{FOG}[[shape]]\ntype = \"cube\"\ninterior = \"smoke\" {MARK}\n"
    ));
    check(&text, &["unknown medium 'smoke'", "fog"]);
}

#[test]
fn unknown_world_medium() {
    let text = format!("world_medium = \"smoke\" {MARK}\n{BASE}");
    check(&text, &["unknown medium 'smoke'"]);
}

#[test]
fn negative_sigma() {
    let text = with(&format!(
        "[[medium]]\nname = \"fog\"\nsigma_a = [0.1, -0.1, 0.1] {MARK}\nsigma_s = [0.5, 0.5, 0.5]\n"
    ));
    check(&text, &["'sigma_a'", ">= 0"]);
}

#[test]
fn phase_g_out_of_range() {
    for g in ["1.0", "-1", "nan"] {
        let text = with(&format!("{FOG}g = {g} {MARK}\n"));
        check(&text, &["'g'", "(-1, 1)"]);
    }
}

#[test]
fn rough_material_alpha_and_ior() {
    for (kind, line, fact) in [
        ("roughconductor", "alpha = 0 ", "'alpha'"),
        ("roughconductor", "alpha = 1.5 ", "'alpha'"),
        ("roughdielectric", "alpha = nan ", "'alpha'"),
        ("roughdielectric", "ior = 1.0 ", "index-matched"),
        (
            "roughconductor",
            "distribution = \"phong\" ",
            "distribution 'phong' (expected ggx or beckmann)",
        ),
    ] {
        let other = match (kind, line.starts_with("ior")) {
            ("roughconductor", _) => "reflectance = [0.9, 0.9, 0.9]",
            (_, true) => "alpha = 0.1",
            _ => "ior = 1.5",
        };
        let text = with(&format!(
            "[[material]]\nname = \"m\"\ntype = \"{kind}\"\n{other}\n{line}{MARK}\n"
        ));
        check(&text, &[fact]);
    }
}

#[test]
fn rough_conductor_needs_one_kind_of_fresnel() {
    let text = with(&format!(
        "[[material]] {MARK}\nname = \"m\"\ntype = \"roughconductor\"\nalpha = 0.1\nreflectance = [1, 1, 1]\neta = [0.2, 0.4, 1.4]\nk = [3, 2.4, 1.8]\n"
    ));
    check(&text, &["'reflectance'", "'eta'", "'k'"]);
}

#[test]
fn conductor_specular_scales_only_the_complex_fresnel() {
    let text = with(&format!(
        "[[material]]\nname = \"m\"\ntype = \"conductor\"\nreflectance = [0.9, 0.9, 0.9]\nspecular = [0.5, 0.5, 0.5] {MARK}\n"
    ));
    check(&text, &["'specular'", "'eta' and 'k'"]);
    let text = with(&format!(
        "[[material]]\nname = \"m\"\ntype = \"conductor\"\neta = [0.2, 0.4, 1.4]\nk = [3, 2.4, 1.8]\nspecular = [1.5, 0.5, 0.5] {MARK}\n"
    ));
    check(&text, &["'specular'", "[0, 1]"]);
}

#[test]
fn sun_needs_exactly_one_of_radiance_and_irradiance() {
    let text = with(&format!(
        "[[light]] {MARK}\ntype = \"sun\"\ndirection = [0, 1, 0]\nradiance = [1, 1, 1]\nirradiance = [1, 1, 1]\n"
    ));
    check(&text, &["'radiance'", "'irradiance'"]);
}

#[test]
fn spot_cone_out_of_range() {
    let text = with(&format!(
        "[[light]]\ntype = \"spot\"\nposition = [0, 1, 0]\ndirection = [0, -1, 0]\nintensity = [1, 1, 1]\ncone_angle = 200 {MARK}\n"
    ));
    check(&text, &["spot cone"]);
}

#[test]
fn zero_light_direction() {
    let text = with(&format!(
        "[[light]]\ntype = \"directional\"\ndirection = [0, 0, 0] {MARK}\nirradiance = [1, 1, 1]\n"
    ));
    check(&text, &["'direction'", "non-zero"]);
}

#[test]
fn cone_on_a_shape_without_emission() {
    let text = edit(
        r#"material = "white""#,
        &format!("material = \"white\"\ncone_angle = 20 {MARK}"),
    );
    check(&text, &["'cone_angle'", "'emission'"]);
}

#[test]
fn heightfield_with_a_bad_wave() {
    let text = with(&format!(
        "[[shape]]\ntype = \"heightfield\"\nmaterial = \"white\"\nwaves = [{{ amplitude = 0.1, wavelength = 0, direction = [1, 0] }}] {MARK}\n"
    ));
    check(&text, &["wave #1", "'wavelength'"]);
}

#[test]
fn valid_media_lights_and_rough_materials_load() {
    let text = format!(
        "world_medium = \"fog\"\n{BASE}{FOG}g = 0.3\n[[material]]\nname = \"gold\"\ntype = \"roughconductor\"\nalpha = 0.2\neta = [0.14, 0.37, 1.44]\nk = [3.98, 2.38, 1.6]\n[[shape]]\ntype = \"heightfield\"\nmaterial = \"gold\"\nsize = [2, 1]\ngrid = [8, 4]\nwaves = [{{ amplitude = 0.01, wavelength = 0.5, direction = [1, 1] }}]\n[[shape]]\ntype = \"disk\"\nradius = 0.1\nemission = [5, 5, 5]\ncone_angle = 30\n[[light]]\ntype = \"sun\"\ndirection = [0, 1, 0]\nirradiance = [2, 2, 2]\n[[light]]\ntype = \"spot\"\nposition = [0, 1, 0]\ndirection = [0, -1, 0]\nintensity = [1, 1, 1]\n[[light]]\ntype = \"directional\"\ndirection = [0, -1, 0]\nirradiance = [1, 1, 1]\n"
    );
    let scene = load_str(&text, "ok.toml", None).unwrap();
    assert!(scene.features.media && scene.features.delta_lights && scene.features.environment);
    assert_eq!(scene.camera_medium, Some(0));
    assert_eq!(scene.lights.len(), 5);
    assert_eq!(scene.infinite_lights.len(), 2);
}

// ---------------------------------------------------------------------------------------------
// Tiled quads (checkerboards of two materials)
// ---------------------------------------------------------------------------------------------

const BLUE: &str = "[[material]]\nname = \"blue\"\ntype = \"diffuse\"\nalbedo = [0.1, 0.3, 0.6]\n";

#[test]
fn tiles_without_tile_material() {
    let text = with(&format!(
        "[[shape]]\ntype = \"quad\"\nmaterial = \"white\"\ntiles = [4, 4] {MARK}\n"
    ));
    check(&text, &["'tiles'", "'tile_material'"]);
}

#[test]
fn tile_material_without_tiles() {
    let text = with(&format!(
        "{BLUE}[[shape]]\ntype = \"quad\"\nmaterial = \"white\"\ntile_material = \"blue\" {MARK}\n"
    ));
    check(&text, &["'tile_material'", "'tiles'"]);
}

#[test]
fn tiles_out_of_range() {
    for tiles in ["[0, 4]", "[4, 2000]"] {
        let text = with(&format!(
            "{BLUE}[[shape]]\ntype = \"quad\"\nmaterial = \"white\"\ntile_material = \"blue\"\ntiles = {tiles} {MARK}\n"
        ));
        check(&text, &["'tiles'", "[1, 1024]"]);
    }
}

#[test]
fn tiles_of_the_wrong_type() {
    let text = with(&format!(
        "{BLUE}[[shape]]\ntype = \"quad\"\nmaterial = \"white\"\ntile_material = \"blue\"\ntiles = [4, \"x\"] {MARK}\n"
    ));
    check(&text, &["tiles"]);
}

#[test]
fn unknown_tile_material() {
    let text = with(&format!(
        "[[shape]]\ntype = \"quad\"\nmaterial = \"white\"\ntiles = [2, 2]\ntile_material = \"blu\" {MARK}\n"
    ));
    check(&text, &["unknown material 'blu'", "white"]);
}

#[test]
fn tiles_on_a_shape_that_is_not_a_quad() {
    let text = with(&format!(
        "{BLUE}[[shape]]\ntype = \"cube\"\nmaterial = \"white\"\ntiles = [2, 2] {MARK}\ntile_material = \"blue\"\n"
    ));
    check(&text, &["shape of type 'cube'", "'tiles'"]);
}

#[test]
fn tiled_emitter() {
    let text = with(&format!(
        "{BLUE}[[shape]]\ntype = \"quad\"\nmaterial = \"white\"\ntiles = [2, 2]\ntile_material = \"blue\"\nemission = [1, 1, 1] {MARK}\n"
    ));
    check(&text, &["tiled quad", "'emission'"]);
}

#[test]
fn tiled_quad_without_material() {
    let text = with(&format!(
        "{BLUE}[[shape]] {MARK}\ntype = \"quad\"\ntiles = [2, 2]\ntile_material = \"blue\"\n"
    ));
    check(&text, &["tiled quad", "'material'"]);
}

#[test]
fn tiled_quad_is_one_quad_with_a_checkerboard_material() {
    // A mirroring transform (negative scale) must keep the quad's front side and its tiles.
    for mirror in [1.0f32, -1.0] {
        let text = with(&format!(
            "{BLUE}[[shape]]\nname = \"tiles\"\ntype = \"quad\"\norigin = [-1, -1, 0]\nedge_u = [2, 0, 0]\nedge_v = [0, 2, 0]\ntiles = [3, 2]\nmaterial = \"white\"\ntile_material = \"blue\"\ntransform = {{ scale = [{mirror}, 1, 1] }}\n"
        ));
        let scene = load_str(&text, "ok.toml", None).unwrap();
        assert_eq!(scene.shapes.len(), 2, "floor plus the tiled quad");
        let ShapeGeometry::Mesh(m) = &scene.shapes[1] else {
            panic!("a tiled quad is a mesh")
        };
        assert_eq!(m.indices.len(), 2);
        assert!((m.area() - 4.0).abs() < 1e-4);
        for t in 0..2 {
            assert!(m.geometric_normal(t).z > 0.999, "front side along +z");
        }
        // Down onto the centre of every tile, and onto points just inside its corners: the
        // tile at the origin corner and those an even number of steps away are white.
        for (i, j) in (0..3).flat_map(|i| (0..2).map(move |j| (i, j))) {
            let expected = if (i + j) % 2 == 0 { "white" } else { "blue" };
            for (a, b) in [(0.5, 0.5), (0.02, 0.02), (0.98, 0.98), (0.02, 0.98)] {
                let x = mirror * (-1.0 + 2.0 * (i as f32 + a) / 3.0);
                let y = -1.0 + 2.0 * (j as f32 + b) / 2.0;
                let ray = Ray::new(Vec3::new(x, y, 1.0), -Vec3::Z);
                let sp = scene.intersect(&ray).expect("the quad is below");
                assert_eq!(sp.info.name, "tiles");
                let name = &scene.materials[sp.material as usize].name;
                assert_eq!(name, expected, "tile ({i}, {j}) at ({x}, {y})");
                assert!(std::ptr::eq(
                    sp.bsdf,
                    &scene.materials[sp.material as usize].bsdf
                ));
            }
        }
    }
}

// ---------------------------------------------------------------------------------------------
// OBJ and PLY files: index forms, polygons, bad references, empty meshes, element counts
// ---------------------------------------------------------------------------------------------

/// A scratch directory for mesh files, removed when dropped.
struct MeshDir(PathBuf);

impl MeshDir {
    fn new(tag: &str) -> MeshDir {
        let d = std::env::temp_dir().join(format!(
            "lodestar-scene-errors-{tag}-{}",
            std::process::id()
        ));
        std::fs::create_dir_all(&d).unwrap();
        MeshDir(d)
    }

    /// `BASE` plus a mesh shape of `kind` ("obj" or "ply") read from the file `name`, written
    /// with `bytes` first; the scene's text and the result of loading it.
    fn load(
        &self,
        name: &str,
        kind: &str,
        bytes: &[u8],
    ) -> (String, lodestar::error::Result<Scene>) {
        std::fs::write(self.0.join(name), bytes).unwrap();
        let text = with(&format!(
            "\n[[shape]]\nname = \"mesh\"\ntype = \"{kind}\"\nmaterial = \"white\"\nfile = \"{name}\" {MARK}\n"
        ));
        let loaded = load_str(&text, "bad.toml", Some(&self.0));
        (text, loaded)
    }

    /// The mesh's triangles (as vertex positions) in a file that must load.
    fn triangles(&self, name: &str, kind: &str, bytes: &[u8]) -> Vec<[Vec3; 3]> {
        let (_, loaded) = self.load(name, kind, bytes);
        let s = loaded.unwrap_or_else(|e| panic!("{name}: {e}"));
        let i = s.shape_info.iter().position(|i| i.name == "mesh").unwrap();
        let ShapeGeometry::Mesh(m) = &s.shapes[i] else {
            panic!("{name} should be a mesh")
        };
        m.indices
            .iter()
            .map(|t| t.map(|k| m.positions[k as usize]))
            .collect()
    }

    /// Loading a scene with this mesh fails with `bad.toml:LINE: cannot load mesh 'PATH': ...`,
    /// LINE the shape's `file` line, naming every fact.
    fn fails(&self, name: &str, kind: &str, bytes: &[u8], facts: &[&str]) -> String {
        let (text, loaded) = self.load(name, kind, bytes);
        let msg = match loaded {
            Ok(_) => panic!("{name} loaded:\n{}", String::from_utf8_lossy(bytes)),
            Err(e) => e.to_string(),
        };
        let file = format!("cannot load mesh '{}': ", self.0.join(name).display());
        let mut all = vec![file.as_str()];
        all.extend_from_slice(facts);
        check_named(msg, "bad.toml", line_of(&text, MARK), &all)
    }
}

impl Drop for MeshDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

const SIX_VERTICES: &str = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 0 1 1\n";

/// Negative OBJ indices count back from the last vertex defined before the face (-1 is the
/// last; OBJ spec): the same triangles as the positive indices they stand for, also after
/// more vertices follow, and mixed with `vt` / `vn` references.
#[test]
fn obj_negative_indices_count_back_from_the_last_vertex() {
    let dir = MeshDir::new("obj-negative");
    let positive = dir.triangles(
        "pos.obj",
        "obj",
        format!("{SIX_VERTICES}f 1 2 3\nf 4 5 6\n").as_bytes(),
    );
    let negative = dir.triangles(
        "neg.obj",
        "obj",
        b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf -3 -2 -1\nv 0 0 1\nv 1 0 1\nv 0 1 1\nf -3 -2 -1\n",
    );
    assert_eq!(positive.len(), 2);
    assert_eq!(negative, positive);
    let with_normals = dir.triangles(
        "neg-vn.obj",
        "obj",
        format!("{SIX_VERTICES}vt 0 0\nvn 0 0 1\nf -6/-1/-1 -5/1/-1 -4//1\nf 4 5 -1\n").as_bytes(),
    );
    assert_eq!(with_normals, positive);
}

/// Faces of more than three vertices are fanned from their first vertex: a convex pentagon
/// becomes three triangles covering its area, a quad two.
#[test]
fn obj_polygons_are_fanned_into_triangles() {
    let dir = MeshDir::new("obj-ngon");
    let v = [
        Vec3::new(0.0, 0.0, 0.0),
        Vec3::new(1.0, 0.0, 0.0),
        Vec3::new(1.0, 1.0, 0.0),
        Vec3::new(0.5, 1.5, 0.0),
        Vec3::new(0.0, 1.0, 0.0),
    ];
    let tris = dir.triangles(
        "pentagon.obj",
        "obj",
        b"v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0.5 1.5 0\nv 0 1 0\nf 1 2 3 4 5\n",
    );
    assert_eq!(
        tris,
        vec![[v[0], v[1], v[2]], [v[0], v[2], v[3]], [v[0], v[3], v[4]]]
    );
    let area: f32 = tris
        .iter()
        .map(|t| (t[1] - t[0]).cross(t[2] - t[0]).length() / 2.0)
        .sum();
    assert!((area - 1.25).abs() < 1e-6, "{area}");
    let quad = dir.triangles(
        "quad.obj",
        "obj",
        b"v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n",
    );
    assert_eq!(quad.len(), 2);
}

/// Face references out of range, of the wrong form, or to texture coordinates or normals the
/// file does not have: errors naming the scene line, the mesh file, the OBJ line and what the
/// index had to be. (`tobj` alone reads index 0 as "none" and ignores references to absent
/// `vt` / `vn`.)
#[test]
fn obj_bad_face_references_name_the_obj_line() {
    let dir = MeshDir::new("obj-bad");
    let tri = "v 0 0 0\nv 1 0 0\nv 0 1 0\n";
    let cases: &[(&str, &str)] = &[
        (
            "f 1 2 4",
            "line 4: vertex index 4, but the file has 3 vertices",
        ),
        (
            "f 1 2 -4",
            "line 4: vertex index -4, but only 3 vertices are defined before it",
        ),
        ("f 0 1 2", "line 4: vertex index 0 (indices count from 1"),
        (
            "vt 0 0\nf 1/1 2/2 3/1",
            "line 5: texture coordinate index 2, but the file has 1",
        ),
        (
            "f 1/1 2/1 3/1",
            "line 4: texture coordinate index 1, but the file has 0",
        ),
        (
            "vt 0 0\nf 1/-2 2/1 3/1",
            "line 5: texture coordinate index -2 of '1/-2', but only 1",
        ),
        (
            "vn 0 0 1\nf 1//1 2//2 3//1",
            "line 5: normal index 2, but the file has 1 normals",
        ),
        (
            "f 1//1 2//1 3//1",
            "line 4: normal index 1, but the file has 0 normals",
        ),
        (
            "vn 0 0 1\nf 1//0 2//1 3//1",
            "line 5: normal index 0 of '1//0'",
        ),
        (
            "f 1 2",
            "line 4: a face needs at least 3 vertices, this one has 2",
        ),
        ("f 1 2 x", "line 4: 'x' is not a vertex index"),
        ("f 1 2 3.0", "line 4: '3.0' is not a vertex index"),
        ("f 1 2 99999999999999999999", "is not a vertex index"),
        (
            "f 1/1/1/1 2 3",
            "'1/1/1/1' is not a face vertex (expected v, v/vt, v//vn or v/vt/vn)",
        ),
        ("f /1 2 3", "'/1' is not a face vertex"),
    ];
    for (k, (faces, fact)) in cases.iter().enumerate() {
        let name = format!("bad{k}.obj");
        dir.fails(&name, "obj", format!("{tri}{faces}\n").as_bytes(), &[fact]);
    }
    let mut latin1 = format!("{tri}f 1 2 3\n# caf").into_bytes();
    latin1.push(0xe9);
    dir.fails(
        "latin1.obj",
        "obj",
        &latin1,
        &["line 5: the file is not UTF-8 text"],
    );
}

/// A mesh file without a face: an error, for OBJ (no `f` lines, or nothing at all) and PLY
/// (a face count of 0).
#[test]
fn meshes_without_faces_are_errors() {
    let dir = MeshDir::new("empty");
    let no_triangles = "the file has no triangles";
    dir.fails(
        "verts.obj",
        "obj",
        b"v 0 0 0\nv 1 0 0\nv 0 1 0\n",
        &[no_triangles],
    );
    dir.fails("empty.obj", "obj", b"", &[no_triangles]);
    dir.fails("comment.obj", "obj", b"# nothing here\n", &[no_triangles]);
    let ply = format!("{}0 0 0\n1 0 0\n1 1 0\n0 1 0\n", ply_header("ascii", 4, 0));
    dir.fails("empty.ply", "ply", ply.as_bytes(), &[no_triangles]);
}

fn ply_header(format: &str, vertices: usize, faces: usize) -> String {
    format!(
        "ply\nformat {format} 1.0\nelement vertex {vertices}\nproperty float x\nproperty float y\nproperty float z\nelement face {faces}\nproperty list uchar int vertex_indices\nend_header\n"
    )
}

/// A binary little-endian PLY of the unit square (4 vertices, one quad) under a header that
/// claims `vertices` and `faces`.
fn binary_square(vertices: usize, faces: usize) -> Vec<u8> {
    let mut b = ply_header("binary_little_endian", vertices, faces).into_bytes();
    for p in [[0f32, 0., 0.], [1., 0., 0.], [1., 1., 0.], [0., 1., 0.]] {
        for x in p {
            b.extend(x.to_le_bytes());
        }
    }
    b.push(4);
    for i in 0..4i32 {
        b.extend(i.to_le_bytes());
    }
    b
}

/// PLY element counts that do not match the data (too large: the data ends inside an
/// element; too small: data is left after the last one, which would otherwise be read as the
/// wrong element or dropped), truncated binary data and bad face indices: errors that say
/// which element and what was expected.
#[test]
fn ply_wrong_element_counts_and_truncated_data_are_errors() {
    let dir = MeshDir::new("ply");
    let body = "0 0 0\n1 0 0\n1 1 0\n0 1 0\n4 0 1 2 3\n";
    let ascii = |v: usize, f: usize| format!("{}{body}", ply_header("ascii", v, f));
    let good = dir.triangles("good.ply", "ply", ascii(4, 1).as_bytes());
    assert_eq!(good.len(), 2);
    assert_eq!(
        dir.triangles("good-le.ply", "ply", &binary_square(4, 1)),
        good
    );
    let ends = "the count is wrong or the file is cut short";
    let after = "after the last element: the header's element counts do not match the data";
    dir.fails(
        "faces-2.ply",
        "ply",
        ascii(4, 2).as_bytes(),
        &[
            "the file ends in item 1 of element 'face', whose header count is 2",
            ends,
        ],
    );
    dir.fails("vertices-5.ply", "ply", ascii(5, 1).as_bytes(), &[ends]);
    dir.fails("vertices-3.ply", "ply", ascii(3, 1).as_bytes(), &[after]);
    dir.fails(
        "faces-0.ply",
        "ply",
        ascii(4, 0).as_bytes(),
        &["11 bytes", after],
    );
    dir.fails(
        "le-faces-2.ply",
        "ply",
        &binary_square(4, 2),
        &["item 1 of element 'face', whose header count is 2", ends],
    );
    dir.fails("le-vertices-3.ply", "ply", &binary_square(3, 1), &[after]);
    let full = binary_square(4, 1);
    for cut in [1, 5, 17, 40] {
        let name = format!("le-cut-{cut}.ply");
        dir.fails(
            &name,
            "ply",
            &full[..full.len() - cut],
            &["the file ends in item", ends],
        );
    }
    let mut extra = full.clone();
    extra.push(b'\n');
    dir.fails("le-extra.ply", "ply", &extra, &["1 bytes", after]);
    dir.fails(
        "claims.ply",
        "ply",
        ascii(1_000_000, 1).as_bytes(),
        &["element 'vertex' claims 1000000 items, more than the file can hold"],
    );
    let faces = |f: &str| {
        format!(
            "{}0 0 0\n1 0 0\n1 1 0\n0 1 0\n{f}\n",
            ply_header("ascii", 4, 1)
        )
    };
    dir.fails(
        "index-4.ply",
        "ply",
        faces("3 0 1 4").as_bytes(),
        &["a face refers to vertex 4, but the file has 4 vertices (numbered from 0)"],
    );
    dir.fails(
        "index-neg.ply",
        "ply",
        faces("3 0 1 -1").as_bytes(),
        &["vertex index -1 in a face"],
    );
    dir.fails(
        "index-word.ply",
        "ply",
        faces("3 0 1 two").as_bytes(),
        &["'two' in element 'face' is not a number"],
    );
}

#[test]
fn pixel_filters() {
    let filter = |f: &str| {
        edit(
            "resolution = [16, 16]",
            &format!("resolution = [16, 16]\nfilter = {f} {MARK}"),
        )
    };
    let ok = |f: &str| {
        load_str(&filter(f), "ok.toml", None)
            .unwrap()
            .camera
            .filter
            .kind()
    };
    use lodestar::filter::FilterKind;
    assert_eq!(ok("{ type = \"box\" }"), FilterKind::Box);
    assert_eq!(ok("{ type = \"tent\" }"), FilterKind::Tent { radius: 1.0 });
    assert_eq!(
        ok("{ type = \"gaussian\", stddev = 0.3 }"),
        FilterKind::Gaussian { stddev: 0.3 }
    );
    check(
        &filter("{ type = \"mitchell\" }"),
        &["unknown filter type 'mitchell'", "box, tent or gaussian"],
    );
    check(
        &filter("{ type = \"tent\", radius = 0 }"),
        &["filter 'radius' must be in (0, 8] pixels, got 0"],
    );
    check(
        &filter("{ type = \"gaussian\", stddev = 3 }"),
        &["filter 'stddev' must be in (0, 2] pixels, got 3"],
    );
    check(
        &filter("{ type = \"gaussian\", radius = 1 }"),
        &["filter 'gaussian' has no 'radius'"],
    );
    check(
        &filter("{ type = \"box\", width = 1 }"),
        &["unknown field `width`"],
    );
}

/// Groups and instances: each instance draws its group's members under its transform, the
/// same shapes (bit for bit in the image) as writing each placement out; the group's
/// members alone are not drawn; errors name the key.
#[test]
fn groups_draw_where_instances_place_them() {
    let head = r#"[camera]
position = [0, 0, 3.9]
look_at = [0, 0, 0]
fov = 40
resolution = [16, 16]

[[material]]
name = "white"
type = "diffuse"
albedo = [0.7, 0.7, 0.7]

[[light]]
type = "point"
position = [0, 0.9, 1]
intensity = [3, 3, 3]
"#;
    let quad = "type = \"quad\"\norigin = [-0.3, -0.3, 0]\nedge_u = [0.6, 0, 0]\nedge_v = [0, 0.6, 0]\nmaterial = \"white\"";
    let ball = "type = \"sphere\"\ncenter = [0, 0, 0.3]\nradius = 0.2\nmaterial = \"white\"";
    let places = [
        "{ translate = [-0.5, 0.2, 0] }",
        "{ scale = 0.5, rotate = { axis = [0, 1, 0], degrees = 30 }, translate = [0.5, -0.3, 0] }",
    ];
    let grouped = format!(
        "{head}\n[[shape]]\n{quad}\ngroup = \"pair\"\n\n[[shape]]\n{ball}\ngroup = \"pair\"\n\n[[shape]]\ntype = \"instance\"\ngroup = \"pair\"\ntransform = {}\n\n[[shape]]\ntype = \"instance\"\nname = \"second\"\ngroup = \"pair\"\ntransform = {}\n",
        places[0], places[1]
    );
    let mut explicit = head.to_string();
    for t in places {
        for shape in [quad, ball] {
            explicit += &format!("\n[[shape]]\n{shape}\ntransform = {t}\n");
        }
    }
    let a = load_str(&grouped, "grouped.toml", None).unwrap();
    let b = load_str(&explicit, "explicit.toml", None).unwrap();
    assert_eq!(a.shapes.len(), 4);
    let render = |s: &Scene| {
        let p = lodestar::integrators::IntegratorParams {
            max_depth: 4,
            options: lodestar::integrators::Options::default(),
        };
        let r = lodestar::integrators::render_named(
            s,
            "pt",
            &p,
            lodestar::render::Budget::Spp(4),
            1,
            1,
            false,
        )
        .unwrap();
        r.result
            .image
            .pixels
            .iter()
            .map(|p| p.to_array().map(f32::to_bits))
            .collect::<Vec<_>>()
    };
    assert_eq!(
        render(&a),
        render(&b),
        "instances differ from the shapes written out"
    );
    // Members alone are not drawn.
    let members_only = grouped
        .split("\n[[shape]]\ntype = \"instance\"")
        .next()
        .unwrap();
    assert_eq!(
        load_str(members_only, "m.toml", None).unwrap().shapes.len(),
        0
    );

    let bad = |from: &str, to: &str| {
        assert!(grouped.contains(from), "{from}");
        grouped.replacen(from, to, 1)
    };
    let e = load_err(&bad(
        "type = \"instance\"\ngroup = \"pair\"",
        &format!("type = \"instance\"\ngroup = \"pairs\" {MARK}"),
    ));
    assert!(
        e.contains("no shape belongs to group 'pairs' (groups: pair)"),
        "{e}"
    );
    let e = load_err(&bad(
        "type = \"instance\"\ngroup = \"pair\"",
        &format!("type = \"instance\" {MARK}"),
    ));
    assert!(e.contains("an instance needs 'group'"), "{e}");
    let e = load_err(&bad(
        "type = \"instance\"\ngroup = \"pair\"",
        &format!("type = \"instance\"\ngroup = \"pair\"\nmaterial = \"white\" {MARK}"),
    ));
    assert!(e.contains("does not take the key 'material'"), "{e}");
    let e = load_err(&bad(
        "radius = 0.2\nmaterial = \"white\"\ngroup",
        &format!("radius = 0.2\nmaterial = \"white\"\nemission = [1, 1, 1] {MARK}\ngroup"),
    ));
    assert!(e.contains("a shape in group 'pair' cannot emit"), "{e}");
}

/// `alpha_u` and `alpha_v` (anisotropic roughness): both or neither, each in (0, 1], and not
/// beside `alpha`.
#[test]
fn anisotropic_roughness_keys() {
    let material = |keys: &str| {
        with(&format!(
            "[[material]]\nname = \"m\"\ntype = \"roughconductor\"\n{keys}\nreflectance = [1, 1, 1]\n"
        ))
    };
    let s = load_str(
        &material("alpha_u = 0.05\nalpha_v = 0.3"),
        "aniso.toml",
        None,
    )
    .unwrap();
    match &s.materials.last().unwrap().bsdf {
        lodestar::bsdf::Bsdf::RoughConductor { alpha, .. } => assert_eq!(
            *alpha,
            lodestar::bsdf::Alpha::Anisotropic { u: 0.05, v: 0.3 }
        ),
        other => panic!("{other:?}"),
    }
    check(
        &material(&format!("alpha_u = 0.05 {MARK}")),
        &["'alpha_u' and 'alpha_v'", "expected both"],
    );
    check(
        &material(&format!(
            "alpha_u = 0.05 {MARK}\nalpha_v = 0.3\nalpha = 0.1"
        )),
        &["'alpha_u' and 'alpha_v'", "expected one roughness"],
    );
    check(
        &material(&format!("alpha_u = 0.05\nalpha_v = 1.5 {MARK}")),
        &["'alpha_v'", "(0, 1]", "1.5"],
    );
}

/// `blend`: `first` and `second` name materials defined before it, smooth (no delta lobe),
/// sided alike; `weight` in [0, 1] or `weight_texture`, one of them.
#[test]
fn blend_material_keys() {
    let parts = "[[material]]\nname = \"matte\"\ntype = \"diffuse\"\nalbedo = [0.5, 0.5, 0.5]\n\
                 [[material]]\nname = \"metal\"\ntype = \"roughconductor\"\nalpha = 0.2\nreflectance = [0.9, 0.9, 0.9]\n\
                 [[material]]\nname = \"mirror\"\ntype = \"conductor\"\nreflectance = [1, 1, 1]\n";
    let blend = |keys: &str| {
        with(&format!(
            "{parts}[[material]]\nname = \"mix\"\ntype = \"blend\"\n{keys}\n"
        ))
    };
    let s = load_str(
        &blend("first = \"matte\"\nsecond = \"metal\"\nweight = 0.3"),
        "blend.toml",
        None,
    )
    .unwrap();
    let mix = s.materials.iter().find(|m| m.name == "mix").unwrap();
    assert!(
        matches!(mix.bsdf, lodestar::bsdf::Bsdf::Blend(_)),
        "{:?}",
        mix.bsdf
    );
    check(
        &blend(&format!(
            "first = \"matte\"\nsecond = \"mirror\" {MARK}\nweight = 0.3"
        )),
        &["'second'", "'mirror'", "delta lobe"],
    );
    check(
        &blend(&format!(
            "first = \"later\" {MARK}\nsecond = \"metal\"\nweight = 0.3"
        )),
        &["'first'", "'later'", "not defined before it"],
    );
    check(
        &blend(&format!(
            "first = \"matte\"\nsecond = \"metal\"\nweight = 1.5 {MARK}"
        )),
        &["'weight'", "[0, 1]", "1.5"],
    );
}
