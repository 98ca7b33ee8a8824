//! A setting that cannot be used, and the small checks every settings type uses to
//! say so. Each settings type checks itself next to its definition (`validate`), and
//! names the key as it appears in faithd.toml, so the user reads which line to fix.

/// A value that failed its check: the dotted key and what is wrong with it.
#[derive(Debug, Clone, PartialEq)]
pub struct Invalid {
    /// Dotted, as in faithd.toml: `gate.switch_channel`.
    pub key: String,
    pub reason: String,
}

impl std::fmt::Display for Invalid {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "`{}` {}", self.key, self.reason)
    }
}

impl std::error::Error for Invalid {}

/// `Ok` when `ok`, otherwise `key` with the reason (only built when needed).
pub fn check(ok: bool, key: &'static str, reason: impl FnOnce() -> String) -> Result<(), Invalid> {
    if ok {
        Ok(())
    } else {
        Err(Invalid {
            key: key.to_owned(),
            reason: reason(),
        })
    }
}

/// A finite number above zero.
pub fn positive(v: f64, key: &'static str) -> Result<(), Invalid> {
    check(v.is_finite() && v > 0.0, key, || {
        format!("must be a positive number, got {v}")
    })
}

/// A finite number of zero or more.
pub fn non_negative(v: f64, key: &'static str) -> Result<(), Invalid> {
    check(v.is_finite() && v >= 0.0, key, || {
        format!("must be a non-negative number, got {v}")
    })
}
