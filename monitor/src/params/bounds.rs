//! The physical bounds of every parameter field and the error a value
//! outside them (or a broken relation between fields) gives.
//!
//! Each field's bounds are written next to it in `mod.rs` (`in (min ..=
//! max, "unit")`); `params_struct!` turns them into a `BOUNDS` table per
//! section with the field's dotted TOML name, and one generic loop checks
//! every entry of every field against it.

use core::fmt;

/// The allowed range of a field (or of one entry of an array field).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Range {
    /// Smallest allowed value (inclusive).
    pub min: f64,
    /// Largest allowed value (inclusive).
    pub max: f64,
    /// The unit, as an engineer reads it (empty: dimensionless).
    pub unit: &'static str,
}

impl Range {
    /// Is `v` a finite number within the range?
    pub fn contains(&self, v: f64) -> bool {
        v.is_finite() && v >= self.min && v <= self.max
    }
}

/// One field of the bounds table.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FieldBounds {
    /// Dotted name as in the TOML file, e.g. `load.masses_kg`.
    pub field: &'static str,
    /// Number of entries (1 for a scalar, N for an `[f64; N]`).
    pub entries: usize,
    /// One range for all entries, or one per entry.
    pub ranges: &'static [Range],
}

impl FieldBounds {
    /// The range of entry `i`.
    pub fn range(&self, i: usize) -> Range {
        if self.ranges.len() == 1 {
            self.ranges[0]
        } else {
            self.ranges[i]
        }
    }

    /// Check every entry of `value` against the bounds.
    pub(crate) fn check(&self, value: &dyn Entries) -> Result<(), ParamError> {
        for i in 0..value.len() {
            let v = value.get(i);
            let r = self.range(i);
            if !r.contains(v) {
                return Err(ParamError {
                    field: self.field,
                    index: (self.entries > 1).then_some(i),
                    value: v,
                    problem: Problem::OutOfBounds {
                        min: r.min,
                        max: r.max,
                        unit: r.unit,
                    },
                });
            }
        }
        Ok(())
    }
}

/// A parameter field's entries as f64 (the bounds check reads every field
/// type alike).
pub(crate) trait Entries {
    /// Number of entries.
    fn len(&self) -> usize;
    /// Entry `i` as f64.
    fn get(&self, i: usize) -> f64;
}

/// The number of entries of a field type, at compile time.
pub(crate) trait EntryCount {
    const COUNT: usize;
}

impl Entries for f64 {
    fn len(&self) -> usize {
        1
    }
    fn get(&self, _: usize) -> f64 {
        *self
    }
}

impl EntryCount for f64 {
    const COUNT: usize = 1;
}

impl Entries for u32 {
    fn len(&self) -> usize {
        1
    }
    fn get(&self, _: usize) -> f64 {
        f64::from(*self)
    }
}

impl EntryCount for u32 {
    const COUNT: usize = 1;
}

impl<const N: usize> Entries for [f64; N] {
    fn len(&self) -> usize {
        N
    }
    fn get(&self, i: usize) -> f64 {
        self[i]
    }
}

impl<const N: usize> EntryCount for [f64; N] {
    const COUNT: usize = N;
}

/// A parameter set that cannot describe a real installation: which field,
/// its value, and what is allowed.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ParamError {
    /// The offending field, dotted as in the TOML file (`section.field`).
    pub field: &'static str,
    /// The entry of an array field, if the field is an array.
    pub index: Option<usize>,
    /// The offending value (for [`Problem::Load`], the implausible load
    /// figure).
    pub value: f64,
    /// What is wrong with it.
    pub problem: Problem,
}

