//! `<transform>` elements: `translate`, `rotate`, `scale`, `matrix` and `lookat` (`lookAt` in a
//! Mitsuba 0.x scene), composed in the order written.

use super::Xml;
use crate::error::Result;
use glam::{Mat4, Vec3, Vec4};
use roxmltree::Node;

impl Xml<'_, '_> {
    /// A `<transform>` element: its operations composed in the order written.
    pub(super) fn transform(&self, node: Node) -> Result<Mat4> {
        let mut m = Mat4::IDENTITY;
        for op in node.children().filter(Node::is_element) {
            let step = match op.tag_name().name() {
                "translate" => Mat4::from_translation(self.xyz(op, 0.0)?),
                "scale" => Mat4::from_scale(self.xyz(op, 1.0)?),
                "rotate" => {
                    let axis = self.xyz(op, 0.0)?;
                    let angle = match self.attr(op, "angle")? {
                        Some(a) => self.number(op, &a)?,
                        None => return self.err(op, "<rotate> needs 'angle' (degrees)"),
                    };
                    let Some(axis) = axis.try_normalize() else {
                        return self.err(op, "<rotate> needs a non-zero axis (x, y, z or value)");
                    };
                    Mat4::from_axis_angle(axis, angle.to_radians())
                }
                "matrix" => {
                    let v = self.attr(op, "value")?.unwrap_or_default();
                    let n = self.numbers(op, &v)?;
                    match n.len() {
                        16 => Mat4::from_cols_slice(&n).transpose(),
                        9 => Mat4::from_mat3(glam::Mat3::from_cols_slice(&n).transpose()),
                        k => {
                            return self
                                .err(op, format!("<matrix> needs 16 (or 9) numbers, got {k}"));
                        }
                    }
                }
                "lookat" | "lookAt" if op.tag_name().name() == "lookat" || self.before_2 => {
                    let p = |key: &str| -> Result<Vec3> {
                        match self.attr(op, key)? {
                            Some(v) => match self.numbers(op, &v)?.as_slice() {
                                [x, y, z] => Ok(Vec3::new(*x, *y, *z)),
                                _ => {
                                    self.err(op, format!("<lookat> '{key}' must be three numbers"))
                                }
                            },
                            None if key == "up" => Ok(Vec3::Y),
                            None => self.err(op, format!("<lookat> needs '{key}'")),
                        }
                    };
                    let (origin, target, up) = (p("origin")?, p("target")?, p("up")?);
                    let Some(dir) = (target - origin).try_normalize() else {
                        return self.err(op, "<lookat> 'target' must differ from 'origin'");
                    };
                    let Some(left) = up.cross(dir).try_normalize() else {
                        return self.err(
                            op,
                            "<lookat> 'up' must not be zero or parallel to the view direction",
                        );
                    };
                    let new_up = dir.cross(left);
                    Mat4::from_cols(
                        left.extend(0.0),
                        new_up.extend(0.0),
                        dir.extend(0.0),
                        origin.extend(1.0),
                    )
                }
                other => {
                    return self.err(
                        op,
                        format!("<{other}> in a transform (expected translate, rotate, scale, matrix or lookat)"),
                    );
                }
            };
            m = step * m;
        }
        if m.row(3) != Vec4::W {
            return self.err(
                node,
                "the transform is projective (its last row is not 0 0 0 1)",
            );
        }
        Ok(m)
    }
}
