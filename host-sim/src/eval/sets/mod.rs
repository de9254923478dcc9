//! The rig sets (`--set`): which plant seeds the monitor is evaluated on,
//! and what is said about each set (name, report heading, help).
//!
//! - `survey`: the survey sets, one row of a table per survey (their
//!   seeds follow from the row's place, so they are never written out).
//! - `by_name`: a set is serialized by its name, as it always was.

mod by_name;
mod survey;

use serde::{Deserialize, Serialize};

pub use survey::SurveyNo;

/// Development rigs: the plant seeds the monitor may be looked at and tuned
/// on. Fixed before any tuning on the plant; never change them.
pub const DEV_RIGS: [u64; 6] = [1, 2, 3, 4, 5, 6];

/// Held-out rigs: plant seeds fixed in advance, before any tuning, and never
/// looked at while tuning (run `--set holdout` only to report). Disjoint
/// from [`DEV_RIGS`]; never change them.
pub const HOLDOUT_RIGS: [u64; 12] = [
    1001, 1002, 1003, 1004, 1005, 1006, 1007, 1008, 1009, 1010, 1011, 1012,
];

/// Further development rigs: more of the population the development rigs
/// come from, to find failures on (tuned on like them; reported
/// separately so that the fixed sets' figures stay comparable). Disjoint
/// from [`DEV_RIGS`] and [`HOLDOUT_RIGS`].
pub const WIDE_RIGS: [u64; 24] = [
    7, 8, 9, 10, 11, 12, 13, 14, 15, 16, 17, 18, 19, 20, 21, 22, 23, 24, 25, 26, 27, 28, 29, 30,
];

/// A set of rigs. Serialized by its name ([`RigSet::name`]: `"dev"`,
/// `"survey2"`, …), as the JSON's `set` has always been written.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(into = "&'static str", try_from = "String")]
pub enum RigSet {
    /// [`DEV_RIGS`].
    Dev,
    /// [`HOLDOUT_RIGS`].
    Holdout,
    /// [`WIDE_RIGS`].
    Wide,
    /// A survey: a larger sample of the development rigs' population (see
    /// [`SurveyNo`]; `RigSet::survey(n)` names survey `n`).
    Survey(SurveyNo),
}

impl RigSet {
    /// Every set, in report order: development sets first, held-out last.
    /// The report, `--set` and the disjointness test read this list. The
    /// surveys come from their table, in order: a new survey is a row of
    /// that table alone; another new set goes here by hand.
    pub const ALL: [RigSet; 3 + SurveyNo::COUNT] = {
        let mut all = [Self::Dev; 3 + SurveyNo::COUNT];
        all[1] = Self::Wide;
        let mut i = 0;
        while i < SurveyNo::COUNT {
            all[2 + i] = Self::survey(i as u8 + 1);
            i += 1;
        }
        all[2 + SurveyNo::COUNT] = Self::Holdout;
        all
    };

    /// Survey `n` (1 for the first, `survey`). Panics if there is no such
    /// survey (at compile time in a constant).
    pub const fn survey(n: u8) -> RigSet {
        match SurveyNo::new(n) {
            Some(n) => Self::Survey(n),
            None => panic!("no such survey"),
        }
    }

    /// The rig seeds of the set.
    pub fn seeds(self) -> &'static [u64] {
        self.facts().seeds
    }

    /// Lower-case name (`--set`, the JSON's `set`).
    pub fn name(self) -> &'static str {
        self.facts().name
    }

    /// The report's heading for the set.
    pub fn title(self) -> &'static str {
        self.facts().title
    }

    /// What the set is for (`--set` help).
    pub fn about(self) -> &'static str {
        self.facts().about
    }

    /// Everything said about the set, in one place per set (the surveys'
    /// in their table).
    fn facts(self) -> SetFacts {
        let (seeds, name, title, about): (&'static [u64], _, _, _) = match self {
            Self::Dev => (&DEV_RIGS, "dev", "Development rigs", "The development rigs"),
            Self::Holdout => (
                &HOLDOUT_RIGS,
                "holdout",
                "Held-out rigs",
                "The held-out rigs",
            ),
            Self::Wide => (
                &WIDE_RIGS,
                "wide",
                "Further development rigs",
                "Further development rigs (seeds 7–30), to find failures on",
            ),
            Self::Survey(n) => return n.facts(),
        };
        SetFacts {
            seeds,
            name,
            title,
            about,
        }
    }
}

/// What [`RigSet`]'s accessors read.
struct SetFacts {
    seeds: &'static [u64],
    name: &'static str,
    title: &'static str,
    about: &'static str,
}

/// Which rig sets to evaluate (command line `--set`): one set by its
/// name ([`RigSet::name`], help [`RigSet::about`]), or `both`. Its
/// values come from [`RigSet::ALL`]: a new survey is one row of the
/// survey table (its ordinal and when it was first run; seeds, name,
/// title and help follow), and any other new set is added to `RigSet`
/// alone (its variant, `ALL` and its arm of `RigSet::facts`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SetChoice {
    /// One set.
    One(RigSet),
    /// The development and the held-out rigs, reported separately.
    Both,
}

impl SetChoice {
    /// Every choice in `--help` order: the development rigs, the held-out
    /// ones, both, then the further development sets.
    const ALL: [SetChoice; RigSet::ALL.len() + 1] = {
        let mut out = [SetChoice::Both; RigSet::ALL.len() + 1];
        out[0] = SetChoice::One(RigSet::Dev);
        out[1] = SetChoice::One(RigSet::Holdout);
        let (mut i, mut k) = (0, 3);
        while i < RigSet::ALL.len() {
            let set = RigSet::ALL[i];
            if !matches!(set, RigSet::Dev | RigSet::Holdout) {
                out[k] = SetChoice::One(set);
                k += 1;
            }
            i += 1;
        }
        out
    };

    /// The sets, in report order.
    pub fn sets(self) -> Vec<RigSet> {
        match self {
            Self::One(set) => vec![set],
            Self::Both => vec![RigSet::Dev, RigSet::Holdout],
        }
    }
}

impl clap::ValueEnum for SetChoice {
    fn value_variants<'a>() -> &'a [Self] {
        &Self::ALL
    }

    fn to_possible_value(&self) -> Option<clap::builder::PossibleValue> {
        let (name, help) = match self {
            Self::One(set) => (set.name(), set.about()),
            Self::Both => ("both", "Both, reported separately"),
        };
        Some(clap::builder::PossibleValue::new(name).help(help))
    }
}
