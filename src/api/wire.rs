//! Frames on the wire: a `Frame` becomes `FrameChunk`s of whole rows (each small enough for a
//! client with the default 4 MiB receive limit), and a `FrameAssembler` puts them back together.
//!
//! Layers, in this order and only those selected: `color` (3 channels), `spp` (1),
//! `filter_width` (1), `unfiltered` (3), then with `components` for each component the render
//! has (`strategy::component_names` order) `spp.<component>` (1) and `filter_width.<component>` (1),
//! then the denoiser inputs `albedo` (3), `normal` (3) and `depth` (1). When that leaves
//! nothing, `color` alone. Pixels are row-major, channels interleaved, little-endian
//! f32 or f16.
use crate::pipeline::frame::{ComponentMaps, Frame, FrameStats, HaltReason, ShadingMaps};
use crate::proto::{
    self, render_update, FrameChunk, FrameComplete, OutputSelection, PixelFormat, RenderStarted, RenderUpdate,
};
use crate::render::aovs::Aovs;
use half::f16;
use std::fmt;
use std::sync::Arc;

/// Default cap on the pixel bytes of one chunk: far below a stock client's 4 MiB receive limit
/// even with every layer in f32 at 1920x1080 (17 rows per chunk; 9 with the layers of three
/// components).
pub const DEFAULT_MAX_CHUNK_BYTES: usize = 1 << 20;

/// The largest image a `FrameAssembler` accepts (a guard against absurd headers).
pub const MAX_ASSEMBLED_PIXELS: u64 = 1 << 28;

/// What one streamed layer holds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LayerKind {
    Color,
    Spp,
    FilterWidth,
    Unfiltered,
    /// `spp.<component>`, the component at this index of the stream's component names.
    ComponentSpp(usize),
    /// `filter_width.<component>`, likewise.
    ComponentFilterWidth(usize),
    /// Denoiser inputs (`render::aovs`).
    Albedo,
    Normal,
    Depth,
    /// The `bandwidth` method's maps (`pipeline::frame::ShadingMaps`).
    Bandwidth,
    Level,
}

impl LayerKind {
    /// The layers of every method, in wire order; the component layers follow them.
    pub const BASE: [LayerKind; 4] = [LayerKind::Color, LayerKind::Spp, LayerKind::FilterWidth, LayerKind::Unfiltered];
    /// The denoiser inputs, which follow the component layers.
    pub const AOVS: [LayerKind; 3] = [LayerKind::Albedo, LayerKind::Normal, LayerKind::Depth];
    /// The shading maps of methods that shade at a predicted rate, which follow the AOVs.
    pub const SHADING: [LayerKind; 2] = [LayerKind::Bandwidth, LayerKind::Level];

    /// The layer's name, without the `.<component>` suffix of component layers.
    pub fn stem(self) -> &'static str {
        match self {
            LayerKind::Color => "color",
            LayerKind::Spp | LayerKind::ComponentSpp(_) => "spp",
            LayerKind::FilterWidth | LayerKind::ComponentFilterWidth(_) => "filter_width",
            LayerKind::Unfiltered => "unfiltered",
            LayerKind::Albedo => "albedo",
            LayerKind::Normal => "normal",
            LayerKind::Depth => "depth",
            LayerKind::Bandwidth => "bandwidth",
            LayerKind::Level => "level",
        }
    }

    /// The base layer of that name (component layers need their component: see `LayerSpec`).
    pub fn from_name(name: &str) -> Option<LayerKind> {
        Self::BASE.into_iter().chain(Self::AOVS).chain(Self::SHADING).find(|k| k.stem() == name)
    }

    pub fn channels(self) -> usize {
        match self {
            LayerKind::Color | LayerKind::Unfiltered | LayerKind::Albedo | LayerKind::Normal => 3,
            LayerKind::Spp | LayerKind::FilterWidth | LayerKind::Depth => 1,
            LayerKind::Bandwidth | LayerKind::Level => 1,
            LayerKind::ComponentSpp(_) | LayerKind::ComponentFilterWidth(_) => 1,
        }
    }

    fn selected(self, sel: &OutputSelection) -> bool {
        match self {
            LayerKind::Color => sel.color,
            LayerKind::Spp => sel.spp,
            LayerKind::FilterWidth => sel.filter_width,
            LayerKind::Unfiltered => sel.unfiltered,
            LayerKind::ComponentSpp(_) | LayerKind::ComponentFilterWidth(_) => sel.components,
            LayerKind::Albedo => sel.albedo,
            LayerKind::Normal => sel.normal,
            LayerKind::Depth => sel.depth,
            LayerKind::Bandwidth => sel.bandwidth,
            LayerKind::Level => sel.level,
        }
    }
}

