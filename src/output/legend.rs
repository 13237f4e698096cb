//! The legend strip under a false-colour map: a colour bar from 0 to the map's maximum, ticks
//! and labels at 0, half and the maximum, and the title, in the 8x8 bitmap font (no font files
//! or text-rendering crates needed, and pixel-exact output).
//!
//! Layout, top to bottom, in font pixels (each `scale` image pixels): margin, bar, ticks,
//! labels, title, margin. Labels sit at the bar's ends and middle, so the canvas must be wide
//! enough to hold them apart; `min_width` says how wide, and the caller widens small maps.
use font8x8::legacy::BASIC_LEGACY;
use image::{Rgb, RgbImage};

pub(super) const BACKGROUND: Rgb<u8> = Rgb([255, 255, 255]);
const INK: Rgb<u8> = Rgb([0, 0, 0]);

const GLYPH: u32 = 8;
const MARGIN: u32 = 4;
const BAR_HEIGHT: u32 = 12;
const TICK_HEIGHT: u32 = 3;
const ROW_GAP: u32 = 3;
/// Least horizontal space between two labels.
const LABEL_GAP: u32 = 8;

pub(super) struct Legend {
    /// Image pixels per font pixel: 1 up to 799 px wide, so text stays about the same size
    /// relative to the map; at most 4.
    scale: u32,
    /// Labels at 0, max / 2 and max.
    labels: [String; 3],
    title: String,
}

impl Legend {
    pub(super) fn new(max: f32, title: &str, map_width: u32) -> Self {
        Self {
            scale: (map_width / 400).clamp(1, 4),
            labels: [0.0, max / 2.0, max].map(format_label),
            title: title.to_string(),
        }
    }

    pub(super) fn height(&self) -> u32 {
        self.scale * (MARGIN + BAR_HEIGHT + TICK_HEIGHT + ROW_GAP + GLYPH + ROW_GAP + GLYPH + MARGIN)
    }

    /// The narrowest canvas that holds the labels apart and the title.
    pub(super) fn min_width(&self) -> u32 {
        let [low, mid, high] = self.labels.each_ref().map(|l| self.text_width(l));
        // The middle label is centred on the bar, so each half must hold half of it, a gap and
        // the wider end label; +1 for the odd pixel of an even-width bar.
        let bar = 2 * (low.max(high) + LABEL_GAP * self.scale) + mid + 1;
        2 * MARGIN * self.scale + bar.max(self.text_width(&self.title))
    }

    /// Draws the legend into `canvas` from row `top` down; `color_at` maps [0, 1] to colour.
    pub(super) fn draw(&self, canvas: &mut RgbImage, top: u32, color_at: impl Fn(f64) -> Rgb<u8>) {
        let s = self.scale;
        let left = MARGIN * s;
        let bar_width = canvas.width().saturating_sub(2 * left).max(1);
        let right = left + bar_width; // exclusive
        let bar_top = top + MARGIN * s;
        let ticks_top = bar_top + BAR_HEIGHT * s;
        let labels_top = ticks_top + TICK_HEIGHT * s + ROW_GAP * s;
        let title_top = labels_top + GLYPH * s + ROW_GAP * s;

        let span = f64::from((bar_width - 1).max(1));
        for i in 0..bar_width {
            let color = color_at(f64::from(i) / span);
            fill(canvas, left + i, bar_top, 1, BAR_HEIGHT * s, color);
        }
        let middle = left + (bar_width - 1) / 2;
        for x in [left, middle, right - s] {
            fill(canvas, x, ticks_top, s, TICK_HEIGHT * s, INK);
        }
        let [low, mid, high] = &self.labels;
        self.draw_text(canvas, left, labels_top, low);
        let mid_x = (middle + s / 2).saturating_sub(self.text_width(mid) / 2);
        self.draw_text(canvas, mid_x, labels_top, mid);
        let high_x = right.saturating_sub(self.text_width(high));
        self.draw_text(canvas, high_x, labels_top, high);
        let title_x = (canvas.width().saturating_sub(self.text_width(&self.title))) / 2;
        self.draw_text(canvas, title_x, title_top, &self.title);
    }

    fn text_width(&self, text: &str) -> u32 {
        text.chars().count() as u32 * GLYPH * self.scale
    }

    /// Draws `text` with its top-left corner at (x, y); characters outside ASCII show as '?'.
    fn draw_text(&self, canvas: &mut RgbImage, x: u32, y: u32, text: &str) {
        draw_text(canvas, x, y, text, self.scale, INK);
    }
}

