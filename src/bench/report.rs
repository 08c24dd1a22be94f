//! The numbers of a bench: one row per run and one median row per integrator, with the MSE
//! speed-up against the first integrator (its MSE over this one's at equal time: per run for
//! the same seed, `median MSE(first) / median MSE(this)` for the medians), printed as a table
//! and written as `report.csv`; the curves as `curves.csv`.
//!
//! Both CSV files have a header line and comma-separated fields (a field with a comma, quote
//! or newline is quoted, quotes doubled). `report.csv`: `scene, integrator, run, seed, seconds,
//! spp, passes, mse, rmse, rel_mse, speedup, variance, var_speedup`, where `run` is the run's
//! index or `median` (seed then gives the first seed); `variance` is the integrator's
//! reference-free variance estimate from its seeds (`run::seed_pair_variance`, the same on
//! every row of an integrator, NaN with one run) and `var_speedup` the first integrator's
//! variance over this one's. `curves.csv`: `scene, integrator, run, seed, seconds, spp,
//! passes, mse, rmse, rel_mse`. `stats.csv`: `scene, integrator, run, seed, key, value`, every
//! run's end-of-render statistics (what `lodestar render` prints after `stats:`), one per line.

use super::run::IntegratorRuns;
use crate::error::Result;
use crate::film::atomic_write;
use crate::metrics::median;
use std::fmt::Write as _;
use std::path::Path;

/// One line of the report: a run, or the medians of an integrator's runs.
#[derive(Debug, Clone)]
pub struct Row {
    /// The integrator entry.
    pub integrator: String,
    /// Run index, or `None` for the median row.
    pub run: Option<usize>,
    /// The run's seed (the first seed for a median row).
    pub seed: u64,
    /// How many runs the row summarises (1 for a run).
    pub runs: usize,
    /// Render seconds (median over the runs for a median row, as for every number below).
    pub seconds: f64,
    /// Samples per pixel.
    pub spp: f64,
    /// Passes.
    pub passes: f64,
    /// MSE against the reference.
    pub mse: f64,
    /// RMSE against the reference.
    pub rmse: f64,
    /// relMSE against the reference.
    pub rel_mse: f64,
    /// The first integrator's MSE over this one's (same run, or medians).
    pub speedup: f64,
    /// The integrator's seed-pair variance (`IntegratorRuns::variance`).
    pub variance: f64,
    /// The first integrator's seed-pair variance over this one's.
    pub var_speedup: f64,
}

/// Per-run rows, in integrator order then run order.
pub fn run_rows(all: &[IntegratorRuns]) -> Vec<Row> {
    let mut rows = Vec::new();
    for ir in all {
        for (k, r) in ir.runs.iter().enumerate() {
            let first = all[0].runs.get(k).map_or(f64::NAN, |f| f.error.mse);
            rows.push(Row {
                integrator: ir.name.clone(),
                run: Some(k),
                seed: r.seed,
                runs: 1,
                seconds: r.seconds,
                spp: r.spp as f64,
                passes: r.passes as f64,
                mse: r.error.mse,
                rmse: r.error.rmse,
                rel_mse: r.error.rel_mse,
                speedup: first / r.error.mse,
                variance: ir.variance,
                var_speedup: all[0].variance / ir.variance,
            });
        }
    }
    rows
}

/// One median row per integrator.
pub fn median_rows(all: &[IntegratorRuns]) -> Vec<Row> {
    let med = |ir: &IntegratorRuns, f: fn(&super::run::Run) -> f64| {
        median(&ir.runs.iter().map(f).collect::<Vec<_>>())
    };
    let first_mse = all.first().map_or(f64::NAN, |f| med(f, |r| r.error.mse));
    all.iter()
        .map(|ir| {
            let mse = med(ir, |r| r.error.mse);
            Row {
                integrator: ir.name.clone(),
                run: None,
                seed: ir.runs.first().map_or(0, |r| r.seed),
                runs: ir.runs.len(),
                seconds: med(ir, |r| r.seconds),
                spp: med(ir, |r| r.spp as f64),
                passes: med(ir, |r| r.passes as f64),
                mse,
                rmse: med(ir, |r| r.error.rmse),
                rel_mse: med(ir, |r| r.error.rel_mse),
                speedup: first_mse / mse,
                variance: ir.variance,
                var_speedup: all[0].variance / ir.variance,
            }
        })
        .collect()
}

impl Row {
    /// The run column: the seed for a single run, `median of N` for a summary of N runs.
    pub fn run_label(&self) -> String {
        match (self.run, self.runs) {
            (None, n) if n > 1 => format!("median of {n}"),
            _ => format!("seed {}", self.seed),
        }
    }
}

