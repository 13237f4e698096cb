//! The frame as one single-part, multi-layer OpenEXR file: every map the method produced, at
//! full f32 precision, losslessly compressed, with the render settings in the header. This is
//! the file comparisons and error metrics are computed from; the PNGs are only for looking at.
//!
//! Channels (the exr crate stores them sorted by name, so reading looks them up by name):
//! `R`,`G`,`B` colour; `spp.Y`; `filter_width.Y` (zeros for unfiltered methods);
//! `unfiltered.R`,`.G`,`.B` only when the frame has an unfiltered colour; and for each component
//! of the light the method sampled separately, `spp.<component>.Y` and
//! `filter_width.<component>.Y` (so viewers show each map as its own greyscale layer, like
//! `spp.Y`). The sorted channel list loses the components' order, so the `wedge.components`
//! attribute lists them. When the render traced denoiser inputs: `albedo.R`,`.G`,`.B`,
//! `normal.X`,`.Y`,`.Z` (world space) and `depth.Z` (scene units, +inf where nothing is hit).
//! For methods that shade at a predicted rate (`bandwidth`): `bandwidth.Y` (cycles per pixel,
//! +inf where not band-limited) and `level.Y` (the pass's shading level per pixel).
use std::collections::{BTreeMap, HashMap};
use std::io::Cursor;
use std::path::Path;

use ::exr::prelude::{
    AnyChannel, AnyChannels, AttributeValue, Blocks, Compression, Encoding, FlatSamples, Image, Layer, LayerAttributes,
    LineOrder, ReadChannels, ReadLayers, Text, Vec2, WritableImage,
};

use super::exr_attributes::{
    attributes_as_text, components_attribute, from_attributes, read_components, to_attributes,
};
use super::exr_canonical::sort_header_attributes;
use super::{OutputError, OutputOptions};
use crate::pipeline::frame::{ComponentMaps, Frame, RenderInfo, ShadingMaps};
use crate::render::aovs::Aovs;
use std::sync::Arc;

/// ZIP over 16-scanline blocks, written in increasing line order: lossless and compact for
/// float data, and with a fixed block order the parallel compressor's output is deterministic.
const ENCODING: Encoding =
    Encoding { compression: Compression::ZIP16, blocks: Blocks::ScanLines, line_order: LineOrder::Increasing };

const RGB: [&str; 3] = ["R", "G", "B"];
const UNFILTERED_RGB: [&str; 3] = ["unfiltered.R", "unfiltered.G", "unfiltered.B"];
const ALBEDO: [&str; 3] = ["albedo.R", "albedo.G", "albedo.B"];
const NORMAL: [&str; 3] = ["normal.X", "normal.Y", "normal.Z"];
const DEPTH: &str = "depth.Z";
const SPP: &str = "spp.Y";
const FILTER_WIDTH: &str = "filter_width.Y";
const BANDWIDTH: &str = "bandwidth.Y";
const LEVEL: &str = "level.Y";

/// A file read back by `read_exr`.
#[derive(Clone, Debug)]
pub struct ExrImage {
    /// The maps and stats. `filter_width` is `None` when the stored map is all zero (which is how
    /// `write_exr` stores `None`); the seconds are 0 when the file was written reproducibly.
    pub frame: Frame,
    pub info: RenderInfo,
    /// The `wedge.*` header attributes as text (numbers in Rust's shortest round-trip form,
    /// vectors as "x y z"), for tests and tools.
    pub attributes: BTreeMap<String, String>,
}

