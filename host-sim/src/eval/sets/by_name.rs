//! [`RigSet`] in serde: by its name (`"dev"`, `"survey2"`, …), the
//! strings the JSON's `set` has always held, with the error an unknown
//! name always gave. The survey names are not literals, hence no derive:
//! serde goes through [`RigSet::name`] and [`RigSet::ALL`].

use super::{RigSet, SetChoice};

impl From<RigSet> for &'static str {
    fn from(set: RigSet) -> Self {
        set.name()
    }
}

impl TryFrom<String> for RigSet {
    type Error = String;

    fn try_from(name: String) -> Result<Self, String> {
        RigSet::ALL
            .into_iter()
            .find(|set| set.name() == name)
            .ok_or_else(|| {
                // In `--set`'s order (dev, holdout, the rest), the order
                // the derive listed them in.
                let known: Vec<_> = SetChoice::ALL
                    .iter()
                    .filter_map(|choice| match choice {
                        SetChoice::One(set) => Some(format!("`{}`", set.name())),
                        SetChoice::Both => None,
                    })
                    .collect();
                format!(
                    "unknown variant `{name}`, expected one of {}",
                    known.join(", ")
                )
            })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_set_is_written_and_read_back_by_its_name() {
        for set in RigSet::ALL {
            let json = serde_json::to_string(&set).unwrap();
            assert_eq!(json, format!("\"{}\"", set.name()));
            assert_eq!(serde_json::from_str::<RigSet>(&json).unwrap(), set);
        }
    }

    #[test]
    fn an_unknown_name_is_an_unknown_variant() {
        let e = serde_json::from_str::<RigSet>("\"survey1\"").unwrap_err();
        assert!(
            e.to_string().starts_with(
                "unknown variant `survey1`, expected one of `dev`, `holdout`, `wide`, `survey`, `survey2`,"
            ),
            "{e}"
        );
        assert!(serde_json::from_str::<RigSet>("\"both\"").is_err());
    }
}
