# wedge: build and test as CI does, then ship the binary in a slim image.
FROM rust:1-slim-bookworm AS build
WORKDIR /src
COPY . .
# The same steps as .ci/run, then the release binary.
RUN rustup component add rustfmt clippy && bash .ci/run && cargo build --release --locked

FROM debian:bookworm-slim
RUN useradd --system --no-create-home wedge
COPY --from=build /src/target/release/wedge /usr/local/bin/wedge
USER wedge
EXPOSE 50051
# Built-in scenes are compiled into the binary, so nothing else is copied.
ENTRYPOINT ["wedge"]
CMD ["serve", "--addr", "0.0.0.0:50051"]