/// Column headers of the bench tables (text and HTML), in [`Row::cells`] order.
pub const COLUMNS: [&str; 12] = [
    "scene",
    "integrator",
    "run",
    "seconds",
    "spp",
    "passes",
    "MSE",
    "RMSE",
    "relMSE",
    "speedup",
    "var(seeds)",
    "speedup(var)",
];

impl Row {
    /// The row's cells as printed, in [`COLUMNS`] order.
    pub fn cells(&self, scene: &str) -> [String; 12] {
        [
            scene.to_string(),
            self.integrator.clone(),
            self.run_label(),
            format!("{:.2}", self.seconds),
            count(self.spp),
            count(self.passes),
            format!("{:.4e}", self.mse),
            format!("{:.4e}", self.rmse),
            format!("{:.4e}", self.rel_mse),
            format!("{:.3}", self.speedup),
            format!("{:.4e}", self.variance),
            format!("{:.3}", self.var_speedup),
        ]
    }
}

/// The text table printed by `lodestar bench`: one row per integrator (medians when there
/// are several runs); text columns left-aligned, numbers right-aligned.
pub fn table(scene: &str, rows: &[Row]) -> String {
    let cells: Vec<[String; 12]> = rows.iter().map(|r| r.cells(scene)).collect();
    let widths: Vec<usize> = (0..COLUMNS.len())
        .map(|c| {
            cells
                .iter()
                .map(|r| r[c].len())
                .chain([COLUMNS[c].len()])
                .max()
                .unwrap_or(0)
        })
        .collect();
    let line = |row: &[String]| {
        let fields: Vec<String> = row
            .iter()
            .enumerate()
            .map(|(c, f)| match c {
                0..=2 => format!("{f:<w$}", w = widths[c]),
                _ => format!("{f:>w$}", w = widths[c]),
            })
            .collect();
        fields.join(" ").trim_end().to_string() + "\n"
    };
    let header: Vec<String> = COLUMNS.iter().map(|c| c.to_string()).collect();
    let mut s = line(&header);
    for r in &cells {
        s.push_str(&line(r));
    }
    s
}

/// A count, with one decimal when a median of an even number of runs fell between two.
fn count(x: f64) -> String {
    if x.fract() == 0.0 {
        format!("{x:.0}")
    } else {
        format!("{x:.1}")
    }
}

/// Write `report.csv`: the per-run rows, then the median rows.
pub fn write_report_csv(path: &Path, scene: &str, all: &[IntegratorRuns]) -> Result<()> {
    let mut s = String::from(
        "scene,integrator,run,seed,seconds,spp,passes,mse,rmse,rel_mse,speedup,variance,var_speedup\n",
    );
    for r in run_rows(all).iter().chain(&median_rows(all)) {
        let run = r.run.map_or("median".to_string(), |k| k.to_string());
        let fields = [
            field(scene),
            field(&r.integrator),
            run,
            r.seed.to_string(),
            format!("{:.6}", r.seconds),
            r.spp.to_string(),
            r.passes.to_string(),
            format!("{:.9e}", r.mse),
            format!("{:.9e}", r.rmse),
            format!("{:.9e}", r.rel_mse),
            format!("{:.9e}", r.speedup),
            format!("{:.9e}", r.variance),
            format!("{:.9e}", r.var_speedup),
        ];
        s.push_str(&fields.join(","));
        s.push('\n');
    }
    write_text(path, &s)
}

/// Write `stats.csv`: every run's end-of-render statistics, one line per statistic, sorted
/// by key within a run (so a bench gathered from parts writes the same lines in the same
/// order as one machine: a part's EXR header does not keep the render's order).
pub fn write_stats_csv(path: &Path, scene: &str, all: &[IntegratorRuns]) -> Result<()> {
    let mut s = String::from("scene,integrator,run,seed,key,value\n");
    for ir in all {
        for (k, r) in ir.runs.iter().enumerate() {
            let mut stats: Vec<&(String, String)> = r.stats.iter().collect();
            stats.sort_by(|a, b| a.0.cmp(&b.0));
            for (key, value) in stats {
                let _ = writeln!(
                    s,
                    "{},{},{k},{},{},{}",
                    field(scene),
                    field(&ir.name),
                    r.seed,
                    field(key),
                    field(value)
                );
            }
        }
    }
    write_text(path, &s)
}

