//! Method options set by name (`wedge bench --set auto.narrow_scale=0.25`), so that a choice a
//! benchmark measured against the default can be rerun from its command line.
//!
//! Each options struct lists the fields it lets a user set, each with its limits
//! (`Setting`); `RenderJob::set` dispatches `GROUP.FIELD=VALUE` to the struct of `GROUP`. A
//! value outside its limits, a name no struct has, or a value that does not parse is an error
//! naming the setting and its limits, never a render that panics or draws NaN (every limit is
//! rendered at in the tests below).
use super::job::RenderJob;

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
            Value::Integer(n) => n as f64,
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

/// Sets `name` (a field of `T`) to `text`.
fn set_in<T: Settable>(options: &mut T, name: &str, text: &str) -> Result<(), String> {
    let Some(setting) = T::settings().iter().find(|s| s.name == name) else {
        let names: Vec<&str> = T::settings().iter().map(|s| s.name).collect();
        return Err(format!("{}.{name}: no such setting; {} has {}", T::GROUP, T::GROUP, names.join(", ")));
    };
    let value = parse(setting, text).map_err(|e| format!("{}.{e}", T::GROUP))?;
    options.apply(name, value);
    Ok(())
}

/// Every settable name (`GROUP.FIELD`) with its limits, for `--help` and errors.
pub fn all_settings() -> Vec<(String, Setting)> {
    use crate::methods::auto::options::AutoOptions;
    use crate::methods::bandwidth::options::BandwidthOptions;
    fn of<T: Settable>() -> impl Iterator<Item = (String, Setting)> {
        T::settings().iter().map(|s| (format!("{}.{}", T::GROUP, s.name), *s))
    }
    of::<AutoOptions>().chain(of::<BandwidthOptions>()).collect()
}

impl RenderJob {
    /// Applies one `GROUP.FIELD=VALUE` assignment (see the module docs).
    pub fn set(&mut self, assignment: &str) -> Result<(), String> {
        assign(&mut self.auto, &mut self.bandwidth, assignment)
    }
}

/// Whether `assignment` would be accepted, without a job to apply it to.
pub fn check(assignment: &str) -> Result<(), String> {
    assign(&mut Default::default(), &mut Default::default(), assignment)
}

fn assign(
    auto: &mut crate::methods::auto::options::AutoOptions,
    bandwidth: &mut crate::methods::bandwidth::options::BandwidthOptions,
    assignment: &str,
) -> Result<(), String> {
    let (key, text) = assignment
        .split_once('=')
        .ok_or_else(|| format!("{assignment:?}: expected NAME=VALUE, e.g. auto.narrow_scale=0.25"))?;
    let key = key.trim();
    let (group, name) =
        key.split_once('.').ok_or_else(|| format!("{key:?}: expected GROUP.NAME, e.g. auto.narrow_scale"))?;
    match group {
        "auto" => set_in(auto, name, text),
        "bandwidth" => set_in(bandwidth, name, text),
        _ => Err(format!("{key}: no group {group:?}; the groups are auto, bandwidth")),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::methods::tests::{all_frames, builtin};
    use crate::pipeline::job::{Halt, Method};

    fn job(scene: &str, method: Method) -> RenderJob {
        let mut j = RenderJob::new(builtin(scene, 12, 9), method, Halt::passes(3));
        j.bounces = 1;
        j
    }

    #[test]
    fn an_assignment_sets_the_field_and_bad_ones_say_why() {
        let mut j = job("cornell", Method::Auto);
        j.set("auto.narrow_scale=0.25").unwrap();
        assert_eq!(j.auto.narrow_scale, 0.25);
        j.set(" bandwidth.lookups_per_sample = 8 ").unwrap();
        assert_eq!(j.bandwidth.lookups_per_sample, 8.0);
        j.set("auto.narrow_linear=false").unwrap();
        assert!(!j.auto.narrow_linear);
        j.set("bandwidth.visibility=control-variate").unwrap();
        assert_eq!(j.bandwidth.visibility, crate::methods::bandwidth::options::Visibility::ControlVariate);
        for (bad, says) in [
            ("auto.narrow_scale", "expected NAME=VALUE"),
            ("narrow_scale=1", "expected GROUP.NAME"),
            ("lobe.beta=1", "no group"),
            ("auto.nope=1", "no such setting"),
            ("auto.narrow_scale=2", "a number from 0 to 1"),
            ("auto.narrow_scale=NaN", "a number from 0 to 1"),
            ("auto.narrow_scale=x", "a number from 0 to 1"),
            ("auto.max_radius=-1", "a whole number"),
            ("auto.max_radius=1.5", "a whole number"),
            ("auto.narrow_linear=yes", "true or false"),
            ("bandwidth.visibility=both", "one of ratio, control-variate"),
        ] {
            let e = j.set(bad).unwrap_err();
            assert!(e.contains(says), "{bad}: {e}");
        }
        // A rejected value leaves the field as it was; `check` agrees with `set`.
        assert_eq!(j.auto.narrow_scale, 0.25);
        assert!(check("auto.beta=3").is_ok() && check("auto.beta=-3").is_err());
    }

    /// Every setting at each of its limits renders a finite image (with a bounce, on a scene
    /// the method acts on: `cornell` for `auto`, `sky-spheres` for `bandwidth`).
    #[test]
    fn every_setting_at_its_limits_renders_a_finite_image() {
        for (key, setting) in all_settings() {
            let (scene, method) =
                if key.starts_with("auto.") { ("cornell", Method::Auto) } else { ("sky-spheres", Method::Bandwidth) };
            let values: Vec<String> = match setting.kind {
                Kind::Number { lo, hi } => vec![lo.to_string(), hi.to_string()],
                Kind::Integer { lo, hi } => vec![lo.to_string(), hi.to_string()],
                Kind::Flag => vec!["false".into(), "true".into()],
                Kind::Choice(words) => words.iter().map(|w| w.to_string()).collect(),
            };
            for v in values {
                let mut j = job(scene, method);
                j.set(&format!("{key}={v}")).unwrap();
                for frame in all_frames(&j) {
                    assert!(frame.color.iter().flatten().all(|x| x.is_finite() && *x >= 0.0), "{key}={v}: not finite");
                }
            }
        }
    }
}
