//! Frames on the wire: a `Frame` becomes `FrameChunk`s of whole rows (each small enough for a
//! client with the default 4 MiB receive limit), and a `FrameAssembler` puts them back together.
//!
//! Layers, in this order and only those selected (colour alone when none is): `color` (3
//! channels), `spp` (1), `filter_width` (1), `unfiltered` (3). Pixels are row-major, channels
//! interleaved, little-endian f32 or f16.
use crate::proto::{
    self, render_update, FrameChunk, FrameComplete, OutputSelection, PixelFormat, RenderStarted, RenderUpdate,
};
use crate::render::frame::{Frame, FrameStats, HaltReason};
use half::f16;
use std::fmt;

/// Default cap on the pixel bytes of one chunk: far below a stock client's 4 MiB receive limit
/// even with every layer in f32 at 1920x1080 (17 rows per chunk).
pub const DEFAULT_MAX_CHUNK_BYTES: usize = 1 << 20;

/// The largest image a `FrameAssembler` accepts (a guard against absurd headers).
pub const MAX_ASSEMBLED_PIXELS: u64 = 1 << 28;

/// One per-pixel layer that can be streamed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LayerKind {
    Color,
    Spp,
    FilterWidth,
    Unfiltered,
}

impl LayerKind {
    /// Wire order.
    pub const ALL: [LayerKind; 4] = [LayerKind::Color, LayerKind::Spp, LayerKind::FilterWidth, LayerKind::Unfiltered];

    pub fn name(self) -> &'static str {
        match self {
            LayerKind::Color => "color",
            LayerKind::Spp => "spp",
            LayerKind::FilterWidth => "filter_width",
            LayerKind::Unfiltered => "unfiltered",
        }
    }

    pub fn from_name(name: &str) -> Option<LayerKind> {
        Self::ALL.into_iter().find(|k| k.name() == name)
    }

    pub fn channels(self) -> usize {
        match self {
            LayerKind::Color | LayerKind::Unfiltered => 3,
            LayerKind::Spp | LayerKind::FilterWidth => 1,
        }
    }

    fn selected(self, sel: &OutputSelection) -> bool {
        match self {
            LayerKind::Color => sel.color,
            LayerKind::Spp => sel.spp,
            LayerKind::FilterWidth => sel.filter_width,
            LayerKind::Unfiltered => sel.unfiltered,
        }
    }
}

/// The layers `sel` streams, in wire order; colour alone when none is selected.
pub fn selected_layers(sel: &OutputSelection) -> Vec<LayerKind> {
    let layers: Vec<LayerKind> = LayerKind::ALL.into_iter().filter(|k| k.selected(sel)).collect();
    if layers.is_empty() {
        vec![LayerKind::Color]
    } else {
        layers
    }
}

