//! Groups and instances: a shape with `group = "G"` belongs to group G and is drawn only
//! where an `instance` of G places it (`type = "instance"`, `group = "G"`, `transform`), the
//! instance's transform applied after the member's own, as Mitsuba's `shapegroup` and
//! `instance`. Each placement becomes a shape of its own in the scene (the geometry is copied,
//! not shared by a second level of the accelerator). Members cannot emit (lights are placed
//! once, as in Mitsuba) and an instance is not a member of a group (no nesting).

use super::*;
use crate::geometry::Transform;

/// One shape to build: its index in the description, the placement to apply after its own
/// transform, and the instance that placed it.
pub(super) struct Placed {
    pub index: usize,
    pub placement: Transform,
    pub instance: Option<String>,
}

impl Builder<'_> {
    /// Every shape to build, in file order: the shapes outside groups once each, and each
    /// instance's group members where it places them.
    pub(super) fn placed_shapes(&self, shapes: &[Spanned<ShapeDesc>]) -> Result<Vec<Placed>> {
        let src = self.src;
        let mut groups: HashMap<&str, Vec<usize>> = HashMap::new();
        for (i, s) in shapes.iter().enumerate() {
            let d = s.get_ref();
            let Some(g) = &d.group else { continue };
            if d.kind.get_ref() == "instance" {
                continue;
            }
            if let Some(e) = &d.emission {
                return src.err(
                    e.span(),
                    format!(
                        "a shape in group '{}' cannot emit (a light is placed once)",
                        g.get_ref()
                    ),
                );
            }
            groups.entry(g.get_ref().as_str()).or_default().push(i);
        }
        let mut out = Vec::new();
        for (i, s) in shapes.iter().enumerate() {
            let d = s.get_ref();
            if d.kind.get_ref() != "instance" {
                if d.group.is_none() {
                    out.push(Placed {
                        index: i,
                        placement: Transform::IDENTITY,
                        instance: None,
                    });
                }
                continue;
            }
            let mut keys = vec![
                ("material", at(&d.material)),
                ("emission", at(&d.emission)),
                ("emission_texture", at(&d.emission_texture)),
                ("interior", at(&d.interior)),
                ("exterior", at(&d.exterior)),
                ("cone_angle", at(&d.cone_angle)),
                ("cone_delta", at(&d.cone_delta)),
            ];
            keys.extend(d.geometry_keys());
            self.only(
                "an instance (it takes 'group', 'transform' and 'name')",
                &keys,
                &[],
            )?;
            let Some(g) = &d.group else {
                return src.err(s.span(), "an instance needs 'group': the group it draws");
            };
            let Some(members) = groups.get(g.get_ref().as_str()) else {
                let mut known: Vec<&str> = groups.keys().copied().collect();
                known.sort_unstable();
                return src.err(
                    g.span(),
                    format!(
                        "no shape belongs to group '{}' (groups: {})",
                        g.get_ref(),
                        if known.is_empty() {
                            "none".to_string()
                        } else {
                            known.join(", ")
                        }
                    ),
                );
            };
            let placement = self.transform(d.transform.as_ref())?;
            let name = d
                .name
                .clone()
                .unwrap_or_else(|| format!("instance #{}", i + 1));
            out.extend(members.iter().map(|&m| Placed {
                index: m,
                placement,
                instance: Some(name.clone()),
            }));
        }
        Ok(out)
    }
}
