//! What the Mitsuba plugins produce (the scene description and the elements already
//! converted), shared by `plugins.rs`, `shapes.rs` and `materials.rs`, and the two helpers both use.

use super::super::SceneDesc;
use super::{SensorMedium, Xml, span};
use crate::error::Result;
use roxmltree::{Node, NodeId};
use std::collections::HashMap;
use toml::Spanned;

/// What the plugins produce, and the objects already converted (by element).
pub(super) struct Out {
    pub(super) desc: SceneDesc,
    /// BSDF element -> material name (`None`: a `null` BSDF).
    pub(super) bsdfs: HashMap<NodeId, Option<String>>,
    pub(super) media: HashMap<NodeId, String>,
    /// Name of Mitsuba's default BSDF (diffuse 0.5, one-sided), once a shape needed it.
    pub(super) default_bsdf: Option<String>,
    pub(super) sensor_medium: Option<SensorMedium>,
}

/// `v` spanned at `node`'s position in the file (for line-numbered errors).
pub(super) fn s<T>(node: Node, v: T) -> Spanned<T> {
    Spanned::new(span(node), v)
}

/// A plugin's `type`, with `$name` parameters substituted (`<integrator type="$integrator">`).
pub(super) fn kind(xml: &Xml, n: Node) -> Result<String> {
    xml.subst(n, xml.raw(n, "type")?)
}