/// One streamed layer: what it holds and its name on the wire. Component layers carry their
/// component's name, so a stream's layers are not a fixed set of static names.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct LayerSpec {
    pub kind: LayerKind,
    pub name: String,
}

impl LayerSpec {
    fn base(kind: LayerKind) -> LayerSpec {
        LayerSpec { kind, name: kind.stem().to_string() }
    }

    fn component(kind: LayerKind, component: &str) -> LayerSpec {
        LayerSpec { kind, name: format!("{}.{component}", kind.stem()) }
    }
}

/// Whether `name` can be a component's name in a layer name: one non-empty dot-free word, so
/// that `spp.<name>` parses back unambiguously.
pub fn is_component_name(name: &str) -> bool {
    !name.is_empty() && name.bytes().all(|b| b.is_ascii_alphanumeric() || b == b'_')
}

/// The layers `sel` streams for a render whose frames carry the component maps `components`
/// (`strategy::component_names`), in wire order; colour alone when that leaves none.
pub fn selected_layers(sel: &OutputSelection, components: &[&str]) -> Vec<LayerSpec> {
    let mut layers: Vec<LayerSpec> =
        LayerKind::BASE.into_iter().filter(|k| k.selected(sel)).map(LayerSpec::base).collect();
    if sel.components {
        for (i, name) in components.iter().enumerate() {
            layers.push(LayerSpec::component(LayerKind::ComponentSpp(i), name));
            layers.push(LayerSpec::component(LayerKind::ComponentFilterWidth(i), name));
        }
    }
    layers.extend(LayerKind::AOVS.into_iter().filter(|k| k.selected(sel)).map(LayerSpec::base));
    layers.extend(LayerKind::SHADING.into_iter().filter(|k| k.selected(sel)).map(LayerSpec::base));
    if layers.is_empty() {
        layers.push(LayerSpec::base(LayerKind::Color));
    }
    layers
}

/// What a stream of `job`'s frames announces first: size, method, seed, triangles, the layers
/// every chunk carries (for `outputs` and the job's `components`) and the `camera` it shows.
pub fn render_started(
    job: &crate::pipeline::job::RenderJob,
    camera: Option<crate::proto::Camera>,
    outputs: &OutputSelection,
    components: &[&str],
) -> crate::proto::RenderStarted {
    crate::proto::RenderStarted {
        width: job.width(),
        height: job.height(),
        method: job.method.to_proto() as i32,
        seed: job.seed,
        triangles: u32::try_from(job.scene.triangle_count()).unwrap_or(u32::MAX),
        layers: layer_names(outputs, components),
        format: outputs.format,
        camera,
    }
}

/// The layer names `sel` streams, in wire order (as in `RenderStarted.layers`).
pub fn layer_names(sel: &OutputSelection, components: &[&str]) -> Vec<String> {
    selected_layers(sel, components).into_iter().map(|l| l.name).collect()
}

/// The selection's pixel format; unknown values are treated as f32 (the server rejects them
/// before a render starts).
pub fn pixel_format(sel: &OutputSelection) -> PixelFormat {
    PixelFormat::try_from(sel.format).unwrap_or(PixelFormat::F32)
}

fn bytes_per_value(format: PixelFormat) -> usize {
    match format {
        PixelFormat::F32 => 4,
        PixelFormat::F16 => 2,
    }
}

/// Rows per chunk so that a chunk's pixel bytes stay within `max_chunk_bytes` (at least one
/// row, whatever the cap).
pub fn rows_per_chunk(width: u32, sel: &OutputSelection, components: &[&str], max_chunk_bytes: usize) -> u32 {
    let value_bytes = bytes_per_value(pixel_format(sel));
    let per_pixel: usize = selected_layers(sel, components).iter().map(|l| l.kind.channels() * value_bytes).sum();
    let row_bytes = (width as usize).saturating_mul(per_pixel).max(1);
    let rows = (max_chunk_bytes / row_bytes).max(1);
    u32::try_from(rows).unwrap_or(u32::MAX)
}

