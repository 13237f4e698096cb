"use strict";
// The viewer: opens a session (WatchSession) on a built-in or uploaded scene, shows its
// progressive frames, orbits and zooms the camera with the mouse (UpdateSession, one call in
// flight, the newest change queued), and switches between the colour and the maps. `status()`
// reports what arrived, for people and for the browser test (tests/web.rs).
const Viewer = (() => {
  const $ = (id) => document.getElementById(id);
  const token = new URLSearchParams(location.search).get("token") || undefined;
  const METHODS = [
    [0, "default"], [1, "uniform"], [2, "aaf"], [3, "adaptive"], [4, "uniform-filtered"],
    [5, "lobe-aware"], [6, "normal-aware"], [7, "auto"],
  ];
  const MAP_LABELS = { spp: "samples per pixel", filter_width: "filter std. dev. (pixels)" };

  const state = {
    session: null, // { id, abort }
    generation: 0,
    started: null, // RenderStarted of the frame being received, with its preview divider
    layers: new Map(), // name -> { channels, values: Float32Array } of the frame being received
    shown: new Map(), // the same, of the last complete frame
    shownInfo: null, // { generation, preview, pass, mean_spp, elapsed_seconds, frames_dropped }
    orbit: null, // { target, offset, up, fov }
    reference: null, // colour of the last full-resolution frame of the first generation
    frames: {}, // generation -> full-resolution frames received
    previews: {}, // generation -> preview frames received
    difference: null, // relative mean difference of the newest frame from `reference`
    errors: [],
    ended: null,
  };

  // ---- the session ---------------------------------------------------------------------------

  function openRequest(source) {
    const [width, height] = $("size").value.split("x").map(Number);
    return {
      ...source, width, height, seed: 1,
      settings: { method: Number($("method").value) },
      outputs: { color: true, spp: true, filter_width: true, components: true, format: 1 },
    };
  }

  async function open(source) {
    if (state.session) state.session.abort.abort();
    const abort = new AbortController();
    const session = { id: null, abort, inFlight: false, queued: null };
    Object.assign(state, {
      session, generation: 0, started: null, orbit: null, reference: null, frames: {}, previews: {},
      difference: null, ended: null,
    });
    state.layers.clear();
    state.shown.clear();
    setStatus("opening…");
    try {
      for await (const e of GrpcWeb.call("WatchSession", { open: openRequest(source) }, { token, signal: abort.signal })) {
        if (state.session !== session) return;
        onEvent(session, e);
      }
      state.ended = "the session ended";
    } catch (err) {
      if (abort.signal.aborted) return;
      state.ended = err.message;
      report(err.message);
    }
    if (state.session === session) setStatus(`session ended: ${state.ended} (drag or pick a scene to open a new one)`);
  }

  function onEvent(session, e) {
    const g = e.generation;
    if (e.session_id) session.id = e.session_id;
    if (e.ack) state.generation = Math.max(state.generation, g);
    if (e.error) report(`${e.error.field}: ${e.error.message}`);
    if (e.started) onStarted(e.started, e.preview_divider || 0);
    if (e.chunk) onChunk(e.chunk);
    if (e.frame_complete) onFrame(g, e.frame_complete, e.preview_divider || 0, e.frames_dropped || 0);
  }

  function onStarted(started, divider) {
    state.started = { ...started, divider };
    state.layers.clear();
    if (!state.orbit && started.camera && divider === 0) state.orbit = orbitOf(started.camera);
    refreshLayerChoice(started.layers);
  }

  function onChunk(chunk) {
    const s = state.started;
    for (const layer of chunk.layers) {
      let l = state.layers.get(layer.name);
      if (!l) {
        l = { channels: layer.channels, values: new Float32Array(s.width * s.height * layer.channels) };
        state.layers.set(layer.name, l);
      }
      l.values.set(floats(layer.data, s.format), (chunk.y * s.width + chunk.x) * layer.channels);
    }
  }

  function onFrame(generation, complete, divider, dropped) {
    const preview = divider > 0;
    const counts = preview ? state.previews : state.frames;
    counts[generation] = (counts[generation] || 0) + 1;
    state.shown = new Map([...state.layers].map(([k, v]) => [k, { channels: v.channels, values: v.values.slice() }]));
    state.shownInfo = { ...complete, generation, preview, divider, frames_dropped: dropped, ...size() };
    const colour = state.shown.get("color");
    if (!preview && colour) {
      if (generation === firstGeneration()) state.reference = colour.values;
      else if (state.reference && state.reference.length === colour.values.length) {
        state.difference = relativeDifference(colour.values, state.reference);
      }
    }
    draw();
  }

  function firstGeneration() {
    return Math.min(...Object.keys(state.frames).map(Number));
  }

  function size() {
    return { width: state.started.width, height: state.started.height };
  }

  // Layer bytes (little-endian f32 or f16) as floats.
  function floats(bytes, format) {
    const view = new DataView(bytes.buffer, bytes.byteOffset, bytes.byteLength);
    if (format === 1) {
      const out = new Float32Array(bytes.length / 2);
      for (let i = 0; i < out.length; i++) out[i] = half(view.getUint16(2 * i, true));
      return out;
    }
    const out = new Float32Array(bytes.length / 4);
    for (let i = 0; i < out.length; i++) out[i] = view.getFloat32(4 * i, true);
    return out;
  }

  function half(h) {
    const s = h & 0x8000 ? -1 : 1;
    const e = (h >> 10) & 0x1f;
    const f = h & 0x3ff;
    if (e === 0) return s * Math.pow(2, -14) * (f / 1024);
    if (e === 31) return f ? NaN : s * Infinity;
    return s * Math.pow(2, e - 15) * (1 + f / 1024);
  }

  function relativeDifference(a, b) {
    let diff = 0, sum = 0;
    for (let i = 0; i < a.length; i++) {
      diff += Math.abs(a[i] - b[i]);
      sum += Math.abs(b[i]);
    }
    return sum > 0 ? diff / sum : 0;
  }

  // ---- changes -------------------------------------------------------------------------------

  // Sends a change: one UpdateSession call in flight, later changes merged into one queued.
  function send(update) {
    const session = state.session;
    if (!session || !session.id) return;
    session.queued = { ...(session.queued || {}), ...update };
    if (!session.inFlight) flush(session);
  }

  async function flush(session) {
    while (session.queued && state.session === session && !state.ended) {
      const update = session.queued;
      session.queued = null;
      session.inFlight = true;
      try {
        await GrpcWeb.unary("UpdateSession", { session_id: session.id, update }, { token });
      } catch (err) {
        report(err.message);
      } finally {
        session.inFlight = false;
      }
    }
  }

  // ---- the camera ----------------------------------------------------------------------------

  const vec = {
    of: (v) => [v?.x || 0, v?.y || 0, v?.z || 0],
    to: (a) => ({ x: a[0], y: a[1], z: a[2] }),
    add: (a, b) => a.map((x, i) => x + b[i]),
    sub: (a, b) => a.map((x, i) => x - b[i]),
    scale: (a, s) => a.map((x) => x * s),
    dot: (a, b) => a[0] * b[0] + a[1] * b[1] + a[2] * b[2],
    cross: (a, b) => [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]],
    norm: (a) => vec.scale(a, 1 / Math.hypot(...a)),
  };

  function orbitOf(camera) {
    const target = vec.of(camera.look_at);
    const up = camera.up ? vec.norm(vec.of(camera.up)) : [0, 1, 0];
    return { target, offset: vec.sub(vec.of(camera.position), target), up };
  }

  // Rodrigues' rotation of `v` about the unit `axis` by `angle`.
  function rotate(v, axis, angle) {
    const [c, s] = [Math.cos(angle), Math.sin(angle)];
    const k = vec.scale(axis, vec.dot(axis, v) * (1 - c));
    return vec.add(vec.add(vec.scale(v, c), vec.scale(vec.cross(axis, v), s)), k);
  }

  // Orbits by `dx`, `dy` pixels of drag and zooms by `zoom` (a factor on the distance).
  function moveCamera(dx, dy, zoom) {
    const o = state.orbit;
    if (!o) return;
    let offset = rotate(o.offset, o.up, -dx * 0.008);
    const right = vec.norm(vec.cross(offset, o.up));
    const tilted = rotate(offset, right, -dy * 0.008);
    // Stay away from the poles, where the view's up would flip.
    const cosine = vec.dot(vec.norm(tilted), o.up);
    if (Math.abs(cosine) < 0.98) offset = tilted;
    o.offset = vec.scale(offset, zoom);
    send({ camera: { position: vec.to(vec.add(o.target, o.offset)), look_at: vec.to(o.target), up: vec.to(o.up) } });
  }

  // ---- drawing -------------------------------------------------------------------------------

  function refreshLayerChoice(layers) {
    const select = $("layer");
    const names = ["color", ...layers.filter((l) => l !== "color")];
    const current = select.value || "color";
    if ([...select.options].map((o) => o.value).join() === names.join()) return;
    select.replaceChildren(...names.map((n) => new Option(n, n)));
    select.value = names.includes(current) ? current : "color";
  }

  function draw() {
    const info = state.shownInfo;
    if (!info) return;
    const name = $("layer").value || "color";
    const layer = state.shown.get(name) || state.shown.get("color");
    const canvas = $("view");
    const [w, h] = [info.width, info.height];
    const scratch = document.createElement("canvas");
    [scratch.width, scratch.height] = [w, h];
    const image = scratch.getContext("2d").createImageData(w, h);
    const legend = $("legend");
    if (!layer) return;
    if (name === "color" || !state.shown.has(name)) {
      Colormap.colour(layer.values, image.data, Number($("exposure").value));
      legend.hidden = true;
    } else {
      const range = Colormap.map(layer.values, image.data);
      const [kind, component] = name.split(".");
      legend.hidden = false;
      Colormap.legend(legend, range, `${MAP_LABELS[kind] || kind}${component ? ` (${component})` : ""}`);
    }
    scratch.getContext("2d").putImageData(image, 0, 0);
    // Previews are drawn at the full frame's size, pixelated.
    const divider = Math.max(info.divider, 1);
    if (canvas.width !== w * divider || canvas.height !== h * divider) {
      [canvas.width, canvas.height] = [w * divider, h * divider];
    }
    const g = canvas.getContext("2d");
    g.imageSmoothingEnabled = false;
    g.drawImage(scratch, 0, 0, canvas.width, canvas.height);
    const spp = info.mean_spp < 10 ? info.mean_spp.toFixed(2) : info.mean_spp.toFixed(0);
    setStatus(
      `generation ${info.generation}${info.preview ? ` · preview 1/${info.divider}` : ""} · pass ${info.pass} · ` +
        `${spp} spp · ${info.elapsed_seconds.toFixed(2)} s${info.is_final ? " · final" : ""}` +
        (info.frames_dropped ? ` · ${info.frames_dropped} frames skipped` : ""),
    );
  }

  function setStatus(text) {
    $("status").textContent = text;
  }

  function report(message) {
    state.errors.push(message);
    $("errors").textContent = message;
  }

  // ---- controls ------------------------------------------------------------------------------

  function source() {
    const v = $("scene").value;
    return v.startsWith("sha256:") ? { scene_digest: v } : { builtin: v };
  }

  async function upload(file) {
    try {
      const reply = await GrpcWeb.unary("PutScene", { scene_json: await file.text() }, { token });
      const option = new Option(`${file.name} (uploaded)`, reply.digest);
      $("scene").add(option);
      $("scene").value = reply.digest;
      open(source());
    } catch (err) {
      report(`${file.name}: ${err.message}`);
    }
  }

  function bind() {
    let drag = null;
    const canvas = $("view");
    canvas.addEventListener("pointerdown", (e) => {
      drag = { x: e.clientX, y: e.clientY };
      canvas.setPointerCapture(e.pointerId);
      if (state.ended) open(source());
    });
    canvas.addEventListener("pointermove", (e) => {
      if (!drag) return;
      moveCamera(e.clientX - drag.x, e.clientY - drag.y, 1);
      drag = { x: e.clientX, y: e.clientY };
    });
    canvas.addEventListener("pointerup", () => (drag = null));
    canvas.addEventListener("wheel", (e) => {
      e.preventDefault();
      moveCamera(0, 0, Math.exp(Math.sign(e.deltaY) * 0.1));
    }, { passive: false });
    $("scene").addEventListener("change", () => open(source()));
    $("size").addEventListener("change", () => open(source()));
    $("method").addEventListener("change", () => send({ settings: { method: Number($("method").value) } }));
    $("layer").addEventListener("change", draw);
    $("exposure").addEventListener("input", draw);
    $("file").addEventListener("change", (e) => e.target.files[0] && upload(e.target.files[0]));
    $("pause").addEventListener("click", () => send({ pause: true }));
    $("resume").addEventListener("click", () => send({ resume: true }));
  }

  async function start() {
    $("method").replaceChildren(...METHODS.map(([v, n]) => new Option(n, v)));
    bind();
    try {
      const reply = await GrpcWeb.unary("ListScenes", {}, { token });
      $("scene").replaceChildren(...reply.scenes.map((s) => new Option(`${s.name}: ${s.description}`, s.name)));
      const wanted = new URLSearchParams(location.search).get("scene");
      if (wanted) $("scene").value = wanted;
      open(source());
    } catch (err) {
      report(`ListScenes: ${err.message}`);
    }
  }

  // What has arrived, as plain data.
  function status() {
    return {
      session_id: state.session?.id || null,
      generation: state.generation,
      frames: { ...state.frames },
      previews: { ...state.previews },
      shown: state.shownInfo && { ...state.shownInfo },
      layers: [...state.shown.keys()],
      difference_from_first: state.difference,
      errors: [...state.errors],
      ended: state.ended,
    };
  }

  // The shown frame's pass and the sum of its colour over each row: what the browser test
  // compares with a native client's frame of the same pass.
  function rowSums() {
    const info = state.shownInfo;
    const colour = state.shown.get("color");
    if (!info || !colour) return null;
    const sums = [];
    for (let y = 0; y < info.height; y++) {
      let sum = 0;
      for (let i = y * info.width * 3; i < (y + 1) * info.width * 3; i++) sum += colour.values[i];
      sums.push(sum);
    }
    return { generation: info.generation, preview: info.preview, pass: info.pass, sums };
  }

  return { start, status, rowSums, state };
})();

window.wedgeViewer = Viewer;
Viewer.start();
