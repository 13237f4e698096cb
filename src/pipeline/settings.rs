//! Method options set by name (`wedge bench --set auto.narrow_scale=0.25`), so that a choice a
//! benchmark measured against the default can be rerun from its command line.
//!
//! Each options struct lists the fields it lets a user set, each with its limits
//! (`Setting`); `RenderJob::set` (`named_options`) dispatches `GROUP.FIELD=VALUE` to the
//! struct of `GROUP`. A value outside its limits, a name no struct has, or a value that does
//! not parse is an error naming the setting and its limits, never a render that panics or
//! draws NaN (`named_options`' tests render at every limit). This module imports nothing of
//! the crate, so that the options structs below it can implement `Settable`.

/// What one settable field takes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Kind {
    /// A finite number in [lo, hi].
    Number { lo: f64, hi: f64 },
    /// A whole number in [lo, hi].
    Integer { lo: u64, hi: u64 },
    /// true or false.
    Flag,
    /// One of these words.
    Choice(&'static [&'static str]),
}

/// A settable field: its name within its group and what it takes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Setting {
    pub name: &'static str,
    pub kind: Kind,
}

impl Setting {
    pub const fn number(name: &'static str, lo: f64, hi: f64) -> Setting {
        Setting { name, kind: Kind::Number { lo, hi } }
    }
    pub const fn integer(name: &'static str, lo: u64, hi: u64) -> Setting {
        Setting { name, kind: Kind::Integer { lo, hi } }
    }
    pub const fn flag(name: &'static str) -> Setting {
        Setting { name, kind: Kind::Flag }
    }
    pub const fn choice(name: &'static str, words: &'static [&'static str]) -> Setting {
        Setting { name, kind: Kind::Choice(words) }
    }

    /// The limits in words, for errors and `--help`.
    pub fn describe(&self) -> String {
        match self.kind {
            Kind::Number { lo, hi } => format!("a number from {lo} to {hi}"),
            Kind::Integer { lo, hi } => format!("a whole number from {lo} to {hi}"),
            Kind::Flag => "true or false".to_string(),
            Kind::Choice(words) => format!("one of {}", words.join(", ")),
        }
    }
}

/// A parsed value, checked against its setting's limits.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Value {
    Number(f64),
    Integer(u64),
    Flag(bool),
    /// Index into the setting's words.
    Choice(usize),
}

impl Value {
    pub fn number(self) -> f64 {
        match self {
            Value::Number(x) => x,
            _ => unreachable!("a number setting parses to a number"),
        }
    }
    pub fn integer(self) -> u64 {
        match self {
            Value::Integer(n) => n,
            _ => unreachable!("an integer setting parses to an integer"),
        }
    }
    pub fn flag(self) -> bool {
        match self {
            Value::Flag(b) => b,
            _ => unreachable!("a flag setting parses to a flag"),
        }
    }
    pub fn choice(self) -> usize {
        match self {
            Value::Choice(i) => i,
            _ => unreachable!("a choice setting parses to a choice"),
        }
    }
}

/// An options struct whose fields can be set by name.
pub trait Settable {
    /// The group name (`auto`, `bandwidth`).
    const GROUP: &'static str;
    /// The fields it lets a user set.
    fn settings() -> &'static [Setting];
    /// Stores `value`, already checked against the limits of the setting called `name`.
    fn apply(&mut self, name: &str, value: Value);
}

/// Parses `text` as a value of `setting`.
pub fn parse(setting: &Setting, text: &str) -> Result<Value, String> {
    let text = text.trim();
    let bad = || format!("{}: {text:?} is not {}", setting.name, setting.describe());
    match setting.kind {
        Kind::Number { lo, hi } => {
            let x: f64 = text.parse().map_err(|_| bad())?;
            if x.is_finite() && (lo..=hi).contains(&x) {
                Ok(Value::Number(x))
            } else {
                Err(bad())
            }
        }
        Kind::Integer { lo, hi } => {
            let n: u64 = text.parse().map_err(|_| bad())?;
            if (lo..=hi).contains(&n) {
                Ok(Value::Integer(n))
            } else {
                Err(bad())
            }
        }
        Kind::Flag => text.parse().map(Value::Flag).map_err(|_| bad()),
        Kind::Choice(words) => words.iter().position(|w| *w == text).map(Value::Choice).ok_or_else(bad),
    }
}