pub fn write_exr(path: &Path, frame: &Frame, info: &RenderInfo, opts: &OutputOptions) -> Result<(), OutputError> {
    let invalid = |reason: String| OutputError::InvalidInput { path: path.to_path_buf(), reason };
    check_frame(frame).map_err(invalid)?;
    let mut attributes = to_attributes(info, &frame.stats, !opts.reproducible).map_err(invalid)?;
    attributes.extend(components_attribute(&frame.components));
    let layer_attributes = LayerAttributes {
        software_name: Some(Text::from(concat!("wedge ", env!("CARGO_PKG_VERSION")))),
        other: attributes.into_iter().map(|(name, value)| (Text::from(name), value)).collect(),
        ..LayerAttributes::default()
    };
    let size = (frame.width as usize, frame.height as usize);
    let layer = Layer::new(size, layer_attributes, ENCODING, channels(frame));

    let mut bytes = Vec::new();
    Image::from_layer(layer).write().to_buffered(Cursor::new(&mut bytes)).map_err(|source| exr_error(path, source))?;
    // Only fails if the exr crate's output is not the format it claims; report, don't panic.
    sort_header_attributes(&mut bytes).map_err(|e| {
        let reason = format!("encoder wrote a header we cannot parse: {e}");
        exr_error(path, ::exr::error::Error::Invalid(reason.into()))
    })?;
    std::fs::write(path, bytes).map_err(|source| OutputError::Io { path: path.to_path_buf(), source })
}

pub fn read_exr(path: &Path) -> Result<ExrImage, OutputError> {
    let image = ::exr::prelude::read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .first_valid_layer()
        .all_attributes()
        .pedantic()
        .from_file(path)
        .map_err(|source| exr_error(path, source))?;
    let not_wedge = |reason: String| OutputError::Format { path: path.to_path_buf(), reason };
    let layer = image.layer_data;
    let (width, height) = (layer.size.width(), layer.size.height());
    let pixel_count = width * height;

    let channel = |name: &str| -> Result<Option<Vec<f32>>, OutputError> {
        let Some(channel) = layer.channel_data.list.iter().find(|c| c.name.eq(name)) else {
            return Ok(None);
        };
        if channel.sampling != Vec2(1, 1) {
            return Err(not_wedge(format!("channel {name} is subsampled")));
        }
        let values: Vec<f32> = match &channel.sample_data {
            FlatSamples::F32(values) => values.clone(),
            other => other.values_as_f32().collect(),
        };
        if values.len() != pixel_count {
            return Err(not_wedge(format!("channel {name} has {} samples", values.len())));
        }
        Ok(Some(values))
    };
    let required = |name: &str| channel(name)?.ok_or_else(|| not_wedge(format!("no {name} channel")));
    let rgb = |names: [&str; 3]| -> Result<Option<Vec<[f32; 3]>>, OutputError> {
        match names.map(channel) {
            [Ok(Some(r)), Ok(Some(g)), Ok(Some(b))] => Ok(Some(interleave(&r, &g, &b))),
            [Ok(None), Ok(None), Ok(None)] => Ok(None),
            [Err(e), _, _] | [_, Err(e), _] | [_, _, Err(e)] => Err(e),
            _ => Err(not_wedge(format!("only some of the channels {names:?}"))),
        }
    };

    let color = rgb(RGB)?.ok_or_else(|| not_wedge(format!("no {RGB:?} channels")))?;
    let unfiltered = rgb(UNFILTERED_RGB)?;
    let spp = required(SPP)?;
    let filter_width = nonzero(required(FILTER_WIDTH)?);

    // Our attributes are layer attributes; merge the image-level ones in case another tool
    // rewrote the file and moved them.
    let mut attributes: HashMap<Text, AttributeValue> = image.attributes.other;
    attributes.extend(layer.attributes.other);
    let (info, stats) = from_attributes(&attributes).map_err(not_wedge)?;
    let components = read_components(&attributes)
        .map_err(not_wedge)?
        .into_iter()
        .map(|name| {
            let (spp, filter_width) = component_channels(&name);
            Ok(ComponentMaps { spp: required(&spp)?, filter_width: nonzero(required(&filter_width)?), name })
        })
        .collect::<Result<Vec<_>, OutputError>>()?;
    let (albedo, normal, depth) = (rgb(ALBEDO)?, rgb(NORMAL)?, channel(DEPTH)?);
    let aovs = (albedo.is_some() || normal.is_some() || depth.is_some()).then(|| {
        Arc::new(Aovs {
            albedo: albedo.unwrap_or_default(),
            normal: normal.unwrap_or_default(),
            depth: depth.unwrap_or_default(),
        })
    });
    let shading = match (channel(BANDWIDTH)?, channel(LEVEL)?) {
        (Some(bandwidth), Some(level)) => Some(ShadingMaps { bandwidth, level, ..ShadingMaps::default() }),
        (None, None) => None,
        _ => return Err(not_wedge(format!("only one of the channels {BANDWIDTH} and {LEVEL}"))),
    };
    let too_large = || not_wedge(format!("image size {width}x{height} exceeds u32"));
    Ok(ExrImage {
        frame: Frame {
            shading,
            width: u32::try_from(width).map_err(|_| too_large())?,
            height: u32::try_from(height).map_err(|_| too_large())?,
            color,
            unfiltered,
            spp,
            filter_width,
            components,
            aovs,
            stats,
        },
        info,
        attributes: attributes_as_text(&attributes),
    })
}

