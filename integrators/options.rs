//! Integrator options, declared once.
//!
//! Every integrator declares its `-O key=value` options in a table of [`Spec`]s (its module's
//! `OPTIONS`): name, type and range ([`Kind`]), default ([`DefaultValue`]) and what the
//! option does. That one declaration serves everything:
//! - parsing and validation: an integrator reads its options through [`Options::declared`],
//!   whose typed getters take the default from the declaration and reject a value outside the
//!   declared type or range with an error naming the option, what it expects and what it got;
//! - `lodestar integrators --options` and `docs/integrators.md` (`option_docs`);
//! - `tests/integrators_doc.rs`, which checks that every option an integrator reads is in its
//!   registry entry's tables and that each declared default, given explicitly, renders the
//!   same image as leaving it out.
//!
//! An option shared by several integrators (`sampler`, bdpt's `rr_depth`, vcm's radius) is one
//! `const Spec` that their tables all list. `--max-depth` is not an `-O` option: every
//! integrator takes it (the scene's `max_depth` by default).

use crate::error::{Error, Result};
use std::cell::{Cell, RefCell};

/// One declared option.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Spec {
    /// The key given with `-O key=value`.
    pub name: &'static str,
    /// Its type and range.
    pub kind: Kind,
    /// The value used when the option is not given.
    pub default: DefaultValue,
    /// What the option does (one line, Markdown).
    pub doc: &'static str,
}

/// The type and range of an option's value.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Kind {
    /// An integer `>= min`.
    Int {
        /// Smallest value allowed.
        min: i64,
    },
    /// A finite number between two bounds.
    Number {
        /// Lower bound.
        lo: Bound,
        /// Upper bound.
        hi: Bound,
    },
    /// `true` or `false`.
    Bool,
    /// One of the words.
    Choice(&'static [&'static str]),
    /// Free text; the string says what it is (`a file path`).
    Text(&'static str),
}

/// One end of a [`Kind::Number`] range.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Bound {
    /// The value itself excluded.
    Open(f64),
    /// The value itself allowed.
    Closed(f64),
    /// No bound on this side.
    Unbounded,
}

