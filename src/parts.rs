//! One render split across machines and merged back.
//!
//! `lodestar render ... --spp S --part I/N` renders the I-th of N disjoint slices (1 <= I <= N)
//! of the passes 0 .. S of the same deterministic render: passes `floor((I-1) S / N)` up to
//! `floor(I S / N)`. Every pass draws its random numbers from (seed, global pass, pixel), and
//! vcm's radius schedule follows the global pass index, so the slices are exactly the passes
//! the whole render would have made. `lodestar merge PARTS... -o out.exr` weights each part's
//! image by its pass count: the merged image is the whole render's, to f32 rounding.
//!
//! What can be split (each integrator's registry entry says, `Entry::parts`): pt, lt, bdpt,
//! vcm and bpm, and guided-pt and guided-bdpt when every part
//! renders with one saved guide cache (`-O load_guides=...`; parts that learn their own caches
//! would each render a different estimator). The Markov-chain integrators cannot: a chain's
//! states depend on all its earlier mutations and each render normalises by its own bootstrap,
//! so N short renders are not slices of one long one. Neither can `--time` budgets (pass counts
//! would depend on each machine's speed), `--dbor` (its cascade is a non-linear function of
//! all passes) or snapshots.
//!
//! Each part's EXR header records the slice (`part`, `first_pass`, `passes`, `total_spp`) and
//! what must agree for parts to belong together: integrator, settings (max_depth and every
//! option), seed, resolution and a fingerprint of the scene file's bytes (`scene_hash`).
//! `merge` refuses anything else, naming the file and the field.

use crate::error::{Error, Result};
use crate::film::Image;
use std::ops::Range;
use std::path::{Path, PathBuf};

/// Slice `index` (1-based) of `count`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Part {
    /// Which slice, from 1.
    pub index: u64,
    /// Number of slices.
    pub count: u64,
}

impl Part {
    /// `I/N` with 1 <= I <= N.
    pub fn parse(text: &str) -> Result<Part> {
        let parsed = text.split_once('/').and_then(|(i, n)| {
            let (index, count) = (i.trim().parse().ok()?, n.trim().parse().ok()?);
            (1..=count)
                .contains(&index)
                .then_some(Part { index, count })
        });
        parsed.ok_or_else(|| {
            Error::new(format!(
                "--part: expected I/N with 1 <= I <= N (e.g. 2/8), got '{text}'"
            ))
        })
    }

    /// The global passes of this slice of a render of `total` passes.
    pub fn passes(&self, total: u64) -> Range<u64> {
        let at = |i: u64| (i as u128 * total as u128 / self.count as u128) as u64;
        at(self.index - 1)..at(self.index)
    }
}

impl std::fmt::Display for Part {
    fn fmt(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
        write!(f, "{}/{}", self.index, self.count)
    }
}

/// What a `--part` render does: its global passes and the header fields that let `merge`
/// check the parts belong together.
pub struct Plan {
    /// The global pass indices this part renders.
    pub passes: Range<u64>,
    /// EXR header fields of the part: `part`, `first_pass`, `total_spp`, `scene_hash`.
    pub meta: Vec<(String, String)>,
}

/// Plan part `text` (`I/N`) of a render of `total` passes (`None`: a time budget), refusing
/// what cannot be split (see the module header; whether the integrator can is its registry
/// entry's `parts`, `integrators::check_parts`). `scene` is the scene file's bytes, for its
/// fingerprint.
pub fn plan(text: &str, total: Option<u64>, dbor_or_snapshots: bool, scene: &[u8]) -> Result<Plan> {
    let part = Part::parse(text)?;
    let Some(total) = total else {
        return Err(Error::new(
            "--part needs --spp (a time budget's pass count depends on the machine)",
        ));
    };
    if dbor_or_snapshots {
        return Err(Error::new(
            "--part cannot be combined with --dbor or --snapshots (neither merges linearly)",
        ));
    }
    let passes = part.passes(total);
    if passes.is_empty() {
        return Err(Error::new(format!(
            "--part {part}: {total} passes split {} ways leaves this part none; use at most {total} parts",
            part.count
        )));
    }
    let meta = vec![
        ("part".to_string(), part.to_string()),
        ("first_pass".to_string(), passes.start.to_string()),
        ("total_spp".to_string(), total.to_string()),
        ("scene_hash".to_string(), fingerprint(scene)),
    ];
    Ok(Plan { passes, meta })
}

/// FNV-1a (64 bits) of a scene file's bytes, in hex: parts rendered from different versions of
/// a scene differ here.
pub fn fingerprint(bytes: &[u8]) -> String {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for &b in bytes {
        h ^= b as u64;
        h = h.wrapping_mul(0x0000_0100_0000_01b3);
    }
    format!("{h:016x}")
}

/// Header fields every part of one render shares.
const SHARED: [&str; 5] = ["integrator", "settings", "seed", "scene_hash", "total_spp"];

/// One part read back: its file, image and header.
pub struct PartFile {
    /// The EXR file.
    pub path: PathBuf,
    /// Its image.
    pub image: Image,
    /// Its header's text attributes.
    pub meta: Vec<(String, String)>,
}

impl PartFile {
    /// Read a part's EXR with its header.
    pub fn read(path: &Path) -> Result<PartFile> {
        let (image, meta) = Image::read_exr(path)?;
        Ok(PartFile {
            path: path.to_path_buf(),
            image,
            meta,
        })
    }