/// Checks that every layer of `frame` has one entry per pixel and, when `sel` streams
/// components, that the frame has the maps of each of `components` (`encode_rows` slices them).
pub fn check_frame(frame: &Frame, sel: &OutputSelection, components: &[&str]) -> Result<(), String> {
    let n = frame.pixel_count();
    let size = || format!("{}x{}", frame.width, frame.height);
    let lens = [
        ("color", Some(frame.color.len())),
        ("spp", Some(frame.spp.len())),
        ("unfiltered", frame.unfiltered.as_ref().map(Vec::len)),
        ("filter_width", frame.filter_width.as_ref().map(Vec::len)),
        ("bandwidth", frame.shading.as_ref().map(|m| m.bandwidth.len())),
        ("level", frame.shading.as_ref().map(|m| m.level.len())),
    ];
    for (name, len) in lens {
        if let Some(len) = len.filter(|&len| len != n) {
            return Err(format!("a {} frame whose {name} layer has {len} pixels", size()));
        }
    }
    if wants_aovs(sel) {
        let Some(aovs) = &frame.aovs else {
            return Err("a frame without the denoiser inputs (albedo, normal, depth) the output asks for".into());
        };
        let lens = [("albedo", aovs.albedo.len()), ("normal", aovs.normal.len()), ("depth", aovs.depth.len())];
        if let Some((name, len)) = lens.into_iter().find(|&(_, len)| len != n) {
            return Err(format!("a {} frame whose {name} layer has {len} pixels", size()));
        }
    }
    if !sel.components {
        return Ok(());
    }
    for &name in components {
        let Some(maps) = find_component(frame, name) else {
            let has: Vec<&str> = frame.components.iter().map(|c| c.name.as_str()).collect();
            return Err(format!("a frame without the {name:?} component maps (it has {has:?})"));
        };
        let lens = [("spp", Some(maps.spp.len())), ("filter_width", maps.filter_width.as_ref().map(Vec::len))];
        for (stem, len) in lens {
            if let Some(len) = len.filter(|&len| len != n) {
                return Err(format!("a {} frame whose {stem}.{name} layer has {len} pixels", size()));
            }
        }
    }
    Ok(())
}

/// Whether `sel` streams any denoiser input (then the render must trace them).
pub fn wants_aovs(sel: &OutputSelection) -> bool {
    sel.albedo || sel.normal || sel.depth
}

fn find_component<'f>(frame: &'f Frame, name: &str) -> Option<&'f ComponentMaps> {
    frame.components.iter().find(|c| c.name == name)
}

/// Encodes rows `y0..y0 + rows` of `frame` as one chunk. The frame must pass `check_frame` with
/// the same `sel` and `components`, and the rows must lie inside it.
pub fn encode_rows(frame: &Frame, sel: &OutputSelection, components: &[&str], y0: u32, rows: u32) -> FrameChunk {
    let format = pixel_format(sel);
    let width = frame.width as usize;
    let start = y0 as usize * width;
    let end = (y0 as usize + rows as usize) * width;
    // A missing map (unfiltered methods' widths) is sent as zeros.
    let scalars = |data: &mut Vec<u8>, map: Option<&[f32]>| match map {
        Some(values) => put_scalars(data, &values[start..end], format),
        None => data.resize(data.len() + (end - start) * bytes_per_value(format), 0),
    };
    let rgb = |data: &mut Vec<u8>, map: Option<&[[f32; 3]]>| match map {
        Some(values) => put_rgb(data, &values[start..end], format),
        None => data.resize(data.len() + (end - start) * 3 * bytes_per_value(format), 0),
    };
    let component = |i: usize| components.get(i).and_then(|name| find_component(frame, name));
    let layers = selected_layers(sel, components)
        .into_iter()
        .map(|layer| {
            let kind = layer.kind;
            let mut data = Vec::with_capacity((end - start) * kind.channels() * bytes_per_value(format));
            match kind {
                LayerKind::Color => put_rgb(&mut data, &frame.color[start..end], format),
                LayerKind::Unfiltered => put_rgb(&mut data, &frame.unfiltered_color()[start..end], format),
                LayerKind::Spp => put_scalars(&mut data, &frame.spp[start..end], format),
                LayerKind::FilterWidth => scalars(&mut data, frame.filter_width.as_deref()),
                LayerKind::ComponentSpp(i) => scalars(&mut data, component(i).map(|c| c.spp.as_slice())),
                LayerKind::ComponentFilterWidth(i) => {
                    scalars(&mut data, component(i).and_then(|c| c.filter_width.as_deref()))
                }
                LayerKind::Albedo => rgb(&mut data, frame.aovs.as_deref().map(|a| a.albedo.as_slice())),
                LayerKind::Normal => rgb(&mut data, frame.aovs.as_deref().map(|a| a.normal.as_slice())),
                LayerKind::Depth => scalars(&mut data, frame.aovs.as_deref().map(|a| a.depth.as_slice())),
                LayerKind::Bandwidth => scalars(&mut data, frame.shading.as_ref().map(|m| m.bandwidth.as_slice())),
                LayerKind::Level => scalars(&mut data, frame.shading.as_ref().map(|m| m.level.as_slice())),
            }
            proto::Layer { name: layer.name, channels: kind.channels() as u32, data }
        })
        .collect();
    FrameChunk { pass: frame.stats.pass, x: 0, y: y0, width: frame.width, height: rows, layers }
}

