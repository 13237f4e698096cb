//! Log-log line plots of error curves (RMSE against spp or seconds, one line per method), as
//! SVG and as PNG with the same layout, like the papers' Fig. 6c / Fig. 10a.
use crate::output::legend::draw_text;
use image::{Rgb, RgbImage};

pub struct Series {
    pub label: String,
    /// (x, y) points, both positive; others are left out.
    pub points: Vec<(f64, f64)>,
}

const W: u32 = 680;
const H: u32 = 420;
const LEFT: f64 = 70.0;
const RIGHT: f64 = 190.0;
const TOP: f64 = 30.0;
const BOTTOM: f64 = 50.0;
const COLORS: [[u8; 3]; 6] =
    [[31, 119, 180], [255, 127, 14], [44, 160, 44], [214, 39, 40], [148, 103, 189], [140, 86, 75]];

/// Decade-aligned log10 range covering every positive value.
fn log_range(values: impl Iterator<Item = f64>) -> (f64, f64) {
    let (lo, hi) = values
        .filter(|v| *v > 0.0 && v.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| (a.min(v), b.max(v)));
    if !lo.is_finite() {
        return (0.0, 1.0);
    }
    let (a, b) = (lo.log10().floor(), hi.log10().ceil());
    (a, if b > a { b } else { a + 1.0 })
}

struct Frame {
    x: (f64, f64),
    y: (f64, f64),
}

impl Frame {
    fn new(series: &[Series]) -> Self {
        let pts = || series.iter().flat_map(|s| s.points.iter().copied()).filter(valid);
        Frame { x: log_range(pts().map(|p| p.0)), y: log_range(pts().map(|p| p.1)) }
    }
    fn px(&self, x: f64) -> f64 {
        LEFT + (x.log10() - self.x.0) / (self.x.1 - self.x.0) * (W as f64 - LEFT - RIGHT)
    }
    fn py(&self, y: f64) -> f64 {
        H as f64 - BOTTOM - (y.log10() - self.y.0) / (self.y.1 - self.y.0) * (H as f64 - TOP - BOTTOM)
    }
    fn decades(range: (f64, f64)) -> impl Iterator<Item = f64> {
        (range.0 as i32..=range.1 as i32).map(|e| 10f64.powi(e))
    }
}

fn valid(p: &(f64, f64)) -> bool {
    p.0 > 0.0 && p.1 > 0.0 && p.0.is_finite() && p.1.is_finite()
}

fn label(v: f64) -> String {
    if (1e-3..1e4).contains(&v) {
        format!("{}", (v * 1e6).round() / 1e6)
    } else {
        format!("1e{}", v.log10().round() as i32)
    }
}

pub fn svg(title: &str, xlabel: &str, ylabel: &str, series: &[Series]) -> String {
    let f = Frame::new(series);
    let mut s = format!(
        "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{W}\" height=\"{H}\" font-family=\"sans-serif\" font-size=\"12\">\n<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n<text x=\"{}\" y=\"18\" text-anchor=\"middle\" font-size=\"14\">{}</text>\n",
        W / 2,
        escape(title)
    );
    let (x0, x1, y0, y1) = (LEFT, W as f64 - RIGHT, TOP, H as f64 - BOTTOM);
    for d in Frame::decades(f.x) {
        let x = f.px(d);
        s += &format!("<line x1=\"{x:.1}\" y1=\"{y0}\" x2=\"{x:.1}\" y2=\"{y1}\" stroke=\"#ddd\"/><text x=\"{x:.1}\" y=\"{}\" text-anchor=\"middle\">{}</text>\n", y1 + 16.0, label(d));
    }
    for d in Frame::decades(f.y) {
        let y = f.py(d);
        s += &format!("<line x1=\"{x0}\" y1=\"{y:.1}\" x2=\"{x1}\" y2=\"{y:.1}\" stroke=\"#ddd\"/><text x=\"{}\" y=\"{:.1}\" text-anchor=\"end\">{}</text>\n", x0 - 6.0, y + 4.0, label(d));
    }
    s += &format!(
        "<rect x=\"{x0}\" y=\"{y0}\" width=\"{}\" height=\"{}\" fill=\"none\" stroke=\"black\"/>\n",
        x1 - x0,
        y1 - y0
    );
    s +=
        &format!("<text x=\"{}\" y=\"{}\" text-anchor=\"middle\">{}</text>\n", (x0 + x1) / 2.0, H - 12, escape(xlabel));
    s += &format!(
        "<text x=\"16\" y=\"{}\" text-anchor=\"middle\" transform=\"rotate(-90 16 {})\">{}</text>\n",
        (y0 + y1) / 2.0,
        (y0 + y1) / 2.0,
        escape(ylabel)
    );
    for (i, ser) in series.iter().enumerate() {
        let c = COLORS[i % COLORS.len()];
        let color = format!("rgb({},{},{})", c[0], c[1], c[2]);
        let pts: Vec<String> =
            ser.points.iter().filter(|p| valid(p)).map(|&(x, y)| format!("{:.1},{:.1}", f.px(x), f.py(y))).collect();
        s += &format!("<polyline fill=\"none\" stroke=\"{color}\" stroke-width=\"2\" points=\"{}\"/>\n", pts.join(" "));
        for p in &pts {
            let (x, y) = p.split_once(',').unwrap_or(("0", "0"));
            s += &format!("<circle cx=\"{x}\" cy=\"{y}\" r=\"3\" fill=\"{color}\"/>\n");
        }
        let ly = TOP + 14.0 + 18.0 * i as f64;
        s += &format!("<line x1=\"{}\" y1=\"{ly}\" x2=\"{}\" y2=\"{ly}\" stroke=\"{color}\" stroke-width=\"2\"/><text x=\"{}\" y=\"{}\">{}</text>\n", x1 + 10.0, x1 + 30.0, x1 + 36.0, ly + 4.0, escape(&ser.label));
    }
    s + "</svg>\n"
}

