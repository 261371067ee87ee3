//! Names that become parts of paths, key expressions and log prefixes (vehicle, platform and
//! process names): the one check they all go through, so `..` or `a/b` can never turn a record
//! directory, a run file or a per-vehicle config into a path outside where it belongs.

/// Longest name accepted anywhere (bytes). Stricter uses (a launch process name is a log prefix:
/// 32 characters) add their own bound on top.
pub const MAX_NAME_BYTES: usize = 64;

/// Why a name was refused.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum NameError {
    #[error("empty")]
    Empty,
    #[error("`.` and `..` are not names (they are directories)")]
    Dots,
    #[error("contains a path separator ('/' or '\\')")]
    Separator,
    #[error("contains a control character")]
    Control,
    #[error("longer than {MAX_NAME_BYTES} bytes")]
    TooLong,
}

/// A vehicle, platform or process name: not empty, not `.` or `..`, no `/` or `\`, no control
/// character (NUL, newline, escape...), at most [`MAX_NAME_BYTES`] bytes.
pub fn check_name(name: &str) -> Result<(), NameError> {
    if name.is_empty() {
        return Err(NameError::Empty);
    }
    if name == "." || name == ".." {
        return Err(NameError::Dots);
    }
    if name.contains(['/', '\\']) {
        return Err(NameError::Separator);
    }
    if name.chars().any(char::is_control) {
        return Err(NameError::Control);
    }
    if name.len() > MAX_NAME_BYTES {
        return Err(NameError::TooLong);
    }
    Ok(())
}

/// [`check_name`] for a config field where empty means "the default" (the interface's `name`,
/// `interprocess.platform`): an error at `field` for anything else [`check_name`] refuses.
pub(crate) fn check_optional(field: &str, name: &str, c: &mut crate::check::Checker) {
    if name.is_empty() {
        return;
    }
    if let Err(why) = check_name(name) {
        c.push(crate::FieldError::new(field, format!("{name:?}"), why));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_that_would_escape_a_directory_or_a_log_line_are_refused() {
        for (bad, why) in [
            ("", NameError::Empty),
            (".", NameError::Dots),
            ("..", NameError::Dots),
            ("../x", NameError::Separator),
            ("a/b", NameError::Separator),
            ("a\\b", NameError::Separator),
            ("a\nb", NameError::Control),
            ("a\0", NameError::Control),
            ("\u{1b}[2J", NameError::Control),
        ] {
            assert_eq!(check_name(bad), Err(why), "{bad:?}");
        }
        assert_eq!(check_name(&"a".repeat(65)), Err(NameError::TooLong));
        for good in ["auv1", "AUV-1", "usv_2", "a.b", "...", "é", &"a".repeat(64)] {
            assert_eq!(check_name(good), Ok(()), "{good:?}");
        }
    }
}
