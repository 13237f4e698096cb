//! Client-supplied text in log lines. Scene names, labels and error messages that quote a
//! request's values come from whoever calls the server: written raw, a name holding a newline
//! forges a separate log line, and terminal escape sequences reach whoever reads the log. Every
//! log field that can hold such text goes through `Escaped`.
use std::fmt::{self, Write};

/// Displays a string with control, formatting and other non-printable characters (newlines,
/// ESC, bidirectional overrides, ...) and backslashes escaped as Rust writes them (`\n`,
/// `\u{1b}`, `\\`), so that one value is always one line of plain text. Quotes stay as they are.
pub struct Escaped<'a>(pub &'a str);

impl fmt::Display for Escaped<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for c in self.0.chars() {
            match c {
                '"' | '\'' => f.write_char(c)?,
                _ => write!(f, "{}", c.escape_debug())?,
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::Escaped;

    #[test]
    fn one_value_stays_one_line_of_plain_text() {
        let cases = [
            ("cornell", "cornell"),
            ("nope\nFORGED-LOG-LINE level=INFO", "nope\\nFORGED-LOG-LINE level=INFO"),
            ("a\r\nb\tc", "a\\r\\nb\\tc"),
            ("\u{1b}[31mred\u{1b}[0m", "\\u{1b}[31mred\\u{1b}[0m"),
            ("abc\u{202e}fed", "abc\\u{202e}fed"),
            ("back\\slash \"quoted\" 'it's'", "back\\\\slash \"quoted\" 'it's'"),
            ("zero\0byte", "zero\\0byte"),
            ("Überraschung ☃", "Überraschung ☃"),
        ];
        for (raw, want) in cases {
            let got = Escaped(raw).to_string();
            assert_eq!(got, want);
            assert!(!got.chars().any(char::is_control), "{got:?}");
        }
    }
}