/// Why a value is refused.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Problem {
    /// Not a finite number within the field's physical bounds.
    OutOfBounds {
        /// Smallest allowed value.
        min: f64,
        /// Largest allowed value.
        max: f64,
        /// The field's unit.
        unit: &'static str,
    },
    /// Inconsistent with other fields: the value must be `rule` `limit`
    /// (e.g. "must be smaller than cylinder.piston_area_m2 =" 0.003117 m²).
    Relation {
        /// The rule, naming the other fields, ending before the limit.
        rule: &'static str,
        /// The limit the rule gives for these parameters.
        limit: f64,
        /// Unit of the value and the limit.
        unit: &'static str,
    },
    /// The angle fit turns rods more than `max_deg` over the stroke;
    /// `value` is the turn, degrees.
    RodTurn {
        /// Which rods the fit describes.
        rods: &'static str,
        /// The stroke, m.
        stroke_m: f64,
        /// The largest plausible turn, degrees.
        max_deg: f64,
    },
    /// The load model built from `[load]` is implausible at a position of
    /// the stroke; `value` is the figure `what`.
    Load {
        /// Which figure of the load model (effective mass, gravity load…).
        what: &'static str,
        /// Piston position, m.
        x_m: f64,
        /// Plausible range of the figure.
        min: f64,
        /// As above.
        max: f64,
        /// The figure's unit.
        unit: &'static str,
    },
}

/// A number as an engineer reads it: plain in the usual range, in
/// exponent form when very large or small (`1e30`, not 31 digits).
pub(crate) struct Num(pub f64);

impl fmt::Display for Num {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let v = self.0;
        let a = v.abs();
        if v.is_finite() && v != 0.0 && !(1e-4..1e7).contains(&a) {
            write!(f, "{v:e}")
        } else {
            write!(f, "{v}")
        }
    }
}

/// A derived figure (a load, a limit computed from other fields) to six
/// significant digits: `2608450`, not `2608453.4725421863`.
pub(crate) struct Sig(pub f64);

impl fmt::Display for Sig {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        use core::fmt::Write;
        let v = self.0;
        let a = v.abs();
        if !v.is_finite() || v == 0.0 {
            return write!(f, "{v}");
        }
        let mut text = heapless::String::<48>::new();
        if (1e-4..1e7).contains(&a) {
            let e = libm::floor(libm::log10(a)) as i32;
            let decimals = (5 - e).max(0) as usize;
            write!(text, "{v:.decimals$}")?;
        } else {
            write!(text, "{v:.5e}")?;
        }
        let (mantissa, exponent) = match text.find('e') {
            Some(k) => text.split_at(k),
            None => (text.as_str(), ""),
        };
        let mantissa = if mantissa.contains('.') {
            mantissa.trim_end_matches('0').trim_end_matches('.')
        } else {
            mantissa
        };
        write!(f, "{mantissa}{exponent}")
    }
}

/// `value unit`, or `value` for a dimensionless figure: as given
/// (`Num`) or derived (`Sig`).
struct WithUnit<N>(N, &'static str);

impl<N: fmt::Display> fmt::Display for WithUnit<N> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.1.is_empty() {
            write!(f, "{}", self.0)
        } else {
            write!(f, "{} {}", self.0, self.1)
        }
    }
}

impl fmt::Display for ParamError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.field)?;
        if let Some(i) = self.index {
            write!(f, "[{i}]")?;
        }
        match self.problem {
            Problem::OutOfBounds { min, max, unit } => {
                let what = if self.value.is_finite() {
                    "is outside"
                } else {
                    "is not a finite number; allowed"
                };
                write!(
                    f,
                    " = {} {what} {} … {}",
                    Num(self.value),
                    Num(min),
                    WithUnit(Num(max), unit)
                )
            }
            Problem::Relation { rule, limit, unit } => write!(
                f,
                " = {} {rule} {}",
                WithUnit(Num(self.value), unit),
                WithUnit(Sig(limit), unit)
            ),
            Problem::RodTurn {
                rods,
                stroke_m,
                max_deg,
            } => write!(
                f,
                ": turns rods {rods} by {}° over the stroke of {} m (cylinder.stroke_m); \
                 at most {}°",
                Sig(self.value),
                Num(stroke_m),
                Num(max_deg)
            ),
            Problem::Load {
                what,
                x_m,
                min,
                max,
                unit,
            } => write!(
                f,
                ": the [load] model (masses, inertias, lever lengths, angle fits, scales, \
                 force offset) gives {what} {} at piston position {} m; plausible {} … {}",
                WithUnit(Sig(self.value), unit),
                Sig(x_m),
                Sig(min),
                WithUnit(Sig(max), unit)
            ),
        }
    }
}
