"use strict";
// Displaying layers: colour through an exposure and the sRGB curve, maps in false colour
// (viridis, as `wedge render` writes its map PNGs) with a legend.
const Colormap = (() => {
  // Viridis at nine evenly spaced points (matplotlib's table), interpolated linearly.
  const VIRIDIS = [
    [68, 1, 84], [72, 40, 120], [62, 73, 137], [49, 104, 142], [38, 130, 142],
    [31, 158, 137], [53, 183, 121], [110, 206, 88], [253, 231, 37],
  ];

  function viridis(t) {
    const x = Math.min(Math.max(t, 0), 1) * (VIRIDIS.length - 1);
    const i = Math.min(Math.floor(x), VIRIDIS.length - 2);
    const f = x - i;
    return VIRIDIS[i].map((a, k) => a + (VIRIDIS[i + 1][k] - a) * f);
  }

  function srgb(linear) {
    const c = Math.min(Math.max(linear, 0), 1);
    return 255 * (c <= 0.0031308 ? 12.92 * c : 1.055 * Math.pow(c, 1 / 2.4) - 0.055);
  }

  // Linear radiance (3 channels) to RGBA bytes.
  function colour(values, rgba, exposure) {
    const scale = Math.pow(2, exposure);
    for (let i = 0, n = rgba.length / 4; i < n; i++) {
      for (let k = 0; k < 3; k++) rgba[4 * i + k] = srgb(values[3 * i + k] * scale);
      rgba[4 * i + 3] = 255;
    }
  }

  // One channel to viridis over [0, max]; returns the range used, for the legend. Pixels that
  // are not finite show black.
  function map(values, rgba) {
    let max = 0;
    for (const v of values) if (Number.isFinite(v) && v > max) max = v;
    const scale = max > 0 ? 1 / max : 0;
    for (let i = 0; i < values.length; i++) {
      const v = values[i];
      const c = Number.isFinite(v) ? viridis(v * scale) : [0, 0, 0];
      rgba.set([c[0], c[1], c[2], 255], 4 * i);
    }
    return { min: 0, max };
  }

  // Draws the legend of a map over [0, max] into a canvas.
  function legend(canvas, range, label) {
    const g = canvas.getContext("2d");
    const [w, h] = [canvas.width, canvas.height];
    g.clearRect(0, 0, w, h);
    const bar = g.createImageData(w, 12);
    for (let x = 0; x < w; x++) {
      const c = viridis(x / (w - 1));
      for (let y = 0; y < 12; y++) bar.data.set([c[0], c[1], c[2], 255], 4 * (y * w + x));
    }
    g.putImageData(bar, 0, 0);
    g.fillStyle = "#ddd";
    g.font = "12px sans-serif";
    g.textBaseline = "top";
    g.fillText("0", 0, 15);
    const top = format(range.max);
    g.fillText(top, w - g.measureText(top).width, 15);
    g.fillText(label, (w - g.measureText(label).width) / 2, 15);
  }

  function format(v) {
    if (v === 0) return "0";
    return Math.abs(v) >= 100 ? v.toFixed(0) : v.toPrecision(3);
  }

  return { viridis, colour, map, legend, format };
})();
