//! Names of enums, one way: the names they have on the wire (their serde names, kebab
//! case) are the names on the command line, in logs and in printed tables.
//!
//! [`names!`](macro@crate::names) gives an enum `as_str`, `Display`, `FromStr` (whose error lists
//! the choices) and `ALL`. Each use is tested against serde, so the two cannot drift.

/// `names!(Enum, "what one is" { Variant => "name", ... })`; see the module doc.
#[macro_export]
macro_rules! names {
    ($t:ident, $what:literal { $($v:ident => $n:literal),* $(,)? }) => {
        impl $t {
            /// Every value, in declaration order.
            pub const ALL: &'static [$t] = &[$($t::$v),*];

            /// Its name on the wire, the command line and in logs.
            pub const fn as_str(self) -> &'static str {
                match self {
                    $($t::$v => $n,)*
                }
            }
        }

        impl ::std::fmt::Display for $t {
            fn fmt(&self, f: &mut ::std::fmt::Formatter<'_>) -> ::std::fmt::Result {
                f.write_str(self.as_str())
            }
        }

        impl ::std::str::FromStr for $t {
            type Err = String;

            fn from_str(s: &str) -> Result<Self, String> {
                match s {
                    $($n => Ok($t::$v),)*
                    _ => Err(format!(
                        "'{s}' is not {} ({})",
                        $what,
                        [$($n),*].join(", ")
                    )),
                }
            }
        }
    };
}
