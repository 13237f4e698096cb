//! Output files of a rendered frame: a lossless multi-layer EXR with everything the method
//! produced and how it was produced (for metrics and reproduction), an sRGB preview PNG, and
//! false-colour PNGs of the spp and filter-width maps, also per component of the light for
//! methods that sample components separately (for looking at where the method spent samples
//! and how widely it filtered).
mod error;
mod exr;
mod exr_attributes;
mod exr_canonical;
mod falsecolor;
pub(crate) mod legend;
mod preview;
#[cfg(test)]
mod test_util;

use std::path::{Path, PathBuf};

use crate::pipeline::frame::{Frame, RenderInfo};

pub use self::error::OutputError;
pub use self::exr::{read_exr, write_exr, ExrImage};
pub use self::falsecolor::write_false_color_png;
pub use self::preview::{tonemap_srgb8, write_preview_png};

#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct OutputOptions {
    /// Leave wall-clock seconds out of file headers, so that identical renders give
    /// byte-identical files (regression tests, content-addressed caches).
    pub reproducible: bool,
}

/// The files `write_frame_files` wrote.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct WrittenFiles {
    pub exr: PathBuf,
    pub preview: PathBuf,
    pub spp_map: PathBuf,
    pub filter_width_map: PathBuf,
    /// Per component, in `Frame::components` order: its spp map, then its filter-width map.
    pub component_maps: Vec<PathBuf>,
    /// For frames with shading maps (`bandwidth`): the bandwidth map, then the level map.
    pub shading_maps: Vec<PathBuf>,
}

/// Writes `<stem>.exr`, `<stem>.png` (preview), `<stem>_spp.png` and `<stem>_filter_width.png`
/// into `dir`, creating it if missing, and for each component `<c>` of the frame
/// `<stem>_spp.<c>.png` and `<stem>_filter_width.<c>.png` (the suffix is the layer's name, as
/// for the total maps); for frames with shading maps, `<stem>_bandwidth.png` and
/// `<stem>_level.png` (drawn as the shading spacing 2^level in pixels, so that the
/// antialiasing levels -1 and -2 read as 1/2 and 1/4 of a pixel).
pub fn write_frame_files(
    dir: &Path,
    stem: &str,
    frame: &Frame,
    info: &RenderInfo,
    opts: &OutputOptions,
) -> Result<WrittenFiles, OutputError> {
    std::fs::create_dir_all(dir).map_err(|source| OutputError::Io { path: dir.to_path_buf(), source })?;
    let files = WrittenFiles {
        exr: dir.join(format!("{stem}.exr")),
        preview: dir.join(format!("{stem}.png")),
        spp_map: dir.join(format!("{stem}_spp.png")),
        filter_width_map: dir.join(format!("{stem}_filter_width.png")),
        component_maps: frame
            .components
            .iter()
            .flat_map(|c| [format!("{stem}_spp.{}.png", c.name), format!("{stem}_filter_width.{}.png", c.name)])
            .map(|name| dir.join(name))
            .collect(),
        shading_maps: match frame.shading {
            Some(_) => vec![dir.join(format!("{stem}_bandwidth.png")), dir.join(format!("{stem}_level.png"))],
            None => Vec::new(),
        },
    };
    write_exr(&files.exr, frame, info, opts)?;
    write_preview_png(&files.preview, frame)?;
    let (width, height) = (frame.width, frame.height);
    write_false_color_png(&files.spp_map, &frame.spp, width, height, "spp")?;
    // Unfiltered methods and components have no map; they filter with width 0 everywhere.
    let zeros = vec![0.0; frame.pixel_count()];
    let filter_width = frame.filter_width.as_deref().unwrap_or(&zeros);
    write_false_color_png(&files.filter_width_map, filter_width, width, height, "filter width (px)")?;
    // `write_exr` checked the components' names, which become part of these file names.
    for (c, paths) in frame.components.iter().zip(files.component_maps.chunks_exact(2)) {
        write_false_color_png(&paths[0], &c.spp, width, height, &format!("{} spp", c.name))?;
        let filter_width = c.filter_width.as_deref().unwrap_or(&zeros);
        write_false_color_png(&paths[1], filter_width, width, height, &format!("{} filter width (px)", c.name))?;
    }
    if let (Some(m), [bandwidth, level]) = (&frame.shading, files.shading_maps.as_slice()) {
        write_false_color_png(bandwidth, &m.bandwidth, width, height, "bandwidth (cycles/px)")?;
        let spacing: Vec<f32> = m.level.iter().map(|&l| l.exp2()).collect();
        write_false_color_png(level, &spacing, width, height, "shading spacing (px)")?;
    }
    Ok(files)
}

