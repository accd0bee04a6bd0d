//! Named choices: enums whose variants are parsed from and printed as one table of names, so parsing,
//! printing and serde agree (`named_choice!`).

/// A name outside a choice's list.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{given}: unknown ({})", known.join(", "))]
pub struct UnknownName {
    pub given: String,
    pub known: Vec<&'static str>,
}

/// An enum of named unit variants: `ALL` in the order reports list them, `name()`, `Display`, `FromStr`
/// and serde as the name (the caller depends on serde). Used for the bench's choices and the model
/// contract's inputs.
#[macro_export]
macro_rules! named_choice {
    ($(#[$doc:meta])* $ty:ident { $($(#[$vdoc:meta])* $variant:ident = $text:literal),+ $(,)? }) => {
        $(#[$doc])*
        #[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
        #[derive(serde::Serialize, serde::Deserialize)]
        pub enum $ty {
            $($(#[$vdoc])* #[serde(rename = $text)] $variant),+
        }

        impl $ty {
            pub const ALL: &'static [$ty] = &[$($ty::$variant),+];

            pub fn name(self) -> &'static str {
                match self {
                    $($ty::$variant => $text),+
                }
            }
        }

        impl std::fmt::Display for $ty {
            fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
                f.write_str(self.name())
            }
        }

        impl std::str::FromStr for $ty {
            type Err = $crate::choice::UnknownName;

            fn from_str(text: &str) -> std::result::Result<$ty, $crate::choice::UnknownName> {
                $ty::ALL.iter().copied().find(|v| v.name() == text).ok_or_else(|| $crate::choice::UnknownName {
                    given: text.to_string(),
                    known: $ty::ALL.iter().map(|v| v.name()).collect(),
                })
            }
        }
    };
}
