//! `RenderJob::set`: a method option set by name, `GROUP.FIELD=VALUE` (the types and limits
//! are `settings`'; this module knows the groups).
use super::job::RenderJob;
use super::settings::{parse, Settable, Setting};
use crate::methods::aaf_indirect::options::IndirectOptions;
use crate::methods::aaf_shadows::options::AafOptions;
use crate::methods::auto::options::AutoOptions;
use crate::methods::bandwidth::options::BandwidthOptions;
use crate::methods::lobe_aware::options::LobeAwareOptions;
use crate::methods::uniform::options::UniformOptions;

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
    (of::<AutoOptions>().chain(of::<BandwidthOptions>()).chain(of::<LobeAwareOptions>()))
        .chain(of::<AafOptions>().chain(of::<IndirectOptions>()))
        .chain(of::<UniformOptions>())
        .collect()
}

impl RenderJob {
    /// Applies one `GROUP.FIELD=VALUE` assignment (see `settings`).
    pub fn set(&mut self, assignment: &str) -> Result<(), String> {
        let mut groups = Groups {
            auto: &mut self.auto,
            bandwidth: &mut self.bandwidth,
            lobe: &mut self.lobe,
            aaf: &mut self.aaf,
            indirect: &mut self.indirect,
            uniform: &mut self.uniform,
        };
        groups.assign(assignment)
    }
}

/// Whether `assignment` would be accepted, without a job to apply it to.
pub fn check(assignment: &str) -> Result<(), String> {
    let (mut auto, mut bandwidth, mut lobe, mut aaf, mut indirect, mut uniform) = Default::default();
    let mut groups = Groups {
        auto: &mut auto,
        bandwidth: &mut bandwidth,
        lobe: &mut lobe,
        aaf: &mut aaf,
        indirect: &mut indirect,
        uniform: &mut uniform,
    };
    groups.assign(assignment)
}

/// The option groups a job carries, by the names `--set` gives them.
struct Groups<'a> {
    auto: &'a mut AutoOptions,
    bandwidth: &'a mut BandwidthOptions,
    lobe: &'a mut LobeAwareOptions,
    aaf: &'a mut AafOptions,
    indirect: &'a mut IndirectOptions,
    uniform: &'a mut UniformOptions,
}

impl Groups<'_> {
    fn assign(&mut self, assignment: &str) -> Result<(), String> {
        let (key, text) = assignment
            .split_once('=')
            .ok_or_else(|| format!("{assignment:?}: expected NAME=VALUE, e.g. auto.narrow_scale=0.25"))?;
        let key = key.trim();
        let (group, name) =
            key.split_once('.').ok_or_else(|| format!("{key:?}: expected GROUP.NAME, e.g. auto.narrow_scale"))?;
        match group {
            "auto" => set_in(self.auto, name, text),
            "bandwidth" => set_in(self.bandwidth, name, text),
            "lobe" => set_in(self.lobe, name, text),
            "aaf" => set_in(self.aaf, name, text),
            "indirect" => set_in(self.indirect, name, text),
            "uniform" => set_in(self.uniform, name, text),
            _ => Err(format!("{key}: no group {group:?}; the groups are {GROUPS}")),
        }
    }
}

/// The groups' names, for messages.
const GROUPS: &str = "auto, bandwidth, lobe, aaf, indirect, uniform";

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
        j.set("aaf.light_sigma=profile").unwrap();
        assert_eq!(j.aaf.light_sigma, crate::methods::aaf_shadows::options::LightSigma::Profile);
        j.set("aaf.k=2").unwrap();
        assert_eq!(j.aaf.constants.k, 2.0);
        j.set("indirect.kernel_scale=0.25").unwrap();
        assert_eq!(j.indirect.kernel_scale, 0.25);
        assert_eq!(j.bandwidth.visibility, crate::methods::bandwidth::options::Visibility::ControlVariate);
        for (bad, says) in [
            ("auto.narrow_scale", "expected NAME=VALUE"),
            ("narrow_scale=1", "expected GROUP.NAME"),
            ("shadows.mu0=1", "no group"),
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
    /// the method acts on: `cornell` for `auto` (and without bounces), `cornell-glossy` for
    /// `lobe-aware`, `sky-spheres` for `bandwidth`, `grids` (direct light) for `aaf`'s soft
    /// shadows and `cornell` with a bounce for its indirect light).
    #[test]
    fn every_setting_at_its_limits_renders_a_finite_image() {
        for (key, setting) in all_settings() {
            // `auto`'s sample counts adapt in direct-light renders only: those too.
            let (scene, method, bounces): (&str, Method, &[u32]) = match key.split('.').next() {
                Some("auto") => ("cornell", Method::Auto, &[0, 1][..]),
                Some("lobe") => ("cornell-glossy", Method::LobeAware, &[1]),
                Some("aaf") => ("grids", Method::Aaf, &[0]),
                Some("indirect") => ("cornell", Method::Aaf, &[1]),
                _ => ("sky-spheres", Method::Bandwidth, &[1]),
            };
            let values: Vec<String> = match setting.kind {
                Kind::Number { lo, hi } => vec![lo.to_string(), hi.to_string()],
                Kind::Integer { lo, hi } => vec![lo.to_string(), hi.to_string()],
                Kind::Flag => vec!["false".into(), "true".into()],
                Kind::Choice(words) => words.iter().map(|w| w.to_string()).collect(),
            };
            for (v, &b) in values.iter().flat_map(|v| bounces.iter().map(move |b| (v, b))) {
                let mut j = job(scene, method);
                j.bounces = b;
                j.set(&format!("{key}={v}")).unwrap();
                for frame in all_frames(&j) {
                    let finite = frame.color.iter().flatten().all(|x| x.is_finite() && *x >= 0.0);
                    assert!(finite, "{key}={v}, {b} bounces: not finite");
                }
            }
        }
    }
}