/// Write `curves.csv`: every curve point of every run.
pub fn write_curves_csv(path: &Path, scene: &str, all: &[IntegratorRuns]) -> Result<()> {
    let mut s = String::from("scene,integrator,run,seed,seconds,spp,passes,mse,rmse,rel_mse\n");
    for ir in all {
        for (k, r) in ir.runs.iter().enumerate() {
            for q in &r.curve {
                let _ = writeln!(
                    s,
                    "{},{},{k},{},{:.6},{},{},{:.9e},{:.9e},{:.9e}",
                    field(scene),
                    field(&ir.name),
                    r.seed,
                    q.seconds,
                    q.spp,
                    q.passes,
                    q.error.mse,
                    q.error.rmse,
                    q.error.rel_mse
                );
            }
        }
    }
    write_text(path, &s)
}

/// A CSV field, quoted when it needs to be.
fn field(text: &str) -> String {
    if text.contains([',', '"', '\n', '\r']) {
        format!("\"{}\"", text.replace('"', "\"\""))
    } else {
        text.to_string()
    }
}

/// Write a text file atomically.
pub fn write_text(path: &Path, text: &str) -> Result<()> {
    atomic_write(path, |tmp| {
        std::fs::write(tmp, text).map_err(|e| e.to_string())
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bench::run::Run;
    use crate::film::Image;
    use crate::metrics::Comparison;
    use glam::DVec3;

    fn runs(name: &str, mses: &[f64]) -> IntegratorRuns {
        let runs = mses
            .iter()
            .enumerate()
            .map(|(k, &mse)| {
                let error = Comparison {
                    mean_a: DVec3::ZERO,
                    mean_b: DVec3::ZERO,
                    mse,
                    rmse: mse.sqrt(),
                    rel_mse: 2.0 * mse,
                };
                Run {
                    seed: 10 + k as u64,
                    seconds: 1.0 + k as f64,
                    spp: 4 + k as u64,
                    passes: 4 + k as u64,
                    error,
                    curve: Vec::new(),
                    stats: Vec::new(),
                }
            })
            .collect();
        IntegratorRuns {
            name: name.to_string(),
            settings: String::new(),
            runs,
            image: Image::new(1, 1),
            metadata: Vec::new(),
            variance: mses[0] / 2.0,
        }
    }

    /// Speed-ups: per run against the first integrator's run with the same seed, and median
    /// over median for the summary.
    #[test]
    fn speedups_and_medians() {
        let all = [runs("a", &[4.0, 8.0, 6.0]), runs("b", &[1.0, 4.0, 2.0])];
        let per_run = run_rows(&all);
        let speed: Vec<f64> = per_run.iter().map(|r| r.speedup).collect();
        assert_eq!(speed, [1.0, 1.0, 1.0, 4.0, 2.0, 3.0]);
        let med = median_rows(&all);
        assert_eq!((med[0].mse, med[1].mse), (6.0, 2.0));
        assert_eq!((med[0].speedup, med[1].speedup), (1.0, 3.0));
        assert_eq!(
            (med[1].seconds, med[1].spp, med[1].rel_mse),
            (2.0, 5.0, 4.0)
        );
        assert_eq!(med[1].run_label(), "median of 3");
        // Variance speed-up: the first integrator's seed-pair variance over this one's.
        assert_eq!((med[0].var_speedup, med[1].var_speedup), (1.0, 4.0));
        assert_eq!(per_run[4].var_speedup, 4.0);
        let t = table("s.toml", &med);
        assert_eq!(t.lines().count(), 3);
        assert!(t.lines().nth(2).unwrap().contains("3.000"), "{t}");
    }

    /// The seed-pair variance of three constant images 1, 2, 4 (one pixel, three channels):
    /// pair MSEs 1, 9, 4, halved and averaged = 14 / 6; one image has none.
    #[test]
    fn seed_pair_variance_averages_half_pair_mses() {
        let img = |v: f32| {
            let mut i = Image::new(1, 1);
            i.pixels[0] = glam::Vec3::splat(v);
            i
        };
        let v = crate::bench::run::seed_pair_variance(&[img(1.0), img(2.0), img(4.0)], None);
        assert!((v.unwrap() - 14.0 / 6.0).abs() < 1e-12);
        let one = crate::bench::run::seed_pair_variance(&[img(1.0)], None);
        assert!(one.unwrap().is_nan());
    }

    #[test]
    fn csv_fields_are_quoted_when_needed() {
        assert_eq!(field("a.toml"), "a.toml");
        assert_eq!(field("a,b"), "\"a,b\"");
        assert_eq!(field("say \"hi\""), "\"say \"\"hi\"\"\"");
    }
}
