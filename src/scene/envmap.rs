//! Readers for the environment map files that scene files reference: OpenEXR (`exr`) and
//! Radiance RGBE (`image`'s `hdr` codec), both as latitude-longitude maps of linear RGB.
//!
//! Every error starts with the file's name. The size limit is checked from the header,
//! before any texel is decoded; texels must be finite (negative ones, which resampling tools
//! leave behind, are read as 0 by the light).
use std::path::Path;

/// A map as read: `height` rows of `width` RGB texels, from the top.
#[derive(Clone, Debug, PartialEq)]
pub struct MapData {
    pub width: usize,
    pub height: usize,
    pub rgb: Vec<[f32; 3]>,
}

/// Reads `path` by its extension (`.exr` or `.hdr`, any case), refusing maps of more than
/// `max_texels` texels.
pub fn load_map(path: &Path, max_texels: u64) -> Result<MapData, String> {
    let name = path.display();
    let ext = path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase);
    let map = match ext.as_deref() {
        Some("exr") => read_exr(path, max_texels),
        Some("hdr") => read_hdr(path, max_texels),
        _ => Err("unknown map format: environment maps are OpenEXR (.exr) or Radiance RGBE (.hdr)".to_string()),
    }
    .map_err(|e| format!("{name}: {e}"))?;
    if let Some(i) = map.rgb.iter().position(|t| !t.iter().all(|c| c.is_finite())) {
        return Err(format!(
            "{name}: texel ({}, {}) is not finite ({:?}); environment maps must hold finite radiance",
            i % map.width,
            i / map.width,
            map.rgb[i]
        ));
    }
    Ok(map)
}

fn check_size(width: usize, height: usize, max_texels: u64) -> Result<(), String> {
    if width == 0 || height == 0 {
        return Err("the map is empty".into());
    }
    let texels = width as u64 * height as u64;
    if texels > max_texels {
        return Err(format!("{width} x {height} = {texels} texels exceeds the limit of {max_texels}"));
    }
    Ok(())
}

fn read_exr(path: &Path, max_texels: u64) -> Result<MapData, String> {
    use exr::prelude::*;
    let meta = exr::meta::MetaData::read_from_file(path, false).map_err(|e| format!("cannot read: {e}"))?;
    let header = meta.headers.first().ok_or("the file has no layers")?;
    let compression = header.compression;
    check_size(header.layer_size.width(), header.layer_size.height(), max_texels)?;
    // The exr crate reads every compression but these (newer than it).
    if matches!(compression, exr::compression::Compression::HTJ2K32 | exr::compression::Compression::HTJ2K256) {
        return Err(format!("cannot read its {compression} compression; save it with ZIP, PIZ or no compression"));
    }
    let image = read_first_rgba_layer_from_file(
        path,
        |size, _| MapData { width: size.width(), height: size.height(), rgb: vec![[0.0; 3]; size.area()] },
        |map: &mut MapData, at, (r, g, b, _a): (f32, f32, f32, f32)| {
            let i = at.y() * map.width + at.x();
            map.rgb[i] = [r, g, b];
        },
    );
    match image {
        Ok(image) => Ok(image.layer_data.channel_data.pixels),
        Err(Error::NotSupported(what)) => Err(format!(
            "cannot read its {} compression ({what}); save it with ZIP, PIZ or no compression",
            compression
        )),
        Err(e) => Err(format!("cannot read: {e}")),
    }
}

