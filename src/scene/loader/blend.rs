//! `type = "blend"` materials: two materials defined before them, mixed by a weight
//! (`bsdf/blend.rs`).

use super::*;

impl Builder<'_> {
    /// A `blend` material's BSDF and sidedness: its `first` and `second` materials, defined
    /// before it, mixed by `weight` or `weight_texture`. Each must be without delta lobes and
    /// without a normal map or opacity of its own, and the two sided alike.
    pub(super) fn blend(
        &self,
        m: &Spanned<MaterialDesc>,
        earlier: &[Material],
        what: &str,
    ) -> Result<(Bsdf, bool)> {
        let (src, d) = (self.src, m.get_ref());
        let part = |key: &str,
                    v: &Option<Spanned<String>>|
         -> Result<(&Material, std::ops::Range<usize>)> {
            let name = src.required(v, m.span(), key, what)?;
            let Some(found) = earlier.iter().find(|x| &x.name == name.get_ref()) else {
                return src.err(
                    name.span(),
                    format!(
                        "{what}: '{key}' names material '{}', which is not defined before it",
                        name.get_ref()
                    ),
                );
            };
            let bad = if found.bsdf.has_delta_lobe() {
                Some("has a delta lobe (a mirror, smooth glass, smooth plastic or a mask)")
            } else if found.normal_map.is_some() {
                Some("has a normal or bump map of its own (put it on the blend)")
            } else if matches!(found.bsdf, Bsdf::Blend(_)) {
                Some("is a blend itself")
            } else {
                None
            };
            if let Some(why) = bad {
                return src.err(
                    name.span(),
                    format!(
                        "{what}: '{key}' material '{}' {why}; a blend mixes two smooth BSDFs",
                        found.name
                    ),
                );
            }
            Ok((found, name.span()))
        };
        let (first, _) = part("first", &d.first)?;
        let (second, at) = part("second", &d.second)?;
        if first.one_sided != second.one_sided {
            return src.err(
                at,
                format!(
                    "{what}: '{}' and '{}' differ in 'one_sided' (expected the same)",
                    first.name, second.name
                ),
            );
        }
        let Some(weight) = self.fraction(("weight", &d.weight), &d.weight_texture, what)? else {
            return src.err(
                m.span(),
                format!("{what} needs 'weight' or 'weight_texture'"),
            );
        };
        let blend = crate::bsdf::Blend::new(first.bsdf.clone(), second.bsdf.clone(), weight)
            .expect("both parts were checked to be without delta lobes");
        Ok((Bsdf::Blend(Box::new(blend)), first.one_sided))
    }
}