    fn get(&self, key: &str) -> Result<&str> {
        self.meta
            .iter()
            .find(|(k, _)| k == key)
            .map(|(_, v)| v.as_str())
            .ok_or_else(|| {
                Error::new(format!(
                    "{}: header has no '{key}': not a part of a split render (render it with --part I/N)",
                    self.path.display()
                ))
            })
    }

    fn number(&self, key: &str) -> Result<u64> {
        let v = self.get(key)?;
        v.parse().map_err(|_| {
            Error::new(format!(
                "{}: header field '{key}' is '{v}', expected a whole number",
                self.path.display()
            ))
        })
    }
}

/// Merge the parts of one render: the image weighted by pass counts, and the header of the
/// whole render (`passes`/`spp` the total, `seconds` summed, `invalid_samples` summed, the
/// slice fields dropped, `merged_parts` = N).
pub fn merge(parts: &[PartFile]) -> Result<(Image, Vec<(String, String)>)> {
    let first = parts
        .first()
        .ok_or_else(|| Error::new("merge: no parts given"))?;
    let part_of = |p: &PartFile| -> Result<Part> {
        Part::parse(p.get("part")?).map_err(|_| {
            Error::new(format!(
                "{}: header field 'part' is '{}', expected I/N",
                p.path.display(),
                p.get("part").unwrap_or("")
            ))
        })
    };
    let n = part_of(first)?.count;
    let total = first.number("total_spp")?;
    let mut seen: Vec<Option<&Path>> = vec![None; n as usize];
    for p in parts {
        let part = part_of(p)?;
        for key in SHARED {
            let (a, b) = (first.get(key)?, p.get(key)?);
            if a != b {
                return Err(Error::new(format!(
                    "{}: '{key}' is '{b}' but {} has '{a}': not parts of the same render",
                    p.path.display(),
                    first.path.display()
                )));
            }
        }
        if (p.image.width, p.image.height) != (first.image.width, first.image.height) {
            return Err(Error::new(format!(
                "{}: image is {}x{} but {} is {}x{}",
                p.path.display(),
                p.image.width,
                p.image.height,
                first.path.display(),
                first.image.width,
                first.image.height
            )));
        }
        if part.count != n {
            return Err(Error::new(format!(
                "{}: 'part' is {part} but {} is one of {n}",
                p.path.display(),
                first.path.display()
            )));
        }
        let expected = part.passes(total);
        let (from, passes) = (p.number("first_pass")?, p.number("passes")?);
        if from != expected.start || passes != expected.end - expected.start {
            return Err(Error::new(format!(
                "{}: part {part} of {total} passes should hold passes {}..{}, its header says {from}..{}",
                p.path.display(),
                expected.start,
                expected.end,
                from + passes
            )));
        }
        let slot = &mut seen[part.index as usize - 1];
        if let Some(other) = slot {
            return Err(Error::new(format!(
                "{}: part {part} is also in {}",
                p.path.display(),
                other.display()
            )));
        }
        *slot = Some(&p.path);
    }
    let missing: Vec<String> = (seen.iter().enumerate())
        .filter(|(_, s)| s.is_none())
        .map(|(i, _)| format!("{}/{n}", i + 1))
        .collect();
    if !missing.is_empty() {
        return Err(Error::new(format!(
            "merge: missing part{} {} of this render",
            if missing.len() > 1 { "s" } else { "" },
            missing.join(", ")
        )));
    }
    // Pass-weighted sum in f64: each part's image is its passes' mean.
    let mut sum = vec![glam::DVec3::ZERO; first.image.pixels.len()];
    let (mut seconds, mut invalid) = (0.0f64, 0u64);
    for p in parts {
        let w = p.number("passes")? as f64;
        for (s, v) in sum.iter_mut().zip(&p.image.pixels) {
            *s += v.as_dvec3() * w;
        }
        seconds += p
            .get("seconds")
            .ok()
            .and_then(|s| s.parse().ok())
            .unwrap_or(0.0);
        invalid += p.number("invalid_samples").unwrap_or(0);
    }
    let image = Image {
        width: first.image.width,
        height: first.image.height,
        pixels: sum.iter().map(|s| (*s / total as f64).as_vec3()).collect(),
    };
    let mut meta: Vec<(String, String)> = first
        .meta
        .iter()
        .filter(|(k, _)| {
            !matches!(
                k.as_str(),
                "part"
                    | "first_pass"
                    | "passes"
                    | "spp"
                    | "seconds"
                    | "invalid_samples"
                    | "threads"
            )
        })
        .cloned()
        .collect();
    meta.extend([
        ("passes".to_string(), total.to_string()),
        ("spp".to_string(), total.to_string()),
        ("seconds".to_string(), format!("{seconds:.3}")),
        ("invalid_samples".to_string(), invalid.to_string()),
        ("merged_parts".to_string(), n.to_string()),
    ]);
    Ok((image, meta))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn slices_cover_every_pass_once() {
        for total in [1u64, 2, 7, 64, 1000] {
            for count in 1..=9u64 {
                let mut next = 0;
                for index in 1..=count {
                    let r = Part { index, count }.passes(total);
                    assert_eq!(r.start, next, "{index}/{count} of {total}");
                    next = r.end;
                }
                assert_eq!(next, total);
            }
        }
        assert_eq!(Part::parse("2/8").unwrap().passes(64), 8..16);
    }

    #[test]
    fn bad_parts_are_refused() {
        for t in ["0/4", "5/4", "1/0", "a/4", "3", "-1/4", ""] {
            assert!(Part::parse(t).is_err(), "{t}");
        }
        assert_eq!(Part::parse(" 4 / 4 ").unwrap(), Part { index: 4, count: 4 });
    }
}
