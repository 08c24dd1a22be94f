//! The specular-chain step's settings, kept on the guide cache (p_g and the sampler read them
//! alike).

/// Default probability of the step where a guide's chain allows it (option `manifold`): off,
/// since it does not yet pay at equal time (`docs/results.md`, "The specular-chain step").
pub const DEFAULT_SHARE: f64 = 0.0;

/// The step's settings (on the cache: p_g and the sampler read them alike).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ManifoldSettings {
    /// Probability of the step where the guide's chain allows it; 0 turns it off.
    pub share: f64,
    /// Testing hooks (negative controls), never changed by the renderer: a factor on the
    /// Jacobian determinant (1; 0 leaves it out of the density), and whether the basin
    /// indicator applies.
    pub jacobian: f64,
    /// Whether the basin indicator applies (see `jacobian`).
    pub basin: bool,
}

impl Default for ManifoldSettings {
    fn default() -> Self {
        ManifoldSettings {
            share: DEFAULT_SHARE,
            jacobian: 1.0,
            basin: true,
        }
    }
}
