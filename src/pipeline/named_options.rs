//! `RenderJob::set`: a method option set by name, `GROUP.FIELD=VALUE` (the types and limits
//! are `settings`'; this module knows the groups).
use super::job::RenderJob;
use super::settings::{parse, Settable, Setting};
use crate::methods::auto::options::AutoOptions;
use crate::methods::bandwidth::options::BandwidthOptions;
use crate::methods::lobe_aware::options::LobeAwareOptions;

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

/// Every settable name (`GROUP.FIELD`) with its limits (the tests render each at its limits).
pub fn all_settings() -> Vec<(String, Setting)> {
    fn of<T: Settable>() -> impl Iterator<Item = (String, Setting)> {
        T::settings().iter().map(|s| (format!("{}.{}", T::GROUP, s.name), *s))
    }
    of::<AutoOptions>().chain(of::<BandwidthOptions>()).chain(of::<LobeAwareOptions>()).collect()
}

impl RenderJob {
    /// Applies one `GROUP.FIELD=VALUE` assignment (see `settings`).
    pub fn set(&mut self, assignment: &str) -> Result<(), String> {
        assign(&mut self.auto, &mut self.bandwidth, &mut self.lobe, assignment)
    }
}

/// Whether `assignment` would be accepted, without a job to apply it to.
pub fn check(assignment: &str) -> Result<(), String> {
    assign(&mut Default::default(), &mut Default::default(), &mut Default::default(), assignment)
}

fn assign(
    auto: &mut AutoOptions,
    bandwidth: &mut BandwidthOptions,
    lobe: &mut LobeAwareOptions,
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
        "lobe" => set_in(lobe, name, text),
        _ => Err(format!("{key}: no group {group:?}; the groups are auto, bandwidth, lobe")),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::methods::tests::{all_frames, builtin};
    use crate::pipeline::job::{Halt, Method};
    use crate::pipeline::settings::Kind;

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
            ("aaf.mu0=1", "no group"),
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
    /// the method acts on: `cornell` for `auto`, `cornell-glossy` for `lobe-aware`,
    /// `sky-spheres` for `bandwidth`).
    #[test]
    fn every_setting_at_its_limits_renders_a_finite_image() {
        for (key, setting) in all_settings() {
            let (scene, method) = match key.split('.').next() {
                Some("auto") => ("cornell", Method::Auto),
                Some("lobe") => ("cornell-glossy", Method::LobeAware),
                _ => ("sky-spheres", Method::Bandwidth),
            };
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
