//! The survey rig sets (`--set survey`, `survey2`, …): larger samples of
//! the development rigs' population, to look for rare failures with
//! `--quick`, each the 48 seeds after the previous one's.
//!
//! Every survey after the first was first run untuned, before anything
//! in it was looked at, to measure the monitor on rigs nobody had tuned
//! on: the second to check whether the held-out rigs' false-alarm rate is
//! chance or a mechanism the other development rigs never showed, each
//! later one set aside at the end of a session and run at the start of
//! the next. From then on each is tuned on like the other development
//! rigs, and reported separately.
//!
//! [`SURVEYS`] holds, one row per survey, only what its number does not
//! give: how its title and help name it and when it was first run. Its
//! seeds, name, title and help are derived from the row and its place, so
//! that the surveys cannot drift apart; a new survey is one more row.

use super::SetFacts;
use std::sync::LazyLock;

/// Every survey, in order: survey `n` is row `n − 1`. Never change or
/// reorder a row: a survey's seeds follow from its place. (The 21st would
/// reach the held-out seeds, 1001–1012: the disjointness test of the sets
/// says so.)
#[rustfmt::skip] // one survey a line
const SURVEYS: &[SurveyFacts] = &[
    SurveyFacts::First,
    later("second", "on 2026-12-05"),
    later("third", "in the session after"),
    later("fourth", "at the start of the ninth session of 2026-12-05"),
    later("fifth", "at the start of the first session of 2026-12-06"),
    later("sixth", "at the start of the second session of 2026-12-06"),
    later("seventh", "at the start of the third session of 2026-12-06"),
    later("eighth", "at the start of the fourth session of 2026-12-06"),
    later("ninth", "at the start of the fifth session of 2026-12-06"),
    later("tenth", "at the start of the sixth session of 2026-12-06"),
    later("eleventh", "at the start of the seventh session of 2026-12-06"),
    later("twelfth", "at the start of the eighth session of 2026-12-06"),
    later("thirteenth", "at the start of the first session of 2026-12-07"),
    later("fourteenth", "at the start of the second session of 2026-12-07"),
    later("fifteenth", "at the start of the third session of 2026-12-07"),
    later("sixteenth", "at the start of the fourth session of 2026-12-07"),
    later("seventeenth", "at the start of the fifth session of 2026-12-07"),
    later("eighteenth", "at the start of the sixth session of 2026-12-07"),
    later("nineteenth", "at the start of the seventh session of 2026-12-07"),
];

/// Rigs in a survey.
const RIGS: usize = 48;

/// The first survey's first seed: the one after the further development
/// rigs' last ([`super::WIDE_RIGS`], 7–30).
const FIRST_SEED: u64 = 31;

/// A survey's row of [`SURVEYS`].
enum SurveyFacts {
    /// The first survey (`survey`): the larger sample, for rare failures,
    /// tuned on from the start.
    First,
    /// A later survey.
    Later {
        /// How its title and help count it ("sixteenth").
        ordinal: &'static str,
        /// When it was first run untuned, as its help says it ("at the
        /// start of the fourth session of 2026-12-07").
        untuned: &'static str,
    },
}

/// A later survey's row (one line of the table).
const fn later(ordinal: &'static str, untuned: &'static str) -> SurveyFacts {
    SurveyFacts::Later { ordinal, untuned }
}

/// The number of a survey: 1 for the first (`survey`) up to the last row
/// of the table, never another (so its seeds and texts always exist).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct SurveyNo(u8);

impl SurveyNo {
    /// How many surveys there are.
    pub const COUNT: usize = SURVEYS.len();

    /// Survey `n` (1 for the first), if there is one.
    pub const fn new(n: u8) -> Option<SurveyNo> {
        if n >= 1 && n as usize <= Self::COUNT {
            Some(SurveyNo(n))
        } else {
            None
        }
    }

    /// The survey's number (1 for the first).
    pub const fn get(self) -> u8 {
        self.0
    }

    /// Its row, seeds and texts.
    fn index(self) -> usize {
        self.0 as usize - 1
    }

    /// Everything said about the survey.
    pub(super) fn facts(self) -> SetFacts {
        let texts = &TEXTS[self.index()];
        SetFacts {
            seeds: &SEEDS[self.index()],
            name: &texts.name,
            title: &texts.title,
            about: &texts.about,
        }
    }
}