/// Rejects frames whose buffers disagree with their size, before the exr crate panics on them.
fn check_frame(frame: &Frame) -> Result<(), String> {
    let n = frame.pixel_count();
    if n == 0 {
        return Err(format!("empty {}x{} frame", frame.width, frame.height));
    }
    let lengths = [
        ("colour", Some(frame.color.len())),
        ("unfiltered colour", frame.unfiltered.as_ref().map(Vec::len)),
        ("spp map", Some(frame.spp.len())),
        ("filter-width map", frame.filter_width.as_ref().map(Vec::len)),
        ("bandwidth map", frame.shading.as_ref().map(|m| m.bandwidth.len())),
        ("level map", frame.shading.as_ref().map(|m| m.level.len())),
    ];
    let component_lengths = frame.components.iter().flat_map(|c| {
        [
            (format!("{} spp map", c.name), Some(c.spp.len())),
            (format!("{} filter-width map", c.name), c.filter_width.as_ref().map(Vec::len)),
        ]
    });
    // Denoiser inputs not traced are empty and left out of the file.
    let aov_lengths = frame.aovs.iter().flat_map(|a| {
        [("albedo", a.albedo.len()), ("normal", a.normal.len()), ("depth", a.depth.len())]
            .into_iter()
            .filter(|&(_, len)| len > 0)
            .map(|(what, len)| (what.to_string(), Some(len)))
    });
    let lengths =
        lengths.into_iter().map(|(what, len)| (what.to_string(), len)).chain(component_lengths).chain(aov_lengths);
    for (what, len) in lengths {
        if let Some(len) = len.filter(|&len| len != n) {
            return Err(format!("{what} has {len} pixels, expected {}x{}", frame.width, frame.height));
        }
    }
    for (i, c) in frame.components.iter().enumerate() {
        // The name becomes part of channel names and of a space-separated attribute.
        if c.name.is_empty() || !c.name.bytes().all(|b| b.is_ascii_alphanumeric() || b == b'_') {
            return Err(format!("component name {:?} is not a single word", c.name));
        }
        if frame.components[..i].iter().any(|d| d.name == c.name) {
            return Err(format!("component {:?} appears twice", c.name));
        }
    }
    Ok(())
}

/// The spp and filter-width channel names of a component.
fn component_channels(name: &str) -> (String, String) {
    (format!("spp.{name}.Y"), format!("filter_width.{name}.Y"))
}

/// `None` for an all-zero map: how `write_exr` stores an absent filter-width map.
fn nonzero(values: Vec<f32>) -> Option<Vec<f32>> {
    Some(values).filter(|w| w.iter().any(|&v| v != 0.0))
}