/// The layer names `sel` streams, in wire order (as in `RenderStarted.layers`).
pub fn layer_names(sel: &OutputSelection) -> Vec<String> {
    selected_layers(sel).into_iter().map(|k| k.name().to_string()).collect()
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
pub fn rows_per_chunk(width: u32, sel: &OutputSelection, max_chunk_bytes: usize) -> u32 {
    let per_pixel: usize = selected_layers(sel).iter().map(|k| k.channels() * bytes_per_value(pixel_format(sel))).sum();
    let row_bytes = (width as usize).saturating_mul(per_pixel).max(1);
    let rows = (max_chunk_bytes / row_bytes).max(1);
    u32::try_from(rows).unwrap_or(u32::MAX)
}

/// Checks that every layer of `frame` has one entry per pixel (`encode_rows` slices them).
pub fn check_frame(frame: &Frame) -> Result<(), String> {
    let n = frame.pixel_count();
    let lens = [
        ("color", Some(frame.color.len())),
        ("spp", Some(frame.spp.len())),
        ("unfiltered", frame.unfiltered.as_ref().map(Vec::len)),
        ("filter_width", frame.filter_width.as_ref().map(Vec::len)),
    ];
    for (name, len) in lens {
        if let Some(len) = len.filter(|&len| len != n) {
            return Err(format!("a {}x{} frame whose {name} layer has {len} pixels", frame.width, frame.height));
        }
    }
    Ok(())
}

/// Encodes rows `y0..y0 + rows` of `frame` as one chunk. The frame must pass `check_frame` and
/// the rows must lie inside it.
pub fn encode_rows(frame: &Frame, sel: &OutputSelection, y0: u32, rows: u32) -> FrameChunk {
    let format = pixel_format(sel);
    let width = frame.width as usize;
    let start = y0 as usize * width;
    let end = (y0 as usize + rows as usize) * width;
    let layers = selected_layers(sel)
        .into_iter()
        .map(|kind| {
            let mut data = Vec::with_capacity((end - start) * kind.channels() * 4);
            match kind {
                LayerKind::Color => put_rgb(&mut data, &frame.color[start..end], format),
                LayerKind::Unfiltered => put_rgb(&mut data, &frame.unfiltered_color()[start..end], format),
                LayerKind::Spp => put_scalars(&mut data, &frame.spp[start..end], format),
                LayerKind::FilterWidth => match &frame.filter_width {
                    Some(w) => put_scalars(&mut data, &w[start..end], format),
                    None => {
                        data.resize((end - start) * bytes_per_value(format), 0);
                    }
                },
            }
            proto::Layer { name: kind.name().to_string(), channels: kind.channels() as u32, data }
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
pub fn encode_frame(frame: &Frame, sel: &OutputSelection, max_chunk_bytes: usize) -> Vec<FrameChunk> {
    let rows = rows_per_chunk(frame.width, sel, max_chunk_bytes);
    chunk_bands(frame.height, rows).map(|(y0, n)| encode_rows(frame, sel, y0, n)).collect()
}

/// The `FrameComplete` message for a frame's stats.
pub fn frame_complete(stats: &FrameStats) -> FrameComplete {
    FrameComplete {
        pass: stats.pass,
        mean_spp: stats.mean_spp,
        rays_traced: stats.rays_traced,
        elapsed_seconds: stats.elapsed_seconds,
        is_final: stats.is_final,
        halt_reason: halt_reason_to_proto(stats.halt_reason) as i32,
        dropped_samples: stats.dropped_samples,
        method_seconds: stats.method_seconds,
    }
}

pub fn halt_reason_to_proto(reason: HaltReason) -> proto::HaltReason {
    match reason {
        HaltReason::None => proto::HaltReason::None,
        HaltReason::MaxPasses => proto::HaltReason::MaxPasses,
        HaltReason::MaxSpp => proto::HaltReason::MaxSpp,
        HaltReason::TimeBudget => proto::HaltReason::TimeBudget,
    }
}

pub fn halt_reason_from_proto(reason: i32) -> HaltReason {
    match proto::HaltReason::try_from(reason) {
        Ok(proto::HaltReason::MaxPasses) => HaltReason::MaxPasses,
        Ok(proto::HaltReason::MaxSpp) => HaltReason::MaxSpp,
        Ok(proto::HaltReason::TimeBudget) => HaltReason::TimeBudget,
        Ok(proto::HaltReason::None) | Err(_) => HaltReason::None,
    }
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
    layers: Vec<LayerKind>,
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
/// `filter_width` and `unfiltered` `None`.
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
    pub fn layers(&self) -> Option<&[LayerKind]> {
        self.header.as_ref().map(|h| h.layers.as_slice())
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
        let mut layers = Vec::with_capacity(started.layers.len());
        for name in &started.layers {
            let Some(kind) = LayerKind::from_name(name) else {
                return err(format!("unknown layer {name:?} in RenderStarted"));
            };
            if layers.contains(&kind) {
                return err(format!("layer {name:?} listed twice in RenderStarted"));
            }
            layers.push(kind);
        }
        if layers.is_empty() {
            return err("RenderStarted lists no layers");
        }
        self.header = Some(Header { started, layers, format });
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
            || chunk.layers.iter().zip(&header.layers).any(|(l, k)| l.name != k.name())
        {
            let got: Vec<&str> = chunk.layers.iter().map(|l| l.name.as_str()).collect();
            let want: Vec<&str> = header.layers.iter().map(|k| k.name()).collect();
            return err(format!("chunk at row {y} of pass {} has layers {got:?}, expected {want:?}", chunk.pass));
        }
        let pixels = (cw * ch) as usize;
        let value_bytes = bytes_per_value(header.format);
        for (layer, kind) in chunk.layers.iter().zip(&header.layers) {
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
                values: header.layers.iter().map(|k| vec![0.0; image_pixels * k.channels()]).collect(),
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
        for ((layer, kind), dest) in chunk.layers.iter().zip(&header.layers).zip(&mut partial.values) {
            let c = kind.channels();
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
            width: w,
            height: h,
            color: vec![[0.0; 3]; n],
            unfiltered: None,
            spp: vec![0.0; n],
            filter_width: None,
            components: Vec::new(),
            stats: FrameStats {
                pass: fc.pass,
                mean_spp: fc.mean_spp,
                rays_traced: fc.rays_traced,
                elapsed_seconds: fc.elapsed_seconds,
                is_final: fc.is_final,
                halt_reason: halt_reason_from_proto(fc.halt_reason),
                dropped_samples: fc.dropped_samples,
                method_seconds: fc.method_seconds,
            },
        };
        for (kind, values) in header.layers.iter().zip(partial.values) {
            match kind {
                LayerKind::Color => frame.color = to_rgb(&values),
                LayerKind::Unfiltered => frame.unfiltered = Some(to_rgb(&values)),
                LayerKind::Spp => frame.spp = values,
                LayerKind::FilterWidth => frame.filter_width = Some(values),
            }
        }
        Ok(frame)
    }
}

fn to_rgb(values: &[f32]) -> Vec<[f32; 3]> {
    values.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use prost::Message;

    fn test_frame(width: u32, height: u32) -> Frame {
        let n = (width * height) as usize;
        let v = |i: usize, k: usize| ((i * 7 + k * 13) % 101) as f32 * 0.37 + 1e-3 * i as f32;
        Frame {
            width,
            height,
            color: (0..n).map(|i| [v(i, 0), v(i, 1), v(i, 2)]).collect(),
            unfiltered: Some((0..n).map(|i| [v(i, 3), v(i, 4), -v(i, 5)]).collect()),
            spp: (0..n).map(|i| (i % 5) as f32 * 4.0).collect(),
            filter_width: Some((0..n).map(|i| v(i, 6) * 0.01).collect()),
            components: Vec::new(),
            stats: FrameStats {
                pass: 3,
                mean_spp: 12.5,
                rays_traced: 12345,
                elapsed_seconds: 0.25,
                is_final: true,
                halt_reason: HaltReason::MaxPasses,
                dropped_samples: 2,
                method_seconds: 0.01,
            },
        }
    }

    fn all_layers(format: PixelFormat) -> OutputSelection {
        OutputSelection {
            color: true,
            spp: true,
            filter_width: true,
            unfiltered: true,
            components: false,
            format: format as i32,
        }
    }

    fn started(frame: &Frame, sel: &OutputSelection) -> RenderStarted {
        RenderStarted {
            width: frame.width,
            height: frame.height,
            layers: layer_names(sel),
            format: sel.format,
            ..Default::default()
        }
    }

    fn round_trip(frame: &Frame, sel: &OutputSelection, max_chunk_bytes: usize) -> Frame {
        let mut asm = FrameAssembler::new();
        asm.start(started(frame, sel)).unwrap();
        for chunk in encode_frame(frame, sel, max_chunk_bytes) {
            asm.chunk(chunk).unwrap();
        }
        asm.complete(&frame_complete(&frame.stats)).unwrap()
    }

    fn bits(v: &[[f32; 3]]) -> Vec<u32> {
        v.iter().flatten().map(|x| x.to_bits()).collect()
    }

    #[test]
    fn layer_order_and_default() {
        assert_eq!(layer_names(&OutputSelection::default()), vec!["color"]);
        let sel = all_layers(PixelFormat::F32);
        assert_eq!(layer_names(&sel), vec!["color", "spp", "filter_width", "unfiltered"]);
        let sel = OutputSelection { unfiltered: true, spp: true, ..Default::default() };
        assert_eq!(layer_names(&sel), vec!["spp", "unfiltered"]);
    }

    #[test]
    fn f32_round_trip_is_bit_exact() {
        let frame = test_frame(16, 9);
        let sel = all_layers(PixelFormat::F32);
        for max in [1, 100, 16 * 8 * 4 * 3, DEFAULT_MAX_CHUNK_BYTES] {
            let back = round_trip(&frame, &sel, max);
            assert_eq!((back.width, back.height), (16, 9));
            assert_eq!(bits(&back.color), bits(&frame.color));
            assert_eq!(bits(back.unfiltered.as_ref().unwrap()), bits(frame.unfiltered.as_ref().unwrap()));
            let b: Vec<u32> = back.spp.iter().map(|x| x.to_bits()).collect();
            let f: Vec<u32> = frame.spp.iter().map(|x| x.to_bits()).collect();
            assert_eq!(b, f);
            let b: Vec<u32> = back.filter_width.as_ref().unwrap().iter().map(|x| x.to_bits()).collect();
            let f: Vec<u32> = frame.filter_width.as_ref().unwrap().iter().map(|x| x.to_bits()).collect();
            assert_eq!(b, f);
            assert_eq!(back.stats, frame.stats);
        }
    }

    #[test]
    fn f16_round_trip_within_precision() {
        let frame = test_frame(7, 3);
        let sel = all_layers(PixelFormat::F16);
        let back = round_trip(&frame, &sel, 64);
        let close = |a: f32, b: f32| (a - b).abs() <= b.abs() * 2f32.powi(-11) + 1e-7;
        for (a, b) in back.color.iter().flatten().zip(frame.color.iter().flatten()) {
            assert!(close(*a, *b), "{a} vs {b}");
        }
        let (bu, fu) = (back.unfiltered.unwrap(), frame.unfiltered.unwrap());
        for (a, b) in bu.iter().flatten().zip(fu.iter().flatten()) {
            assert!(close(*a, *b), "{a} vs {b}");
        }
        for (a, b) in back.spp.iter().zip(&frame.spp) {
            assert!(close(*a, *b), "{a} vs {b}");
        }
        for (a, b) in back.filter_width.unwrap().iter().zip(frame.filter_width.unwrap().iter()) {
            assert!(close(*a, *b), "{a} vs {b}");
        }
    }

    #[test]
    fn odd_sizes_and_one_row_chunks() {
        let frame = test_frame(7, 3);
        let sel = all_layers(PixelFormat::F32);
        // A cap below one row still sends one row per chunk.
        let chunks = encode_frame(&frame, &sel, 1);
        assert_eq!(chunks.len(), 3);
        for (i, c) in chunks.iter().enumerate() {
            assert_eq!((c.x, c.y, c.width, c.height), (0, i as u32, 7, 1));
            assert_eq!(c.pass, 3);
            let channels: Vec<u32> = c.layers.iter().map(|l| l.channels).collect();
            assert_eq!(channels, vec![3, 1, 1, 3]);
        }
        // Two rows per chunk: 2 + 1.
        let row = 7 * 8 * 4;
        let chunks = encode_frame(&frame, &sel, 2 * row + row / 2);
        let heights: Vec<u32> = chunks.iter().map(|c| c.height).collect();
        assert_eq!(heights, vec![2, 1]);
        let back = round_trip(&frame, &sel, 2 * row + row / 2);
        assert_eq!(bits(&back.color), bits(&frame.color));
    }

    #[test]
    fn chunk_size_limits_respected() {
        let frame = test_frame(33, 17);
        for format in [PixelFormat::F32, PixelFormat::F16] {
            let sel = all_layers(format);
            for max in [33 * 8 * 4, 2000, 5000, 20_000] {
                let chunks = encode_frame(&frame, &sel, max);
                let rows: u32 = chunks.iter().map(|c| c.height).sum();
                assert_eq!(rows, 17);
                for c in &chunks {
                    let bytes: usize = c.layers.iter().map(|l| l.data.len()).sum();
                    assert!(bytes <= max, "{bytes} > {max}");
                }
            }
        }
    }

    #[test]
    fn default_cap_fits_a_4_mib_client_at_1080p() {
        let (w, h) = (1920u32, 1080u32);
        let n = (w * h) as usize;
        let frame = Frame {
            width: w,
            height: h,
            color: vec![[1.0; 3]; n],
            unfiltered: None,
            spp: vec![1.0; n],
            filter_width: None,
            components: Vec::new(),
            stats: FrameStats::default(),
        };
        let sel = all_layers(PixelFormat::F32);
        let chunks = encode_frame(&frame, &sel, DEFAULT_MAX_CHUNK_BYTES);
        assert!(chunks.len() > 1);
        for c in chunks {
            let msg = RenderUpdate { kind: Some(render_update::Kind::Chunk(c)) };
            assert!(msg.encoded_len() < 4 << 20);
        }
    }

    #[test]
    fn unfiltered_frame_sends_color_and_zero_widths() {
        let mut frame = test_frame(5, 4);
        frame.unfiltered = None;
        frame.filter_width = None;
        let sel = all_layers(PixelFormat::F32);
        let back = round_trip(&frame, &sel, 1);
        assert_eq!(bits(back.unfiltered.as_ref().unwrap()), bits(&frame.color));
        assert!(back.filter_width.unwrap().iter().all(|&w| w == 0.0));
    }

    #[test]
    fn missing_row_is_an_error() {
        let frame = test_frame(7, 3);
        let sel = all_layers(PixelFormat::F32);
        let mut asm = FrameAssembler::new();
        asm.start(started(&frame, &sel)).unwrap();
        let chunks = encode_frame(&frame, &sel, 1);
        asm.chunk(chunks[0].clone()).unwrap();
        asm.chunk(chunks[2].clone()).unwrap();
        let e = asm.complete(&frame_complete(&frame.stats)).unwrap_err();
        assert!(e.0.contains("missing 1 of 3 rows (first: row 1)"), "{e}");
    }

    #[test]
    fn malformed_chunks_are_errors() {
        let frame = test_frame(7, 3);
        let sel = all_layers(PixelFormat::F32);
        let chunks = encode_frame(&frame, &sel, 1);
        let fresh = || {
            let mut asm = FrameAssembler::new();
            asm.start(started(&frame, &sel)).unwrap();
            asm
        };

        // Before RenderStarted.
        assert!(FrameAssembler::new().chunk(chunks[0].clone()).is_err());
        // Outside the image.
        let mut c = chunks[2].clone();
        c.y = 3;
        let e = fresh().chunk(c).unwrap_err();
        assert!(e.0.contains("outside"), "{e}");
        let mut c = chunks[0].clone();
        c.x = 1;
        assert!(fresh().chunk(c).is_err());
        // Wrong layers.
        let mut c = chunks[0].clone();
        c.layers.swap(0, 1);
        let e = fresh().chunk(c).unwrap_err();
        assert!(e.0.contains("expected [\"color\""), "{e}");
        let mut c = chunks[0].clone();
        c.layers.pop();
        assert!(fresh().chunk(c).is_err());
        // Wrong byte length.
        let mut c = chunks[0].clone();
        c.layers[1].data.pop();
        let e = fresh().chunk(c).unwrap_err();
        assert!(e.0.contains("bytes, expected"), "{e}");
        // Duplicate row.
        let mut asm = fresh();
        asm.chunk(chunks[1].clone()).unwrap();
        assert!(asm.chunk(chunks[1].clone()).is_err());
        // Pass mismatch.
        let mut asm = fresh();
        asm.chunk(chunks[0].clone()).unwrap();
        let mut c = chunks[1].clone();
        c.pass = 4;
        assert!(asm.chunk(c).is_err());
        // Unknown layer in RenderStarted.
        let mut s = started(&frame, &sel);
        s.layers.push("depth".into());
        assert!(FrameAssembler::new().start(s).is_err());
        // Empty update.
        assert!(fresh().push(RenderUpdate { kind: None }).is_err());
    }

    #[test]
    fn push_drives_a_whole_stream() {
        let frame = test_frame(9, 5);
        let sel = OutputSelection { spp: true, format: PixelFormat::F32 as i32, ..Default::default() };
        let mut asm = FrameAssembler::new();
        let mut updates = vec![render_update::Kind::Started(started(&frame, &sel))];
        for pass in 0..2 {
            let mut f = frame.clone();
            f.stats.pass = pass;
            f.stats.is_final = pass == 1;
            updates.extend(encode_frame(&f, &sel, 100).into_iter().map(render_update::Kind::Chunk));
            updates.push(render_update::Kind::FrameComplete(frame_complete(&f.stats)));
        }
        let mut frames = Vec::new();
        for kind in updates {
            if let Some(f) = asm.push(RenderUpdate { kind: Some(kind) }).unwrap() {
                frames.push(f);
            }
        }
        assert_eq!(frames.len(), 2);
        assert_eq!(frames[1].spp, frame.spp);
        assert!(frames[1].stats.is_final && !frames[0].stats.is_final);
        // Colour was not streamed: zeros.
        assert!(frames[1].color.iter().flatten().all(|&v| v == 0.0));
        assert!(frames[1].unfiltered.is_none() && frames[1].filter_width.is_none());
        assert!(!asm.in_frame());
    }
}