/// The row bands `(y0, rows)` a frame of `height` rows is cut into.
pub fn chunk_bands(height: u32, rows_per_chunk: u32) -> impl Iterator<Item = (u32, u32)> {
    let step = rows_per_chunk.max(1);
    (0..height).step_by(step as usize).map(move |y0| (y0, step.min(height - y0)))
}

/// Splits `frame` into row chunks of at most `max_chunk_bytes` pixel bytes each (at least one
/// row per chunk). The frame must pass `check_frame`.
pub fn encode_frame(
    frame: &Frame,
    sel: &OutputSelection,
    components: &[&str],
    max_chunk_bytes: usize,
) -> Vec<FrameChunk> {
    let rows = rows_per_chunk(frame.width, sel, components, max_chunk_bytes);
    chunk_bands(frame.height, rows).map(|(y0, n)| encode_rows(frame, sel, components, y0, n)).collect()
}

/// The `FrameComplete` message for a frame's stats.
impl From<&FrameStats> for FrameComplete {
    fn from(stats: &FrameStats) -> FrameComplete {
        FrameComplete {
            pass: stats.pass,
            mean_spp: stats.mean_spp,
            rays_traced: stats.rays_traced,
            elapsed_seconds: stats.elapsed_seconds,
            is_final: stats.is_final,
            halt_reason: proto::HaltReason::from(stats.halt_reason) as i32,
            dropped_samples: stats.dropped_samples,
            method_seconds: stats.method_seconds,
            pass_complete: stats.pass_complete,
            estimated_relative_error: stats.estimated_error.unwrap_or(0.0),
            shaded_points: stats.shaded_points,
            full_resolution_points: stats.full_resolution_points,
        }
    }
}

impl From<HaltReason> for proto::HaltReason {
    fn from(reason: HaltReason) -> proto::HaltReason {
        match reason {
            HaltReason::None => proto::HaltReason::None,
            HaltReason::MaxPasses => proto::HaltReason::MaxPasses,
            HaltReason::MaxSpp => proto::HaltReason::MaxSpp,
            HaltReason::TimeBudget => proto::HaltReason::TimeBudget,
            HaltReason::NoiseTarget => proto::HaltReason::NoiseTarget,
        }
    }
}

impl From<proto::HaltReason> for HaltReason {
    fn from(reason: proto::HaltReason) -> HaltReason {
        match reason {
            proto::HaltReason::None => HaltReason::None,
            proto::HaltReason::MaxPasses => HaltReason::MaxPasses,
            proto::HaltReason::MaxSpp => HaltReason::MaxSpp,
            proto::HaltReason::TimeBudget => HaltReason::TimeBudget,
            proto::HaltReason::NoiseTarget => HaltReason::NoiseTarget,
        }
    }
}

/// The core halt reason of a wire value; an unknown value (a newer server) reads as none.
fn halt_reason_from_wire(value: i32) -> HaltReason {
    proto::HaltReason::try_from(value).map_or(HaltReason::None, HaltReason::from)
}

fn put_value(out: &mut Vec<u8>, v: f32, format: PixelFormat) {
    match format {
        PixelFormat::F32 => out.extend_from_slice(&v.to_le_bytes()),
        PixelFormat::F16 => out.extend_from_slice(&f16::from_f32(v).to_le_bytes()),
    }
}

fn put_rgb(out: &mut Vec<u8>, pixels: &[[f32; 3]], format: PixelFormat) {
    for p in pixels {
        for &v in p {
            put_value(out, v, format);
        }
    }
}

