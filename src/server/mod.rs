//! gRPC layer.
