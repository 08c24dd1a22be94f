//! The statistics a guided render reports (`RenderResult::stats`): the cache, the learning
//! and render phases, the share's decision, and where U's error sits against the cache
//! (`docs/cli.md`, "The guided integrators", says what each means).

use super::cache::GuideCache;
use super::coverage;
use super::estimator::{COVERAGE_CLASSES, FAILURE_REASONS, PG_ZERO_VERTICES, Stats};
use super::share;

/// What the driver knows at the end of a render.
pub struct Facts<'a> {
    /// The cache rendered with.
    pub cache: &'a GuideCache,
    /// Learning passes run.
    pub learn_passes: u64,
    /// Seconds spent learning, rebuilds included.
    pub learn_seconds: f64,
    /// Seconds of those spent rebuilding the cache.
    pub rebuild_seconds: f64,
    /// Seconds spent in the render passes.
    pub render_seconds: f64,
    /// The unguided share the render used.
    pub alpha: f64,
    /// What measuring the share decided (`None` when it was not measured).
    pub decision: Option<&'a share::Decision>,
    /// Counters of the learning passes.
    pub learning: &'a Stats,
    /// Counters of the render passes.
    pub render: &'a Stats,
    /// Learning passes kept in the image.
    pub kept: u64,
    /// Of those, the passes that kept their mixed estimate (the rest kept U's own).
    pub kept_guided: u64,
    /// The render passes' image variance by coverage class, plus the guided samples' share.
    pub class_var: Option<[f64; coverage::CLASSES + 1]>,
}

/// A statistic as a (key, value) pair of strings.
pub fn stat(k: &str, v: impl ToString) -> (String, String) {
    (k.to_string(), v.to_string())
}

/// The render's statistics, in a fixed order.
pub fn stats(f: &Facts) -> Vec<(String, String)> {
    let (cache, rs, stats) = (f.cache, f.render, f.learning);
    let (learn_passes, learn_seconds, rebuild_seconds) =
        (f.learn_passes, f.learn_seconds, f.rebuild_seconds);
    let (render_seconds, alpha, decision, kept, class_var) =
        (f.render_seconds, f.alpha, f.decision, f.kept, f.class_var);
    vec![
        stat("guide_paths", cache.len()),
        stat(
            "bytes_per_guide_path",
            format!("{:.0}", cache.bytes_per_path()),
        ),
        stat("learning_iterations", learn_passes),
        stat("learning_seconds", format!("{learn_seconds:.3}")),
        stat("cache_rebuild_seconds", format!("{rebuild_seconds:.3}")),
        stat("render_seconds", format!("{render_seconds:.3}")),
        stat("unguided_share", format!("{alpha:.3}")),
        stat(
            "share_relative_cost",
            decision.as_ref().map_or("-".to_string(), |d| {
                let cells: Vec<String> = share::RATIOS
                    .iter()
                    .zip(d.relative)
                    .map(|(r, c)| format!("{r:.3}:{c:.3}"))
                    .collect();
                cells.join("/")
            }),
        ),
        stat("rays_unguided", rs.rays_u),
        stat("rays_guided", rs.rays_g),
        stat("pg_candidates", rs.pg_candidates),
        stat("learning_passes_kept", kept),
        stat("learning_passes_kept_guided", f.kept_guided),
        stat("guided_samples", rs.guided),
        stat("chain_step_samples", rs.chain_steps),
        stat(
            "failed_guided_share",
            format!("{:.4}", rs.failed as f64 / rs.guided.max(1) as f64),
        ),
        stat(
            "mean_pg_candidates",
            format!(
                "{:.2}",
                rs.pg_candidates as f64 / rs.pg_evaluations.max(1) as f64
            ),
        ),
        stat("pg_evaluations", rs.pg_evaluations),
        stat("invalid_unguided_paths", rs.invalid),
        stat(
            "unguided_density_disagreements",
            stats.pu_disagreements + rs.pu_disagreements,
        ),
        stat("learning_guided_samples", stats.guided),
        stat("guide_structures", cache.structures()),
        stat(
            "unguided_paths_by_coverage",
            coverage_shares(&rs.coverage_paths.map(|n| n as f64)),
        ),
        stat(
            "unguided_second_moment_by_coverage",
            coverage_shares(&rs.coverage_m2),
        ),
        stat(
            "variance_by_coverage",
            class_var.map_or_else(
                || "n/a".to_string(),
                |v| {
                    let names = coverage::CLASS_NAMES.iter().map(|c| c.to_string());
                    shares(names, &v[..coverage::CLASSES])
                },
            ),
        ),
        stat(
            "class_variance_over_total",
            class_var.map_or_else(
                || "n/a".to_string(),
                |v| {
                    let classes: f64 = v[..coverage::CLASSES].iter().sum();
                    format!(
                        "{:.3}",
                        classes / v[coverage::CLASSES].max(f64::MIN_POSITIVE)
                    )
                },
            ),
        ),
        stat(
            "pg_zero_second_moment_by_vertex",
            vertex_shares(&rs.pg_zero_m2_by_vertex),
        ),
        stat(
            &format!("failures_{FAILURE_REASONS}"),
            format!("{:?}", rs.reasons),
        ),
        stat(
            "failed_walks_by_vertex",
            vertex_shares(&rs.failed_by_vertex.map(|n| n as f64)),
        ),
    ]
}

/// `class:share/...` of U's paths or second moment by [`COVERAGE_CLASSES`].
fn coverage_shares(sums: &[f64; 3]) -> String {
    shares(COVERAGE_CLASSES.iter().map(|c| c.to_string()), sums)
}

/// `x1:share/.../x7+:share` of the p_g = 0 class's second moment by the vertex where p_g
/// vanished, or of the failed guided walks by the vertex they were drawing.
fn vertex_shares(sums: &[f64; PG_ZERO_VERTICES]) -> String {
    let names = (1..=PG_ZERO_VERTICES).map(|v| match v {
        PG_ZERO_VERTICES => format!("x{v}+"),
        _ => format!("x{v}"),
    });
    shares(names, sums)
}

/// `name:share/...`, each sum's share of their total.
fn shares(names: impl Iterator<Item = String>, sums: &[f64]) -> String {
    let total: f64 = sums.iter().sum();
    let cells: Vec<String> = names
        .zip(sums)
        .map(|(name, x)| format!("{name}:{:.3}", x / total.max(f64::MIN_POSITIVE)))
        .collect();
    cells.join("/")
}
