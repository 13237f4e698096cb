# wedge: build and test as CI does, then ship the binary in a slim image.
FROM rust:1-slim-bookworm AS build
WORKDIR /src
COPY . .
# The same steps as .ci/run, then the release binary.
RUN rustup component add rustfmt clippy && bash .ci/run && cargo build --release --locked

FROM debian:bookworm-slim
RUN useradd --system --uid 10001 --no-create-home wedge
COPY --from=build /src/target/release/wedge /usr/local/bin/wedge
# Numeric, so that Kubernetes can check runAsNonRoot.
USER 10001
EXPOSE 50051
# Built-in scenes are compiled into the binary, so nothing else is copied.
ENTRYPOINT ["wedge"]
# Beyond loopback wedge serves only with TLS and bearer tokens: mount them at /etc/wedge, e.g.
#   docker run -p 50051:50051 -v "$PWD/secrets:/etc/wedge:ro" wedge
# with tls.crt, tls.key (PEM) and tokens (one per line) in ./secrets.
CMD ["serve", "--addr", "0.0.0.0:50051", "--tls-cert", "/etc/wedge/tls.crt", "--tls-key", "/etc/wedge/tls.key", "--token-file", "/etc/wedge/tokens"]
