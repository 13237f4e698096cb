use super::*;
use prost::Message;

/// The components the test frames carry, in wire order.
const COMPONENTS: &[&str] = &["shadow", "diffuse"];

fn test_frame(width: u32, height: u32) -> Frame {
    let n = (width * height) as usize;
    let v = |i: usize, k: usize| ((i * 7 + k * 13) % 101) as f32 * 0.37 + 1e-3 * i as f32;
    Frame {
        shading: Some(ShadingMaps {
            bandwidth: (0..n).map(|i| if i % 7 == 0 { f32::INFINITY } else { v(i, 8) * 0.01 }).collect(),
            level: (0..n).map(|i| (i % 6) as f32 - 2.0).collect(),
            analysis_seconds: 0.0,
        }),
        width,
        height,
        color: (0..n).map(|i| [v(i, 0), v(i, 1), v(i, 2)]).collect(),
        unfiltered: Some((0..n).map(|i| [v(i, 3), v(i, 4), -v(i, 5)]).collect()),
        spp: (0..n).map(|i| (i % 5) as f32 * 4.0).collect(),
        filter_width: Some((0..n).map(|i| v(i, 6) * 0.01).collect()),
        components: COMPONENTS
            .iter()
            .enumerate()
            .map(|(c, name)| ComponentMaps {
                name: name.to_string(),
                spp: (0..n).map(|i| ((i + c) % 3) as f32 * 2.0).collect(),
                filter_width: Some((0..n).map(|i| v(i, 7 + c) * 0.02).collect()),
            })
            .collect(),
        aovs: None,
        stats: FrameStats {
            pass: 3,
            mean_spp: 12.5,
            rays_traced: 12345,
            elapsed_seconds: 0.25,
            is_final: true,
            halt_reason: HaltReason::MaxPasses,
            dropped_samples: 2,
            method_seconds: 0.01,
            pass_complete: true,
            estimated_error: Some(0.03),
            shaded_points: 40,
            full_resolution_points: 160,
        },
    }
}

fn all_layers(format: PixelFormat) -> OutputSelection {
    OutputSelection {
        color: true,
        spp: true,
        filter_width: true,
        unfiltered: true,
        components: true,
        format: format as i32,
        ..Default::default()
    }
}

fn started(frame: &Frame, sel: &OutputSelection) -> RenderStarted {
    RenderStarted {
        width: frame.width,
        height: frame.height,
        layers: layer_names(sel, COMPONENTS),
        format: sel.format,
        // The method whose frames have shading maps, for frames that have them.
        method: if frame.shading.is_some() { crate::proto::Method::Bandwidth as i32 } else { 0 },
        ..Default::default()
    }
}

fn encode(frame: &Frame, sel: &OutputSelection, max_chunk_bytes: usize) -> Vec<FrameChunk> {
    encode_frame(frame, sel, COMPONENTS, max_chunk_bytes)
}

fn round_trip(frame: &Frame, sel: &OutputSelection, max_chunk_bytes: usize) -> Frame {
    let mut asm = FrameAssembler::new();
    asm.start(started(frame, sel)).unwrap();
    for chunk in encode(frame, sel, max_chunk_bytes) {
        asm.chunk(chunk).unwrap();
    }
    asm.complete(&FrameComplete::from(&frame.stats)).unwrap()
}

fn bits(v: &[[f32; 3]]) -> Vec<u32> {
    v.iter().flatten().map(|x| x.to_bits()).collect()
}

fn scalar_bits(v: &[f32]) -> Vec<u32> {
    v.iter().map(|x| x.to_bits()).collect()
}

/// Components as (name, spp bits, filter-width bits).
#[allow(clippy::type_complexity)]
fn component_bits(frame: &Frame) -> Vec<(String, Vec<u32>, Option<Vec<u32>>)> {
    let maps = |c: &ComponentMaps| (c.name.clone(), scalar_bits(&c.spp), c.filter_width.as_deref().map(scalar_bits));
    frame.components.iter().map(maps).collect()
}