fn channels(frame: &Frame) -> AnyChannels<FlatSamples> {
    // Unfiltered methods and components have no map; they filter with width 0 everywhere.
    let widths = |w: &Option<Vec<f32>>| w.clone().unwrap_or_else(|| vec![0.0; frame.pixel_count()]);
    let components = frame.components.iter().flat_map(|c| {
        let (spp, filter_width) = component_channels(&c.name);
        [channel(&spp, c.spp.clone()), channel(&filter_width, widths(&c.filter_width))]
    });
    let list = rgb_channels(RGB, &frame.color)
        .into_iter()
        .chain(frame.unfiltered.iter().flat_map(|u| rgb_channels(UNFILTERED_RGB, u)))
        .chain([channel(SPP, frame.spp.clone()), channel(FILTER_WIDTH, widths(&frame.filter_width))])
        .chain(components)
        .chain(aov_channels(frame))
        .chain(
            frame
                .shading
                .iter()
                .flat_map(|m| [channel(BANDWIDTH, m.bandwidth.clone()), channel(LEVEL, m.level.clone())]),
        );
    AnyChannels::sort(list.collect())
}

/// The channels of the denoiser inputs the frame has (none, or those traced).
fn aov_channels(frame: &Frame) -> Vec<AnyChannel<FlatSamples>> {
    let Some(a) = frame.aovs.as_deref() else { return Vec::new() };
    let mut list = Vec::new();
    if !a.albedo.is_empty() {
        list.extend(rgb_channels(ALBEDO, &a.albedo));
    }
    if !a.normal.is_empty() {
        list.extend(rgb_channels(NORMAL, &a.normal));
    }
    if !a.depth.is_empty() {
        list.push(channel(DEPTH, a.depth.clone()));
    }
    list
}

fn rgb_channels(names: [&str; 3], pixels: &[[f32; 3]]) -> [AnyChannel<FlatSamples>; 3] {
    std::array::from_fn(|c| channel(names[c], pixels.iter().map(|p| p[c]).collect()))
}

fn channel(name: &str, values: Vec<f32>) -> AnyChannel<FlatSamples> {
    AnyChannel {
        name: Text::from(name),
        sample_data: FlatSamples::F32(values),
        // OpenEXR's default `pLinear` is 0 for every channel; the exr crate would guess it
        // from the name, and it only matters to lossy compressors anyway.
        quantize_linearly: false,
        sampling: Vec2(1, 1),
    }
}

fn interleave(r: &[f32], g: &[f32], b: &[f32]) -> Vec<[f32; 3]> {
    r.iter().zip(g).zip(b).map(|((&r, &g), &b)| [r, g, b]).collect()
}

