//! What the rows of a learning pass collect for the seeder: each row's brightest candidate
//! paths ([`Candidate`], with the sampling that made it, [`Source`]) and the luminance of
//! every sample ([`LearnRow`]).

use super::cache::Record;

/// Candidates a row keeps for the seeder (the largest values).
pub const ROW_CANDIDATES: usize = 48;

/// One candidate path of a learning pass.
pub struct Candidate {
    /// The path with its luminance, unguided density and C.
    pub record: Record,
    /// Pixel of x_1.
    pub pixel: u32,
    /// Luminance of the sample's contribution to its pixel.
    pub value: f64,
    /// A guided sample of a guide path with fewer than `NEIGHBOURS` neighbours: recorded
    /// whatever its trust, to densify sparse regions of the cache (spec §6.3a).
    pub densify: bool,
    /// Which sampling made the path.
    pub source: Source,
}

/// Which sampling made a candidate.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Source {
    /// U's sample from stream (seed, pass, index) of a learning pass (which replays it).
    Unguided {
        /// The pass's stream index.
        pass: u64,
        /// The sample's index in the pass (its pixel).
        index: u64,
    },
    /// A guided sample.
    Guided,
    /// A state of a seeder's Markov chain.
    Chain,
}

/// What one row of a learning pass collects for the seeder.
pub struct LearnRow {
    /// (pixel, luminance of the contribution) of every sample.
    pub samples: Vec<(u32, f32)>,
    /// The row's brightest candidate paths (at most `ROW_CANDIDATES` once cut).
    pub candidates: Vec<Candidate>,
    /// Smallest value among the kept candidates once the list has been cut (a smaller one
    /// cannot enter it).
    floor: f64,
}

impl Default for LearnRow {
    fn default() -> Self {
        LearnRow {
            samples: Vec::new(),
            candidates: Vec::new(),
            floor: f64::NEG_INFINITY,
        }
    }
}

impl LearnRow {
    /// Keep a candidate among the row's `ROW_CANDIDATES` largest values; `make` (which copies
    /// the path) only runs for a value that can still make it.
    pub fn offer(&mut self, value: f64, make: impl FnOnce() -> Candidate) {
        if value <= self.floor {
            return;
        }
        let list = &mut self.candidates;
        list.push(make());
        if list.len() >= 2 * ROW_CANDIDATES {
            self.cut();
        }
    }

    /// Whether a candidate of `value` would be kept by [`Self::offer`] now.
    pub fn would_keep(&self, value: f64) -> bool {
        value > self.floor
    }

    /// The value at or below which [`Self::offer`] keeps nothing (it only rises).
    pub fn floor(&self) -> f64 {
        self.floor
    }

    /// Sort the candidates by value and keep the largest `ROW_CANDIDATES`.
    pub fn cut(&mut self) {
        let list = &mut self.candidates;
        list.sort_by(|a, b| b.value.total_cmp(&a.value));
        list.truncate(ROW_CANDIDATES);
        if list.len() == ROW_CANDIDATES {
            self.floor = list[ROW_CANDIDATES - 1].value;
        }
    }
}