#[test]
fn layer_order_and_default() {
    assert_eq!(layer_names(&OutputSelection::default(), COMPONENTS), vec!["color"]);
    let sel = all_layers(PixelFormat::F32);
    let components = ["spp.shadow", "filter_width.shadow", "spp.diffuse", "filter_width.diffuse"];
    let mut expected = vec!["color", "spp", "filter_width", "unfiltered"];
    assert_eq!(layer_names(&sel, &[]), expected);
    expected.extend(components);
    assert_eq!(layer_names(&sel, COMPONENTS), expected);
    let sel = OutputSelection { unfiltered: true, spp: true, ..Default::default() };
    assert_eq!(layer_names(&sel, COMPONENTS), vec!["spp", "unfiltered"]);
    // Components alone: colour only when the method has none.
    let sel = OutputSelection { components: true, ..Default::default() };
    assert_eq!(layer_names(&sel, COMPONENTS), components);
    assert_eq!(layer_names(&sel, &[]), vec!["color"]);
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
        assert_eq!(component_bits(&back), component_bits(&frame));
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
    for (a, b) in back.filter_width.as_ref().unwrap().iter().zip(frame.filter_width.as_ref().unwrap()) {
        assert!(close(*a, *b), "{a} vs {b}");
    }
    let names: Vec<&str> = back.components.iter().map(|c| c.name.as_str()).collect();
    assert_eq!(names, COMPONENTS);
    for (bc, fc) in back.components.iter().zip(&frame.components) {
        let (bw, fw) = (bc.filter_width.as_ref().unwrap(), fc.filter_width.as_ref().unwrap());
        for (a, b) in bc.spp.iter().chain(bw).zip(fc.spp.iter().chain(fw)) {
            assert!(close(*a, *b), "{} {a} vs {b}", bc.name);
        }
    }
}

#[test]
fn odd_sizes_and_one_row_chunks() {
    let frame = test_frame(7, 3);
    let sel = all_layers(PixelFormat::F32);
    // A cap below one row still sends one row per chunk.
    let chunks = encode(&frame, &sel, 1);
    assert_eq!(chunks.len(), 3);
    for (i, c) in chunks.iter().enumerate() {
        assert_eq!((c.x, c.y, c.width, c.height), (0, i as u32, 7, 1));
        assert_eq!(c.pass, 3);
        let channels: Vec<u32> = c.layers.iter().map(|l| l.channels).collect();
        assert_eq!(channels, vec![3, 1, 1, 3, 1, 1, 1, 1]);
    }
    // Two rows per chunk: 2 + 1.
    let row = 7 * 12 * 4;
    let chunks = encode(&frame, &sel, 2 * row + row / 2);
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
        // The smallest cap is one f32 row of every layer.
        for max in [33 * 12 * 4, 2000, 5000, 20_000] {
            let chunks = encode(&frame, &sel, max);
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
        shading: None,
        width: w,
        height: h,
        color: vec![[1.0; 3]; n],
        unfiltered: None,
        spp: vec![1.0; n],
        filter_width: None,
        components: COMPONENTS
            .iter()
            .map(|name| ComponentMaps { name: name.to_string(), spp: vec![1.0; n], filter_width: None })
            .collect(),
        aovs: None,
        stats: FrameStats::default(),
    };
    let sel = all_layers(PixelFormat::F32);
    check_frame(&frame, &sel, COMPONENTS).unwrap();
    let chunks = encode(&frame, &sel, DEFAULT_MAX_CHUNK_BYTES);
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
    frame.components[1].filter_width = None;
    let sel = all_layers(PixelFormat::F32);
    let back = round_trip(&frame, &sel, 1);
    assert_eq!(bits(back.unfiltered.as_ref().unwrap()), bits(&frame.color));
    assert!(back.filter_width.as_ref().unwrap().iter().all(|&w| w == 0.0));
    // A component's zero widths come back as no map, as in the EXR file.
    assert!(back.components[0].filter_width.is_some() && back.components[1].filter_width.is_none());
    assert_eq!(component_bits(&back), component_bits(&frame));
}

#[test]
fn missing_row_is_an_error() {
    let frame = test_frame(7, 3);
    let sel = all_layers(PixelFormat::F32);
    let mut asm = FrameAssembler::new();
    asm.start(started(&frame, &sel)).unwrap();
    let chunks = encode(&frame, &sel, 1);
    asm.chunk(chunks[0].clone()).unwrap();
    asm.chunk(chunks[2].clone()).unwrap();
    let e = asm.complete(&FrameComplete::from(&frame.stats)).unwrap_err();
    assert!(e.0.contains("missing 1 of 3 rows (first: row 1)"), "{e}");
}