/// The value an option takes when it is not given.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum DefaultValue {
    /// An integer.
    Int(i64),
    /// A number.
    Number(f64),
    /// `true` or `false`.
    Bool(bool),
    /// A word of a [`Kind::Choice`].
    Word(&'static str),
    /// Absent: the option is off unless given (a file to write, a technique to isolate).
    Absent,
    /// Computed by the integrator (from the scene, or from the estimator it guides); the
    /// string says how.
    Computed(&'static str),
}

impl Kind {
    /// A number in `[lo, hi]`.
    pub const fn closed(lo: f64, hi: f64) -> Kind {
        Kind::Number {
            lo: Bound::Closed(lo),
            hi: Bound::Closed(hi),
        }
    }

    /// A number in `(lo, hi)`.
    pub const fn open(lo: f64, hi: f64) -> Kind {
        Kind::Number {
            lo: Bound::Open(lo),
            hi: Bound::Open(hi),
        }
    }

    /// A number in `(lo, hi]`.
    pub const fn open_closed(lo: f64, hi: f64) -> Kind {
        Kind::Number {
            lo: Bound::Open(lo),
            hi: Bound::Closed(hi),
        }
    }

    /// A number in `[lo, hi)`.
    pub const fn closed_open(lo: f64, hi: f64) -> Kind {
        Kind::Number {
            lo: Bound::Closed(lo),
            hi: Bound::Open(hi),
        }
    }

    /// A number `> lo`.
    pub const fn above(lo: f64) -> Kind {
        Kind::Number {
            lo: Bound::Open(lo),
            hi: Bound::Unbounded,
        }
    }

    /// What a value must be, as an error message and the docs say it: `an integer >= 1`,
    /// `a number in (0, 1]`, `one of mis, bsdf, nee`.
    pub fn expected(&self) -> String {
        match *self {
            Kind::Int { min } => format!("an integer >= {min}"),
            Kind::Number { lo, hi } => match (lo, hi) {
                (Bound::Open(a), Bound::Unbounded) => format!("a number > {a}"),
                (Bound::Closed(a), Bound::Unbounded) => format!("a number >= {a}"),
                (Bound::Unbounded, Bound::Unbounded) => "a number".to_string(),
                (lo, hi) => {
                    let (l, a) = match lo {
                        Bound::Open(a) => ('(', a),
                        Bound::Closed(a) => ('[', a),
                        Bound::Unbounded => ('(', f64::NEG_INFINITY),
                    };
                    let (h, b) = match hi {
                        Bound::Open(b) => (')', b),
                        Bound::Closed(b) => (']', b),
                        Bound::Unbounded => (')', f64::INFINITY),
                    };
                    format!("a number in {l}{a}, {b}{h}")
                }
            },
            Kind::Bool => "true or false".to_string(),
            Kind::Choice(words) => format!("one of {}", words.join(", ")),
            Kind::Text(what) => what.to_string(),
        }
    }

    /// The type column of an options table: `integer >= 1`, `(0, 1]`, `` `mis` / `bsdf` ``.
    pub fn column(&self) -> String {
        match *self {
            Kind::Bool => "`true` / `false`".to_string(),
            Kind::Choice(words) => words
                .iter()
                .map(|w| format!("`{w}`"))
                .collect::<Vec<_>>()
                .join(" / "),
            _ => {
                let e = self.expected();
                e.strip_prefix("an ")
                    .or_else(|| e.strip_prefix("a "))
                    .unwrap_or(&e)
                    .to_string()
            }
        }
    }

    fn contains(&self, v: f64) -> bool {
        let Kind::Number { lo, hi } = *self else {
            return true;
        };
        let above = match lo {
            Bound::Open(a) => v > a,
            Bound::Closed(a) => v >= a,
            Bound::Unbounded => true,
        };
        let below = match hi {
            Bound::Open(b) => v < b,
            Bound::Closed(b) => v <= b,
            Bound::Unbounded => true,
        };
        v.is_finite() && above && below
    }
}

impl DefaultValue {
    /// The default column of an options table: `5`, `` `mis` ``, `—`, or how it is computed.
    pub fn column(&self) -> String {
        match *self {
            DefaultValue::Int(v) => v.to_string(),
            DefaultValue::Number(v) => v.to_string(),
            DefaultValue::Bool(b) => format!("`{b}`"),
            DefaultValue::Word(w) => format!("`{w}`"),
            DefaultValue::Absent => "—".to_string(),
            DefaultValue::Computed(how) => how.to_string(),
        }
    }

    /// The default as a value to pass with `-O`, where it is one (not absent or computed).
    pub fn literal(&self) -> Option<String> {
        match *self {
            DefaultValue::Int(v) => Some(v.to_string()),
            DefaultValue::Number(v) => Some(v.to_string()),
            DefaultValue::Bool(b) => Some(b.to_string()),
            DefaultValue::Word(w) => Some(w.to_string()),
            DefaultValue::Absent | DefaultValue::Computed(_) => None,
        }
    }
}

/// Option `sampler` of pt, bdpt, lt, vcm, bpm and the guided integrators.
pub const SAMPLER: Spec = Spec {
    name: "sampler",
    kind: Kind::Choice(&["independent", "sobol"]),
    default: DefaultValue::Word("independent"),
    doc: "whose numbers each pixel sample draws: `sobol`: padded Owen-scrambled Sobol points \
          per pixel (`math/sobol.rs`), stratifying every pair of numbers a path draws over the \
          pixel's samples; unbiased, and lower error on smooth integrands (direct light from \
          area lights). bdpt: the camera and light subpaths' numbers; vcm: the camera \
          subpaths' (light subpaths stay independent); guided integrators: U's numbers in the \
          render passes (learning passes, guided samples and chains stay independent)",
};

/// `key=value` options as given, with typed access through [`Options::declared`]; keys nobody
/// read are reported (pbrt's ReportUnused).
#[derive(Debug, Default)]
pub struct Options {
    entries: Vec<(String, String, Cell<bool>)>,
    /// Every key an integrator asked for, given or not (`tests/integrators_doc.rs` checks
    /// them against the declarations).
    asked: RefCell<Vec<String>>,
}

impl Options {
    /// Parse `key=value` strings.
    pub fn parse(items: &[String]) -> Result<Options> {
        let mut entries: Vec<(String, String, Cell<bool>)> = Vec::new();
        for item in items {
            let Some((k, v)) = item.split_once('=') else {
                return Err(Error::new(format!(
                    "option '{item}' must have the form key=value"
                )));
            };
            let k = k.trim().to_string();
            if entries.iter().any(|(e, _, _)| *e == k) {
                return Err(Error::new(format!("option '{k}' is given twice")));
            }
            entries.push((k, v.trim().to_string(), Cell::new(false)));
        }
        Ok(Options {
            entries,
            asked: Default::default(),
        })
    }

    /// The options read through the declarations `tables` (an integrator's tables, as in
    /// its registry entry; where two declare a name the first stands).
    pub fn declared<'a>(&'a self, tables: &'a [&'a [Spec]]) -> Declared<'a> {
        Declared {
            options: self,
            tables,
        }
    }

    fn raw(&self, key: &str) -> Option<&str> {
        {
            let mut asked = self.asked.borrow_mut();
            if !asked.iter().any(|k| k == key) {
                asked.push(key.to_string());
            }
        }
        self.entries
            .iter()
            .find(|(k, _, _)| k == key)
            .map(|(_, v, used)| {
                used.set(true);
                v.as_str()
            })
    }

    /// The keys asked for so far, given or not, in the order first asked.
    pub fn asked(&self) -> Vec<String> {
        self.asked.borrow().clone()
    }

    /// Whether `key` was given.
    pub fn has(&self, key: &str) -> bool {
        self.entries.iter().any(|(k, _, _)| k == key)
    }

    /// An error naming the first key no integrator read.
    pub(crate) fn check_all_used(&self, integrator: &str) -> Result<()> {
        match self.entries.iter().find(|(_, _, used)| !used.get()) {
            Some((k, _, _)) => Err(Error::new(format!(
                "option '{k}' is not a setting of integrator '{integrator}'"
            ))),
            None => Ok(()),
        }
    }
}

