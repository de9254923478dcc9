//! The macros that declare a parameter section: its struct, `NOMINAL`,
//! its `BOUNDS` table and the bounds check, from one field list.

macro_rules! params_struct {
    (
        section $section:literal;
        $(#[$m:meta])*
        pub struct $name:ident {
            $($(#[$fm:meta])* pub $field:ident : $ty:ty = $default:expr, in $bound:tt,)*
        }
    ) => {
        $(#[$m])*
        #[derive(Clone, Debug, PartialEq)]
        #[cfg_attr(feature = "serde", derive(Serialize, Deserialize))]
        #[cfg_attr(feature = "serde", serde(default, deny_unknown_fields))]
        pub struct $name {
            $(
                $(#[$fm])*
                #[doc = ""]
                #[doc = concat!("Bounds: `", stringify!($bound), "`.")]
                pub $field: $ty,
            )*
        }
        impl $name {
            /// The reference thesis rig's values.
            pub const NOMINAL: Self = Self { $($field: $default,)* };
            /// Physical bounds of every field, in declaration order.
            pub const BOUNDS: &'static [FieldBounds] = &[$(FieldBounds {
                field: concat!($section, ".", stringify!($field)),
                entries: <$ty as bounds::EntryCount>::COUNT,
                ranges: &ranges!($bound),
            },)*];
            /// Check every field against [`Self::BOUNDS`].
            fn check_bounds(&self) -> Result<(), ParamError> {
                let values: &[&dyn bounds::Entries] = &[$(&self.$field,)*];
                for (b, v) in Self::BOUNDS.iter().zip(values) {
                    b.check(*v)?;
                }
                Ok(())
            }
        }
        impl Default for $name {
            fn default() -> Self { Self::NOMINAL }
        }
    };
}

/// The ranges of a field's bounds: `(min ..= max, "unit")` for every entry,
/// or `[(…), (…)]` one per entry.
macro_rules! ranges {
    (($lo:literal ..= $hi:literal, $unit:literal)) => {
        [Range { min: $lo, max: $hi, unit: $unit }]
    };
    ([$(($lo:literal ..= $hi:literal, $unit:literal)),+ $(,)?]) => {
        [$(Range { min: $lo, max: $hi, unit: $unit }),+]
    };
}