#[test]
fn malformed_chunks_are_errors() {
    let frame = test_frame(7, 3);
    let sel = all_layers(PixelFormat::F32);
    let chunks = encode(&frame, &sel, 1);
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
    s.layers.push("motion".into());
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
        updates.extend(encode(&f, &sel, 100).into_iter().map(render_update::Kind::Chunk));
        updates.push(render_update::Kind::FrameComplete(FrameComplete::from(&f.stats)));
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
    assert!(frames[1].components.is_empty());
    assert!(!asm.in_frame());
}

#[test]
fn component_layers_in_render_started_are_checked() {
    let frame = test_frame(4, 2);
    let sel = all_layers(PixelFormat::F32);
    let start = |extra: &[&str]| {
        let mut s = started(&frame, &sel);
        s.layers.extend(extra.iter().map(|l| l.to_string()));
        FrameAssembler::new().start(s)
    };
    let mut asm = FrameAssembler::new();
    asm.start(started(&frame, &sel)).unwrap();
    assert_eq!(asm.components().unwrap(), COMPONENTS);
    let kinds: Vec<LayerKind> = asm.layers().unwrap().iter().map(|l| l.kind).collect();
    let (spp, width) = (LayerKind::ComponentSpp, LayerKind::ComponentFilterWidth);
    assert_eq!(kinds[4..], [spp(0), width(0), spp(1), width(1)]);
    for bad in ["foo.bar", "spp.", "spp.a.b", "spp.a b", "filter_width.", ".shadow", "spp.shadow", "color"] {
        let e = start(&[bad]).unwrap_err();
        assert!(e.0.contains(&format!("{bad:?}")), "{bad}: {e}");
    }
    let e = start(&["spp.shadow"]).unwrap_err();
    assert!(e.0.contains("twice"), "{e}");
    // Both layers of a component, or neither.
    let e = start(&["spp.glossy"]).unwrap_err();
    assert!(e.0.contains("filter_width.glossy"), "{e}");
    let e = start(&["filter_width.glossy"]).unwrap_err();
    assert!(e.0.contains("spp.glossy"), "{e}");
    start(&["filter_width.glossy", "spp.glossy"]).unwrap();
}

#[test]
fn frames_whose_components_do_not_match_are_reported() {
    let sel = all_layers(PixelFormat::F32);
    let frame = test_frame(4, 3);
    check_frame(&frame, &sel, COMPONENTS).unwrap();
    let mut missing = frame.clone();
    missing.components.pop();
    let e = check_frame(&missing, &sel, COMPONENTS).unwrap_err();
    assert!(e.contains("\"diffuse\""), "{e}");
    // Not streamed: not checked.
    let base_only = OutputSelection { components: false, ..sel };
    check_frame(&missing, &base_only, COMPONENTS).unwrap();
    let mut short = frame.clone();
    short.components[0].spp.pop();
    let e = check_frame(&short, &sel, COMPONENTS).unwrap_err();
    assert!(e.contains("spp.shadow layer has 11 pixels"), "{e}");
    let mut long = frame.clone();
    long.components[1].filter_width.as_mut().unwrap().push(0.0);
    let e = check_frame(&long, &sel, COMPONENTS).unwrap_err();
    assert!(e.contains("filter_width.diffuse layer has 13 pixels"), "{e}");
    // A frame with components the render did not announce streams only the announced ones.
    let chunks = encode_frame(&frame, &sel, &["diffuse"], DEFAULT_MAX_CHUNK_BYTES);
    let names: Vec<&str> = chunks[0].layers.iter().map(|l| l.name.as_str()).collect();
    assert_eq!(names[4..], ["spp.diffuse", "filter_width.diffuse"]);
}

#[test]
fn halt_reasons_round_trip_through_the_wire() {
    use crate::proto;
    for r in
        [HaltReason::None, HaltReason::MaxPasses, HaltReason::MaxSpp, HaltReason::TimeBudget, HaltReason::NoiseTarget]
    {
        assert_eq!(HaltReason::from(proto::HaltReason::from(r)), r);
        let stats = FrameStats { halt_reason: r, ..FrameStats::default() };
        assert_eq!(halt_reason_from_wire(FrameComplete::from(&stats).halt_reason), r);
    }
    assert_eq!(halt_reason_from_wire(99), HaltReason::None);
}

