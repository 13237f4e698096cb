//! The boundary between the wire and the core, used by the server, the CLI and the client
//! alike: `request` turns a `RenderRequest` into a validated job (limits, conversions), `wire`
//! is the frame codec (rows of at most 1 MiB) and the client-side `FrameAssembler`.
pub mod request;
pub mod wire;