/// [`Options`] read through a table of declarations: each getter takes the option's default
/// and range from its [`Spec`].
pub struct Declared<'a> {
    options: &'a Options,
    tables: &'a [&'a [Spec]],
}

impl Declared<'_> {
    /// The declaration of `key`; asking for an undeclared key is a fault of the integrator's
    /// code, reported as an error rather than read without a declaration.
    fn spec(&self, key: &str) -> Result<&Spec> {
        let mut all = self.tables.iter().flat_map(|t| t.iter());
        all.find(|s| s.name == key).ok_or_else(|| {
            Error::new(format!(
                "internal: option '{key}' is read but not declared in the integrator's table"
            ))
        })
    }

    /// The error for value `got` of `spec`; an option with one allowed word (a choice the
    /// integrator restricts) also says why, from its doc line.
    fn bad(spec: &Spec, got: &str) -> Error {
        let why = match spec.kind {
            Kind::Choice([_]) => format!(" ({})", spec.doc),
            _ => String::new(),
        };
        Error::new(format!(
            "option '{}': expected {}, got '{got}'{why}",
            spec.name,
            spec.kind.expected()
        ))
    }

    /// Whether `key` was given.
    pub fn has(&self, key: &str) -> bool {
        self.options.has(key)
    }

    /// Integer option `key`, its declared default when absent.
    pub fn int<T: TryFrom<i64>>(&self, key: &str) -> Result<T> {
        let spec = self.spec(key)?;
        let DefaultValue::Int(default) = spec.default else {
            return Err(Error::new(format!(
                "internal: option '{key}' has no integer default; read it with int_or"
            )));
        };
        self.int_or(key, default)
    }

    /// Integer option `key`, `default` when absent (for a [`DefaultValue::Computed`] one).
    pub fn int_or<T: TryFrom<i64>>(&self, key: &str, default: i64) -> Result<T> {
        let spec = self.spec(key)?;
        let Kind::Int { min } = spec.kind else {
            return Err(Error::new(format!(
                "internal: option '{key}' is not an integer"
            )));
        };
        let (v, got) = match self.options.raw(key) {
            None => (default, default.to_string()),
            Some(s) => (s.parse::<i64>().map_err(|_| Self::bad(spec, s))?, s.into()),
        };
        if v < min {
            return Err(Self::bad(spec, &got));
        }
        T::try_from(v).map_err(|_| Self::bad(spec, &got))
    }

    /// Number option `key`, its declared default when absent.
    pub fn number(&self, key: &str) -> Result<f64> {
        let spec = self.spec(key)?;
        match spec.default {
            DefaultValue::Number(d) => Ok(self.number_given(key)?.unwrap_or(d)),
            _ => Err(Error::new(format!(
                "internal: option '{key}' has no number default; read it with number_given"
            ))),
        }
    }

    /// Number option `key` if given (for a default the integrator computes).
    pub fn number_given(&self, key: &str) -> Result<Option<f64>> {
        let spec = self.spec(key)?;
        if !matches!(spec.kind, Kind::Number { .. }) {
            return Err(Error::new(format!(
                "internal: option '{key}' is not a number"
            )));
        }
        match self.options.raw(key) {
            None => Ok(None),
            Some(s) => match s.parse::<f64>() {
                Ok(v) if spec.kind.contains(v) => Ok(Some(v)),
                _ => Err(Self::bad(spec, s)),
            },
        }
    }

    /// `true` / `false` option `key`, its declared default when absent.
    pub fn flag(&self, key: &str) -> Result<bool> {
        let spec = self.spec(key)?;
        let DefaultValue::Bool(default) = spec.default else {
            return Err(Error::new(format!(
                "internal: option '{key}' is not true/false"
            )));
        };
        match self.options.raw(key) {
            None => Ok(default),
            Some("true") => Ok(true),
            Some("false") => Ok(false),
            Some(s) => Err(Self::bad(spec, s)),
        }
    }

    /// Word option `key` (one of its declared choices), its declared default when absent.
    pub fn word(&self, key: &str) -> Result<&'static str> {
        let spec = self.spec(key)?;
        let (Kind::Choice(words), DefaultValue::Word(default)) = (spec.kind, spec.default) else {
            return Err(Error::new(format!(
                "internal: option '{key}' is not a choice"
            )));
        };
        match self.options.raw(key) {
            None => Ok(default),
            Some(s) => words
                .iter()
                .copied()
                .find(|w| *w == s)
                .ok_or_else(|| Self::bad(spec, s)),
        }
    }

    /// Text option `key` if given (an empty value counts as not given).
    pub fn text(&self, key: &str) -> Result<Option<String>> {
        let spec = self.spec(key)?;
        if !matches!(spec.kind, Kind::Text(_)) {
            return Err(Error::new(format!("internal: option '{key}' is not text")));
        }
        Ok(self
            .options
            .raw(key)
            .filter(|s| !s.is_empty())
            .map(str::to_string))
    }
}