/// Every survey's seeds: survey `n` has the [`RIGS`] seeds from
/// `FIRST_SEED + RIGS·(n − 1)`.
static SEEDS: [[u64; RIGS]; SurveyNo::COUNT] = {
    let mut seeds = [[0; RIGS]; SurveyNo::COUNT];
    let mut k = 0;
    while k < RIGS * SurveyNo::COUNT {
        seeds[k / RIGS][k % RIGS] = FIRST_SEED + k as u64;
        k += 1;
    }
    seeds
};

/// A survey's name, title and help, written once from its row (the
/// accessors of [`super::RigSet`] lend them out for the program's life).
struct Texts {
    name: String,
    title: String,
    about: String,
}

/// Every survey's [`Texts`], by row.
static TEXTS: LazyLock<Vec<Texts>> = LazyLock::new(|| {
    SURVEYS
        .iter()
        .zip(SEEDS.iter())
        .enumerate()
        .map(|(i, (facts, seeds))| {
            let (first, last) = (seeds[0], seeds[RIGS - 1]);
            match facts {
                SurveyFacts::First => Texts {
                    name: "survey".into(),
                    title: "Survey development rigs".into(),
                    about: format!(
                        "A larger sample of development rigs (seeds {first}–{last}), \
                         for rare failures (use with `--quick`)"
                    ),
                },
                SurveyFacts::Later { ordinal, untuned } => Texts {
                    name: format!("survey{}", i + 1),
                    title: format!("{} survey development rigs", capitalized(ordinal)),
                    about: format!(
                        "{} {ordinal} survey sample (seeds {first}–{last}), \
                         first run untuned {untuned} (use with `--quick`)",
                        article(ordinal)
                    ),
                },
            }
        })
        .collect()
});

/// `word` with its first letter in upper case ("Sixteenth").
fn capitalized(word: &str) -> String {
    let mut chars = word.chars();
    chars
        .next()
        .map(|c| c.to_uppercase().chain(chars).collect())
        .unwrap_or_default()
}

/// The indefinite article before `word`: "An eighth", "A ninth".
fn article(word: &str) -> &'static str {
    if word.starts_with(['a', 'e', 'i', 'o', 'u']) {
        "An"
    } else {
        "A"
    }
}

#[cfg(test)]
mod tests {
    use super::super::RigSet;

    #[test]
    fn survey_n_has_the_48_seeds_from_31_plus_48_n_minus_1() {
        for n in 1..=super::SurveyNo::COUNT as u8 {
            let first = 31 + 48 * (u64::from(n) - 1);
            let seeds: Vec<u64> = (first..first + 48).collect();
            assert_eq!(RigSet::survey(n).seeds(), seeds, "survey {n}");
        }
        assert_eq!(RigSet::survey(16).seeds()[0], 751);
    }

    #[test]
    fn the_texts_read_as_they_were_written_out() {
        let expected = [
            (1, "survey", "Survey development rigs", "A larger sample of development rigs (seeds 31–78), for rare failures (use with `--quick`)"),
            (8, "survey8", "Eighth survey development rigs", "An eighth survey sample (seeds 367–414), first run untuned at the start of the fourth session of 2026-12-06 (use with `--quick`)"),
            (16, "survey16", "Sixteenth survey development rigs", "A sixteenth survey sample (seeds 751–798), first run untuned at the start of the fourth session of 2026-12-07 (use with `--quick`)"),
            (17, "survey17", "Seventeenth survey development rigs", "A seventeenth survey sample (seeds 799–846), first run untuned at the start of the fifth session of 2026-12-07 (use with `--quick`)"),
            (18, "survey18", "Eighteenth survey development rigs", "An eighteenth survey sample (seeds 847–894), first run untuned at the start of the sixth session of 2026-12-07 (use with `--quick`)"),
            (19, "survey19", "Nineteenth survey development rigs", "A nineteenth survey sample (seeds 895–942), first run untuned at the start of the seventh session of 2026-12-07 (use with `--quick`)"),
        ];
        for (n, name, title, about) in expected {
            let s = RigSet::survey(n);
            assert_eq!((s.name(), s.title(), s.about()), (name, title, about));
        }
    }

    #[test]
    fn there_is_no_survey_0_nor_one_past_the_table() {
        assert!(super::SurveyNo::new(0).is_none());
        assert!(super::SurveyNo::new(super::SurveyNo::COUNT as u8 + 1).is_none());
    }
}