/// Draws `text` in the 8x8 bitmap font, each font pixel `scale` canvas pixels, top-left at
/// (x, y), clipped to the canvas; characters outside ASCII show as '?'.
pub(crate) fn draw_text(canvas: &mut RgbImage, x: u32, y: u32, text: &str, scale: u32, color: Rgb<u8>) {
    let s = scale.max(1);
    for (i, c) in text.chars().enumerate() {
        let glyph = BASIC_LEGACY[if c.is_ascii() { c as usize } else { '?' as usize }];
        let glyph_x = x + i as u32 * GLYPH * s;
        for (row, bits) in (0..).zip(glyph) {
            // Bit 0 of each row byte is the leftmost pixel.
            for column in (0..GLYPH).filter(|&b| bits >> b & 1 == 1) {
                fill(canvas, glyph_x + column * s, y + row * s, s, s, color);
            }
        }
    }
}

/// Fills a rectangle, clipped to the canvas.
fn fill(canvas: &mut RgbImage, x: u32, y: u32, width: u32, height: u32, color: Rgb<u8>) {
    for yy in y..(y + height).min(canvas.height()) {
        for xx in x..(x + width).min(canvas.width()) {
            canvas.put_pixel(xx, yy, color);
        }
    }
}

/// Compact tick label: at most about three significant digits, no trailing zeros, scientific
/// outside [0.01, 10000): "0", "0.125", "12.5", "1234", "1.2e4", "5e-3".
pub(super) fn format_label(value: f32) -> String {
    if value == 0.0 {
        return "0".into();
    }
    if !value.is_finite() {
        return value.to_string();
    }
    let value = f64::from(value);
    let magnitude = value.abs();
    if !(1e-2..1e4).contains(&magnitude) {
        let text = format!("{value:.1e}");
        let (mantissa, exponent) = text.split_once('e').expect("{:e} output has an exponent");
        return format!("{}e{exponent}", trim_fraction(mantissa));
    }
    let decimals = (2 - magnitude.log10().floor() as i32).max(0) as usize;
    trim_fraction(&format!("{value:.decimals$}")).to_string()
}

fn trim_fraction(number: &str) -> &str {
    if number.contains('.') {
        number.trim_end_matches('0').trim_end_matches('.')
    } else {
        number
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn labels_are_compact() {
        let cases = [
            (0.0, "0"),
            (-0.0, "0"),
            (1.0, "1"),
            (64.0, "64"),
            (32.0, "32"),
            (12.5, "12.5"),
            (1.5, "1.5"),
            (0.5, "0.5"),
            (0.125, "0.125"),
            (0.0123, "0.0123"),
            (100.0, "100"),
            (1234.0, "1234"),
            (9999.0, "9999"),
            (12345.0, "1.2e4"),
            (10000.0, "1e4"),
            (0.005, "5e-3"),
            (0.0012, "1.2e-3"),
            (-12.5, "-12.5"),
            (4.56789, "4.57"),
            (f32::INFINITY, "inf"),
        ];
        for (value, expected) in cases {
            assert_eq!(format_label(value), expected, "for {value}");
        }
    }

    #[test]
    fn small_maps_get_a_legend_wide_enough_for_the_text() {
        let legend = Legend::new(1234.5, "filter width (px)", 64);
        assert_eq!(legend.scale, 1);
        // The title alone is 17 glyphs of 8 px.
        assert!(legend.min_width() >= 17 * 8 + 2 * MARGIN);
        assert_eq!(Legend::new(1.0, "spp", 1920).scale, 4);
    }

    #[test]
    fn legend_draws_bar_labels_and_title() {
        for max in [0.0, 1.0, 12.5, 123456.0] {
            let legend = Legend::new(max, "spp", 16);
            let width = legend.min_width();
            let mut canvas = RgbImage::from_pixel(width, legend.height(), BACKGROUND);
            legend.draw(&mut canvas, 0, |t| Rgb([(t * 255.0) as u8, 0, 0]));
            // Bar ends show the colour function's ends.
            let bar_y = MARGIN + 1;
            assert_eq!(canvas.get_pixel(MARGIN, bar_y).0, [0, 0, 0]);
            assert_eq!(canvas.get_pixel(width - MARGIN - 1, bar_y).0, [255, 0, 0]);
            // Some ink in the label row and in the title row.
            let labels_top = MARGIN + BAR_HEIGHT + TICK_HEIGHT + ROW_GAP;
            let ink_in_rows = |top: u32| (top..top + GLYPH).any(|y| (0..width).any(|x| *canvas.get_pixel(x, y) == INK));
            assert!(ink_in_rows(labels_top));
            assert!(ink_in_rows(labels_top + GLYPH + ROW_GAP));
        }
    }
}