fn read_hdr(path: &Path, max_texels: u64) -> Result<MapData, String> {
    use image::codecs::hdr::HdrDecoder;
    use image::ImageDecoder;
    let file = std::fs::File::open(path).map_err(|e| format!("cannot open: {e}"))?;
    let decoder = HdrDecoder::new(std::io::BufReader::new(file)).map_err(|e| format!("cannot read: {e}"))?;
    let (width, height) = decoder.dimensions();
    check_size(width as usize, height as usize, max_texels)?;
    let image = image::DynamicImage::from_decoder(decoder).map_err(|e| format!("cannot read: {e}"))?.into_rgb32f();
    Ok(MapData { width: width as usize, height: height as usize, rgb: image.pixels().map(|p| p.0).collect() })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn temp(name: &str) -> std::path::PathBuf {
        let dir = std::env::temp_dir().join(format!("wedge-envmap-{}-{name}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        dir.join(name)
    }

    /// A 4 x 2 map whose texel (x, y) holds (x, y, x + y) + 0.5.
    fn texel(x: usize, y: usize) -> [f32; 3] {
        [x as f32 + 0.5, y as f32 + 0.5, (x + y) as f32 + 0.5]
    }

    fn write_exr(path: &Path, compression: exr::compression::Compression) {
        use exr::prelude::*;
        let channels = SpecificChannels::rgb(|at: Vec2<usize>| {
            let t = texel(at.x(), at.y());
            (t[0], t[1], t[2])
        });
        let layer = Layer::new(
            (4, 2),
            LayerAttributes::named("map"),
            Encoding { compression, ..Encoding::default() },
            channels,
        );
        Image::from_layer(layer).write().to_file(path).unwrap();
    }

    #[test]
    fn an_exr_map_reads_back_texel_for_texel() {
        let path = temp("map.exr");
        write_exr(&path, exr::compression::Compression::ZIP16);
        let map = load_map(&path, 8).unwrap();
        assert_eq!((map.width, map.height), (4, 2));
        for y in 0..2 {
            for x in 0..4 {
                assert_eq!(map.rgb[y * 4 + x], texel(x, y));
            }
        }
    }

    #[test]
    fn an_hdr_map_reads_back_within_rgbe_precision() {
        let path = temp("map.hdr");
        let pixels: Vec<image::Rgb<f32>> = (0..8).map(|i| image::Rgb(texel(i % 4, i / 4))).collect();
        let file = std::fs::File::create(&path).unwrap();
        image::codecs::hdr::HdrEncoder::new(file).encode(&pixels, 4, 2).unwrap();
        let map = load_map(&path, 8).unwrap();
        assert_eq!((map.width, map.height), (4, 2));
        for (i, t) in map.rgb.iter().enumerate() {
            let want = texel(i % 4, i / 4);
            // RGBE keeps 8 bits of mantissa for the brightest channel.
            assert!((0..3).all(|c| (t[c] - want[c]).abs() <= want[c].max(t[c]) / 64.0), "{t:?} vs {want:?}");
        }
    }

    #[test]
    fn the_texel_limit_is_checked_before_decoding() {
        let path = temp("big.exr");
        write_exr(&path, exr::compression::Compression::Uncompressed);
        let e = load_map(&path, 7).unwrap_err();
        assert!(e.starts_with(&path.display().to_string()) && e.contains("exceeds the limit of 7"), "{e}");
    }

    #[test]
    fn an_unreadable_compression_names_the_file_and_the_compression() {
        // An uncompressed file whose header is changed to say HTJ2K (code 10), which the exr
        // crate cannot decode (it reads the rest, DWAA and DWAB included).
        let path = temp("htj2k.exr");
        write_exr(&path, exr::compression::Compression::Uncompressed);
        let mut bytes = std::fs::read(&path).unwrap();
        let key = b"compression\0compression\0";
        let at = bytes.windows(key.len()).position(|w| w == key).unwrap() + key.len() + 4;
        assert_eq!(bytes[at], 0, "uncompressed");
        bytes[at] = 10;
        std::fs::write(&path, &bytes).unwrap();
        let e = load_map(&path, 8).unwrap_err();
        assert!(e.starts_with(&path.display().to_string()), "{e}");
        assert!(e.contains("compression") && e.contains("ZIP"), "{e}");
    }

    #[test]
    fn unknown_formats_missing_files_and_non_finite_texels_are_refused_by_name() {
        let e = load_map(Path::new("sky.png"), 8).unwrap_err();
        assert!(e.starts_with("sky.png: unknown map format"), "{e}");
        let missing = temp("missing.hdr");
        let e = load_map(&missing, 8).unwrap_err();
        assert!(e.starts_with(&missing.display().to_string()) && e.contains("cannot open"), "{e}");
        let path = temp("nan.exr");
        {
            use exr::prelude::*;
            let channels =
                SpecificChannels::rgb(|at: Vec2<usize>| (if at.x() == 1 { f32::NAN } else { 1.0 }, 1.0, 1.0));
            Image::from_channels((2, 1), channels).write().to_file(&path).unwrap();
        }
        let e = load_map(&path, 8).unwrap_err();
        assert!(e.contains("texel (1, 0) is not finite"), "{e}");
    }
}