fn escape(s: &str) -> String {
    s.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;")
}

pub fn png(title: &str, xlabel: &str, ylabel: &str, series: &[Series]) -> RgbImage {
    let f = Frame::new(series);
    let mut img = RgbImage::from_pixel(W, H, Rgb([255, 255, 255]));
    let (x0, x1, y0, y1) = (LEFT, W as f64 - RIGHT, TOP, H as f64 - BOTTOM);
    let grey = Rgb([221, 221, 221]);
    let black = Rgb([0, 0, 0]);
    for d in Frame::decades(f.x) {
        let x = f.px(d);
        line(&mut img, (x, y0), (x, y1), grey, 1);
        let t = label(d);
        draw_text(&mut img, (x - 4.0 * t.len() as f64).max(0.0) as u32, (y1 + 6.0) as u32, &t, 1, black);
    }
    for d in Frame::decades(f.y) {
        let y = f.py(d);
        line(&mut img, (x0, y), (x1, y), grey, 1);
        let t = label(d);
        draw_text(&mut img, (x0 - 6.0 - 8.0 * t.len() as f64).max(0.0) as u32, (y - 4.0).max(0.0) as u32, &t, 1, black);
    }
    for (a, b) in [((x0, y0), (x1, y0)), ((x1, y0), (x1, y1)), ((x1, y1), (x0, y1)), ((x0, y1), (x0, y0))] {
        line(&mut img, a, b, black, 1);
    }
    draw_text(&mut img, (W / 2).saturating_sub(4 * title.len() as u32), 8, title, 1, black);
    draw_text(&mut img, ((x0 + x1) / 2.0) as u32 - 4 * xlabel.len() as u32, H - 20, xlabel, 1, black);
    draw_text(&mut img, 4, (TOP - 14.0) as u32, ylabel, 1, black);
    for (i, ser) in series.iter().enumerate() {
        let c = Rgb(COLORS[i % COLORS.len()]);
        let pts: Vec<(f64, f64)> = ser.points.iter().filter(|p| valid(p)).map(|&(x, y)| (f.px(x), f.py(y))).collect();
        for w in pts.windows(2) {
            line(&mut img, w[0], w[1], c, 2);
        }
        let ly = TOP + 14.0 + 18.0 * i as f64;
        line(&mut img, (x1 + 10.0, ly), (x1 + 30.0, ly), c, 2);
        draw_text(&mut img, (x1 + 36.0) as u32, (ly - 4.0) as u32, &ser.label, 1, black);
    }
    img
}

/// A line `width` pixels thick, by stepping along its longer axis (clipped to the image).
fn line(img: &mut RgbImage, a: (f64, f64), b: (f64, f64), c: Rgb<u8>, width: i64) {
    let steps = (b.0 - a.0).abs().max((b.1 - a.1).abs()).ceil().max(1.0) as i64;
    for k in 0..=steps {
        let t = k as f64 / steps as f64;
        let (x, y) = (a.0 + t * (b.0 - a.0), a.1 + t * (b.1 - a.1));
        for dx in 0..width {
            for dy in 0..width {
                let (px, py) = (x.round() as i64 + dx, y.round() as i64 + dy);
                if px >= 0 && py >= 0 && (px as u32) < img.width() && (py as u32) < img.height() {
                    img.put_pixel(px as u32, py as u32, c);
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn series() -> Vec<Series> {
        vec![
            Series { label: "uniform".into(), points: vec![(1.0, 0.1), (10.0, 0.03), (100.0, 0.01)] },
            Series { label: "aaf".into(), points: vec![(9.0, 0.01), (40.0, 0.004), (0.0, 1.0)] },
        ]
    }

    #[test]
    fn axes_span_whole_decades_and_map_monotonically() {
        let f = Frame::new(&series());
        assert_eq!(f.x, (0.0, 2.0));
        assert_eq!(f.y, (-3.0, -1.0));
        assert!(f.px(1.0) < f.px(10.0) && f.py(0.1) < f.py(0.01));
        assert!((f.px(1.0) - LEFT).abs() < 1e-9);
    }

    #[test]
    fn svg_has_a_line_per_series_and_skips_non_positive_points() {
        let s = svg("t", "spp", "RMSE", &series());
        assert_eq!(s.matches("<polyline").count(), 2);
        assert_eq!(s.matches("<circle").count(), 5);
        assert!(s.contains(">uniform<") && s.contains(">aaf<"));
    }

    #[test]
    fn png_draws_the_series_colours() {
        let img = png("t", "spp", "RMSE", &series());
        assert_eq!(img.dimensions(), (W, H));
        for c in &COLORS[..2] {
            assert!(img.pixels().any(|p| p.0 == *c), "colour {c:?} missing");
        }
    }
}
