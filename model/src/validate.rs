//! Validation of decoded messages.
//!
//! Decoding proves a message is well formed; validation proves it is sensible: every number
//! finite and in range, every list bounded. Checks that need the site (is a point inside
//! the tunnel?) are done by the receiver with [`crate::scenario::Tunnel::check_inside`],
//! because only it knows which site it serves.

use std::fmt;

/// What was wrong with a message, and where in it.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub struct Invalid {
    /// Dotted path of the offending field, e.g. `observations[2].position.x`.
    pub field: String,
    pub reason: String,
}

impl fmt::Display for Invalid {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}: {}", self.field, self.reason)
    }
}

impl Invalid {
    pub fn new(field: impl Into<String>, reason: impl Into<String>) -> Self {
        Self {
            field: field.into(),
            reason: reason.into(),
        }
    }

    /// Prefix the field path, for nested structures.
    pub fn within(mut self, parent: &str) -> Self {
        self.field = if self.field.is_empty() {
            parent.to_owned()
        } else {
            format!("{parent}.{}", self.field)
        };
        self
    }
}

/// A message (or part of one) that can check itself.
pub trait Validate {
    fn validate(&self) -> Result<(), Invalid>;
}

/// `v` must be a finite number.
pub fn finite(field: &str, v: f64) -> Result<(), Invalid> {
    if v.is_finite() {
        Ok(())
    } else {
        Err(Invalid::new(field, format!("{v} is not a finite number")))
    }
}

/// `v` must be finite and within `[lo, hi]`.
pub fn in_range(field: &str, v: f64, lo: f64, hi: f64) -> Result<(), Invalid> {
    finite(field, v)?;
    if (lo..=hi).contains(&v) {
        Ok(())
    } else {
        Err(Invalid::new(field, format!("{v} is outside [{lo}, {hi}]")))
    }
}

/// A list must not exceed `max` entries (bounds the work a single message can cause).
pub fn max_len<T>(field: &str, v: &[T], max: usize) -> Result<(), Invalid> {
    if v.len() <= max {
        Ok(())
    } else {
        Err(Invalid::new(
            field,
            format!("{} entries, at most {max} allowed", v.len()),
        ))
    }
}

/// Validate every element, naming the index of the first bad one.
pub fn each<T: Validate>(field: &str, v: &[T]) -> Result<(), Invalid> {
    v.iter()
        .enumerate()
        .try_for_each(|(i, x)| x.validate().map_err(|e| e.within(&format!("{field}[{i}]"))))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn range_checks_name_the_field() {
        assert!(in_range("a", 1.0, 0.0, 2.0).is_ok());
        let e = in_range("a.b", f64::NAN, 0.0, 2.0).unwrap_err();
        assert_eq!(e.field, "a.b");
        assert!(e.to_string().contains("not a finite"));
        assert!(
            in_range("a", 3.0, 0.0, 2.0)
                .unwrap_err()
                .reason
                .contains("outside")
        );
        assert_eq!(Invalid::new("x", "r").within("p").field, "p.x");
    }
}

/// Why a TOML file (a site, a robot profile) was rejected: the file, then what. Each
/// message is whole (the cause is in it, not chained after it: a chain would print the
/// TOML error twice).
#[derive(Debug, thiserror::Error)]
pub enum FileError {
    #[error("{origin}: cannot read: {error}")]
    Io {
        origin: String,
        error: std::io::Error,
    },
    #[error("{origin}: {error}")]
    Syntax {
        origin: String,
        error: Box<toml::de::Error>,
    },
    #[error("{origin}: {invalid}")]
    Invalid { origin: String, invalid: Invalid },
    /// A name that is neither a file nor one of the shipped ones.
    #[error("{0}")]
    Unknown(String),
}

/// Parse TOML `text` and `check` it; `origin` (a file name) prefixes every error.
pub fn from_toml<T: serde::de::DeserializeOwned>(
    text: &str,
    origin: &str,
    check: impl FnOnce(&T) -> Result<(), Invalid>,
) -> Result<T, FileError> {
    let t: T = toml::from_str(text).map_err(|e| FileError::Syntax {
        origin: origin.to_owned(),
        error: Box::new(e),
    })?;
    check(&t).map_err(|invalid| FileError::Invalid {
        origin: origin.to_owned(),
        invalid,
    })?;
    Ok(t)
}

/// Read, parse and `check` a TOML file.
pub fn load_toml<T: serde::de::DeserializeOwned>(
    path: &std::path::Path,
    check: impl FnOnce(&T) -> Result<(), Invalid>,
) -> Result<T, FileError> {
    let origin = path.display().to_string();
    let text = std::fs::read_to_string(path).map_err(|error| FileError::Io {
        origin: origin.clone(),
        error,
    })?;
    from_toml(&text, &origin, check)
}