fn put_scalars(out: &mut Vec<u8>, values: &[f32], format: PixelFormat) {
    for &v in values {
        put_value(out, v, format);
    }
}

fn decode_values(data: &[u8], format: PixelFormat) -> Vec<f32> {
    match format {
        PixelFormat::F32 => data.chunks_exact(4).map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]])).collect(),
        PixelFormat::F16 => data.chunks_exact(2).map(|b| f16::from_le_bytes([b[0], b[1]]).to_f32()).collect(),
    }
}

/// Why a stream of updates could not be assembled into frames.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct AssembleError(pub String);

impl fmt::Display for AssembleError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "malformed frame stream: {}", self.0)
    }
}
impl std::error::Error for AssembleError {}

fn err<T>(msg: impl Into<String>) -> Result<T, AssembleError> {
    Err(AssembleError(msg.into()))
}

/// The stream's header, checked.
struct Header {
    started: RenderStarted,
    layers: Vec<LayerSpec>,
    /// The components of the `spp.<c>`/`filter_width.<c>` layers, in order of first mention.
    components: Vec<String>,
    format: PixelFormat,
}

/// A frame being filled in.
struct Partial {
    pass: u32,
    /// Per layer, in header order: channels-interleaved values for the whole image.
    values: Vec<Vec<f32>>,
    covered: Vec<bool>,
    covered_count: usize,
}

/// Rebuilds frames from a `Render` stream: feed it every `RenderUpdate` in order; it returns a
/// frame on each `FrameComplete`.
///
/// Layers that were not streamed are filled in as follows: `color` zeros, `spp` zeros,
/// `filter_width` and `unfiltered` `None`, `components` empty, `aovs` `None` when no denoiser
/// input was streamed (else those not streamed are empty). A component's `filter_width` is
/// `None` when its layer is all zero (how unfiltered components are sent).
#[derive(Default)]
pub struct FrameAssembler {
    header: Option<Header>,
    partial: Option<Partial>,
}

impl FrameAssembler {
    pub fn new() -> Self {
        Self::default()
    }

    /// The stream's `RenderStarted`, once it arrived.
    pub fn started(&self) -> Option<&RenderStarted> {
        self.header.as_ref().map(|h| &h.started)
    }

    /// The layers the stream carries, once `RenderStarted` arrived.
    pub fn layers(&self) -> Option<&[LayerSpec]> {
        self.header.as_ref().map(|h| h.layers.as_slice())
    }

    /// The components whose maps the stream carries (in `Frame::components` order), once
    /// `RenderStarted` arrived.
    pub fn components(&self) -> Option<&[String]> {
        self.header.as_ref().map(|h| h.components.as_slice())
    }

    /// True when chunks of a frame arrived whose `FrameComplete` has not.
    pub fn in_frame(&self) -> bool {
        self.partial.is_some()
    }

    /// Takes the next update; returns the frame it completes, if any.
    pub fn push(&mut self, update: RenderUpdate) -> Result<Option<Frame>, AssembleError> {
        match update.kind {
            Some(render_update::Kind::Started(s)) => self.start(s).map(|()| None),
            Some(render_update::Kind::Chunk(c)) => self.chunk(c).map(|()| None),
            Some(render_update::Kind::FrameComplete(fc)) => self.complete(&fc).map(Some),
            None => err("update without content"),
        }
    }

    /// Takes the stream's `RenderStarted`.
    pub fn start(&mut self, started: RenderStarted) -> Result<(), AssembleError> {
        if self.header.is_some() {
            return err("a second RenderStarted");
        }
        if started.width == 0 || started.height == 0 {
            return err(format!("RenderStarted has an empty image ({}x{})", started.width, started.height));
        }
        if started.width as u64 * started.height as u64 > MAX_ASSEMBLED_PIXELS {
            return err(format!(
                "RenderStarted announces a {}x{} image, more than this client accepts",
                started.width, started.height
            ));
        }
        let format = match PixelFormat::try_from(started.format) {
            Ok(f) => f,
            Err(_) => return err(format!("unknown pixel format {}", started.format)),
        };
        let (layers, components) = parse_layers(&started.layers)?;
        self.header = Some(Header { started, layers, components, format });
        Ok(())
    }