#[cfg(test)]
mod tests {
    use super::test_util::TempDir;
    use super::*;
    use crate::pipeline::frame::ComponentMaps;

    #[test]
    fn writes_all_four_files_creating_the_directory() {
        let dir = TempDir::new("frame_files");
        let out = dir.path().join("nested").join("out");
        let frame = Frame {
            width: 3,
            height: 5,
            color: vec![[0.25, 0.5, 1.0]; 15],
            spp: (0..15).map(|i| i as f32).collect(),
            ..Frame::default()
        };
        let info = RenderInfo { scene: "cornell-box".into(), method: "uniform".into(), ..RenderInfo::default() };
        let files = write_frame_files(&out, "final", &frame, &info, &OutputOptions::default()).unwrap();
        assert_eq!(
            files,
            WrittenFiles {
                exr: out.join("final.exr"),
                preview: out.join("final.png"),
                spp_map: out.join("final_spp.png"),
                filter_width_map: out.join("final_filter_width.png"),
                component_maps: Vec::new(),
                shading_maps: Vec::new(),
            }
        );
        let read = read_exr(&files.exr).unwrap();
        assert_eq!(read.info, info);
        let preview = image::open(&files.preview).unwrap();
        assert_eq!((preview.width(), preview.height()), (3, 5));
        for map in [&files.spp_map, &files.filter_width_map] {
            let map = image::open(map).unwrap();
            // The legend widens and lengthens the canvas of such a small map.
            assert!(map.width() > 3 && map.height() > 5);
        }
    }

    #[test]
    fn writes_a_map_per_component_map() {
        let dir = TempDir::new("frame_files_components");
        let out = dir.path();
        let component = |name: &str, width: Option<f32>| ComponentMaps {
            name: name.into(),
            spp: (0..15).map(|i| (i % 3) as f32).collect(),
            filter_width: width.map(|w| vec![w; 15]),
        };
        let frame = Frame {
            width: 3,
            height: 5,
            color: vec![[0.25, 0.5, 1.0]; 15],
            spp: (0..15).map(|i| i as f32).collect(),
            components: vec![component("shadow", Some(2.0)), component("diffuse", None)],
            ..Frame::default()
        };
        let files = write_frame_files(out, "final", &frame, &RenderInfo::default(), &OutputOptions::default()).unwrap();
        let names = [
            "final_spp.shadow.png",
            "final_filter_width.shadow.png",
            "final_spp.diffuse.png",
            "final_filter_width.diffuse.png",
        ];
        let expected: Vec<PathBuf> = names.iter().map(|name| out.join(name)).collect();
        assert_eq!(files.component_maps, expected);
        for path in &expected {
            let map = image::open(path).unwrap();
            assert!(map.width() > 3 && map.height() > 5, "{}", path.display());
        }
        assert_eq!(read_exr(&files.exr).unwrap().frame.components.len(), 2);
    }

    #[test]
    fn writes_bandwidth_and_level_maps_when_the_frame_has_them() {
        let dir = TempDir::new("frame_files_shading");
        let out = dir.path();
        let frame = Frame {
            width: 3,
            height: 5,
            color: vec![[0.25, 0.5, 1.0]; 15],
            spp: vec![4.0; 15],
            shading: Some(crate::pipeline::frame::ShadingMaps {
                bandwidth: (0..15).map(|i| if i == 0 { f32::INFINITY } else { i as f32 * 0.1 }).collect(),
                level: (0..15).map(|i| (i % 5) as f32 - 2.0).collect(),
                analysis_seconds: 0.0,
            }),
            ..Frame::default()
        };
        let files = write_frame_files(out, "final", &frame, &RenderInfo::default(), &OutputOptions::default()).unwrap();
        assert_eq!(files.shading_maps, vec![out.join("final_bandwidth.png"), out.join("final_level.png")]);
        for path in &files.shading_maps {
            let map = image::open(path).unwrap();
            assert!(map.width() > 3 && map.height() > 5, "{}", path.display());
        }
        let back = read_exr(&files.exr).unwrap().frame.shading.unwrap();
        assert_eq!(back.level, frame.shading.as_ref().unwrap().level);
    }

    #[test]
    fn errors_name_the_failing_path() {
        let dir = TempDir::new("frame_files_error");
        // A regular file where the output directory should be.
        let blocker = dir.path().join("blocker");
        std::fs::write(&blocker, b"").unwrap();
        let frame = Frame { width: 1, height: 1, color: vec![[0.0; 3]], spp: vec![1.0], ..Frame::default() };
        let opts = OutputOptions::default();
        let error = write_frame_files(&blocker, "x", &frame, &RenderInfo::default(), &opts).unwrap_err();
        assert!(matches!(error, OutputError::Io { .. }), "{error}");
        assert!(error.to_string().contains("blocker"), "{error}");
    }
}
