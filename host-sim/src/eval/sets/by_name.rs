//! [`RigSet`] in serde: by its name, exactly as the derived
//! implementation of the enum of unit variants it once was wrote and read
//! it (`"dev"`, `"survey2"`, …, the same errors), so that JSON written
//! before the surveys became one table still reads back. The survey
//! names are not literals any more, hence no derive.

use super::{RigSet, SurveyNo};
use serde::de::{self, Deserializer, EnumAccess, Unexpected, VariantAccess, Visitor};
use serde::{Deserialize, Serialize, Serializer};
use std::fmt;
use std::sync::LazyLock;

/// Every set in the order of the old enum's variants (dev, holdout, wide,
/// then the surveys): a set's place is its variant index.
fn declared() -> impl Iterator<Item = RigSet> {
    [RigSet::Dev, RigSet::Holdout, RigSet::Wide]
        .into_iter()
        .chain((1..=SurveyNo::COUNT).map(|n| RigSet::survey(n as u8)))
}

/// The sets' names in [`declared`] order (serde's list of variants).
static NAMES: LazyLock<Vec<&'static str>> =
    LazyLock::new(|| declared().map(RigSet::name).collect());

impl RigSet {
    /// Index of the set's variant in the old enum.
    fn variant_index(self) -> u32 {
        match self {
            Self::Dev => 0,
            Self::Holdout => 1,
            Self::Wide => 2,
            Self::Survey(n) => 2 + u32::from(n.get()),
        }
    }
}

impl Serialize for RigSet {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        serializer.serialize_unit_variant("RigSet", self.variant_index(), self.name())
    }
}

impl<'de> Deserialize<'de> for RigSet {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        deserializer.deserialize_enum("RigSet", &NAMES, SetVisitor)
    }
}

/// Reads a unit variant of `RigSet`.
struct SetVisitor;

impl<'de> Visitor<'de> for SetVisitor {
    type Value = RigSet;

    fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
        f.write_str("enum RigSet")
    }

    fn visit_enum<A: EnumAccess<'de>>(self, data: A) -> Result<RigSet, A::Error> {
        let (Variant(set), variant) = data.variant()?;
        variant.unit_variant()?;
        Ok(set)
    }
}

/// A variant's identifier: its name, or its index.
struct Variant(RigSet);

impl<'de> Deserialize<'de> for Variant {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        deserializer
            .deserialize_identifier(VariantVisitor)
            .map(Variant)
    }
}

/// Reads a [`Variant`].
struct VariantVisitor;

impl<'de> Visitor<'de> for VariantVisitor {
    type Value = RigSet;

    fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
        f.write_str("variant identifier")
    }

    fn visit_u64<E: de::Error>(self, index: u64) -> Result<RigSet, E> {
        usize::try_from(index)
            .ok()
            .and_then(|i| declared().nth(i))
            .ok_or_else(|| {
                let expected = format!("variant index 0 <= i < {}", NAMES.len());
                E::invalid_value(Unexpected::Unsigned(index), &expected.as_str())
            })
    }

    fn visit_str<E: de::Error>(self, name: &str) -> Result<RigSet, E> {
        declared()
            .find(|set| set.name() == name)
            .ok_or_else(|| E::unknown_variant(name, &NAMES))
    }

    fn visit_bytes<E: de::Error>(self, name: &[u8]) -> Result<RigSet, E> {
        match std::str::from_utf8(name) {
            Ok(name) => self.visit_str(name),
            Err(_) => Err(E::unknown_variant(&String::from_utf8_lossy(name), &NAMES)),
        }
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
        assert_eq!(NAMES.len(), RigSet::ALL.len());
        assert_eq!(&NAMES[..5], ["dev", "holdout", "wide", "survey", "survey2"]);
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