fn exr_error(path: &Path, source: ::exr::error::Error) -> OutputError {
    match source {
        ::exr::error::Error::Io(source) => OutputError::Io { path: path.to_path_buf(), source },
        source => OutputError::Exr { path: path.to_path_buf(), source },
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::output::exr_attributes::{METHOD_SECONDS, SECONDS};
    use crate::output::exr_canonical::header_attributes;
    use crate::output::test_util::TempDir;
    use crate::pipeline::frame::{CameraInfo, ComponentMaps, FrameStats, HaltReason, ShadingMaps};

    fn info() -> RenderInfo {
        RenderInfo {
            scene: "cornell-box".into(),
            method: "aaf".into(),
            seed: 0xdead_beef_cafe_f00d,
            bounces: 4,
            camera: CameraInfo {
                position: [0.0, 1.0, 3.5],
                look_at: [0.0, 1.0, 0.0],
                up: [0.0, 1.0, 0.0],
                vertical_fov_deg: 45.0,
            },
        }
    }

    /// A frame whose values exercise the float encoding: NaN, infinities, -0, subnormals.
    fn frame(width: u32, height: u32, filtered: bool) -> Frame {
        let n = (width * height) as usize;
        let special = [f32::NAN, f32::INFINITY, -0.0, 1e-40, -3.5, f32::MAX];
        let value = |i: usize, c: usize| match (i * 3 + c) % 17 {
            k @ 0..=5 => special[k],
            k => (i * 7 + c) as f32 * 0.013 + k as f32,
        };
        let rgb = |offset: usize| (0..n).map(|i| [0, 1, 2].map(|c| value(i + offset, c))).collect();
        Frame {
            // Bandwidth maps are infinite where not band-limited, and levels go below 0.
            shading: (!filtered).then(|| ShadingMaps {
                bandwidth: (0..n).map(|i| value(i, 2)).collect(),
                level: (0..n).map(|i| (i % 7) as f32 - 2.0).collect(),
                analysis_seconds: 0.0,
            }),
            width,
            height,
            color: rgb(0),
            unfiltered: filtered.then(|| rgb(5)),
            spp: (0..n).map(|i| (i % 5 * 4) as f32).collect(),
            filter_width: filtered.then(|| (0..n).map(|i| (i + 1) as f32 * 0.25).collect()),
            // Not in alphabetical order, which the file's sorted channels would give.
            components: ["shadow", "diffuse", "glossy"]
                .iter()
                .enumerate()
                .filter(|_| filtered)
                .map(|(c, name)| ComponentMaps {
                    name: name.to_string(),
                    spp: (0..n).map(|i| ((i + c) % 4) as f32).collect(),
                    // Glossy unfiltered: stored as zeros, read back as `None`.
                    filter_width: (c < 2).then(|| (0..n).map(|i| value(i + c, 1)).collect()),
                })
                .collect(),
            aovs: None,
            stats: FrameStats {
                pass: 3,
                mean_spp: 7.75,
                rays_traced: 123_456_789_012,
                elapsed_seconds: 1.5,
                is_final: true,
                halt_reason: HaltReason::MaxSpp,
                dropped_samples: 2,
                method_seconds: 0.25,
                pass_complete: true,
                estimated_error: None,
                shaded_points: 17,
                full_resolution_points: 123_456_789_012,
            },
        }
    }

    fn rgb_bits(pixels: &[[f32; 3]]) -> Vec<[u32; 3]> {
        pixels.iter().map(|p| p.map(f32::to_bits)).collect()
    }

    fn bits(values: &[f32]) -> Vec<u32> {
        values.iter().map(|v| v.to_bits()).collect()
    }

    fn assert_same_pixels(read: &Frame, written: &Frame) {
        assert_eq!((read.width, read.height), (written.width, written.height));
        assert_eq!(rgb_bits(&read.color), rgb_bits(&written.color));
        assert_eq!(read.unfiltered.as_deref().map(rgb_bits), written.unfiltered.as_deref().map(rgb_bits));
        assert_eq!(bits(&read.spp), bits(&written.spp));
        assert_eq!(read.filter_width.as_deref().map(bits), written.filter_width.as_deref().map(bits));
        let names = |f: &Frame| f.components.iter().map(|c| c.name.clone()).collect::<Vec<_>>();
        assert_eq!(names(read), names(written));
        for (r, w) in read.components.iter().zip(&written.components) {
            assert_eq!(bits(&r.spp), bits(&w.spp), "{}", w.name);
            assert_eq!(r.filter_width.as_deref().map(bits), w.filter_width.as_deref().map(bits), "{}", w.name);
        }
    }

    const REPRODUCIBLE: OutputOptions = OutputOptions { reproducible: true };
    const TIMED: OutputOptions = OutputOptions { reproducible: false };

    #[test]
    fn round_trip_is_bit_exact() {
        let dir = TempDir::new("exr_round_trip");
        for (width, height) in [(3, 5), (1, 1), (17, 2), (40, 33)] {
            let path = dir.path().join(format!("{width}x{height}.exr"));
            let written = frame(width, height, true);
            write_exr(&path, &written, &info(), &TIMED).unwrap();
            let read = read_exr(&path).unwrap();
            assert_same_pixels(&read.frame, &written);
            assert_eq!(read.frame.stats, written.stats);
            assert_eq!(read.info, info());
        }
    }

    #[test]
    fn denoiser_inputs_are_named_layers_and_round_trip() {
        let dir = TempDir::new("exr_aovs");
        let path = dir.path().join("f.exr");
        let mut written = frame(4, 3, true);
        let n = 12;
        written.aovs = Some(Arc::new(Aovs {
            albedo: (0..n).map(|i| [0.1 * i as f32, 0.5, 1.0]).collect(),
            normal: (0..n).map(|i| [0.0, 1.0, -0.01 * i as f32]).collect(),
            depth: (0..n).map(|i| if i == 0 { f32::INFINITY } else { i as f32 }).collect(),
        }));
        write_exr(&path, &written, &info(), &REPRODUCIBLE).unwrap();
        let read = read_exr(&path).unwrap().frame;
        assert_same_pixels(&read, &written);
        let (r, w) = (read.aovs.as_deref().unwrap(), written.aovs.as_deref().unwrap());
        assert_eq!(rgb_bits(&r.albedo), rgb_bits(&w.albedo));
        assert_eq!(rgb_bits(&r.normal), rgb_bits(&w.normal));
        assert_eq!(bits(&r.depth), bits(&w.depth));
        // Under the names denoising tools look for.
        let image = ::exr::prelude::read_all_flat_layers_from_file(&path).unwrap();
        let names: Vec<String> = image.layer_data[0].channel_data.list.iter().map(|c| c.name.to_string()).collect();
        for name in ALBEDO.iter().chain(&NORMAL).chain([&DEPTH]) {
            assert!(names.iter().any(|n| n == name), "{name} missing from {names:?}");
        }
        // Without them, no such channels and none read back.
        write_exr(&path, &frame(4, 3, true), &info(), &REPRODUCIBLE).unwrap();
        assert!(read_exr(&path).unwrap().frame.aovs.is_none());
        // Depth alone (a frame assembled from a stream that carried only depth).
        let mut depth_only = written.clone();
        depth_only.aovs = Some(Arc::new(Aovs { depth: w.depth.clone(), ..Aovs::default() }));
        write_exr(&path, &depth_only, &info(), &REPRODUCIBLE).unwrap();
        let r = read_exr(&path).unwrap().frame.aovs.unwrap();
        assert!(r.albedo.is_empty() && r.normal.is_empty() && bits(&r.depth) == bits(&w.depth));
        // A wrong-sized input is refused, not written.
        let mut bad = written.clone();
        bad.aovs = Some(Arc::new(Aovs { depth: vec![1.0; 5], ..w.clone() }));
        assert!(write_exr(&path, &bad, &info(), &REPRODUCIBLE).unwrap_err().to_string().contains("depth"));
    }

    #[test]
    fn round_trip_without_unfiltered_or_filter_width() {
        let dir = TempDir::new("exr_unfiltered");
        let path = dir.path().join("f.exr");
        let written = frame(3, 5, false);
        write_exr(&path, &written, &info(), &REPRODUCIBLE).unwrap();
        let read = read_exr(&path).unwrap();
        assert_same_pixels(&read.frame, &written);
        assert!(read.frame.unfiltered.is_none() && read.frame.filter_width.is_none());
        let expected_stats = FrameStats { elapsed_seconds: 0.0, method_seconds: 0.0, ..written.stats };
        assert_eq!(read.frame.stats, expected_stats);
        assert_eq!(read.info, info());
    }

    #[test]
    fn all_zero_filter_width_reads_back_as_none() {
        // `write_exr` stores `None` as zeros, so zeros are all `read_exr` can give back; `Frame`
        // treats the two alike (`filter_width_at` is 0 either way).
        let dir = TempDir::new("exr_zero_width");
        let path = dir.path().join("f.exr");
        let mut written = frame(3, 5, true);
        written.filter_width = Some(vec![0.0; 15]);
        write_exr(&path, &written, &info(), &REPRODUCIBLE).unwrap();
        let read = read_exr(&path).unwrap().frame;
        assert!(read.filter_width.is_none());
        assert!(read.unfiltered.is_some());
    }

    #[test]
    fn channels_compression_and_software_are_as_documented() {
        let dir = TempDir::new("exr_channels");
        for filtered in [true, false] {
            let path = dir.path().join(format!("{filtered}.exr"));
            write_exr(&path, &frame(3, 5, filtered), &info(), &REPRODUCIBLE).unwrap();
            let image = ::exr::prelude::read_first_flat_layer_from_file(&path).unwrap();
            let layer = &image.layer_data;
            let names: Vec<String> = layer.channel_data.list.iter().map(|c| c.name.to_string()).collect();
            let expected: &[&str] = if filtered {
                &[
                    "B",
                    "G",
                    "R",
                    "filter_width.Y",
                    "filter_width.diffuse.Y",
                    "filter_width.glossy.Y",
                    "filter_width.shadow.Y",
                    "spp.Y",
                    "spp.diffuse.Y",
                    "spp.glossy.Y",
                    "spp.shadow.Y",
                    "unfiltered.B",
                    "unfiltered.G",
                    "unfiltered.R",
                ]
            } else {
                &["B", "G", "R", "bandwidth.Y", "filter_width.Y", "level.Y", "spp.Y"]
            };
            assert_eq!(names, expected);
            let attributes = read_exr(&path).unwrap().attributes;
            let components = attributes.get("wedge.components").map(String::as_str);
            assert_eq!(components, filtered.then_some("shadow diffuse glossy"));
            let all_f32 = layer.channel_data.list.iter().all(|c| matches!(c.sample_data, FlatSamples::F32(_)));
            assert!(all_f32);
            assert_eq!(layer.encoding.compression, Compression::ZIP16);
            let software = layer.attributes.software_name.as_ref().unwrap();
            assert_eq!(software.to_string(), format!("wedge {}", env!("CARGO_PKG_VERSION")));
        }
    }

    #[test]
    fn writes_are_byte_identical() {
        let dir = TempDir::new("exr_deterministic");
        let write = |name: &str, frame: &Frame, opts: &OutputOptions| {
            let path = dir.path().join(name);
            write_exr(&path, frame, &info(), opts).unwrap();
            std::fs::read(path).unwrap()
        };
        let frame_a = frame(40, 33, true);
        // Both option values are deterministic for the same frame.
        for opts in [REPRODUCIBLE, TIMED] {
            assert_eq!(write("a.exr", &frame_a, &opts), write("b.exr", &frame_a, &opts));
        }
        // Reproducible files do not depend on how long the render took.
        let mut frame_b = frame_a.clone();
        frame_b.stats.elapsed_seconds = 99.0;
        frame_b.stats.method_seconds = 12.0;
        assert_eq!(write("a.exr", &frame_a, &REPRODUCIBLE), write("b.exr", &frame_b, &REPRODUCIBLE));
        assert_ne!(write("a.exr", &frame_a, &TIMED), write("b.exr", &frame_b, &TIMED));
    }

    #[test]
    fn timed_and_reproducible_files_differ_only_in_the_times() {
        let dir = TempDir::new("exr_times");
        let written = frame(3, 5, true);
        let read = |opts: &OutputOptions| {
            let path = dir.path().join(format!("{}.exr", opts.reproducible));
            write_exr(&path, &written, &info(), opts).unwrap();
            read_exr(&path).unwrap()
        };
        let (timed, reproducible) = (read(&TIMED), read(&REPRODUCIBLE));
        assert_same_pixels(&timed.frame, &reproducible.frame);
        assert_eq!(timed.info, reproducible.info);
        assert_eq!(timed.attributes[SECONDS], "1.5");
        assert_eq!(timed.attributes[METHOD_SECONDS], "0.25");
        let mut without_times = timed.attributes.clone();
        without_times.remove(SECONDS);
        without_times.remove(METHOD_SECONDS);
        assert_eq!(without_times, reproducible.attributes);
        let stats_without_times = FrameStats { elapsed_seconds: 0.0, method_seconds: 0.0, ..timed.frame.stats };
        assert_eq!(stats_without_times, reproducible.frame.stats);
    }

    #[test]
    fn header_attributes_are_sorted_by_name() {
        let dir = TempDir::new("exr_sorted");
        let path = dir.path().join("f.exr");
        write_exr(&path, &frame(3, 5, true), &info(), &TIMED).unwrap();
        let bytes = std::fs::read(&path).unwrap();
        let names: Vec<&[u8]> = header_attributes(&bytes).unwrap().iter().map(|a| a.name(&bytes)).collect();
        assert!(names.windows(2).all(|w| w[0] < w[1]), "{names:?}");
        assert!(names.contains(&&b"wedge.seed"[..]) && names.contains(&&b"software"[..]));
    }

    #[test]
    fn inconsistent_frames_are_rejected_naming_the_file() {
        let dir = TempDir::new("exr_invalid");
        let path = dir.path().join("bad.exr");
        let mut short_spp = frame(3, 5, true);
        short_spp.spp.pop();
        let mut long_width = frame(3, 5, true);
        long_width.filter_width.as_mut().unwrap().push(1.0);
        let mut short_component = frame(3, 5, true);
        short_component.components[1].spp.pop();
        let mut long_component_width = frame(3, 5, true);
        long_component_width.components[0].filter_width.as_mut().unwrap().push(1.0);
        let mut dotted_name = frame(3, 5, true);
        dotted_name.components[0].name = "a.b".into();
        let mut spaced_name = frame(3, 5, true);
        spaced_name.components[0].name = "a b".into();
        let mut twice = frame(3, 5, true);
        twice.components[2].name = "shadow".into();
        let bad_frames =
            [short_spp, long_width, short_component, long_component_width, dotted_name, spaced_name, twice];
        for bad in bad_frames.into_iter().chain([Frame::default()]) {
            let error = write_exr(&path, &bad, &info(), &REPRODUCIBLE).unwrap_err();
            assert!(matches!(error, OutputError::InvalidInput { .. }), "{error}");
            assert!(error.to_string().contains("bad.exr"), "{error}");
            assert!(!path.exists());
        }
    }

    #[test]
    fn reading_names_the_file_and_what_is_missing() {
        let dir = TempDir::new("exr_foreign");
        let missing = dir.path().join("missing.exr");
        let error = read_exr(&missing).unwrap_err();
        assert!(matches!(error, OutputError::Io { .. }), "{error}");
        assert!(error.to_string().contains("missing.exr"), "{error}");

        // A plain RGB file from another tool: no spp channel, no wedge attributes.
        let foreign = dir.path().join("foreign.exr");
        ::exr::prelude::write_rgb_file(&foreign, 2, 2, |_, _| (0.5f32, 0.5f32, 0.5f32)).unwrap();
        let error = read_exr(&foreign).unwrap_err();
        assert!(matches!(error, OutputError::Format { .. }), "{error}");
        assert!(error.to_string().contains("foreign.exr"), "{error}");
        assert!(error.to_string().contains("spp.Y"), "{error}");

        // A component listed in the header without its channels.
        let path = dir.path().join("no_component.exr");
        let mut written = frame(3, 5, true);
        written.components.truncate(1);
        write_exr(&path, &written, &info(), &REPRODUCIBLE).unwrap();
        let mut image = ::exr::prelude::read_all_data_from_file(&path).unwrap();
        let attributes = &mut image.layer_data[0].attributes.other;
        attributes.insert(Text::from("wedge.components"), AttributeValue::Text(Text::from("shadow diffuse")));
        image.write().to_file(&path).unwrap();
        let error = read_exr(&path).unwrap_err();
        assert!(matches!(error, OutputError::Format { .. }), "{error}");
        assert!(error.to_string().contains("spp.diffuse.Y"), "{error}");
    }
}