    /// Takes one chunk of the current frame.
    pub fn chunk(&mut self, chunk: FrameChunk) -> Result<(), AssembleError> {
        let Some(header) = &self.header else {
            return err("FrameChunk before RenderStarted");
        };
        let (w, h) = (header.started.width as u64, header.started.height as u64);
        let (x, y, cw, ch) = (chunk.x as u64, chunk.y as u64, chunk.width as u64, chunk.height as u64);
        if cw == 0 || ch == 0 || x + cw > w || y + ch > h {
            return err(format!(
                "chunk {}x{} at ({x}, {y}) of pass {} is empty or outside the {w}x{h} image",
                chunk.width, chunk.height, chunk.pass
            ));
        }
        if chunk.layers.len() != header.layers.len()
            || chunk.layers.iter().zip(&header.layers).any(|(l, h)| l.name != h.name)
        {
            let got: Vec<&str> = chunk.layers.iter().map(|l| l.name.as_str()).collect();
            let want: Vec<&str> = header.layers.iter().map(|h| h.name.as_str()).collect();
            return err(format!("chunk at row {y} of pass {} has layers {got:?}, expected {want:?}", chunk.pass));
        }
        let pixels = (cw * ch) as usize;
        let value_bytes = bytes_per_value(header.format);
        for (layer, spec) in chunk.layers.iter().zip(&header.layers) {
            let kind = spec.kind;
            if layer.channels as usize != kind.channels() {
                return err(format!(
                    "layer {} has {} channels, expected {}",
                    layer.name,
                    layer.channels,
                    kind.channels()
                ));
            }
            let want = pixels * kind.channels() * value_bytes;
            if layer.data.len() != want {
                return err(format!(
                    "layer {} of the {}x{} chunk at ({x}, {y}) of pass {} has {} bytes, expected {want}",
                    layer.name,
                    chunk.width,
                    chunk.height,
                    chunk.pass,
                    layer.data.len()
                ));
            }
        }

        let image_pixels = (w * h) as usize;
        let partial = match &mut self.partial {
            Some(p) if p.pass != chunk.pass => {
                return err(format!("chunk of pass {} while pass {} is incomplete", chunk.pass, p.pass))
            }
            Some(p) => p,
            None => self.partial.insert(Partial {
                pass: chunk.pass,
                values: header.layers.iter().map(|l| vec![0.0; image_pixels * l.kind.channels()]).collect(),
                covered: vec![false; image_pixels],
                covered_count: 0,
            }),
        };
        for row in 0..ch {
            let first = ((y + row) * w + x) as usize;
            let cover = &mut partial.covered[first..first + cw as usize];
            if cover.iter().any(|&c| c) {
                return err(format!("row {} of pass {} sent twice", y + row, chunk.pass));
            }
            cover.fill(true);
        }
        partial.covered_count += pixels;
        for ((layer, spec), dest) in chunk.layers.iter().zip(&header.layers).zip(&mut partial.values) {
            let c = spec.kind.channels();
            let values = decode_values(&layer.data, header.format);
            let row_len = cw as usize * c;
            for (row, src) in values.chunks_exact(row_len).enumerate() {
                let first = ((y + row as u64) * w + x) as usize * c;
                dest[first..first + row_len].copy_from_slice(src);
            }
        }
        Ok(())
    }

