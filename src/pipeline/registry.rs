//! The one table of methods. Each row names a method (CLI name, wire enum value), says what it
//! renders (its per-component maps, whether it filters, whether it needs the shared G-buffer)
//! and how it is built. The CLI, the request validation, the wire conversions, the stream's
//! layer list and the pass loop all read this table; adding a method is one folder under
//! `methods/` plus one row here (and its enum variant and wire value).
use super::job::{Method, RenderJob};
use super::strategy::Strategy;
use crate::methods::mode::FilterMode;
use crate::methods::{auto, bandwidth::BandwidthShading, parts, uniform::Uniform};
use crate::proto;

pub struct MethodSpec {
    pub method: Method,
    /// The name on the CLI, in scene files' canonical JSON (lower case) and in outputs.
    pub name: &'static str,
    pub proto: proto::Method,
    /// One line for `--help` and the docs.
    pub summary: &'static str,
    /// Whether frames are filtered (then they carry unfiltered colour and filter widths).
    pub filters: bool,
    /// Whether the pipeline builds the shared G-buffer before pass 0 for the job.
    pub needs_gbuffer: fn(&RenderJob) -> bool,
    /// The names of the per-component maps (`Frame::components`) a frame of the job carries,
    /// in order: known before the render starts, so a stream can announce its layers.
    pub components: fn(&RenderJob) -> Vec<&'static str>,
    pub build: fn(&RenderJob) -> Box<dyn Strategy>,
}

pub const METHODS: &[MethodSpec] = &[
    MethodSpec {
        method: Method::Uniform,
        name: "uniform",
        proto: proto::Method::Uniform,
        summary: "plain Monte Carlo: the same samples everywhere, no filter (the baseline)",
        filters: false,
        needs_gbuffer: |_| false,
        components: |_| Vec::new(),
        build: |job| Box::new(Uniform::new(job)),
    },
    MethodSpec {
        method: Method::Aaf,
        name: "aaf",
        proto: proto::Method::Aaf,
        summary: "axis-aligned filtering of soft shadows (Mehta 2012) and indirect light (Mehta 2013)",
        filters: true,
        needs_gbuffer: |_| true,
        components: |job| parts::component_names(job, FilterMode::Aaf),
        build: |job| parts::build(job, FilterMode::Aaf),
    },
    MethodSpec {
        method: Method::Adaptive,
        name: "adaptive",
        proto: proto::Method::Adaptive,
        summary: "AAF's adaptive sample counts without its filter (a baseline)",
        filters: false,
        needs_gbuffer: |_| true,
        components: |job| parts::component_names(job, FilterMode::Adaptive),
        build: |job| parts::build(job, FilterMode::Adaptive),
    },
    MethodSpec {
        method: Method::UniformFiltered,
        name: "uniform-filtered",
        proto: proto::Method::UniformFiltered,
        summary: "the same samples everywhere and a fixed-width filter (a baseline)",
        filters: true,
        needs_gbuffer: |_| true,
        components: |job| parts::component_names(job, FilterMode::UniformFiltered),
        build: |job| parts::build(job, FilterMode::UniformFiltered),
    },
    MethodSpec {
        method: Method::LobeAware,
        name: "lobe-aware",
        proto: proto::Method::LobeAware,
        summary: "indirect light filtered with specular lobe-aware weights (Tokuyoshi 2015)",
        filters: true,
        needs_gbuffer: |_| true,
        components: |job| parts::component_names(job, FilterMode::LobeAware),
        build: |job| parts::build(job, FilterMode::LobeAware),
    },
    MethodSpec {
        method: Method::NormalAware,
        name: "normal-aware",
        proto: proto::Method::NormalAware,
        summary: "indirect light filtered with normal-aware weights (Tokuyoshi's baseline, Eq. 4)",
        filters: true,
        needs_gbuffer: |_| true,
        components: |job| parts::component_names(job, FilterMode::NormalAware),
        build: |job| parts::build(job, FilterMode::NormalAware),
    },
    MethodSpec {
        method: Method::Auto,
        name: "auto",
        proto: proto::Method::Auto,
        summary: "all light filtered apart: AAF's widths (Mehta 2012, 2013) with lobe-aware weights (Tokuyoshi 2015)",
        filters: true,
        needs_gbuffer: auto::needs_gbuffer,
        components: auto::component_names,
        build: auto::build,
    },
    MethodSpec {
        method: Method::Bandwidth,
        name: "bandwidth",
        proto: proto::Method::Bandwidth,
        summary: "environment light shaded on nested grids at its predicted bandwidth (Bagher 2012)",
        filters: false,
        needs_gbuffer: |_| true,
        components: |_| Vec::new(),
        build: |job| Box::new(BandwidthShading::new(job)),
    },
];

/// The method the product recommends: the one the README's first command and a request that
/// names no method render with.
pub const DEFAULT_METHOD: Method = Method::Auto;

impl Method {
    pub const ALL: [Method; 8] = [
        Method::Uniform,
        Method::Aaf,
        Method::Adaptive,
        Method::UniformFiltered,
        Method::LobeAware,
        Method::NormalAware,
        Method::Auto,
        Method::Bandwidth,
    ];

    /// This method's row.
    pub fn spec(self) -> &'static MethodSpec {
        METHODS.iter().find(|s| s.method == self).expect("every method has a registry row")
    }

    pub fn name(self) -> &'static str {
        self.spec().name
    }

    pub fn filters(self) -> bool {
        self.spec().filters
    }

    pub fn from_name(name: &str) -> Option<Method> {
        METHODS.iter().find(|s| s.name == name).map(|s| s.method)
    }

    pub fn to_proto(self) -> proto::Method {
        self.spec().proto
    }

    /// The method of a wire value (`None` for METHOD_UNSPECIFIED).
    pub fn from_proto(m: proto::Method) -> Option<Method> {
        METHODS.iter().find(|s| s.proto == m).map(|s| s.method)
    }
}

/// The names of the per-component maps the frames of `job` carry, in order.
pub fn component_names(job: &RenderJob) -> Vec<&'static str> {
    (job.method.spec().components)(job)
}

/// The strategy of `job.method`.
pub fn make_strategy(job: &RenderJob) -> Box<dyn Strategy> {
    (job.method.spec().build)(job)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_method_has_one_row_and_distinct_names_and_wire_values() {
        assert_eq!(METHODS.len(), Method::ALL.len());
        for (i, a) in METHODS.iter().enumerate() {
            assert_eq!(a.method.spec().name, a.name);
            assert_eq!(Method::from_name(a.name), Some(a.method));
            assert_eq!(Method::from_proto(a.proto), Some(a.method));
            for b in &METHODS[i + 1..] {
                assert!(a.method != b.method && a.name != b.name && a.proto != b.proto);
            }
        }
        assert_eq!(Method::from_proto(proto::Method::Unspecified), None);
        // Every wire value but UNSPECIFIED has a row.
        for v in 1..=8 {
            let m = proto::Method::try_from(v).unwrap();
            assert!(Method::from_proto(m).is_some(), "{m:?} has no row");
        }
    }

    /// On an area-lit scene with a bounce, where every method has something to filter.
    #[test]
    fn filtering_methods_need_the_g_buffer() {
        use crate::pipeline::job::Halt;
        let scene = crate::methods::tests::builtin("cornell", 8, 8);
        for s in METHODS {
            let mut job = RenderJob::new(scene.clone(), s.method, Halt::passes(1));
            job.bounces = 1;
            assert!(!s.filters || (s.needs_gbuffer)(&job), "{} filters without a G-buffer", s.name);
        }
    }
}