/// The denoiser inputs follow the component layers, travel bit-exact in f32, and a frame
/// without them cannot be sent when the output asks for them.
#[test]
fn denoiser_inputs_round_trip() {
    let mut frame = test_frame(5, 4);
    let n = 20;
    frame.aovs = Some(std::sync::Arc::new(Aovs {
        albedo: (0..n).map(|i| [i as f32 * 0.01, 0.5, 1.0]).collect(),
        normal: (0..n).map(|i| [0.0, -1.0, i as f32 * 0.05]).collect(),
        depth: (0..n).map(|i| if i == 3 { f32::INFINITY } else { 10.0 + i as f32 }).collect(),
    }));
    let sel = OutputSelection { albedo: true, normal: true, depth: true, ..all_layers(PixelFormat::F32) };
    let names = layer_names(&sel, COMPONENTS);
    assert_eq!(names[names.len() - 3..], ["albedo", "normal", "depth"]);
    assert!(check_frame(&frame, &sel, COMPONENTS).is_ok());
    for max in [1, DEFAULT_MAX_CHUNK_BYTES] {
        let back = round_trip(&frame, &sel, max);
        let (a, b) = (back.aovs.as_deref().unwrap(), frame.aovs.as_deref().unwrap());
        assert_eq!(bits(&a.albedo), bits(&b.albedo));
        assert_eq!(bits(&a.normal), bits(&b.normal));
        assert_eq!(scalar_bits(&a.depth), scalar_bits(&b.depth));
    }
    // Depth alone: the others stay empty; nothing asked, nothing assembled.
    let depth_only = OutputSelection { depth: true, ..Default::default() };
    assert_eq!(layer_names(&depth_only, COMPONENTS), ["depth"]);
    let back = round_trip(&frame, &depth_only, DEFAULT_MAX_CHUNK_BYTES);
    let a = back.aovs.as_deref().unwrap();
    assert!(a.albedo.is_empty() && a.normal.is_empty() && a.depth.len() == n);
    assert!(round_trip(&frame, &all_layers(PixelFormat::F32), DEFAULT_MAX_CHUNK_BYTES).aovs.is_none());
    let mut without = frame.clone();
    without.aovs = None;
    assert!(check_frame(&without, &depth_only, COMPONENTS).unwrap_err().contains("denoiser inputs"));
    let mut short = frame.clone();
    short.aovs = Some(std::sync::Arc::new(Aovs { depth: vec![1.0; 3], ..(*frame.aovs.clone().unwrap()).clone() }));
    assert!(check_frame(&short, &depth_only, COMPONENTS).unwrap_err().contains("depth layer has 3 pixels"));
}

/// The bandwidth method's maps follow the denoiser inputs and travel bit-exact in f32 (infinite
/// bandwidths and negative levels included); other methods send zeros, which the assembler
/// drops: their frames have no such maps.
#[test]
fn shading_maps_round_trip() {
    let frame = test_frame(5, 4);
    let sel = OutputSelection { depth: true, bandwidth: true, level: true, ..all_layers(PixelFormat::F32) };
    let names = layer_names(&sel, COMPONENTS);
    assert_eq!(names[names.len() - 3..], ["depth", "bandwidth", "level"]);
    let mut with_aovs = frame.clone();
    with_aovs.aovs = Some(std::sync::Arc::new(Aovs { depth: vec![1.0; 20], ..Aovs::default() }));
    for max in [1, DEFAULT_MAX_CHUNK_BYTES] {
        let back = round_trip(&with_aovs, &sel, max);
        let (a, b) = (back.shading.as_ref().unwrap(), frame.shading.as_ref().unwrap());
        assert_eq!(scalar_bits(&a.bandwidth), scalar_bits(&b.bandwidth));
        assert_eq!(scalar_bits(&a.level), scalar_bits(&b.level));
        assert_eq!((back.stats.shaded_points, back.stats.full_resolution_points), (40, 160));
    }
    let level_only = OutputSelection { level: true, ..Default::default() };
    assert_eq!(layer_names(&level_only, COMPONENTS), ["level"]);
    let mut plain = frame.clone();
    plain.shading = None;
    let chunks = encode(&plain, &level_only, DEFAULT_MAX_CHUNK_BYTES);
    assert!(chunks.iter().flat_map(|c| &c.layers).all(|l| l.data.iter().all(|&b| b == 0)));
    assert!(round_trip(&plain, &level_only, DEFAULT_MAX_CHUNK_BYTES).shading.is_none());
    assert!(round_trip(&frame, &all_layers(PixelFormat::F32), DEFAULT_MAX_CHUNK_BYTES).shading.is_none());
    let mut short = frame.clone();
    short.shading.as_mut().unwrap().level.pop();
    let e = check_frame(&short, &sel, COMPONENTS).unwrap_err();
    assert!(e.contains("level layer has 19 pixels"), "{e}");
}