/// Option `sampler` ([`SAMPLER`]) read through `o`.
pub fn sampler(o: &Declared) -> Result<crate::math::SamplerKind> {
    Ok(match o.word(SAMPLER.name)? {
        "sobol" => crate::math::SamplerKind::Sobol,
        _ => crate::math::SamplerKind::Independent,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    const TABLE: &[Spec] = &[
        Spec {
            name: "n",
            kind: Kind::Int { min: 1 },
            default: DefaultValue::Int(5),
            doc: "",
        },
        Spec {
            name: "x",
            kind: Kind::open_closed(0.0, 1.0),
            default: DefaultValue::Number(0.5),
            doc: "",
        },
        Spec {
            name: "w",
            kind: Kind::Choice(&["a", "b"]),
            default: DefaultValue::Word("a"),
            doc: "",
        },
        Spec {
            name: "f",
            kind: Kind::Bool,
            default: DefaultValue::Bool(false),
            doc: "",
        },
    ];

    fn read(items: &[&str]) -> Options {
        Options::parse(&items.iter().map(|s| s.to_string()).collect::<Vec<_>>()).unwrap()
    }

    #[test]
    fn defaults_come_from_the_declaration() {
        let o = read(&[]);
        let d = o.declared(&[TABLE]);
        assert_eq!(d.int::<u32>("n").unwrap(), 5);
        assert_eq!(d.number("x").unwrap(), 0.5);
        assert_eq!(d.word("w").unwrap(), "a");
        assert!(!d.flag("f").unwrap());
        assert_eq!(o.asked(), ["n", "x", "w", "f"]);
    }

    #[test]
    fn values_outside_the_declared_range_are_errors_naming_option_and_range() {
        for (item, key, expected) in [
            ("n=0", "n", "an integer >= 1"),
            ("n=1.5", "n", "an integer >= 1"),
            ("x=0", "x", "a number in (0, 1]"),
            ("x=1.01", "x", "a number in (0, 1]"),
            ("x=nan", "x", "a number in (0, 1]"),
            ("w=c", "w", "one of a, b"),
            ("f=yes", "f", "true or false"),
        ] {
            let o = read(&[item]);
            let d = o.declared(&[TABLE]);
            let e = match key {
                "n" => d.int::<u32>(key).err(),
                "x" => d.number(key).err(),
                "w" => d.word(key).err(),
                _ => d.flag(key).err(),
            }
            .unwrap_or_else(|| panic!("{item} accepted"))
            .to_string();
            assert!(
                e.contains(&format!("option '{key}'")) && e.contains(expected),
                "{e}"
            );
        }
        let o = read(&["x=1"]);
        assert_eq!(o.declared(&[TABLE]).number("x").unwrap(), 1.0);
    }

    #[test]
    fn an_undeclared_read_and_an_unread_option_are_errors() {
        let o = read(&["zz=1"]);
        assert!(o.declared(&[TABLE]).int::<u32>("zz").is_err());
        let o = read(&["n=2", "m=3"]);
        o.declared(&[TABLE]).int::<u32>("n").unwrap();
        let e = o.check_all_used("pt").unwrap_err().to_string();
        assert!(e.contains("'m'") && e.contains("'pt'"), "{e}");
    }

    #[test]
    fn columns_read_as_the_docs_write_them() {
        assert_eq!(Kind::Int { min: 1 }.column(), "integer >= 1");
        assert_eq!(Kind::open_closed(0.0, 1.0).column(), "number in (0, 1]");
        assert_eq!(Kind::above(0.0).column(), "number > 0");
        assert_eq!(Kind::Choice(&["a", "b"]).column(), "`a` / `b`");
        assert_eq!(DefaultValue::Number(0.75).column(), "0.75");
        assert_eq!(DefaultValue::Word("mis").literal().as_deref(), Some("mis"));
        assert_eq!(DefaultValue::Computed("scene's").literal(), None);
    }
}
