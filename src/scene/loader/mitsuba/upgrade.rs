//! Mitsuba 0.x scenes as Mitsuba 3 reads them: the scene's version and the property names
//! upgrade from camelCase (the rest of the upgrade, `<lookAt>` and the diffuse BSDF's
//! `diffuse_reflectance`, is applied where those are read).

/// A scene's `version` attribute as (major, minor, patch).
pub(super) fn version(v: &str) -> Option<(u32, u32, u32)> {
    let mut parts = v.trim().split('.').map(|p| p.trim().parse::<u32>().ok());
    let triple = (parts.next()??, parts.next()??, parts.next()??);
    parts.next().is_none().then_some(triple)
}

/// A Mitsuba 0.x property name in Mitsuba 3's spelling: camelCase to snake_case as Mitsuba 3
/// upgrades it (`maxDepth` -> `max_depth`, `intIOR` -> `int_ior`, `sampleCount` ->
/// `sample_count`): an underscore where a lower-case letter meets an upper-case one, and that
/// run of capitals lowered.
pub(super) fn snake_case(name: &str) -> String {
    let c: Vec<char> = name.chars().collect();
    let mut out = String::with_capacity(name.len() + 4);
    let mut i = 0;
    while i < c.len() {
        out.push(c[i]);
        if c[i].is_ascii_lowercase() && i + 1 < c.len() && c[i + 1].is_ascii_uppercase() {
            out.push('_');
            i += 1;
            while i < c.len() && c[i].is_ascii_uppercase() {
                out.push(c[i].to_ascii_lowercase());
                i += 1;
            }
            continue;
        }
        i += 1;
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn versions_and_names_upgrade_as_mitsuba_3_does() {
        assert_eq!(version("0.5.0"), Some((0, 5, 0)));
        assert_eq!(version("3.0"), None);
        assert_eq!(snake_case("maxDepth"), "max_depth");
        assert_eq!(snake_case("intIOR"), "int_ior");
        assert_eq!(snake_case("toWorld"), "to_world");
        assert_eq!(snake_case("sample_count"), "sample_count");
    }
}