    /// Ends the current frame and returns it.
    pub fn complete(&mut self, fc: &FrameComplete) -> Result<Frame, AssembleError> {
        let Some(header) = &self.header else {
            return err("FrameComplete before RenderStarted");
        };
        let Some(partial) = self.partial.take() else {
            return err(format!("FrameComplete for pass {} without chunks", fc.pass));
        };
        if partial.pass != fc.pass {
            return err(format!("FrameComplete for pass {} while pass {} was being sent", fc.pass, partial.pass));
        }
        let (w, h) = (header.started.width, header.started.height);
        let n = partial.covered.len();
        if partial.covered_count != n {
            let first_missing = partial.covered.iter().position(|&c| !c).unwrap_or(0);
            let missing_rows = partial.covered.chunks_exact(w as usize).filter(|r| r.iter().any(|&c| !c)).count();
            return err(format!(
                "frame of pass {} is missing {missing_rows} of {h} rows (first: row {})",
                fc.pass,
                first_missing / w as usize
            ));
        }
        let mut frame = Frame {
            shading: None,
            width: w,
            height: h,
            color: vec![[0.0; 3]; n],
            unfiltered: None,
            spp: vec![0.0; n],
            filter_width: None,
            components: header
                .components
                .iter()
                .map(|name| ComponentMaps { name: name.clone(), spp: vec![0.0; n], filter_width: None })
                .collect(),
            aovs: None,
            stats: FrameStats {
                pass: fc.pass,
                mean_spp: fc.mean_spp,
                rays_traced: fc.rays_traced,
                elapsed_seconds: fc.elapsed_seconds,
                is_final: fc.is_final,
                halt_reason: halt_reason_from_wire(fc.halt_reason),
                dropped_samples: fc.dropped_samples,
                method_seconds: fc.method_seconds,
                pass_complete: fc.pass_complete,
                estimated_error: (fc.estimated_relative_error > 0.0).then_some(fc.estimated_relative_error),
                shaded_points: fc.shaded_points,
                full_resolution_points: fc.full_resolution_points,
            },
        };
        let mut aovs: Option<Aovs> = None;
        let mut shading: Option<ShadingMaps> = None;
        for (spec, values) in header.layers.iter().zip(partial.values) {
            match spec.kind {
                LayerKind::Color => frame.color = to_rgb(&values),
                LayerKind::Unfiltered => frame.unfiltered = Some(to_rgb(&values)),
                LayerKind::Spp => frame.spp = values,
                LayerKind::FilterWidth => frame.filter_width = Some(values),
                LayerKind::ComponentSpp(i) => {
                    if let Some(c) = frame.components.get_mut(i) {
                        c.spp = values;
                    }
                }
                LayerKind::ComponentFilterWidth(i) => {
                    if let Some(c) = frame.components.get_mut(i) {
                        c.filter_width = Some(values).filter(|w| w.iter().any(|&v| v != 0.0));
                    }
                }
                LayerKind::Albedo => aovs.get_or_insert_with(Aovs::default).albedo = to_rgb(&values),
                LayerKind::Normal => aovs.get_or_insert_with(Aovs::default).normal = to_rgb(&values),
                LayerKind::Depth => aovs.get_or_insert_with(Aovs::default).depth = values,
                LayerKind::Bandwidth => shading.get_or_insert_with(ShadingMaps::default).bandwidth = values,
                LayerKind::Level => shading.get_or_insert_with(ShadingMaps::default).level = values,
            }
        }
        frame.aovs = aovs.map(Arc::new);
        // Other methods stream zeros in these layers: their frames have no such maps.
        frame.shading = shading.filter(|_| header.started.method == proto::Method::Bandwidth as i32);
        Ok(frame)
    }
}

/// Parses `RenderStarted.layers`: the base layers by name, `spp.<c>` and `filter_width.<c>` as
/// component layers. Returns the layers and the components in order of first mention; every
/// component must have both layers (the server always sends them together).
fn parse_layers(names: &[String]) -> Result<(Vec<LayerSpec>, Vec<String>), AssembleError> {
    let mut layers: Vec<LayerSpec> = Vec::with_capacity(names.len());
    let mut components: Vec<String> = Vec::new();
    for name in names {
        if layers.iter().any(|l| l.name == *name) {
            return err(format!("layer {name:?} listed twice in RenderStarted"));
        }
        let kind = match LayerKind::from_name(name) {
            Some(kind) => kind,
            None => {
                let (kind, component): (fn(usize) -> LayerKind, &str) = match name.split_once('.') {
                    Some(("spp", c)) if is_component_name(c) => (LayerKind::ComponentSpp, c),
                    Some(("filter_width", c)) if is_component_name(c) => (LayerKind::ComponentFilterWidth, c),
                    _ => return err(format!("unknown layer {name:?} in RenderStarted")),
                };
                let i = components.iter().position(|c| c == component).unwrap_or_else(|| {
                    components.push(component.to_string());
                    components.len() - 1
                });
                kind(i)
            }
        };
        layers.push(LayerSpec { kind, name: name.clone() });
    }
    if layers.is_empty() {
        return err("RenderStarted lists no layers");
    }
    for (i, c) in components.iter().enumerate() {
        for kind in [LayerKind::ComponentSpp(i), LayerKind::ComponentFilterWidth(i)] {
            if !layers.iter().any(|l| l.kind == kind) {
                return err(format!("RenderStarted lists a {c} component without its {}.{c} layer", kind.stem()));
            }
        }
    }
    Ok((layers, components))
}

fn to_rgb(values: &[f32]) -> Vec<[f32; 3]> {
    values.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect()
}

#[cfg(test)]
mod tests;
