"use strict";
// The protobuf wire format, for the messages the viewer sends and reads, and gRPC-web calls
// over fetch (https://github.com/grpc/grpc/blob/master/doc/PROTOCOL-WEB.md). Written out here
// so that the page needs no build step and no downloaded library; proto/wedge/v1/wedge.proto is
// the schema, and the field numbers below are copied from it.
const GrpcWeb = (() => {
  // A schema maps field names to [number, type, repeated]. Types: "uint" (varint, read as a
  // Number: exact below 2^53), "bool", "enum", "float", "double", "string", "bytes", or a
  // schema (a nested message).
  const Vec3 = { x: [1, "float"], y: [2, "float"], z: [3, "float"] };
  const Camera = {
    position: [1, Vec3], look_at: [2, Vec3], up: [3, Vec3], vertical_fov_deg: [4, "float"],
    width: [5, "uint"], height: [6, "uint"],
  };
  const CameraOverride = { position: [1, Vec3], look_at: [2, Vec3], up: [3, Vec3], vertical_fov_deg: [4, "float"] };
  const RenderSettings = {
    method: [1, "enum"], max_passes: [2, "uint"], max_mean_spp: [3, "float"], time_budget_seconds: [4, "float"],
    bounces: [5, "uint"], initial_spp: [6, "uint"],
  };
  const OutputSelection = {
    color: [1, "bool"], spp: [2, "bool"], filter_width: [3, "bool"], unfiltered: [4, "bool"],
    format: [5, "enum"], components: [6, "bool"],
  };
  const RenderRequest = {
    builtin: [2, "string"], scene_digest: [10, "string"], camera: [3, CameraOverride], width: [4, "uint"],
    height: [5, "uint"], settings: [6, RenderSettings], seed: [7, "uint"], outputs: [8, OutputSelection],
    frame_every: [9, "uint"],
  };
  const SessionUpdate = {
    camera: [1, CameraOverride], width: [2, "uint"], height: [3, "uint"], settings: [4, RenderSettings],
    outputs: [5, OutputSelection], pause: [6, "bool"], resume: [7, "bool"],
  };
  const RenderStarted = {
    width: [1, "uint"], height: [2, "uint"], method: [3, "enum"], seed: [4, "uint"], triangles: [5, "uint"],
    layers: [6, "string", true], format: [7, "enum"], camera: [8, Camera],
  };
  const Layer = { name: [1, "string"], channels: [2, "uint"], data: [3, "bytes"] };
  const FrameChunk = {
    pass: [1, "uint"], x: [2, "uint"], y: [3, "uint"], width: [4, "uint"], height: [5, "uint"],
    layers: [6, Layer, true],
  };
  const FrameComplete = {
    pass: [1, "uint"], mean_spp: [2, "double"], rays_traced: [3, "uint"], elapsed_seconds: [4, "double"],
    is_final: [5, "bool"], halt_reason: [6, "enum"], dropped_samples: [7, "uint"], method_seconds: [8, "double"],
    pass_complete: [9, "bool"], estimated_relative_error: [10, "double"],
  };
  const schemas = {
    ListScenesRequest: {},
    ListScenesResponse: {
      scenes: [1, {
        name: [1, "string"], description: [2, "string"], width: [3, "uint"], height: [4, "uint"],
        triangles: [5, "uint"], lights: [6, "uint"],
      }, true],
    },
    PutSceneRequest: { scene_json: [2, "string"] },
    PutSceneResponse: { digest: [1, "string"], bytes: [2, "uint"], triangles: [3, "uint"] },
    WatchSessionRequest: { open: [1, RenderRequest] },
    UpdateSessionRequest: { session_id: [1, "string"], update: [2, SessionUpdate] },
    UpdateSessionResponse: { update: [1, "uint"] },
    SessionEvent: {
      generation: [1, "uint"], ack: [2, { update: [1, "uint"] }], started: [3, RenderStarted],
      chunk: [4, FrameChunk], frame_complete: [5, FrameComplete],
      error: [6, { update: [1, "uint"], field: [2, "string"], message: [3, "string"] }],
      frames_dropped: [7, "uint"], preview_divider: [8, "uint"], session_id: [9, "string"],
    },
  };

  const utf8 = { enc: new TextEncoder(), dec: new TextDecoder() };

  function encode(schema, msg) {
    const out = [];
    const varint = (n) => {
      n = Number(n);
      while (n >= 0x80) {
        out.push((n % 0x80) | 0x80);
        n = Math.floor(n / 0x80);
      }
      out.push(n);
    };
    const bytes = (b) => {
      varint(b.length);
      for (const x of b) out.push(x);
    };
    for (const [name, [number, type, repeated]] of Object.entries(schema)) {
      const value = msg[name];
      if (value === undefined || value === null) continue;
      for (const v of repeated ? value : [value]) {
        if (typeof type === "object") {
          varint((number << 3) | 2);
          bytes(encode(type, v));
        } else if (type === "string") {
          varint((number << 3) | 2);
          bytes(utf8.enc.encode(v));
        } else if (type === "bytes") {
          varint((number << 3) | 2);
          bytes(v);
        } else if (type === "float" || type === "double") {
          const size = type === "float" ? 4 : 8;
          varint((number << 3) | (size === 4 ? 5 : 1));
          const view = new DataView(new ArrayBuffer(size));
          if (size === 4) view.setFloat32(0, v, true);
          else view.setFloat64(0, v, true);
          for (const x of new Uint8Array(view.buffer)) out.push(x);
        } else {
          varint(number << 3);
          varint(type === "bool" ? (v ? 1 : 0) : v);
        }
      }
    }
    return Uint8Array.from(out);
  }

  function decode(schema, buf) {
    const byNumber = new Map(Object.entries(schema).map(([name, [n, type, rep]]) => [n, [name, type, rep]]));
    const view = new DataView(buf.buffer, buf.byteOffset, buf.byteLength);
    const msg = {};
    let pos = 0;
    const varint = () => {
      let n = 0, scale = 1, b;
      do {
        if (pos >= buf.length) throw new Error("truncated varint");
        b = buf[pos++];
        n += (b & 0x7f) * scale;
        scale *= 0x80;
      } while (b & 0x80);
      return n;
    };
    // Proto3 leaves scalars at their defaults off the wire: start from them.
    const defaults = { uint: 0, enum: 0, float: 0, double: 0, bool: false, string: "", bytes: new Uint8Array(0) };
    for (const [, [name, type, rep]] of byNumber) {
      if (rep) msg[name] = [];
      else if (typeof type === "string") msg[name] = defaults[type];
    }
    while (pos < buf.length) {
      const tag = varint();
      const [number, wire] = [Math.floor(tag / 8), tag & 7];
      let value;
      if (wire === 0) value = varint();
      else if (wire === 1) { value = view.getFloat64(pos, true); pos += 8; }
      else if (wire === 5) { value = view.getFloat32(pos, true); pos += 4; }
      else if (wire === 2) {
        const len = varint();
        value = buf.subarray(pos, pos + len);
        pos += len;
      } else throw new Error(`unsupported wire type ${wire}`);
      const field = byNumber.get(number);
      if (!field) continue; // a field this page does not know
      const [name, type, rep] = field;
      if (typeof type === "object") value = decode(type, value);
      else if (type === "string") value = utf8.dec.decode(value);
      else if (type === "bool") value = value !== 0;
      if (rep) msg[name].push(value);
      else msg[name] = value;
    }
    return msg;
  }

  class GrpcError extends Error {
    constructor(code, message) {
      super(`${GrpcError.names[code] || `status ${code}`}: ${message}`);
      this.code = code;
      this.grpcMessage = message;
    }
  }
  GrpcError.names = [
    "OK", "CANCELLED", "UNKNOWN", "INVALID_ARGUMENT", "DEADLINE_EXCEEDED", "NOT_FOUND", "ALREADY_EXISTS",
    "PERMISSION_DENIED", "RESOURCE_EXHAUSTED", "FAILED_PRECONDITION", "ABORTED", "OUT_OF_RANGE",
    "UNIMPLEMENTED", "INTERNAL", "UNAVAILABLE", "DATA_LOSS", "UNAUTHENTICATED",
  ];

  // The status in a trailers frame or in the response's headers (a trailers-only answer).
  function statusOf(get) {
    const code = get("grpc-status");
    if (code === null || code === undefined) return null;
    let message = get("grpc-message") || "";
    try { message = decodeURIComponent(message); } catch (_) { /* keep it as sent */ }
    return { code: Number(code), message };
  }

  // Calls `method` of wedge.v1.Renderer and yields each response message; throws GrpcError
  // with the call's status when it is not OK.
  async function* call(method, request, { token, signal } = {}) {
    const resName = method === "WatchSession" ? "SessionEvent" : `${method}Response`;
    const body = encode(schemas[`${method}Request`], request);
    const framed = new Uint8Array(5 + body.length);
    new DataView(framed.buffer).setUint32(1, body.length, false);
    framed.set(body, 5);
    const headers = { "content-type": "application/grpc-web+proto", "x-grpc-web": "1" };
    if (token) headers.authorization = `Bearer ${token}`;
    const res = await fetch(`/wedge.v1.Renderer/${method}`, { method: "POST", headers, body: framed, signal });
    if (!res.ok) throw new GrpcError(2, `HTTP ${res.status}`);
    const early = statusOf((h) => res.headers.get(h));
    if (early && early.code !== 0) throw new GrpcError(early.code, early.message);
    const reader = res.body.getReader();
    let pending = new Uint8Array(0);
    let status = early;
    for (;;) {
      const { value, done } = await reader.read();
      if (done) break;
      const joined = new Uint8Array(pending.length + value.length);
      joined.set(pending);
      joined.set(value, pending.length);
      pending = joined;
      while (pending.length >= 5) {
        const len = new DataView(pending.buffer, pending.byteOffset).getUint32(1, false);
        if (pending.length < 5 + len) break;
        const [flag, payload] = [pending[0], pending.subarray(5, 5 + len)];
        pending = pending.subarray(5 + len);
        if (flag & 0x80) {
          const lines = utf8.dec.decode(payload).split("\r\n");
          const trailers = new Map(lines.filter((l) => l.includes(":")).map((l) => {
            const i = l.indexOf(":");
            return [l.slice(0, i).trim().toLowerCase(), l.slice(i + 1).trim()];
          }));
          status = statusOf((h) => trailers.get(h));
        } else {
          yield decode(schemas[resName], payload);
        }
      }
    }
    if (!status) throw new GrpcError(14, "the stream ended without a status");
    if (status.code !== 0) throw new GrpcError(status.code, status.message);
  }

  // A call with one response message.
  async function unary(method, request, options) {
    let reply = null;
    for await (const m of call(method, request, options)) reply = m;
    return reply;
  }

  return { encode, decode, call, unary, schemas, GrpcError };
})();
