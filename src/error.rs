//! The one error type of lodestar: a message meant for a human, naming the file, the line or
//! key, and what was expected. Every user-facing failure (bad scene, bad CLI value, I/O) becomes
//! one of these and ends as a single line on stderr with a non-zero exit.

use std::fmt;

/// A failure meant for the user: one line saying where (file, line, key or flag) and what was
/// expected.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Error {
    message: String,
}

/// A result whose error is lodestar's [`Error`].
pub type Result<T> = std::result::Result<T, Error>;

impl Error {
    /// An error with this message; control characters in it (a newline in a file name, a
    /// parser quoting the character it choked on) are escaped, so it stays one line.
    pub fn new(message: impl Into<String>) -> Self {
        Error {
            message: one_line(message.into()),
        }
    }

    /// Prefix the message with context, e.g. the file being read.
    pub fn context(self, what: impl fmt::Display) -> Self {
        Error {
            message: one_line(format!("{what}: {}", self.message)),
        }
    }

    /// The message, one line, as printed.
    pub fn message(&self) -> &str {
        &self.message
    }
}

/// `message` with its control characters written as escapes (`\n`, `\t`, `\u{..}`).
fn one_line(message: String) -> String {
    if !message.chars().any(char::is_control) {
        return message;
    }
    message
        .chars()
        .map(|c| {
            if c.is_control() {
                c.escape_default().to_string()
            } else {
                c.to_string()
            }
        })
        .collect()
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.message)
    }
}

impl std::error::Error for Error {}

/// `bail!("...", args)` returns early with an [`Error`].
#[macro_export]
macro_rules! bail {
    ($($arg:tt)*) => { return Err($crate::error::Error::new(format!($($arg)*))) };
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn messages_are_one_line() {
        let e = Error::new("cannot load mesh 'a\nb.obj'\t(x)\r");
        assert_eq!(e.message(), "cannot load mesh 'a\\nb.obj'\\t(x)\\r");
        let e = Error::new("ok").context("file\u{7}.toml:3");
        assert_eq!(e.message(), "file\\u{7}.toml:3: ok");
    }
}
