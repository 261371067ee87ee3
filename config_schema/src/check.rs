//! Small validation helpers shared by every section's `check`.
//!
//! Each helper pushes at most one [`FieldError`] and treats NaN and ±inf as errors first, because
//! TOML accepts `nan` and `inf` and every range comparison is false for NaN.

use crate::FieldError;

/// Collects errors while a config is walked; `at` builds child paths.
#[derive(Debug, Default)]
pub(crate) struct Checker {
    pub(crate) errors: Vec<FieldError>,
}

/// `prefix.name`, or `name` at the top level.
pub(crate) fn at(prefix: &str, name: &str) -> String {
    if prefix.is_empty() {
        name.to_owned()
    } else {
        format!("{prefix}.{name}")
    }
}

impl Checker {
    pub(crate) fn push(&mut self, e: FieldError) {
        self.errors.push(e);
    }

    /// False (with an error) when `v` is NaN or infinite.
    pub(crate) fn finite(&mut self, path: &str, v: f64) -> bool {
        if v.is_finite() {
            true
        } else {
            self.push(FieldError::new(path, v, "not a finite number"));
            false
        }
    }

    /// `lo <= v <= hi`.
    pub(crate) fn within(&mut self, path: &str, v: f64, lo: f64, hi: f64) {
        if self.finite(path, v) && !(lo..=hi).contains(&v) {
            self.push(FieldError::new(path, v, format!("outside [{lo}, {hi}]")));
        }
    }

    /// `0 < v <= hi`.
    pub(crate) fn positive_up_to(&mut self, path: &str, v: f64, hi: f64) {
        if self.finite(path, v) && !(v > 0.0 && v <= hi) {
            self.push(FieldError::new(path, v, format!("outside (0, {hi}]")));
        }
    }

    /// `v > 0`.
    pub(crate) fn positive(&mut self, path: &str, v: f64) {
        if self.finite(path, v) && v <= 0.0 {
            self.push(FieldError::new(path, v, "must be greater than 0"));
        }
    }

    /// `v >= 0`.
    pub(crate) fn non_negative(&mut self, path: &str, v: f64) {
        if self.finite(path, v) && v < 0.0 {
            self.push(FieldError::new(path, v, "negative; must be 0 or more"));
        }
    }

    pub(crate) fn latitude(&mut self, path: &str, v: f64) {
        self.within(path, v, -90.0, 90.0);
    }

    pub(crate) fn longitude(&mut self, path: &str, v: f64) {
        self.within(path, v, -180.0, 180.0);
    }

    pub(crate) fn port(&mut self, path: &str, p: u16) {
        if p == 0 {
            self.push(FieldError::new(
                path,
                p,
                "port 0 is not allowed; use 1-65535",
            ));
        }
    }

    /// Integer in `[lo, hi]`.
    pub(crate) fn count(&mut self, path: &str, v: u64, lo: u64, hi: u64) {
        if !(lo..=hi).contains(&v) {
            self.push(FieldError::new(path, v, format!("outside [{lo}, {hi}]")));
        }
    }

    /// Integer `>= lo`.
    pub(crate) fn at_least(&mut self, path: &str, v: u64, lo: u64) {
        if v < lo {
            self.push(FieldError::new(path, v, format!("must be at least {lo}")));
        }
    }

    pub(crate) fn non_empty(&mut self, path: &str, v: &str) {
        if v.trim().is_empty() {
            self.push(FieldError::new(path, "\"\"", "must not be empty"));
        }
    }

    /// `initial <= max`, reported on `initial_path`.
    pub(crate) fn ordered(&mut self, initial_path: &str, initial: u64, max_path: &str, max: u64) {
        if initial > max {
            self.push(FieldError::new(
                initial_path,
                initial,
                format!("greater than {max_path} ({max})"),
            ));
        }
    }
}
